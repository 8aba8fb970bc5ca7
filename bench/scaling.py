"""Real-time factor of the default scene against module count.

assemblies/surface-screw-traverse.yaml (EELS 1.0 on flat ice, joint PIDs, screw
schedule, SDF screw contact) with ``robot.modules`` = 4, 10, 30, 100, each run for
``--duration`` simulated seconds at the given integrator and step, after a warm-up run
(numba caches, first touch). Reports wall time per simulated second, the real-time
factor (sim time / wall time; > 1 is faster than real time), µs per step, the build
time, and whether the run completed.

    .venv/bin/python bench/scaling.py [--modules 4,10,30,100] [--integrator semi_implicit_euler]
                                      [--method ros2] [--jacobian-every N] [--dense] [--dt 0.001]
                                      [--duration 2] [--repeats 2] [--accuracy SECONDS] [--json FILE]

Each row also times MuJoCo's screw snake with as many modules in this process, one MuJoCo run
after each timed snakesim run (../shared/peers/mujoco_snake.py; bench/interleaved.py: wall clock and
CPU time), and prints the ratio per pair (median [min]), the
process's peak resident memory (``peak_rss_mb``: rows run in ascending module count), and
the peak of ``snakesim check --modules N`` in a child process of its own
(``check_peak_mb``, the child's own VmHWM). Issue 13's target: ≤ 1 GB at 100 modules.
Measured (2-core shared machine, /usr/bin/time): 100 modules, ``check`` 6.56 -> 1.19 GB,
a run 2.05 -> 1.29 GB (the rest was the one Data's 0.92 GB of nv³ tensors, zeroed, so touched,
by its constructor: components/multibody/model.py ``new_data``); with the forward dynamics and
the implicit step on the link tree (no Data, components/multibody/articulated_solve_kernels.py)
a 100-module run peaks at ~0.28 GB; ``check --baseline`` 3.4 GB. ``--dense`` (rosenbrock_w)
also times the previous path (Pinocchio's ABA, CRBA and one dense LU per Jacobian) in the same
process.

Targets (issue 6): ≥ 10x real time at 10 modules, ≥ 1.5x at 100 modules. Reference
figures from the issue: MuJoCo ~17-25x at 10 modules but 0.17x at 100; a hand-written
Pinocchio + numpy loop ~8x at 10 and 1.7x at 100. At 100 modules Pinocchio 4.1's Data
takes ~0.9 GB and a few seconds to build (components/multibody/model.py ``new_data``).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import gc  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import click  # noqa: E402

from snakesim.framework.session import load_session  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from interleaved import compare  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from validation_scenes import session  # noqa: E402

SCENE = "surface-screw-traverse"
TARGETS = {10: 10.0, 100: 1.5}


def check_peak_mb(modules: int) -> float | None:
    """Peak resident memory, MB, of ``snakesim check SCENE --modules N`` in a child process: its own
    VmHWM (/proc/self/status), read as it exits. Not the child's getrusage ru_maxrss: Linux carries
    the parent's high-water mark across fork and exec, so that would report this process's peak."""
    code = ("import sys\nfrom snakesim.framework.cli import main\nsys.argv[0] = 'snakesim'\ntry:\n    main()\n"
            "finally:\n    hwm = [ln for ln in open('/proc/self/status') if ln.startswith('VmHWM:')]\n"
            "    sys.stderr.write('\\n' + (hwm[0] if hwm else 'VmHWM: nan kB\\n'))\n")
    proc = subprocess.run([sys.executable, "-c", code, "check", SCENE, "--modules", str(modules)],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("VmHWM:")]
    if proc.returncode != 0 or not lines:
        return None
    return float(lines[-1].split()[1]) / 1024.0


def _one_run(s):
    gc.collect()
    gc.disable()
    try:
        return s.run().summary
    finally:
        gc.enable()


def _best_run(s, repeats):
    s.run()         # warm-up
    best = None
    for _ in range(repeats):
        r = _one_run(s)
        if best is None or r["wall_time_s"] < best["wall_time_s"]:
            best = r
    return best


def _interleaved_runs(s, modules, dt, duration, repeats):
    """``repeats`` runs of the session, each followed by MuJoCo's snake with as many modules (Euler at
    min(dt, 2 ms), min(duration, 2) s; bench/interleaved.py): (fastest run's summary, the comparison)."""
    s.run()         # warm-up
    summaries = []

    def one():
        summaries.append(_one_run(s))
        return summaries[-1]

    cmp = compare(one, modules=modules, mujoco_dt=dt if dt <= 2e-3 else 2e-3, mujoco_duration=min(duration, 2.0),
                  repeats=repeats)
    return min(summaries, key=lambda r: r["wall_time_s"]), cmp


def scene_row(modules: int, integrator: str, dt: float, duration: float, repeats: int, params: dict,
              dense: bool = False) -> dict:
    t0 = time.perf_counter()
    s = load_session(SCENE, overrides=[f"robot.modules={modules}"],
                     sim_overrides={"duration": duration, "integrator": {"name": integrator, "params": params},
                                    "dt": dt})
    build = time.perf_counter() - t0
    best, cmp = _interleaved_runs(s, modules, dt, duration, repeats)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    nv = s.plan.components["robot"].dyn.model.nv
    del s
    gc.collect()
    dense_rtf = None
    if dense and integrator == "rosenbrock_w":
        # the previous path, timed in this process after this row's peak memory was read: Pinocchio's
        # ABA (its Data: nv³ tensors), the implicit step's M from its CRBA and one dense LU
        s = session(SCENE, [f"robot.modules={modules}"],
                    {"duration": duration, "integrator": {"name": integrator, "params": params}, "dt": dt},
                    lambda r: r.components["robot"].params.__setitem__("dynamics", "pinocchio"))
        mb = s.plan.components["robot"]
        mb.structured_solve, mb.dyn.tree_mass_matrix = False, None
        dense_rtf = _best_run(s, repeats)["real_time_factor"]
        del s, mb
        gc.collect()
    return {"modules": modules, "nv": nv, "integrator": integrator, "dt_s": dt, "sim_time_s": best["sim_time_s"],
            "wall_time_s": best["wall_time_s"], "real_time_factor": best["real_time_factor"],
            "us_per_step": best["wall_time_s"] / max(1, best["steps"]) * 1e6, "build_s": build,
            "completed": best["completed"], "target_rtf": TARGETS.get(modules), "dense_lu_rtf": dense_rtf,
            "peak_rss_mb": peak,
            "check_peak_mb": check_peak_mb(modules),
            "real_time_factor_cpu": cmp["snakesim_rtf_cpu_best"],
            "mujoco_rtf": cmp.get("mujoco_rtf_wall_best"), "x_mujoco_wall": cmp.get("ratio_wall"),
            "x_mujoco_cpu": cmp.get("ratio_cpu"), "interleaved": cmp["repeats"]}


ACCURACY_SETS = ["settle=0.5", "phase=1.5"]      # the schedule compressed: drive, turn, stop from 8 s


def accuracy_row(modules: int, integrator: str, dt: float, params: dict, horizon: float) -> dict:
    """Tail error of the setting against the converged reference (rk4 at 0.25 ms, the validation
    reference setting) at ``modules`` on the compressed schedule over ``horizon`` s: max |tail (x, y)
    − reference| and max |yaw − reference| (tests/validation/validation_scenes.py track_error), as
    bench/tradeoff.py measures the 10-module traverse."""
    from validation_scenes import REFERENCE, tail_track, track_error
    sets = ACCURACY_SETS + [f"robot.modules={modules}"]
    ref = session(SCENE, sets, {"duration": horizon, "dt": REFERENCE["dt"], "integrator": REFERENCE["integrator"]}).run()
    r = session(SCENE, sets, {"duration": horizon, "dt": dt,
                              "integrator": {"name": integrator, "params": params}}).run()
    t, p = tail_track(r)
    t_ref, p_ref = tail_track(ref)
    return {"modules": modules, "horizon_s": horizon, "rtf": r.summary["real_time_factor"],
            "reference_rtf": ref.summary["real_time_factor"], **track_error(t, p, t_ref, p_ref)}


@click.command()
@click.option("--modules", default="4,10,30,100", help="comma-separated module counts")
@click.option("--integrator", default="semi_implicit_euler")
@click.option("--dt", default=0.001, help="s, base step (the recommended default)")
@click.option("--duration", default=2.0, help="simulated seconds per run")
@click.option("--repeats", default=2, help="timed runs per module count (best kept)")
@click.option("--method", default=None, help="rosenbrock_w's method (ros2, ros34pw2)")
@click.option("--jacobian-every", type=int, default=None, help="rosenbrock_w's jacobian_every")
@click.option("--dense", is_flag=True, help="rosenbrock_w: also time the dense-LU solve of the implicit step "
                                              "(the link-tree factorisation off) in the same process")
@click.option("--accuracy", type=float, default=None,
              help="also the tail error against rk4 at 0.25 ms over this many seconds of the compressed "
                   "schedule (settle 0.5, phases 1.5 s), per module count")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default="bench/results/scaling.json",
              show_default=True, help="write the figures here (machine-readable)")
