"""A campaign: check everything up front, run the missing runs on a back end, keep the records and the table.

``prepare`` checks the dispersion file against the scene (every path resolved
with the scene, component parameter names checked against the component's
Params, metrics against what the scene records and which of its components
report) before anything runs; run i's
sample is drawn when run i is submitted (``Samples``), so any N starts at once,
and an N whose records could not be held (``RECORD_BYTES`` a run, against the
memory limit) is refused up front with the estimate. ``run_campaign`` submits the runs not yet recorded in OUT (a
bounded window of futures, so a campaign of 10^5 runs holds ~2 per worker in
flight), appends each finished run's record, and rebuilds the table at the end
or on interruption.
"""

from __future__ import annotations

import sys
import time
from concurrent.futures import FIRST_COMPLETED, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

from snakesim.framework.errors import ConfigError, SnakesimError

from .dispersions import DispersionFile, Samples, grid_size, load_dispersions, set_item
from .metrics import ReportMetric, parse_metrics, signal_metrics
from .results import RecordLog, check_identity, write_table
from .runner import RunTask, SceneSpec

WINDOW_PER_SLOT = 2          # futures in flight per worker thread: keeps workers busy, Ctrl-C prompt
#: bytes a finished run takes in memory (its record, kept for the table, and its row of the table)
RECORD_BYTES = 4000
#: the least time a base step takes (s): the CPU-time estimate of a refused campaign is a lower bound
MIN_STEP_S = 1e-6


@dataclass
class Plan:
    """Everything a campaign needs, checked: the scene, the dispersions, N runs' samples and metrics."""

    scene: SceneSpec
    dispersions: DispersionFile
    n: int
    seed: int
    samples: Samples | list[dict]      # run i's values, drawn when asked for
    metrics: tuple | None

    def identity(self) -> dict:
        """What makes two campaigns the same one (compared on resume)."""
        return {"scene": self.scene.assembly, "config_files": list(self.scene.config_files),
                "sets": list(self.scene.sets), "sim": {k: v for k, v in self.scene.sim},
                "dispersion_file": self.dispersions.text, "seed": self.seed, "n": self.n}

    def task(self, i: int, out: Path | None, save_runs: bool, timeout_s: float | None) -> RunTask:
        params = self.samples[i]
        return RunTask(index=i, scene=self.scene, sets=tuple(set_item(p, v) for p, v in params.items()),
                       parameters=params, metrics=self.metrics,
                       run_dir=str(out / "runs" / f"run-{i:05d}") if (save_runs and out is not None) else None,
                       timeout_s=timeout_s)


def _check_path(scene: SceneSpec, d, value, registry) -> None:
    """Resolve the scene with this one dispersion; a component parameter must be one its Params declares."""
    from snakesim.framework.assembly import resolve

    item = set_item(d.path, value)
    try:
        resolved = resolve(scene.assembly, search_path=registry.assembly_paths(), config_files=scene.config_files,
                           overrides=list(scene.sets) + [item], sim_overrides=scene.sim_overrides())
        parts = d.path.split(".")
        if parts[0] == "components" and len(parts) >= 4 and parts[2] == "params":
            spec = resolved.components[parts[1]]
            cls = registry.component(spec.type)
            fields = getattr(getattr(cls, "Params", None), "model_fields", None)
            if fields is not None and parts[3] not in fields:
                raise ConfigError(f"unknown parameter; {cls.__name__} takes: {', '.join(fields) or 'none'}",
                                  "--set", ".".join(parts[:4]))
        elif parts[0] == "components" and len(parts) >= 3 and parts[2] not in ("params", "rate", "uses", "type"):
            raise ConfigError(f"unknown key '{parts[2]}' of a component; valid: type, params, rate, uses",
                              "--set", d.path)
    except ConfigError as e:
        raise ConfigError(f"dispersion '{d.path}' ({d.dist}) does not fit scene {scene.assembly}: {e.detail}",
                          d.where, e.key or d.path) from None
    return resolved


