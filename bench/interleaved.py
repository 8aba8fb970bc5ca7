"""snakesim against MuJoCo's screw snake, timed in turns in this process (wall and CPU time).

On a shared, loaded machine one timing of each side, taken minutes apart, can differ by 1.5x
from load alone. So the two are run alternately, ``repeats`` pairs (snakesim, then MuJoCo), each
timed by the wall clock (``time.perf_counter``) and by this process's CPU time
(``time.process_time``: what the process itself ran, not the time other processes took the core;
numba and MuJoCo run on this one thread, BLAS is pinned to one). Each pair gives a ratio
RTF_snakesim / RTF_MuJoCo; the report gives their min and median for both clocks, and each side's
best.

MuJoCo's model is ../shared/peers/mujoco_snake.py's (its ``mjcf``, controls and step loop,
re-timed here with both clocks), at any of its integrators: Euler at 1 ms (the benches' former anchor) or
``implicitfast`` at 10 ms, MuJoCo's comparable snake at its own large stable step (issue 24's speed anchor:
``../shared/peers/mujoco_snake.py --integrator implicitfast --dt 0.01``).

    from interleaved import compare
    res = compare(run_snakesim, modules=10, mujoco_dt=1e-2, mujoco_integrator="implicitfast", repeats=5)

As a script it times a scene as a user runs it (its own settings, the run summary's real-time factor and CPU
time) against the anchor, in turns::

    .venv/bin/python bench/interleaved.py [SCENE] [--duration S] [--repeats N]
                                          [--mujoco-integrator implicitfast] [--mujoco-dt 0.01] [--json FILE]

``run_snakesim()`` runs one timed snakesim run and returns its summary: ``wall_time_s`` and
``cpu_time_s`` are the run's own step loop's (framework/simulator.py), without the build, the
recorder's set-up or a garbage collection around the call.
"""

from __future__ import annotations

import importlib.util
import statistics
import time
from pathlib import Path

import numpy as np

PEER = Path(__file__).resolve().parents[2] / "shared" / "peers" / "mujoco_snake.py"


