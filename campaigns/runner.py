"""One campaign run on a worker: build (or reuse) the scene, run it, reduce it to a record.

This is the only code that runs on workers, whichever back end: a local
process or a Dask worker calls :func:`execute` with a :class:`RunTask` and gets
a plain JSON-able dict back. It never raises: a failing build or run, a run
that diverges or one that exceeds its wall-time limit is a record with its
``status`` and ``reason`` (the campaign goes on). A run that ran records the
summary's ``outcome`` (success | failure) and ``failure_kind``
(framework/outcomes.py); a build error or a timeout is a failure with no kind.

Reuse: a worker keeps its registry (plugins loaded once), its imports and
numba's compiled kernels across runs, and the last few built Sessions keyed by
(scene, every override): a run whose parameters equal an earlier one's on this
worker (a grid or choice value seen before) re-runs that Session from its
initial state without building. A changed number needs a rebuild in this
framework (component parameters are frozen and ``setup()`` derives constants
from them), so continuous dispersions build every run.
"""

from __future__ import annotations

import os
import socket
import threading
import time
import traceback
from collections import OrderedDict
from dataclasses import dataclass, field

STATUSES = ("ok", "stopped", "diverged", "error", "timeout")
SESSION_CACHE_SIZE = 4      # built Sessions kept per worker thread (a robot scene holds ~100 MB at most)


@dataclass(frozen=True)
class SceneSpec:
    """The scene every run starts from: name or path, ``--config`` files, fixed ``--set`` items, sim flags."""

    assembly: str
    config_files: tuple[str, ...] = ()
    sets: tuple[str, ...] = ()
    sim: tuple[tuple[str, object], ...] = ()       # (key, value) of --duration/--dt/--integrator

    def sim_overrides(self) -> dict:
        return {k: v for k, v in self.sim if v is not None}


@dataclass(frozen=True)
class RunTask:
    """Run ``index`` of a campaign: the scene, this run's dispersion ``--set`` items and where to write."""

    index: int
    scene: SceneSpec
    sets: tuple[str, ...]                 # this run's sampled values as --set items
    parameters: dict = field(default_factory=dict, compare=False, hash=False)   # path -> value (for the record)
    metrics: tuple | None = None          # metrics.Metric declarations; None: the defaults
    run_dir: str | None = None            # write signals.csv, summary.json, config.yaml here
    timeout_s: float | None = None        # wall-time limit of build + run, s


class RunTimeout(Exception):
    """Raised from the simulator's progress callback when a run passes its wall-time limit."""


_local = threading.local()      # per worker thread: Sessions are not thread-safe


def _cache() -> OrderedDict:
    if not hasattr(_local, "sessions"):
        _local.sessions = OrderedDict()
    return _local.sessions


def _session(task: RunTask):
    """A built Session for the task's scene and overrides: reused when this worker built it before."""
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    key = (task.scene, task.sets)
    cache = _cache()
    if key in cache:
        cache.move_to_end(key)
        return cache[key], True
    reg = default_registry()
    resolved = resolve(task.scene.assembly, search_path=reg.assembly_paths(),
                       config_files=task.scene.config_files, overrides=list(task.scene.sets) + list(task.sets),
                       sim_overrides=task.scene.sim_overrides())
    s = Session(resolved, reg)
    cache[key] = s
    while len(cache) > SESSION_CACHE_SIZE:
        cache.popitem(last=False)
    return s, False


#: failure kinds (framework/outcomes.py) whose runs are recorded as ``diverged``; other failures are ``stopped``
DIVERGED_KINDS = ("blow_up", "non_finite", "integrator", "numerical")


def _status(summary: dict) -> str:
    """``ok`` for a run whose outcome is a success (its duration reached, or a success stop),
    ``diverged`` for a numerical failure (blow-up, non-finite state, integrator), ``stopped`` for
    any other failure (a scene's stop rule, a guard, a mobility failure, the memory limit)."""
    if summary.get("outcome") == "success":
        return "ok"
    return "diverged" if summary.get("failure_kind") in DIVERGED_KINDS else "stopped"


def execute(task: RunTask) -> dict:
    """Build and run one task; return its record (never raises)."""
    from snakesim.framework.errors import SnakesimError

    from .metrics import evaluate

    t0, cpu0 = time.perf_counter(), time.process_time()
    rec = {"run": task.index, "parameters": dict(task.parameters), "worker": f"{socket.gethostname()}:{os.getpid()}"}
    deadline = None if task.timeout_s is None else t0 + task.timeout_s

    def watchdog(t, t_end):
        # called by the simulator about every 0.5 s of wall time: the limit is checked that often
        if deadline is not None and time.perf_counter() > deadline:
            raise RunTimeout(f"wall-time limit {task.timeout_s:g} s passed at t = {t:.6g} s of {t_end:.6g} s")

    session = None
    try:
        session, reused = _session(task)
        rec["session_reused"] = reused
        rec["build_s"] = time.perf_counter() - t0
        if deadline is not None and time.perf_counter() > deadline:
            raise RunTimeout(f"wall-time limit {task.timeout_s:g} s passed while building")
        result = session.run(out_dir=task.run_dir, progress=watchdog)
        sm = result.summary
        status = _status(sm)
        rec.update(status=status, reason=None if status == "ok" else sm["stop_reason"],
                   stop_reason=sm["stop_reason"], outcome=sm["outcome"], failure_kind=sm["failure_kind"],
                   completed=bool(sm["completed"]), sim_time_s=sm["sim_time_s"],
                   wall_time_s=sm["wall_time_s"], real_time_factor=sm["real_time_factor"], steps=sm["steps"])
        try:
            rec["metrics"] = evaluate(task.metrics, result.log, sm)     # sm: report metrics
        except Exception as e:          # a metric that cannot be computed is this run's error, not the campaign's
            rec.update(status="error", reason=f"metrics: {type(e).__name__}: {e}", metrics={})
    except RunTimeout as e:
        rec.update(status="timeout", reason=str(e), outcome="failure", completed=False, metrics={})
        _cache().pop((task.scene, task.sets), None)       # stopped mid-run: do not reuse it
    except SnakesimError as e:
        rec.update(status="error", reason=f"{type(e).__name__}: {e}", outcome="failure", completed=False, metrics={})
        _cache().pop((task.scene, task.sets), None)
    except Exception as e:              # noqa: BLE001  a component's bug must not end the campaign
        tb = traceback.extract_tb(e.__traceback__)[-1]
        rec.update(status="error", reason=f"{type(e).__name__}: {e} ({tb.filename}:{tb.lineno})",
                   outcome="failure", completed=False, metrics={})
        _cache().pop((task.scene, task.sets), None)
    rec.setdefault("session_reused", False)
    rec["run_wall_s"] = time.perf_counter() - t0
    rec["cpu_s"] = time.process_time() - cpu0      # this worker's CPU: wall/cpu shows contention for cores
    return rec