def prepare(scene: SceneSpec, dispersion_file: str, n, seed: int | None = None, registry=None) -> Plan:
    """Load and check the dispersion file against the scene, and sample every run; nothing runs."""
    from snakesim.framework.registry import default_registry

    if isinstance(n, bool) or not isinstance(n, int) or n <= 0:
        raise ConfigError(f"the number of runs must be a positive integer, got {n!r}", "-n")
    df = load_dispersions(dispersion_file)
    metrics = parse_metrics(df.metrics, df.path)
    seed = df.seed if seed is None else seed
    if seed < 0:
        raise ConfigError(f"the seed must be a non-negative integer, got {seed}", "--seed")
    samples = Samples(df, n, seed)
    flags = dict(scene.sim)
    for d in df.dispersions:
        parts = d.path.split(".")
        if parts[0] == "sim" and len(parts) == 2 and parts[1] in flags:
            # explicit flags are the last layer: they would silently replace every sampled value
            raise ConfigError(f"dispersion '{d.path}' would be overridden by --{parts[1]} {flags[parts[1]]} "
                              f"on every run; drop one of them", d.where, d.path)
    clash = {m.name for m in metrics or ()} & set(df.paths)
    if clash:
        raise ConfigError(f"metric name '{sorted(clash)[0]}' is also a dispersed parameter: both would be one "
                          f"column of the table; rename the metric", df.path, f"metrics.{sorted(clash)[0]}")
    reg = registry or default_registry()
    resolved = None
    for d in df.dispersions:
        resolved = _check_path(scene, d, samples[0][d.path], reg)
    _check_metric_signals(metrics, resolved, df.path)
    _check_metric_reports(metrics, resolved, df.path, reg)
    check_campaign_size(n, resolved)
    return Plan(scene=scene, dispersions=df, n=n, seed=seed, samples=samples, metrics=metrics)


def campaign_estimate(n: int, resolved=None) -> dict:
    """What N runs need: memory for their records and table (bytes), and (with the resolved scene) base steps
    a run and a lower bound on the CPU time of all of them (s, at :data:`MIN_STEP_S` a step)."""
    est = {"runs": n, "memory_bytes": n * float(RECORD_BYTES), "steps_per_run": None, "cpu_s_at_least": None}
    sim = getattr(resolved, "sim", None)
    if sim is not None and getattr(sim, "duration", None) and getattr(sim, "dt", None):
        steps = max(1.0, float(sim.duration) / float(sim.dt))
        est.update(steps_per_run=steps, cpu_s_at_least=n * steps * MIN_STEP_S)
    return est


