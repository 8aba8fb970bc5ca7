"""Linearly implicit Rosenbrock W-methods on the components' own Jacobian (stiff contact, PIDs).

A W-method keeps its order for *any* matrix in place of the Jacobian; only its stability depends
on it. So J need only carry the stiff terms, and here it is what the components declare
(:mod:`snakesim.framework.linearization`: the contact's spring-damper and regularised-friction
slopes through the contact points' Jacobians, the PID gains, the mass matrix), assembled
analytically in one pass, never by finite differences; what no component declares is integrated
explicitly, at the explicit method's stability limit. A robot at rest is a fixed point of every
method here at any step: f(x*) = 0 gives zero stage slopes.

``method``:

``ros2`` (default) Verwer, Spee, Blom & Hundsdorfer, SIAM J. Sci. Comput. 20 (1999): 2 stages,
    order 2 for any W, L-stable, not stiffly accurate::

        W k1 = f(x),  W k2 = f(x ⊕ h k1) − 2 k1,  x₊ = x ⊕ h (3/2 k1 + 1/2 k2),  W = I − γhJ, γ = 1 + 1/√2

    Robust where the friction regularisation makes the problem both very stiff and strongly
    nonlinear (held robots: the walls hold, the default scene's stop phase creep at the
    converged rate at 10 ms; bench/held_cases.py). While driving its tail error grows ∝ h
    (the contact's onset is not smooth): 5.3 mm over the 45 s traverse at 5 ms, 20 mm at 10 ms.
    ``jacobian_every: 3`` at 5 ms keeps 6.6 mm / 0.003 rad there (11 mm at 5) and the held cases
    within 0.2 % of their converged creep, for ~25 % less time per step (bench/tradeoff.py).
``ros34pw2`` Rang & Angermann, BIT 45 (2005): 4 stages, order 3 for any W, L-stable and stiffly
    accurate (the last stage is the solution), built so that index-1 DAEs keep order 3. More
    accurate while driving (7.1 mm over the 45 s traverse at 10 ms), but its internal stages
    overshoot the friction's narrow linear range on held robots: the stop phase creeps 2.5x
    too fast at 10 ms and the walls hold slides even at 2 ms.
    Transformed (U) form, Hairer & Wanner II, sec. IV.7::

        (1/(γh) I − J) U_i = f(x ⊕ Σ_j a_ij U_j) + Σ_j (c_ij / h) U_j,     x₊ = x ⊕ Σ m_i U_i

    with a = AΓ⁻¹, c = diag(1/γ) − Γ⁻¹, m = bᵀΓ⁻¹ from the method's (α, γ, b).

``jacobian_refresh``: when J is assembled. ``steps`` (default): every ``jacobian_every`` steps.
``on_sources``: also at a step where a time-driven source (a component with no inputs and no
continuous state: a schedule, a sampled source) shows a value other than at the step
before, and at every step for ``refresh_window`` s after; ``refresh_substeps`` splits the steps of
that window into as many equal steps. Where the stiff terms' slopes move fast in a driven scene is
the transient after a set-point jump (the screws spin up, the friction's slip regime changes): a
stale J, or a large step, costs accuracy there and hardly anywhere else, so between jumps J can be
kept for many steps and the step made large. On the 45 s default traverse (bench/tradeoff.py, one
run, against RK4 at 0.25 ms): 5 ms, ``jacobian_every: 8``, window 50 ms: 5.3 mm / 0.0028 rad (as
with J at every step; ``jacobian_every: 3`` without the rule: 6.6 mm, 4: 10.4 mm); 10 ms,
``jacobian_every: 8``, window 100 ms at 4 substeps: 4.3 mm / 0.0020 rad (J at every step, no
substeps: 19.5 mm), ~2.8x MuJoCo's speed; the held cases (bench/held_cases.py) within 0.2 %. A
window under ~3 steps loses it (window 0 at 1/150 s: 14 mm on the compressed schedule). The watch
is a compare of the sources' outputs with a copy at each step (a few hundred ns).

Stage slopes evaluated at x ⊕ u are mapped back to the chart at x (``dexp_inv``, Munthe-Kaas)
as in the explicit methods. Cost per step: ``stages`` evaluations of f (the first is the
simulator's) and as many structured solves; per Jacobian refresh (``jacobian_every`` steps) one
assembly and one factorisation per multibody: O(links) on its link tree (the articulated-body
elimination of components/multibody/articulated_solve_kernels.py; 100 EELS 1.0 modules, nv = 306:
~0.06 ms against 4.7 ms for the dense LU it replaced), a dense (nv × nv) LU where the tree
elimination does not apply (framework/linearization.py).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numba import njit
from pydantic import Field

from ..linear_solve_kernels import bind
from ..linearization import Linearization
from .base import FixedStep, FixedStepParams


# ROS2's vector updates, bound to the work arrays (h in a one-element array): the same operations as
# NumPy's ``dx = h ka``, ``f -= 2 ka``, ``dx = 1.5h ka; dx += 0.5h kb``, without a ufunc call each
@njit(cache=True)
def _ros2_offset(ka, h, dx):
    for i in range(dx.size):
        dx[i] = ka[i] * h[0]


@njit(cache=True)
def _changed(live, seen):
    """True if ``live`` differs from ``seen`` (then copied into it)."""
    for i in range(live.size):
        if live[i] != seen[i]:
            seen[:] = live
            return True
    return False


@njit(cache=True)
def _ros2_rhs(f, ka):
    for i in range(f.size):
        f[i] -= 2.0 * ka[i]


@njit(cache=True)
def _ros2_result(ka, kb, h, dx):
    a, b = 1.5 * h[0], 0.5 * h[0]
    for i in range(dx.size):
        dx[i] = ka[i] * a + b * kb[i]


def _transformed(gamma: float, alpha: np.ndarray, gam: np.ndarray, b: np.ndarray):
    """(γ, a, c, m) of the U form from the k form's α (strictly lower), γ_ij (lower, off the diagonal)
    and b."""
    G = gam + gamma * np.eye(len(b))
    Gi = np.linalg.inv(G)
    a = alpha @ Gi
    c = np.diag(np.full(len(b), 1.0 / gamma)) - Gi
    m = b @ Gi
    return gamma, np.tril(a, -1), np.tril(c, -1), m


_G = 4.3586652150845900e-01
ROS34PW2 = _transformed(
    _G,
    np.array([[0, 0, 0, 0],
              [8.7173304301691801e-01, 0, 0, 0],
              [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0],
              [0, 0, 1.0, 0]]),
    np.array([[0, 0, 0, 0],
              [-8.7173304301691801e-01, 0, 0, 0],
              [-9.0338057013044082e-01, 5.4180672388095326e-02, 0, 0],
              [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, 0]]),
    np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G]))
_ALPHA = np.array([0.0, 8.7173304301691801e-01, 8.4457060015369423e-01 - 1.1299064236484185e-01, 1.0])  # stage times
GAMMA_ROS2 = 1.0 + 1.0 / np.sqrt(2.0)


class RosenbrockWParams(FixedStepParams):
    method: Literal["ros2", "ros34pw2"] = Field("ros2", description="the W-method: ros2 (robust on held robots) "
                                                                   "or ros34pw2 (more accurate while driving)")
    jacobian_every: int = Field(1, ge=1, description="steps between Jacobian assemblies (the LU is refreshed with it)")
    jacobian_refresh: Literal["steps", "on_sources"] = Field(
        "steps", description="steps: assemble every jacobian_every steps; on_sources: also at a step where a "
                             "time-driven source's output (a component with no inputs and no continuous state, "
                             "e.g. a schedule's set-points) changed since the last assembly, and at every step "
                             "for refresh_window s after it")
    refresh_window: float = Field(0.0, ge=0.0, description="s of assembly at every step after a source change "
                                                           "(jacobian_refresh: on_sources)")
    refresh_substeps: int = Field(1, ge=1, description="steps per base step at a source change and in its window "
                                                       "(jacobian_refresh: on_sources): the transient after a "
                                                       "set-point jump taken at a finer step")


class RosenbrockW(FixedStep):
    name = "rosenbrock_w"
    order = 2
    description = "linearly implicit Rosenbrock W-method (ROS2, or ROS34PW2) on the components' analytic Jacobians"
    Params = RosenbrockWParams

    def _alloc(self, nx, ndx):
        sys = self.sys
        self.lin = Linearization(sys)
        self.lin.gamma_hint = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]
        self.x0 = np.zeros(nx)
        self.f1 = np.zeros(ndx)
        self.U = np.zeros((4, ndx))
        self.rhs = np.zeros(ndx)
        self.dx = np.zeros(ndx)
        self.h_lu = None
        self.age = 0
        self.stats.update(jacobians=0)
        # a stage's state goes straight into the plan's X (x0 keeps the step's start), as does the result
        self._to_x = sys.bind_integrate(self.x0, self.dx, sys.X)
        self._dexp_inv = sys.bind_dexp_inv(self.x0, self.dx, self.f1)
        # the solves on these work arrays, bound once per factorisation change (Linearization.bind_solve)
        self._solve_k1 = self.lin.bind_solve(sys.DX, self.U[0])      # the simulator's k1 is sys.DX
        self._solve_f1 = self.lin.bind_solve(self.f1, self.U[1])
        self._solve_rhs = tuple(self.lin.bind_solve(self.rhs, self.U[i]) for i in range(4))
        self.gamma = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]
        self.h = np.zeros(1)
        ka, kb = self.U[0], self.U[1]
        self._offset = bind(_ros2_offset, ka, self.h, self.dx)
        self._rhs2 = bind(_ros2_rhs, self.f1, ka)
        self._result = bind(_ros2_result, ka, kb, self.h, self.dx)
        self._watched = self._sources() if self.p.jacobian_refresh == "on_sources" else ()
        self._burst_until = -np.inf
        self._event = False
        self.stats.update(source_refreshes=0)

    def _sources(self):
        """(live, copy) of each numeric output read in the plan whose component has no inputs and no continuous
        state: a function of time and discrete state only (schedules, sampled sources), whose jump is an
        event the stiff terms answer (a screw set-point: the friction's slip regime changes)."""
        plan = self.sys
        stateful = {s.comp.name for s in plan.slices}
        out = []
        for ref in dict.fromkeys(plan.sources.values()):
            comp = plan.components[ref.comp]
            if ref.comp in stateful or comp.inputs:
                continue
            live = getattr(plan.io[ref.comp][2], ref.port, None)
            if isinstance(live, np.ndarray) and live.dtype == np.float64:
                live = live.reshape(-1)
                out.append((live, live.copy()))
        return tuple(out)

    def _source_event(self, t, first: bool) -> bool:
        """A watched source changed since the last step (its copies updated), or the refresh window is
        open; at a run's first step the copies are only taken."""
        hit = False
        for live, seen in self._watched:
            hit |= _changed(live, seen)
        if hit and not first:
            self.stats["source_refreshes"] += 1
            self._burst_until = t + self.p.refresh_window
            return True
        return t < self._burst_until

    def substeps_now(self, t0):
        self._event = bool(self._watched) and self._source_event(t0, self.h_lu is None)
        return self.p.substeps * (self.p.refresh_substeps if self._event else 1)

    def step(self, t, h, k1):
        sys, lin = self.sys, self.lin
        np.copyto(self.x0, sys.X)
        if self.h_lu is None or self.age >= self.p.jacobian_every or self._event:
            lin.assemble(t)                 # the plan was just evaluated at (t, x0): k1 is f there
            self.stats["jacobians"] += 1
            self.age = 0
            self.h_lu = None
        if h != self.h_lu:
            lin.factor(self.gamma * h)
            self.h_lu = h
        self.age += 1
        if self.p.method == "ros2":
            self._ros2(t, h, k1)
        else:
            self._ros34pw2(t, h, k1)

    def _stage_slope(self, t, u=None):
        """f at x0 ⊕ u, in the chart at x0, into self.f1 (u None: already in self.dx)."""
        sys = self.sys
        if u is not None:
            np.copyto(self.dx, u)
        self._to_x()
        np.copyto(self.f1, sys.f(t, sys.X))
        self._dexp_inv()
        self.stats["f_evals"] += 1
        return self.f1

    def _ros34pw2(self, t, h, k1):
        gamma, a, c, m = ROS34PW2
        U, gh, rhs = self.U, gamma * h, self.rhs
        for i in range(4):
            if i == 0:
                np.multiply(k1, gh, out=rhs)
            else:
                u = a[i, 0] * U[0]
                for j in range(1, i):
                    u += a[i, j] * U[j]
                f = self._stage_slope(t + h * _ALPHA[i], u)
                np.multiply(f, gh, out=rhs)
                for j in range(i):
                    rhs += (gamma * c[i, j]) * U[j]
            self._solve_rhs[i]()
        np.multiply(U[0], m[0], out=self.dx)
        for i in range(1, 4):
            self.dx += m[i] * U[i]
        self._to_x()

    def _ros2(self, t, h, k1):
        if k1 is self.sys.DX:
            self._solve_k1()                        # ka
        else:
            self.lin.solve(k1, self.U[0])
        self.h[0] = h
        self._offset()                              # dx = h ka: the stage's offset
        self._stage_slope(t + h)                    # f1 = f(x0 ⊕ dx) in the chart at x0
        self._rhs2()                                # f1 −= 2 ka
        self._solve_f1()                            # kb
        self._result()                              # dx = 3/2 h ka + 1/2 h kb
        self._to_x()

