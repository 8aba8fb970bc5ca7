"""Changing the simulation state between two steps: reset to the initial state, or write a component's state.

A component that may change the world between steps (a simulation-control
interface: reset, place the robot) overrides
:meth:`Component.edit_state <snakesim.framework.component.Component.edit_state>`;
the step loop calls it once per base step, after the gates (``hold``), with
this run's :class:`StateEdit`. Through it the component *requests*; the
simulator applies the requests, in order, at the end of that step::

    edit.reset()                                  # every state back to its initial value (X0, XD0)
    edit.write("robot", index, values)            # elements of a component's continuous state
    edit.write_discrete("pid", index, values)     # elements of a component's discrete state

What an edited step means (time never goes back; ``t`` the tick the requests
were made at, ``dt`` the base step):

- the state at ``t + dt`` is the edited one. With a reset among the requests
  nothing is integrated over ``[t, t + dt]`` (the whole state is replaced:
  continuous X = X0, discrete XD = XD0, bit for bit); with writes only, the
  step is integrated as usual and the written elements then replace what it
  gave, so every other component moves on normally;
- the integrator is restarted (:meth:`Integrator.restart`): no step size,
  Jacobian or multistep history from before the edit is used after it;
- the last good state (kept for a blow-up report) becomes the edited state;
- outputs are recomputed from the new state at ``t + dt`` (the next pass);
  outputs a discrete component holds between its ticks (zero-order hold)
  change at its next tick, and per-run caches (a publisher's DDS writers,
  counters, a command source's held set-points) are not state and are kept.

Requests are checked when made (a name that has no state, an index out of
range, non-finite or mis-sized values raise ``ValueError`` naming them), so an
invalid request never reaches the state. A component writes only what its
layout means: the multibody's base pose, for instance, through
:mod:`snakesim.components.multibody.state_write`.

Cost: nothing per step unless a component in the plan overrides ``edit_state``
(the loop skips the hook list when it is empty, like ``holds``).
"""

from __future__ import annotations

import numpy as np


class StateEdit:
    """One run's requests to change the state between two steps (see the module docstring).

    Made by the simulator for a run whose plan has ``edit_state`` hooks; a
    component only calls :meth:`reset`, :meth:`write`, :meth:`write_discrete`
    and reads :meth:`continuous` / :meth:`discrete` (copies of the current state).
    """

    def __init__(self, plan, X0: np.ndarray, XD0: np.ndarray):
        self._plan = plan
        self._X0, self._XD0 = X0, XD0
        self._x = {s.comp.name: s.x for s in plan.slices}
        self._xd = dict(plan.dslices)
        #: pending requests, in order: ("reset",), ("x", slice, index, values), ("xd", slice, index, values)
        self.requests: list[tuple] = []

    # -- what a component may request ------------------------------------------------------------
    def reset(self) -> None:
        """Every component's continuous and discrete state back to its value at t0 (X0, XD0)."""
        self.requests.append(("reset",))

    def write(self, component: str, index, values) -> None:
        """Set elements ``index`` of ``component``'s continuous state (its own layout) to ``values``."""
        self.requests.append(("x",) + self._check(component, index, values, self._x, "continuous"))

    def write_discrete(self, component: str, index, values) -> None:
        """Set elements ``index`` of ``component``'s discrete state to ``values``."""
        self.requests.append(("xd",) + self._check(component, index, values, self._xd, "discrete"))

    # -- reading (copies: the state changes only through requests) -------------------------------
    def continuous(self, component: str) -> np.ndarray:
        """A copy of ``component``'s continuous state now (at the tick of the call)."""
        return self._plan.X[self._slice(component, self._x, "continuous")].copy()

    def discrete(self, component: str) -> np.ndarray:
        return self._plan.XD[self._slice(component, self._xd, "discrete")].copy()

    def has_continuous(self, component: str) -> bool:
        return component in self._x

    @property
    def pending(self) -> bool:
        return bool(self.requests)

    # -- the simulator's side ------------------------------------------------------------------
    @property
    def resets(self) -> bool:
        """Whether a reset is among the pending requests (the step is then not integrated)."""
        return any(r[0] == "reset" for r in self.requests)

    def apply(self) -> list[str]:
        """Apply the pending requests to the plan's X and XD, in order; what was done, one line each."""
        X, XD = self._plan.X, self._plan.XD
        done = []
        for req in self.requests:
            if req[0] == "reset":
                np.copyto(X, self._X0)
                np.copyto(XD, self._XD0)
                done.append("reset to the initial state")
            else:
                kind, sl, name, index, values = req
                target = (X if kind == "x" else XD)[sl]
                target[index] = values
                done.append(f"{name}: {values.size} {'continuous' if kind == 'x' else 'discrete'} "
                            f"state element(s) written")
        self.requests.clear()
        return done

    # -- checks --------------------------------------------------------------------------------
    def _slice(self, component: str, slices: dict, kind: str) -> slice:
        sl = slices.get(component)
        if sl is None:
            raise ValueError(f"state edit: component '{component}' has no {kind} state; components with "
                             f"{kind} state: {', '.join(slices) or 'none'}")
        return sl

    def _check(self, component, index, values, slices, kind):
        sl = self._slice(component, slices, kind)
        n = sl.stop - sl.start
        index = np.asarray(index, dtype=np.intp).ravel()
        values = np.array(values, dtype=float).ravel()
        if index.size != values.size:
            raise ValueError(f"state edit of '{component}': {index.size} indices for {values.size} values")
        if index.size and (index.min() < 0 or index.max() >= n):
            raise ValueError(f"state edit of '{component}': index out of range (its {kind} state has {n} elements)")
        if np.unique(index).size != index.size:
            raise ValueError(f"state edit of '{component}': an index is given twice")
        if not np.all(np.isfinite(values)):
            k = int(np.flatnonzero(~np.isfinite(values))[0])
            raise ValueError(f"state edit of '{component}': value for element {int(index[k])} is {values[k]} "
                             "(not finite)")
        return sl, component, index, values