def _fmt_time(s: float) -> str:
    for unit, size in (("years", 3.156e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= size:
            return f"{s / size:.3g} {unit}"
    return f"{s:.3g} s"


def check_campaign_size(n: int, resolved=None) -> None:
    """Refuse, before anything is drawn or run, a campaign whose records would not fit in memory, with the
    estimate of its memory and time and the largest N that fits."""
    from snakesim.framework.limits import fmt_bytes, memory_limit_bytes

    est, limit = campaign_estimate(n, resolved), memory_limit_bytes()
    if est["memory_bytes"] <= limit:
        return
    time_text = ""
    if est["cpu_s_at_least"] is not None:
        time_text = (f"; each run is {est['steps_per_run']:.3g} steps, so even at {MIN_STEP_S * 1e6:g} µs a step "
                     f"they take at least {_fmt_time(est['cpu_s_at_least'])} of CPU time")
    raise ConfigError(f"{n} runs: their records and table would take ~{fmt_bytes(est['memory_bytes'])} "
                      f"(~{fmt_bytes(RECORD_BYTES)} a run), over the memory limit {fmt_bytes(limit)} (half the "
                      f"physical memory, or SNAKESIM_MEMORY_LIMIT){time_text}; at most {int(limit // RECORD_BYTES)} "
                      f"runs fit in one campaign: split it (--seed, separate --out folders)", "-n")


def _check_metric_signals(metrics, resolved, file: str) -> None:
    """A declared metric must name a recorded port or one of its columns (``port.x``, ``port[2]``)."""
    if not metrics:
        return
    ports = [r for r, _ in resolved.record]
    for m in signal_metrics(metrics):
        if not any(m.signal == p or m.signal.startswith(p + ".") or m.signal.startswith(p + "[") for p in ports):
            raise ConfigError(f"'{m.signal}' is not recorded by the scene; recorded ports: {', '.join(ports) or 'none'}",
                              file, f"metrics.{m.name}.signal")


def _check_metric_reports(metrics, resolved, file: str, registry) -> None:
    """A report metric must name a component of the scene whose type reports (defines ``report``); whether
    the key is there is known only after a run (the report's content), so that is the run's error."""
    reports = [m for m in metrics or () if isinstance(m, ReportMetric)]
    if not reports:
        return
    reporting = [name for name, _, cls in registry.classes_in(resolved) if callable(getattr(cls, "report", None))]
    for m in reports:
        if m.component not in resolved.components:
            raise ConfigError(f"'{m.component}' is not a component of the scene; its components: "
                              f"{', '.join(resolved.components) or 'none'} (those that report: "
                              f"{', '.join(reporting) or 'none'})", file, f"metrics.{m.name}.report")
        cls = registry.components.get(resolved.components[m.component].type)
        if cls is not None and not callable(getattr(cls, "report", None)):
            raise ConfigError(f"component '{m.component}' ({cls.__name__}) gives no report; the scene's components "
                              f"that report: {', '.join(reporting) or 'none'}", file, f"metrics.{m.name}.report")


class Progress:
    """One status line on stderr: done/total, failed, runs per minute, estimated time left."""

    def __init__(self, total: int, already: int, stream=None, quiet: bool = False):
        self.total, self.already, self.quiet = total, already, quiet
        self.stream = stream
        self.done = self.failed = 0
        self.t0 = time.perf_counter()
        self._last = 0.0

    def update(self, failed: bool, force: bool = False) -> None:
        self.done += 1
        self.failed += failed
        self.show(force)

    def show(self, force: bool = False) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        if not force and now - self._last < 0.2 and self.already + self.done < self.total:
            return
        self._last = now
        out = self.stream or sys.stderr
        finished = self.already + self.done
        elapsed = now - self.t0
        rate = self.done / elapsed if elapsed > 0 and self.done else 0.0
        left = (self.total - finished) / rate if rate else float("nan")
        eta = "--:--" if left != left else time.strftime("%H:%M:%S", time.gmtime(left))
        frac = finished / self.total
        bar = "#" * int(24 * frac)
        out.write(f"\r  [{bar:<24}] {finished}/{self.total} done, {self.failed} failed, "
                  f"{60 * rate:.3g} runs/min, ETA {eta} ")
        out.flush()

    def close(self) -> None:
        if not self.quiet:
            (self.stream or sys.stderr).write("\n")


def run_campaign(plan: Plan, out: Path, backend, *, save_runs: bool = False, timeout_s: float | None = None,
                 retry_failed: bool = False, fresh: bool = False, quiet: bool = False, stream=None,
                 stop_after: int | None = None) -> dict:
    """Run every run of ``plan`` not yet recorded in ``out``; return {"records", "table", "ran", "resumed"}.

    ``stop_after`` ends the loop after that many newly finished runs (what an
    interruption does; the tests' and the benchmark's hook).
    """
    out = Path(out)
    resumed = check_identity(out, plan.identity(), fresh=fresh)
    log = RecordLog(out)
    records = log.load()
    if retry_failed:
        records = {i: r for i, r in records.items() if r.get("status") not in ("error", "timeout")}
    # the runs to do, in order, generated as the window frees (never a list of N)
    n_todo = plan.n - sum(1 for i in records if 0 <= i < plan.n)
    queue = (i for i in range(plan.n) if i not in records)
    if not quiet and stream is None:
        g = grid_size(plan.dispersions.dispersions)
        if g > 1 and plan.n % g:
            print(f"note: N = {plan.n} is not a multiple of the grid's {g} points: the first "
                  f"{plan.n % g} points run once more than the rest", file=sys.stderr)
        if resumed:
            print(f"resuming {out}: {len(records)} of {plan.n} runs recorded, {n_todo} to run", file=sys.stderr)
    progress = Progress(plan.n, len(records), stream=stream, quiet=quiet)
    if n_todo:
        progress.show(force=True)
    window = WINDOW_PER_SLOT * backend.slots
    pending: dict = {}
    queue_done = n_todo == 0
    ran = 0

    def finish(rec):
        nonlocal ran
        log.append(rec)
        records[rec["run"]] = rec
        ran += 1
        progress.update(rec["status"] not in plan.dispersions.success)

    from .runner import execute

    try:
        while not queue_done or pending:
            while not queue_done and len(pending) < window and (stop_after is None or ran + len(pending) < stop_after):
                i = next(queue, None)
                if i is None:
                    queue_done = True
                    break
                task = plan.task(i, out, save_runs, timeout_s)
                pending[backend.executor.submit(execute, task)] = task
            if not pending:
                break
            done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            broken = False
            for fut in done:
                task = pending.pop(fut)
                try:
                    rec = fut.result()
                except BrokenProcessPool as e:
                    broken = True
                    rec = _lost(task, f"worker process died while this run was in flight ({e})")
                except Exception as e:      # noqa: BLE001  e.g. dask's KilledWorker: that run's problem
                    rec = _lost(task, f"{type(e).__name__}: {e}")
                finish(rec)
            if broken:
                # every other in-flight run shared the broken pool: record them too, then go on on a fresh one
                for fut, task in list(pending.items()):
                    finish(_lost(task, "worker pool broke (another run's worker process died) while in flight"))
                pending.clear()
                backend.restart()
    except BaseException:
        # the table is still written from what finished; when that fails too (a full disk), the first
        # error is the one reported
        _close(progress, pending)
        try:
            write_table(out, records, [d.path for d in plan.dispersions.dispersions])
        except SnakesimError:
            pass
        raise
    _close(progress, pending)
    table = write_table(out, records, [d.path for d in plan.dispersions.dispersions])
    return {"records": records, "table": table, "ran": ran, "resumed": resumed}


def _close(progress: Progress, pending: dict) -> None:
    progress.close()
    for fut in pending:
        fut.cancel()


def _lost(task: RunTask, reason: str) -> dict:
    return {"run": task.index, "parameters": dict(task.parameters), "status": "error", "reason": reason,
            "outcome": "failure", "completed": False, "metrics": {}, "worker": None, "session_reused": False}

