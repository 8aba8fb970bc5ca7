"""Campaign throughput and overhead: runs per minute with 1 and 2 workers, and the cost per run of the machinery.

Three measurements on the same N runs of one scene (default: the pendulum,
5 s at dt = 1 ms with rk4, damping and theta0 dispersed uniformly):

    alone       resolve + build + run of each run's overrides in this one process, warm
                (the scene run by hand, no campaign): s per run
    1 worker    the campaign on a local pool of 1 worker; 2 workers: of 2. Each pool is
                started and warmed once (one run per worker: imports, registry, numba caches;
                its time is reported), then each timed campaign writes its records, table
                and Parquet like a real one; runs per minute = N / wall time of the campaign.
                The three are interleaved --repeats times and the best of each counts: the
                machine is shared and its speed drifts.

    ratio       runs/min with 2 workers / with 1 (goal >= 1.8 on 2 cores)
    cores got   the workers' CPU seconds / wall time: how many cores the workers actually had
                (below 2 with 2 workers means other processes took the rest, not the campaign)
    overhead    1-worker s per run - alone s per run (sensitive to the machine's load), and
                directly: dispatch + records (campaign wall x workers - the runs' own wall on
                the workers) / N, and inside the worker what is neither build nor simulation

A second table shows what a worker's reuse buys on a robot scene
(``--reuse-scene``, default contact-screw-drive): the first build in a fresh
process (imports, numba caches), later builds with new numbers (what a
continuous dispersion pays every run), and a re-run of a cached Session (what
a repeated grid or choice value pays).

    python bench/campaign.py [--n 24] [--duration 5] [--repeats 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

GOAL_RATIO = 1.8


def _plan(scene, duration, n, tmp):
    from snakesim.campaigns.campaign import prepare
    from snakesim.campaigns.runner import SceneSpec

    f = Path(tmp) / "bench-dispersions.yaml"
    f.write_text(textwrap.dedent("""
        seed: 1
        dispersions:
          damping: {dist: uniform, low: 0.01, high: 0.2}
          components.pend.params.theta0: {dist: uniform, low: 0.05, high: 0.4}
    """).lstrip("\n"))
    return prepare(SceneSpec(scene, sim=(("duration", duration),)), str(f), n)


def alone(plan) -> float:
    """s per run: each run's overrides resolved, built and run in this process (warm)."""
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    reg = default_registry()

    def one(i):
        t = plan.task(i, None, False, None)
        r = resolve(t.scene.assembly, search_path=reg.assembly_paths(), overrides=list(t.sets),
                    sim_overrides=t.scene.sim_overrides())
        Session(r, reg).run()

    one(0)
    t0 = time.perf_counter()
    for i in range(plan.n):
        one(i)
    return (time.perf_counter() - t0) / plan.n


def start_pool(plan, workers: int, tmp):
    """A local pool, warmed by one run per worker (imports, registry, numba caches); its start-up time."""
    from dataclasses import replace

    from snakesim.campaigns.backends import local_pool
    from snakesim.campaigns.campaign import run_campaign

    t0 = time.perf_counter()
    backend = local_pool(workers)
    warm = replace(plan, n=workers, samples=plan.samples[:workers])
    run_campaign(warm, Path(tmp) / f"warm-{workers}", backend, quiet=True)
    return backend, time.perf_counter() - t0


def campaign(plan, backend, workers: int, tmp, rep: int) -> dict:
    """One timed campaign of plan.n runs on a warm pool (records, table and Parquet written as usual)."""
    from snakesim.campaigns.campaign import run_campaign

    t0 = time.perf_counter()
    res = run_campaign(plan, Path(tmp) / f"timed-{workers}-{rep}", backend, quiet=True)
    wall = time.perf_counter() - t0
    statuses = {r["status"] for r in res["records"].values()}
    recs = list(res["records"].values())
    cpu = sum(r.get("cpu_s", 0.0) for r in recs)
    in_worker = sum(r["run_wall_s"] for r in recs)
    # what the machinery adds: the parent's dispatch, records and table (wall not spent inside a
    # run on a worker), and inside the worker what is neither build nor simulation (metrics, watchdog)
    dispatch = (wall * workers - in_worker) / plan.n
    worker_extra = sum(r["run_wall_s"] - r["build_s"] - r["wall_time_s"] for r in recs) / plan.n
    return {"workers": workers, "dispatch_s_per_run": dispatch, "worker_extra_s_per_run": worker_extra, "busy_cores": cpu / wall, "cpu_s_per_run": cpu / plan.n,
            "wall_s": wall, "runs_per_min": 60 * plan.n / wall, "s_per_run": wall / plan.n,
            "statuses": sorted(statuses)}