def _peer():
    if not PEER.exists() or importlib.util.find_spec("mujoco") is None:
        return None
    spec = importlib.util.spec_from_file_location("mujoco_snake", PEER)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class MujocoSnake:
    """The peer's screw snake, built once; ``time(duration)`` -> (wall s, CPU s, steps) of stepping it
    ``duration`` simulated seconds from its initial state (the peer's loop: mj_step in chunks of 100)."""

    def __init__(self, modules: int, dt: float, integrator: str = "Euler"):
        import mujoco

        peer = _peer()
        self.mj, self.dt = mujoco, dt
        self.m = mujoco.MjModel.from_xml_string(peer.mjcf(modules, dt, integrator))
        self.d = mujoco.MjData(self.m)
        u = np.zeros(3 * modules)
        u[2::3] = peer.W_SCREW * np.where(np.arange(modules) % 2 == 0, 1.0, -1.0)
        self.u = u

    def time(self, duration: float) -> tuple[float, float, int]:
        mj, m, d = self.mj, self.m, self.d
        mj.mj_resetData(m, d)
        d.ctrl[:] = self.u
        steps, chunk = int(round(duration / self.dt)), 100
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(steps // chunk):
            mj.mj_step(m, d, chunk)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if not np.isfinite(d.qpos).all():
            raise FloatingPointError("MuJoCo's snake blew up")
        return wall, cpu, (steps // chunk) * chunk


def available() -> bool:
    return _peer() is not None


def compare(run_snakesim, modules: int = 10, mujoco_dt: float = 1e-3, mujoco_duration: float = 5.0,
            repeats: int = 5, mujoco_integrator: str = "Euler") -> dict:
    """``repeats`` alternating timings of snakesim (``run_snakesim()`` -> its run summary) and MuJoCo's
    snake with as many modules (``mujoco_integrator`` — Euler, RK4, implicit, implicitfast — at ``mujoco_dt``,
    ``mujoco_duration`` s). Returns both sides' real-time factors per repeat (wall and CPU) and the ratios'
    min / median / max; None for MuJoCo when it is not installed (then only snakesim's figures)."""
    mj = MujocoSnake(modules, mujoco_dt, mujoco_integrator) if available() else None
    if mj is not None:
        mj.time(min(0.5, mujoco_duration))                  # first touch
    rows = []
    for _ in range(repeats):
        c0 = time.process_time()
        sm = run_snakesim()
        # the step loop's own CPU time (the simulator's summary, as wall_time_s), else the whole call's
        cpu = sm.get("cpu_time_s", time.process_time() - c0)
        row = {"snakesim_rtf_wall": sm["real_time_factor"], "snakesim_rtf_cpu": sm["sim_time_s"] / max(cpu, 1e-9),
               "snakesim_wall_s": sm["wall_time_s"], "snakesim_cpu_s": cpu, "completed": sm["completed"]}
        if mj is not None:
            w, c, n = mj.time(mujoco_duration)
            sim = n * mj.dt
            row.update(mujoco_rtf_wall=sim / w, mujoco_rtf_cpu=sim / max(c, 1e-9))
            row.update(ratio_wall=row["snakesim_rtf_wall"] / row["mujoco_rtf_wall"],
                       ratio_cpu=row["snakesim_rtf_cpu"] / row["mujoco_rtf_cpu"])
        rows.append(row)
    out = {"modules": modules, "mujoco_dt": mujoco_dt, "mujoco_integrator": mujoco_integrator, "repeats": rows,
           "snakesim_rtf_wall_best": max(r["snakesim_rtf_wall"] for r in rows),
           "snakesim_rtf_cpu_best": max(r["snakesim_rtf_cpu"] for r in rows)}
    if mj is not None:
        out["mujoco_rtf_wall_best"] = max(r["mujoco_rtf_wall"] for r in rows)
        out["mujoco_rtf_cpu_best"] = max(r["mujoco_rtf_cpu"] for r in rows)
        for clock in ("wall", "cpu"):
            rs = [r[f"ratio_{clock}"] for r in rows]
            out[f"ratio_{clock}"] = {"min": min(rs), "median": statistics.median(rs), "max": max(rs)}
    return out


def describe(res: dict) -> str:
    """One line: both sides' best RTF and the ratios (median [min, max]) by wall and CPU time."""
    s = (f"snakesim RTF {res['snakesim_rtf_wall_best']:.3g} wall / {res['snakesim_rtf_cpu_best']:.3g} CPU (best of "
         f"{len(res['repeats'])})")
    if "ratio_wall" in res:
        w, c = res["ratio_wall"], res["ratio_cpu"]
        s += (f"; MuJoCo ({res['modules']} modules, {res.get('mujoco_integrator', 'Euler')} "
              f"{res['mujoco_dt'] * 1e3:g} ms) "
              f"{res['mujoco_rtf_wall_best']:.3g} wall / {res['mujoco_rtf_cpu_best']:.3g} CPU; "
              f"x MuJoCo, per interleaved pair: wall median {w['median']:.2f} [min {w['min']:.2f}, "
              f"max {w['max']:.2f}], CPU median {c['median']:.2f} [min {c['min']:.2f}, max {c['max']:.2f}]")
    else:
        s += "; MuJoCo not available (pip install mujoco): no ratio"
    return s


def main(argv=None) -> dict:
    """A scene at its own settings against MuJoCo's snake, in turns (see the module docstring)."""
    import argparse
    import json
    import os

    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # as `snakesim` runs
        os.environ.setdefault(var, "1")
    from snakesim.framework.session import load_session

    a = argparse.ArgumentParser(description="a scene at its own settings against MuJoCo's snake, timed in turns")
    a.add_argument("scene", nargs="?", default="surface-screw-traverse")
    a.add_argument("--duration", type=float, default=None, help="s (default: the scene's)")
    a.add_argument("--repeats", type=int, default=3)
    a.add_argument("--modules", type=int, default=10, help="MuJoCo snake's modules")
    a.add_argument("--mujoco-integrator", default="implicitfast", choices=["Euler", "RK4", "implicit", "implicitfast"])
    a.add_argument("--mujoco-dt", type=float, default=0.01)
    a.add_argument("--mujoco-duration", type=float, default=5.0)
    a.add_argument("--json")
    args = a.parse_args(argv)
    s = load_session(args.scene, sim_overrides={"duration": args.duration} if args.duration else None)
    s.run()                                                   # first touch (the session's compiled code is loaded)
    res = compare(lambda: s.run().summary, args.modules, args.mujoco_dt, args.mujoco_duration, args.repeats,
                  args.mujoco_integrator)
    print(f"{args.scene} ({s.resolved.sim.duration:g} s, {s.integrator.name} dt={s.resolved.sim.dt:g}): "
          + describe(res))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return res


if __name__ == "__main__":
    main()
