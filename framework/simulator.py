"""The step loop: major output pass, record, stop checks, discrete updates, integrate.

At each base tick k (t = t0 + k·dt, never accumulated):
  1. every node due at this tick computes its outputs, in topological order,
     then the continuous derivatives (they are the integrator's first stage);
  2. the recorder copies the recorded ports; stop conditions are checked;
  3. discrete components due at this tick update their state (their outputs,
     computed in 1, are held until their next tick: zero-order hold);
  3b. components with a ``hold()`` (gates: pause, single steps, lockstep) may hold
     the loop here; with ``realtime`` the wall time held does not count as lag;
  3c. components with an ``edit_state()`` may request state changes (reset to the
     initial state, writes): the step's result at t + dt is then the edited state,
     the integrator restarts (:mod:`.state_edit`); time still moves forward by dt;
  4. the integrator advances the continuous state to t + dt, re-evaluating
     only the nodes continuous states depend on;
  5. non-finite state stops the run, naming the component, and keeps the last
     good state; so do non-finite recorded outputs (checked as each row is
     recorded) and non-finite outputs a sink is about to read (at its tick, before
     its update), naming the component and port, and a linear-algebra failure
     (``LinAlgError``) in a component or the integrator, naming which.

Between 2 and the stop conditions, components' once-per-base-step guards
(``Component.check``: the multibody's blow-up guard) look at the state at t.

Every run ends with an ``outcome`` in its summary (:mod:`.outcomes`): ``success`` when it
reached its duration or a stop declared a success, otherwise ``failure`` with a
``failure_kind``: ``stop_rule`` (a scene's stop: entry), ``guard`` / ``mobility`` /
``blow_up`` (a component's stop), ``non_finite``, ``integrator``, ``numerical`` (a
component's LinAlgError), ``memory_limit``, ``interrupted`` (``request_stop``). When a
failure and a success stop hold at the same tick, the failure wins. ``completed`` keeps
its meaning: the run reached its duration (no stop of either outcome).

The recording grows in chunks (:mod:`.recorder`); with ``out_dir`` each full chunk is
appended to ``signals.csv`` as it fills (``write_run`` adds the rest), so a killed run
keeps its signals up to the last full chunk. A recording that reaches the memory limit
ends the run there, like a stop condition (the rows so far kept), instead of being
refused before the first step.

``request_stop(reason)`` (a signal handler: Ctrl-C, SIGTERM) ends the run at the
next step boundary like a component's stop, never inside a kernel; a request
made before the run starts is kept for it.

``realtime`` paces simulated time to the wall clock; when the run falls behind
by more than ``LAG_WARN_S`` it says so on logger ``snakesim.run`` (how far
behind, at most once per ``LAG_WARN_EVERY_S`` of wall time) instead of
drifting silently; the summary keeps the largest lag (``realtime_max_lag_s``). The
first step's excess wall time (components opening lazily: DDS, first JIT calls)
is not lag: pacing starts after it.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import SnakesimError
from .limits import step_count
from .outcomes import FAILURE, INTERRUPTED, SUCCESS
from .recorder import Recorder
from .state_edit import StateEdit
from .stiffness import step_check

logger = logging.getLogger("snakesim.run")
LAG_WARN_S = 0.1            # s behind the wall clock before a --realtime run warns
LAG_WARN_EVERY_S = 5.0      # s of wall time between two lag warnings


@dataclass
class RunResult:
    log: Recorder
    summary: dict
    last_good_state: dict | None = None
    extra: dict = field(default_factory=dict)

    def __getitem__(self, key):
        return self.log[key]


@dataclass(frozen=True)
class _Tally:
    """Where a run stands: its last tick and the counters its summary reports."""
    k: int
    t: float
    wall: float
    cpu: float
    held: float
    n_edits: int
    max_lag: float


class Run:
    """A run in progress (:meth:`Simulator.start`): advanced tick by tick on demand, its state, outputs
    and log kept between calls, until it stops or :meth:`finish` ends it."""

    def __init__(self, simulator: "Simulator", loop, log: Recorder, t0: float):
        self.simulator, self.log, self.t0 = simulator, log, t0
        self._loop = loop
        self._tally: _Tally | None = None        # where it is paused (None before the first advance)
        self.result: RunResult | None = None     # once it ended (a stop, or finish())
        self.realtime = False
        next(loop)                                # set up: initial state, once-only outputs

    @classmethod
    def ended_with(cls, simulator: "Simulator", result: RunResult) -> "Run":
        """A run already over (made elsewhere, e.g. ``Session.run``), holding its result."""
        run = cls.__new__(cls)
        run.simulator, run.log, run.t0, run._loop = simulator, result.log, result.summary["t_end_s"], None
        run._tally, run.result, run.realtime = None, result, False
        return run

    @property
    def k(self) -> int:
        """The last tick reached (-1 before the first advance)."""
        if self.result is not None:
            return self.result.summary["steps"]
        return -1 if self._tally is None else self._tally.k

    @property
    def ended(self) -> bool:
        return self.result is not None

    def advance(self, k: int) -> bool:
        """Run to tick ``k`` (its outputs computed and recorded); False when the run ended on the way
        (a stop: :attr:`result` says why)."""
        if self.result is not None:
            return False
        try:
            self._tally = self._loop.send(k)
        except StopIteration as stop:
            self.result = stop.value
            return False
        return True

    def finish(self) -> RunResult:
        """End the run where it stands (``duration reached``), or the result it stopped with."""
        if self.result is None:
            try:
                self._loop.send(None)
            except StopIteration as stop:
                self.result = stop.value
        return self.result

    def summary(self) -> dict:
        """The summary so far: the final one once the run ended, else where it is paused
        (``stop_reason`` None, ``outcome`` None: still running)."""
        if self.result is not None:
            return self.result.summary
        tally = self._tally or _Tally(-1, self.t0, 0.0, 0.0, 0.0, 0, 0.0)
        s = self.simulator._summary(tally, self.t0, None, None, self.realtime)
        s.update(stop_reason=None, completed=False, outcome=None, running=True)
        return s


class Simulator:
    """Runs a compiled :class:`~snakesim.framework.plan.Plan`; it reads the plan and never changes it."""

    def __init__(self, plan, integrator):
        self.plan = plan
        self.integrator = integrator
        # every run starts from the initial state (one session, many runs)
        self.X0, self.XD0 = plan.X.copy(), plan.XD.copy()
        self.requested: tuple[str, str] | None = None      # (reason, source) from request_stop
        self.sink_checks = _sink_checks(plan)
        self.step_check: dict | None = None

    def request_stop(self, reason: str, source: str = "run") -> None:
        """End the run at the next step boundary (safe from a signal handler: it only sets the stop flag);
        the run's outcome is a failure of kind ``interrupted``."""
        self.requested = (reason, source)
        self.plan.stop_flag.set(reason, source, FAILURE, INTERRUPTED)

    def run(self, duration: float, t0: float = 0.0, progress=None, realtime: bool = False,
            out_dir: Path | None = None) -> RunResult:
        """One run from the initial state to ``t0 + duration`` (or its stop): :meth:`start`, advanced to
        its last tick, finished."""
        n_steps = self.steps_in(duration)
        log = Recorder(self.plan.record_refs, self.plan, n_steps // self.plan.record_every + 1, duration)
        if out_dir is not None:     # full chunks go to signals.csv as they fill: a killed run keeps them
            try:
                log.stream_to(Path(out_dir) / "signals.csv")
            except OSError as e:
                raise SnakesimError(f"could not write the run to {out_dir}: {e}") from None
        run = self.start(log, t0, progress=progress, realtime=realtime)
        run.advance(n_steps)
        return run.finish()

    def steps_in(self, duration: float) -> int:
        """Base steps in ``duration``, which must be a whole number of them."""
        dt = self.plan.dt
        n_steps = step_count(duration, dt)
        if n_steps < 1 or abs(n_steps * dt - duration) > 1e-9 * max(1.0, duration):
            raise SnakesimError(f"duration {duration:g} s is not a whole number of steps dt = {dt:g} s "
                                f"(nearest: {max(1, n_steps) * dt:g} s)")
        return n_steps

    def start(self, log: Recorder, t0: float = 0.0, progress=None, realtime: bool = False) -> "Run":
        """A run from the initial state, advanced on demand (:meth:`Run.advance`): the one step loop
        that :meth:`run` and a :class:`~.simulation.Simulation` share. Nothing is evaluated yet."""
        run = Run(self, self._loop(log, t0, progress, realtime), log, t0)
        run.realtime = realtime
        return run

    def _loop(self, log: Recorder, t0: float, progress, realtime: bool):
        """The step loop, as a generator: sent the tick to reach, it runs ticks (outputs, record, guards
        and stops at each; then updates, gates, edits and the integrator step to the next) until that
        tick's outputs are computed and recorded, and yields there (a pause: the state, outputs and log
        are those at that tick); sent None it ends the run. It returns the run's result."""
        plan, integ = self.plan, self.integrator
        dt = plan.dt
        X, XD = plan.X, plan.XD
        np.copyto(X, self.X0)
        np.copyto(XD, self.XD0)
        if plan.nx:
            integ.bind(plan)      # fresh work arrays, step size and Jacobian
        X_good, XD_good = X.copy(), XD.copy()
        # the good state one base step earlier (swapped with X_good, never copied): a blow-up flagged at t
        # (kind blow_up) keeps the state at the start of the step that gained the energy
        X_prev, XD_prev = X.copy(), XD.copy()
        for fn, x, u, y in plan.once:
            fn(t0, x, u, y)
        if self.step_check is None:     # the stiffest mode vs the step: once (time-invariant inputs known now)
            self.step_check = step_check(plan, integ) or {}
        has_cont, has_disc = plan.nx > 0, plan.XD.size > 0
        # each phase's evaluation: the major pass, then the derivatives (the integrator's first stage)
        passes = tuple(m + plan.derivs for m in plan.major) if has_cont else plan.major
        updates, n_phases, rec_every = plan.updates, plan.n_phases, plan.record_every
        stops, flag, DX, advance = plan.stops, plan.stop_flag, plan.DX, integ.advance
        flag.clear()
        if self.requested:
            flag.set(*self.requested, FAILURE, INTERRUPTED)
        self.inputs_changed = False
        sink_checks, record = self.sink_checks, log.record
        stop_reason, bad = None, None
        kind = None               # the failure kind when the run ends in a failure (outcomes.py)
        checks, restart = plan.checks, True
        isfinite, copyto = math.isfinite, np.copyto
        holds, edits = plan.holds, plan.edits
        editor = StateEdit(plan, self.X0, self.XD0) if edits else None
        n_edits = 0
        perf, cpu_time = time.perf_counter, time.process_time
        until = yield             # the first tick to reach
        wall0 = perf()
        cpu0 = cpu_time()       # this process's CPU time: what others take of a shared core does not count
        next_report = wall0 + 0.5
        held = 0.0                # wall s spent in holds (not lag for realtime pacing)
        warmup = 0.0              # wall s the first step took beyond dt (lazy opening; not lag either)
        paused = paused_cpu = 0.0       # wall / CPU s between advances (the caller's, not the run's)
        max_lag, next_lag_warn = 0.0, wall0
        t_prev = t_good = t = t0
        k = -1
        while True:
            k += 1
            t = t0 + k * dt
            phase = k % n_phases
            try:
                for fn, x, u, y in passes[phase]:
                    fn(t, x, u, y)
            except (np.linalg.LinAlgError, FloatingPointError) as e:
                stop_reason, bad = f"component {_name_of(fn)} failed at t = {t:.6g} s: {type(e).__name__}: {e}", True
                kind = "numerical"
                break
            if k % rec_every == 0:
                bad_out = record(t)
                if bad_out is not None:
                    if log.limit_reached:       # the row is kept; a stop, not a blow-up (but no full run either)
                        stop_reason, kind = bad_out, "memory_limit"
                    else:
                        stop_reason, bad, kind = f"{bad_out} at t = {t:.6g} s", True, "non_finite"
                    break
            for what, v, nan_ok in sink_checks[phase]:
                if not isfinite(v.dot(v)) and (np.isinf(v).any() if nan_ok else not np.isfinite(v).all()):
                    stop_reason, bad, kind = f"{what} at t = {t:.6g} s ({_bad_values(v)})", True, "non_finite"
                    break
            if bad:
                break
            if checks:
                for fn, u in checks:
                    fn(t, u, restart)
                restart = False
            for cond in stops:
                if cond.hit():
                    if cond.outcome == FAILURE:       # a failure outranks a success met at the same tick
                        stop_reason, kind = f"stop condition: {cond.reason} at t = {t:.6g} s", "stop_rule"
                        break
                    if stop_reason is None:
                        stop_reason = f"stop condition: {cond.reason} at t = {t:.6g} s"
            # a component's stop (or an interrupt) names its source; it wins unless it is a success
            # and a failing stop condition holds at the same tick
            if flag.reason is not None and (kind is None or flag.outcome == FAILURE):
                stop_reason = f"{flag.source}: {flag.reason} at t = {t:.6g} s"
                kind = flag.kind
            if stop_reason:
                break
            if k >= until:        # paused at tick k: its outputs computed and recorded, nothing past it
                p0, c0 = perf(), cpu_time()
                until = yield _Tally(k, t, perf() - wall0 - paused, cpu_time() - cpu0 - paused_cpu, held,
                                     n_edits, max_lag)
                paused += perf() - p0
                paused_cpu += cpu_time() - c0
                if until is None:
                    break
                if self.inputs_changed:     # open inputs set while paused: tick k's outputs and derivatives
                    try:                    # again, with them (and its recorded row)
                        self.reevaluate(log, k, t)
                    except (np.linalg.LinAlgError, FloatingPointError) as e:
                        stop_reason, bad = f"evaluation failed at t = {t:.6g} s{_where(e)}: {_what(e)}", True
                        kind = "numerical"
                        break
            for fn, xd, u in updates[phase]:
                fn(t, xd, u)
            if holds:
                h0 = perf()
                for fn, u in holds:
                    fn(t, u)
                held += perf() - h0
            if edits:
                for fn, u in edits:
                    fn(t, u, editor)
                if editor.requests:
                    n_edits += 1
                    stop_reason, bad, kind = self._edit_step(editor, t, dt)
                    if stop_reason:
                        break
                    copyto(X_good, X)
                    copyto(XD_good, XD)
                    t_prev = t_good = t + dt      # no earlier state belongs to this one
                    restart = True        # guards compare nothing across an edit
                    continue              # the edited state is the state at t + dt
            if has_cont:
                try:
                    advance(t, t + dt, DX)
                except (SnakesimError, FloatingPointError, np.linalg.LinAlgError) as e:
                    # e.g. an adaptive step collapsing, a singular matrix: stop like a blow-up, keeping the
                    # last good state
                    bad, kind = True, "integrator"
                    stop_reason = f"integrator {integ.name} failed after t = {t:.6g} s{_where(e)}: {_what(e)}"
                    break
            # X·X is finite iff every element is (an overflow to inf only sends it to the exact test)
            if has_disc:
                if not (isfinite(X.dot(X) + XD.dot(XD)) or (np.isfinite(X).all() and np.isfinite(XD).all())):
                    bad, kind = self._offender(), "non_finite"
                    stop_reason = f"non-finite state in component '{bad[0]}' after t = {t:.6g} s ({bad[1]})"
                    break
                XD_prev, XD_good = XD_good, XD_prev
                copyto(XD_good, XD)
            elif not (isfinite(X.dot(X)) or np.isfinite(X).all()):
                bad, kind = self._offender(), "non_finite"
                stop_reason = f"non-finite state in component '{bad[0]}' after t = {t:.6g} s ({bad[1]})"
                break
            X_prev, X_good = X_good, X_prev
            copyto(X_good, X)
            t_prev, t_good = t_good, t + dt
            if progress is not None and (k & 255) == 0:
                now = perf()
                if now >= next_report:
                    progress(t, t0 + until * dt)
                    next_report = now + 0.5
            if realtime:
                now = perf()
                ahead = (t + dt - t0) - (now - wall0 - held - warmup - paused)
                if k == 0 and ahead < 0:
                    # the first step opens what components open lazily (DDS, first JIT calls): not lag
                    warmup, ahead = -ahead, 0.0
                if ahead > 0:
                    time.sleep(ahead)
                else:
                    max_lag = max(max_lag, -ahead)
                    if -ahead > LAG_WARN_S and now >= next_lag_warn:
                        logger.warning("realtime: %.3g s behind the wall clock at t = %.6g s "
                                       "(real-time factor %.3g so far)", -ahead, t + dt,
                                    (t + dt - t0) / max(now - wall0 - held - warmup - paused, 1e-9))
                        next_lag_warn = now + LAG_WARN_EVERY_S
        tally = _Tally(k, t, perf() - wall0 - paused, cpu_time() - cpu0 - paused_cpu, held, n_edits, max_lag)
        summary = self._summary(tally, t0, stop_reason, kind, realtime)
        last_good = None
        if kind == "blow_up" and not bad and t_prev < t_good:     # the state before the step that blew up
            bad, X_good, XD_good, t_good = True, X_prev, XD_prev if has_disc else XD_good, t_prev
        if bad:
            last_good = {"t": t_good, "X": X_good.copy(), "XD": XD_good.copy(),
                         "components": {s.comp.name: X_good[s.x].copy() for s in plan.slices}}
            summary["last_good_time_s"] = t_good
        return RunResult(log, summary, last_good)

    def reevaluate(self, log: Recorder, k: int, t: float) -> None:
        """Tick ``k``'s outputs and derivatives at ``t`` again (open inputs set while the run is paused
        there), and its recorded row."""
        self.inputs_changed = False
        plan = self.plan
        phase = k % plan.n_phases
        for fn, x, u, y in plan.major[phase]:
            fn(t, x, u, y)
        if plan.nx:
            for fn, x, u, y in plan.derivs:
                fn(t, x, u, y)
        if k % plan.record_every == 0:
            log.rerecord(t)

    def _summary(self, tally: "_Tally", t0: float, stop_reason: str | None, kind: str | None,
                 realtime: bool) -> dict:
        plan, integ = self.plan, self.integrator
        sim_time = (tally.t - t0)
        wall = tally.wall
        summary = {
            "sim_time_s": sim_time,
            "wall_time_s": wall,
            "real_time_factor": sim_time / wall if wall > 0 else float("inf"),
            "cpu_time_s": tally.cpu,
            "steps": tally.k,
            "dt_s": plan.dt,
            "t_end_s": tally.t,
            "stop_reason": stop_reason or "duration reached",
            "completed": stop_reason is None,        # reached its duration: no stop of either outcome
            "outcome": FAILURE if kind is not None else SUCCESS,
            "failure_kind": kind,
            "integrator": {"name": integ.name, **integ.stats} if plan.nx > 0 else None,
        }
        if self.step_check:
            summary["step_check"] = self.step_check
        if plan.holds:
            summary["held_wall_time_s"] = tally.held
        if plan.edits:
            summary["state_edits"] = tally.n_edits
        if realtime:
            summary["realtime_max_lag_s"] = tally.max_lag
        return summary

    def _edit_step(self, editor: StateEdit, t: float, dt: float):
        """One base step whose result is the edited state: integrated first unless a reset replaces the
        whole state, then the requests applied and the integrator restarted. (stop reason, bad, failure
        kind) or (None, None, None)."""
        plan, integ = self.plan, self.integrator
        if plan.nx and not editor.resets:
            try:
                integ.advance(t, t + dt, plan.DX)
            except (SnakesimError, FloatingPointError, np.linalg.LinAlgError) as e:
                editor.requests.clear()
                return f"integrator {integ.name} failed after t = {t:.6g} s{_where(e)}: {_what(e)}", True, "integrator"
        for line in editor.apply():
            logger.info("state edit at t = %.6g s: %s", t + dt, line)
        if not (np.isfinite(plan.X).all() and np.isfinite(plan.XD).all()):
            bad = self._offender()
            return f"non-finite state in component '{bad[0]}' after t = {t:.6g} s ({bad[1]})", bad, "non_finite"
        if plan.nx:
            integ.restart()
        return None, None, None

    def _offender(self) -> tuple[str, str]:
        plan = self.plan
        bad_x = np.flatnonzero(~np.isfinite(plan.X))
        if bad_x.size:
            name = plan.component_of_x(int(bad_x[0]))
            return name, f"{bad_x.size} non-finite continuous state element(s)"
        bad_d = np.flatnonzero(~np.isfinite(plan.XD))
        return plan.component_of_xd(int(bad_d[0])), f"{bad_d.size} non-finite discrete state element(s)"


def _sink_checks(plan) -> tuple[tuple[tuple[str, np.ndarray], ...], ...]:
    """Per phase: (what, flat view, NaN allowed) of every floating-point output a sink reads at that
    phase's tick."""
    per_phase = []
    periods = {n: c["period_steps"] for n, c in plan.report.get("components", {}).items()}
    for phase in range(plan.n_phases):
        seen: dict = {}
        for dst, src in plan.sources.items():
            comp = plan.components.get(dst.comp)
            buf = plan.out_buffers.get(src)
            if comp is None or not comp.is_sink or phase % periods.get(dst.comp, 1) or src in seen:
                continue
            if isinstance(buf, np.ndarray) and np.issubdtype(buf.dtype, np.inexact) and buf.size:
                port = plan.components[src.comp].outputs.get(src.port)
                seen[src] = (f"non-finite output '{src.comp}.{src.port}' of component '{src.comp}', read by "
                             f"sink '{dst.comp}' ({dst.port})", buf.reshape(-1), getattr(port, "may_be_nan", False))
        per_phase.append(tuple(seen.values()))
    return tuple(per_phase)


def _bad_values(v: np.ndarray) -> str:
    bad = np.flatnonzero(~np.isfinite(v))
    return f"{bad.size} of {v.size} element(s) non-finite, first [{bad[0]}] = {v[bad[0]]:g}"


def _name_of(fn) -> str:
    owner = getattr(fn, "__self__", None)
    name = getattr(owner, "name", None)
    return f"'{name}'" if name else repr(getattr(fn, "__qualname__", fn))


def _where(e: BaseException) -> str:
    """' in component NAME' for the innermost component method the exception passed through, or ''."""
    from .component import Component

    name, tb = None, e.__traceback__
    while tb is not None:
        owner = tb.tb_frame.f_locals.get("self")
        if isinstance(owner, Component):
            name = owner.name
        tb = tb.tb_next
    return f" in component '{name}'" if name else ""


def _what(e: BaseException) -> str:
    return str(e) if isinstance(e, SnakesimError) else f"{type(e).__name__}: {e}"


def write_run(out_dir: Path, result: RunResult, config_text: str) -> None:
    """signals.csv, summary.json, config.yaml (+ last_good_state.npz after a blow-up; a stale one from an
    earlier run in the folder is removed, so it never sits beside a good summary)."""
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "config.yaml").write_text(config_text)      # first: small, and what reruns it
        result.log.write_csv(out_dir / "signals.csv")
        npz = out_dir / "last_good_state.npz"
        if result.last_good_state is not None:
            s = result.last_good_state
            np.savez(npz, t=s["t"], X=s["X"], XD=s["XD"],
                     **{f"x_{k.replace('/', '__')}": v for k, v in s["components"].items()})
            result.summary["last_good_state_file"] = "last_good_state.npz"
        elif npz.exists():
            npz.unlink()
        (out_dir / "summary.json").write_text(json.dumps(result.summary, indent=2, default=float) + "\n")
    except OSError as e:
        raise SnakesimError(f"could not write the run to {out_dir}: {e}") from None