REUSE_SCRIPT = """
import json, sys, time
t0 = time.perf_counter()
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session
reg = default_registry()
t_reg = time.perf_counter() - t0
scene, dur = sys.argv[1], sys.argv[2]
def build(extra):
    r = resolve(scene, search_path=reg.assembly_paths(), overrides=[f"sim.duration={dur}"] + extra)
    return Session(r, reg)
out = {"import_and_registry_s": t_reg}
t = time.perf_counter(); s = build([]); out["first_build_s"] = time.perf_counter() - t
t = time.perf_counter(); s.run(); out["first_run_s"] = time.perf_counter() - t
builds = []
for dt in (0.001, 0.0005, 0.00025):          # new numbers each time: a rebuild, as a continuous dispersion does
    t = time.perf_counter(); s2 = build([f"sim.dt={dt}"]); builds.append(time.perf_counter() - t)
out["later_build_s"] = min(builds)
t = time.perf_counter(); s.run(); out["rerun_cached_session_s"] = time.perf_counter() - t
print(json.dumps(out))
"""


def reuse(scene: str, duration: float) -> dict:
    """Build costs in a fresh process (subprocess: nothing imported or compiled yet)."""
    p = subprocess.run([sys.executable, "-c", REUSE_SCRIPT, scene, str(duration)], capture_output=True, text=True,
                       check=True)
    return {"scene": scene, "duration_s": duration, **json.loads(p.stdout.strip().splitlines()[-1])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="pendulum")
    ap.add_argument("--n", type=int, default=24, help="runs per timed campaign")
    ap.add_argument("--duration", type=float, default=5.0, help="simulated s per run")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repetitions; the best counts")
    ap.add_argument("--reuse-scene", default="contact-screw-drive")
    ap.add_argument("--reuse-duration", type=float, default=0.2)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    load = os.getloadavg()[0]        # before this bench adds its own processes
    with tempfile.TemporaryDirectory() as tmp:
        plan = _plan(a.scene, a.duration, a.n, tmp)
        pool1, start1 = start_pool(plan, 1, tmp)
        pool2, start2 = start_pool(plan, 2, tmp)
        alones, ones, twos = [], [], []
        # interleaved, best of --repeats: the machine is shared, its speed drifts between measurements
        for rep in range(a.repeats):
            alones.append(alone(plan))
            ones.append(campaign(plan, pool1, 1, tmp, rep))
            twos.append(campaign(plan, pool2, 2, tmp, rep))
        pool1.close()
        pool2.close()
    s_alone = min(alones)
    one = min(ones, key=lambda r: r["wall_s"])
    two = min(twos, key=lambda r: r["wall_s"])
    one["pool_start_s"], two["pool_start_s"] = start1, start2
    ratio = two["runs_per_min"] / one["runs_per_min"]
    overhead = one["s_per_run"] - s_alone
    print(f"{a.scene}, {a.duration:g} s per run, N = {a.n}, {os.cpu_count()} cores, load average {load:.2f} before "
          f"the bench (other processes take cores from the workers)\n")
    print(f"best of {a.repeats}, interleaved\n")
    print("| how | s/run | runs/min | pool start-up + warm-up s | worker CPU s/run | cores the workers got |")
    print("|---|---:|---:|---:|---:|---:|")
    print(f"| alone, one process | {s_alone:.3f} | {60 / s_alone:.1f} | — | — | — |")
    for r in (one, two):
        print(f"| campaign, {r['workers']} worker{'s' * (r['workers'] > 1)} | {r['s_per_run']:.3f} | "
              f"{r['runs_per_min']:.1f} | {r['pool_start_s']:.2f} | {r['cpu_s_per_run']:.3f} | "
              f"{r['busy_cores']:.2f} |")
    print(f"\nratio 2/1 workers: {ratio:.2f} (goal >= {GOAL_RATIO}); 1 worker - alone: {1e3 * overhead:.1f} ms per run "
          f"({100 * overhead / s_alone:.1f} % of a run alone)")
    print(f"machinery per run (1 worker): dispatch + records {1e3 * one['dispatch_s_per_run']:.1f} ms, "
          f"in the worker besides build and simulation {1e3 * one['worker_extra_s_per_run']:.1f} ms")
    ru = reuse(a.reuse_scene, a.reuse_duration)
    print(f"\nreuse on a worker, {ru['scene']} ({ru['duration_s']:g} s runs): imports + registry "
          f"{ru['import_and_registry_s']:.2f} s, first build {ru['first_build_s']:.3f} s, later builds "
          f"{ru['later_build_s']:.3f} s, run {ru['first_run_s']:.3f} s, re-run of a cached Session "
          f"{ru['rerun_cached_session_s']:.3f} s")
    result = {"scene": a.scene, "duration_s": a.duration, "n": a.n, "cores": os.cpu_count(),
              "python": platform.python_version(), "load_average_1min": load, "alone_s_per_run": s_alone, "one_worker": one,
              "two_workers": two, "repeats": a.repeats, "all": {"alone": alones, "one": ones, "two": twos}, "ratio": ratio, "goal_ratio": GOAL_RATIO, "overhead_s_per_run": overhead,
              "reuse": ru}
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(result, indent=2))
    return 0 if ratio >= GOAL_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
