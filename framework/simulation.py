"""A simulation you advance from Python: Drake's ``Simulator.AdvanceTo`` over a compiled plan.

Made by :meth:`.builder.Builder.build` (components as objects) or :func:`load` (a scene file, the
assembly front end)::

    sim = load("pendulum", open=["pend.tau"])
    sim.advance_to(1.0)                   # runs ticks up to t = 1 s; the state is kept
    sim.set_input("pend.tau", 0.2)        # an open input: what the component reads from now on
    sim.step(100)                         # 100 base steps more
    sim["pend.theta"], sim.state("pend"), sim.log["pend.theta"], sim.summary

It drives the same step loop as ``snakesim run`` (:meth:`.simulator.Simulator.start`): a run advanced
to 1 s and then to 2 s is bit for bit the run to 2 s, with the same stops, outcomes, non-finite checks,
gates, state edits and recording. At every pause (after ``advance_to``/``step``, and right after it is
made or :meth:`Simulation.reset`) the simulation stands at a base tick whose outputs are computed and
recorded; what follows that tick (discrete updates, gates, edits, the integrator step) runs on the next
advance. An open input set while paused holds from that tick on (zero-order hold): the tick's outputs
and derivatives are evaluated again with it before the run moves on, and its recorded row taken again.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .binding import Cell
from .errors import SnakesimError
from .limits import step_count
from .recorder import Recorder
from .run_reports import add_reports
from .simulator import Run, RunResult, Simulator
from .warm_up import close_after_run, open_before_run, warm_up
from .wiring import PortRef


def _ref(port, kind: str | None = None) -> PortRef:
    """A PortRef from a port handle (``pend.out.theta``) or its text (``"pend.theta"``)."""
    comp = getattr(port, "component", None)
    if comp is not None:
        if kind is not None and port.kind != kind:
            raise SnakesimError(f"{port.ref} is an {port.kind}, an {kind} is expected here")
        return PortRef(comp.name, port.port)
    text = str(port)
    if "." not in text:
        raise SnakesimError(f"'{text}': expected 'component.port'")
    c, p = text.rsplit(".", 1)
    return PortRef(c, p)


class Simulation:
    """A built scene you advance, read and drive from Python (see the module's text)."""

    def __init__(self, plan, integrator, settings, session=None):
        self.plan, self.integrator, self.settings = plan, integrator, settings
        self.session = session        # the assembly front end's Session, when made by load()
        self.simulator: Simulator = session.simulator if session is not None else Simulator(plan, integrator)
        if session is None:
            warm_up(plan, integrator, settings.t0)       # compiled code loaded now, not in the first advance
        self._inputs0 = {r: (b.value if isinstance(b, Cell) else b.copy()) for r, b in plan.open_inputs.items()}
        self._run = None
        self.reset()

    @property
    def components(self) -> dict:
        """The components it runs, by name: their ports (``sim.components["robot"].out.joint_q``), their
        parameters (``.p``) and resources (the multibody's ``.robot``)."""
        return dict(self.plan.components)

    # -- time ---------------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        return self.plan.dt

    @property
    def t0(self) -> float:
        return self.settings.t0

    @property
    def steps(self) -> int:
        """Base steps taken since the initial state."""
        return self._run.k

    @property
    def t(self) -> float:
        """The simulated time it stands at."""
        return self.t0 + self._run.k * self.plan.dt

    @property
    def ended(self) -> bool:
        """True once the run stopped (a stop condition, a component's stop, a failure) or :meth:`finish`."""
        return self._run.ended

    def reset(self) -> Simulation:
        """Back to the initial state at t0 (and open inputs to their initial values), a fresh log; the
        outputs at t0 computed and recorded."""
        if self._run is not None and not self._run.ended:
            self._run.finish()
            close_after_run(self.plan)
        for ref, v in self._inputs0.items():
            buf = self.plan.open_inputs[ref]
            if isinstance(buf, Cell):
                buf.value = v
            else:
                np.copyto(buf, v)
        log = Recorder(self.plan.record_refs, self.plan, None, self.settings.duration)
        open_before_run(self.plan, self.t0)
        self._run = self.simulator.start(log, self.t0, realtime=self.settings.realtime)
        self._run.advance(0)
        return self

    def advance_to(self, t: float) -> dict:
        """Run until simulated time ``t`` (a whole number of base steps from t0; never backwards) or
        until the run stops; the summary so far."""
        n = step_count(t - self.t0, self.plan.dt)
        if abs(self.t0 + n * self.plan.dt - t) > 1e-9 * max(1.0, abs(t)):
            raise SnakesimError(f"t = {t:g} s is not a whole number of base steps dt = {self.plan.dt:g} s from "
                                f"t0 = {self.t0:g} s (nearest: {self.t0 + n * self.plan.dt:g} s)")
        return self._advance(n)

    def step(self, n: int = 1) -> dict:
        """``n`` base steps more (or until the run stops); the summary so far."""
        if int(n) != n or n < 0:
            raise SnakesimError(f"step takes a whole number of base steps >= 0, got {n!r}")
        return self._advance(self._run.k + int(n))

    def _advance(self, k: int) -> dict:
        if k < self._run.k:
            raise SnakesimError(f"cannot go back from t = {self.t:g} s to {self.t0 + k * self.plan.dt:g} s: "
                                "reset() and advance again")
        if self._run.ended:
            if k > self._run.k:
                s = self._run.result.summary
                raise SnakesimError(f"the run ended at t = {s['t_end_s']:g} s ({s['stop_reason']}); "
                                    "reset() to start again")
        elif k > self._run.k:
            self._run.advance(k)
            if self._run.ended:
                close_after_run(self.plan)
                add_reports(self.plan, self._run.result.summary)
        return self.summary

    def finish(self) -> RunResult:
        """End the run where it stands: its result (log, summary, last good state), as ``snakesim run``
        gives it; :meth:`reset` starts another."""
        if not self._run.ended:
            self._run.finish()
            close_after_run(self.plan)
            add_reports(self.plan, self._run.result.summary)
        return self._run.result

    def run(self, duration: float | None = None, out_dir: Path | None = None) -> RunResult:
        """From the initial state for ``duration`` (the configured one by default), then the result;
        with ``out_dir`` the run is written there as ``snakesim run --out`` writes it (a scene from
        :func:`load`)."""
        duration = self.settings.duration if duration is None else duration
        if out_dir is not None:
            if self.session is None:
                raise SnakesimError("writing a run folder needs a scene loaded from a file (load())")
            if duration != self.settings.duration:
                raise SnakesimError("a run written to a folder runs the scene's duration (sim.duration); "
                                    "give another with load(..., sim_overrides={'duration': ...})")
            if not self._run.ended:
                self._run.finish()        # the session's run uses the same plan buffers: this one ends first
            result = self.session.run(out_dir=out_dir)
            self._run = Run.ended_with(self.simulator, result)
            return result
        self.reset()
        self.advance_to(self.t0 + duration)
        return self.finish()

    # -- reading --------------------------------------------------------------------------------------
    @property
    def summary(self) -> dict:
        """The run's summary so far (``outcome`` None while it can go on), the final one once it ended."""
        return self._run.summary()

    @property
    def log(self) -> Recorder:
        """The recorded signals so far: ``log['pend.theta']``, ``log.columns``, ``log.rows``."""
        self._fresh()
        return self._run.log

    def _fresh(self) -> None:
        """After open inputs were set: the outputs (and recorded row) of the tick it stands at, with them."""
        if self.simulator.inputs_changed and not self._run.ended and self._run.k >= 0:
            self.simulator.reevaluate(self._run.log, self._run.k, self.t)

    def arrays(self) -> dict[str, np.ndarray]:
        """The log as {column: array} (``t`` first), copies."""
        log = self.log
        rows = log.rows
        return {c: rows[:, i].copy() for i, c in enumerate(log.columns)}

    def table(self):
        """The log as a ``pyarrow.Table`` (one float64 column per recorded element)."""
        import pyarrow as pa
        return pa.table(self.arrays())

    def dataframe(self):
        """The log as a ``pandas.DataFrame`` (pandas must be installed)."""
        return self.table().to_pandas()

    def value(self, port):
        """An output port's current value (a copy; a structured port's object), e.g.
        ``sim.value(robot.out.joint_q)`` or ``sim.value("robot.joint_q")``; an input's value for an
        input handle or an open input."""
        ref = _ref(port)
        plan = self.plan
        self._fresh()
        if getattr(port, "kind", "output") == "input":
            return self._input_value(ref)
        if ref not in plan.out_buffers:
            if ref in plan.open_inputs:
                return self._input_value(ref)
            raise self._unknown(ref, "output")
        buf = plan.out_buffers[ref]
        return buf.value if isinstance(buf, Cell) else buf.copy()

    __getitem__ = value

    def _input_value(self, ref: PortRef):
        plan = self.plan
        if ref.comp not in plan.components or ref.port not in plan.components[ref.comp].inputs:
            raise self._unknown(ref, "input")
        _, u, _ = plan.io[ref.comp]
        v = getattr(u, ref.port)
        return v if not isinstance(v, np.ndarray) else v.copy()

    def _unknown(self, ref: PortRef, kind: str) -> SnakesimError:
        plan = self.plan
        if ref.comp not in plan.components:
            why = ("it was pruned (nothing reads its outputs)" if ref.comp in plan.pruned
                   else f"components: {', '.join(plan.components)}")
            return SnakesimError(f"no component '{ref.comp}' in this simulation; {why}")
        c = plan.components[ref.comp]
        ports = c.outputs if kind == "output" else c.inputs
        return SnakesimError(f"{ref.comp} has no {kind} '{ref.port}'; its {kind}s: {', '.join(ports) or 'none'}")

    def state(self, component=None):
        """The continuous state (a copy) of one component (its name or the object), or {name: state}
        of every component with state (discrete states included)."""
        plan = self.plan
        if component is None:
            out = {s.comp.name: plan.X[s.x].copy() for s in plan.slices}
            out.update({n: plan.XD[sl].copy() for n, sl in plan.dslices.items()})
            return out
        name = getattr(component, "name", component)
        for s in plan.slices:
            if s.comp.name == name:
                return plan.X[s.x].copy()
        if name in plan.dslices:
            return plan.XD[plan.dslices[name]].copy()
        raise SnakesimError(f"'{name}' has no state in this simulation; components with state: "
                            f"{', '.join([s.comp.name for s in plan.slices] + list(plan.dslices)) or 'none'}")

    # -- driving --------------------------------------------------------------------------------------
    @property
    def open_inputs(self) -> list[str]:
        """The inputs set from Python (declared open at build)."""
        return [str(r) for r in self.plan.open_inputs]

    def set_input(self, port, value) -> None:
        """Set an open input: the component reads ``value`` from the tick the simulation stands at until
        it is set again (zero-order hold)."""
        ref = _ref(port, "input")
        plan = self.plan
        if ref not in plan.open_inputs:
            if ref.comp in plan.components and ref.port in plan.components[ref.comp].inputs:
                src = plan.sources.get(ref)
                raise SnakesimError(f"input {ref} is not open" + (f" (it is wired from {src})" if src else "")
                                    + "; declare it open at build (Builder.open, load(..., open=[...]))")
            if ref.comp in plan.pruned:
                raise SnakesimError(f"input {ref}: component '{ref.comp}' was pruned (nothing reads its outputs)")
            raise self._unknown(ref, "input")
        buf = plan.open_inputs[ref]
        if isinstance(buf, Cell):
            buf.value = value
        else:
            v = np.asarray(value, dtype=buf.dtype)
            if v.shape != buf.shape and v.size != 1:
                raise SnakesimError(f"input {ref} takes shape {buf.shape}, got {v.shape}")
            if not np.all(np.isfinite(v)):
                raise SnakesimError(f"input {ref}: value is not finite: {value!r}")
            np.copyto(buf, v)
        self.simulator.inputs_changed = True

    def __repr__(self) -> str:
        return (f"<Simulation t = {self.t:g} s, {len(self.plan.components)} components, dt = {self.plan.dt:g} s"
                f"{', ended' if self.ended else ''}>")


def load(assembly, *, open=(), config_files=(), overrides=(), sim_overrides=None, registry=None) -> Simulation:
    """A scene file (or name) as a :class:`Simulation`, through the same resolve and build as
    ``snakesim run``. ``open``: inputs (``"pid.setpoint"``) to set from Python; an input the scene
    wires is unwired (its upstream then pruned if nothing else reads it)."""
    from .assembly import resolve
    from .registry import default_registry
    from .session import Session

    registry = registry or default_registry()
    resolved = resolve(assembly, search_path=registry.assembly_paths(), config_files=config_files,
                       overrides=overrides, sim_overrides=sim_overrides)
    texts = [str(_ref(p, "input")) for p in ([open] if isinstance(open, str) else open)]
    resolved.connections = [c for c in resolved.connections if c[1] not in texts]
    session = Session(resolved, registry, open_inputs=[(t, "load(open=...)") for t in texts])
    return Simulation(session.plan, session.integrator, resolved.sim, session)