def main(modules, integrator, dt, duration, repeats, method, jacobian_every, dense, accuracy, json_path):
    params = {"method": method} if method else {}
    if jacobian_every:
        params["jacobian_every"] = jacobian_every
    elif integrator == "rosenbrock_w":      # explicit: the scene's own params merge under the override
        params["jacobian_every"] = 1
    rows = [scene_row(int(m), integrator, dt, duration, repeats, params, dense)
            for m in sorted(map(int, modules.split(",")))]
    print(f"{SCENE}, {integrator}{params or ''} at dt = {dt * 1e3:g} ms, {duration:g} s simulated, best of {repeats}")
    print("MuJoCo: its screw snake with as many modules, timed in this process (Euler at min(dt, 2 ms));\n"
          "peak MB: the process's peak so far (rows run in ascending module count, so a row's figure is its own\n"
          "peak unless an earlier row's was higher); check MB: `snakesim check --modules N`'s peak, its own process")
    print("RTF: the fastest of the runs by the wall clock (CPU: by process CPU time); ratio: RTF / MuJoCo's RTF per\n"
          "interleaved pair (each run followed by a MuJoCo run), median [min], wall clock and CPU time")
    print(f"{'modules':>7s} {'nv':>5s} {'build s':>8s} {'wall s':>8s} {'us/step':>9s} {'RTF':>7s} {'RTF CPU':>7s} "
          f"{'target':>7s} {'MuJoCo':>7s} {'ratio wall':>13s} {'ratio CPU':>13s} {'peak MB':>8s} {'check MB':>8s}")
    for r in rows:
        tgt = f"{r['target_rtf']:g}" if r["target_rtf"] else "-"
        flag = "" if r["completed"] else "  (did not complete)"
        if r["target_rtf"] and r["real_time_factor"] < r["target_rtf"]:
            flag += "  (below target)"
        mj = r["mujoco_rtf"]
        fmt = lambda x: f"{x['median']:.2f} [{x['min']:.2f}]" if x else "-"  # noqa: E731
        mjs = f"{mj:7.2f}" if mj else f"{'-':>7s}"
        print(f"{r['modules']:7d} {r['nv']:5d} {r['build_s']:8.2f} {r['wall_time_s']:8.3f} {r['us_per_step']:9.1f} "
              f"{r['real_time_factor']:7.2f} {r['real_time_factor_cpu']:7.2f} {tgt:>7s} {mjs} "
              f"{fmt(r['x_mujoco_wall']):>13s} {fmt(r['x_mujoco_cpu']):>13s} {r['peak_rss_mb']:8.0f} "
              f"{r['check_peak_mb'] or float('nan'):8.0f}{flag}")
        if r["dense_lu_rtf"]:
            print(f"{'':7s} previous path (Pinocchio ABA, CRBA + dense LU in the implicit step), this process: "
                  f"RTF {r['dense_lu_rtf']:.2f}; link tree {r['real_time_factor'] / r['dense_lu_rtf']:.2f}x faster")
    acc = []
    if accuracy:
        print(f"\naccuracy: tail error against rk4 at 0.25 ms, {accuracy:g} s of the compressed schedule "
              f"({', '.join(ACCURACY_SETS)}); issue 13's rule: < 1 cm, < 0.02 rad")
        print(f"{'modules':>7s} {'pos err mm':>10s} {'yaw err rad':>11s} {'RTF':>7s}")
        for m in sorted(map(int, modules.split(","))):
            a = accuracy_row(m, integrator, dt, params, accuracy)
            acc.append(a)
            print(f"{m:7d} {a['pos_err_m'] * 1e3:10.2f} {a['yaw_err_rad']:11.4f} {a['rtf']:7.2f}", flush=True)
    if json_path:
        with open(json_path, "w") as fh:
            json.dump({"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
                       "scene": SCENE, "rows": rows, "accuracy": acc}, fh, indent=2)
        print(f"wrote {json_path}")


if __name__ == "__main__":
    main()
