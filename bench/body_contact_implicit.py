"""Body contact integrated implicitly: rosenbrock_w on body_contact's analytic Jacobian against RK4, on the
Mini EELS scenes, in one process (wall-time ratios; the machine drifts between runs).

    .venv/bin/python bench/body_contact_implicit.py [--duration-crawl 6] [--duration-climb 4]

mini-eels-crawl: the late crawl speed (m/s, fit over the second half); mini-eels-pipe-climb: the evaluation's
net climb (m). Each row: integrator, step, result, wall s, and the result's deviation from RK4 at 0.5 ms.
"""

from __future__ import annotations

import time

import click
import numpy as np

from snakesim.framework.session import load_session


def crawl(duration, **sim):
    s = load_session("mini-eels-crawl", sim_overrides={"duration": duration, **sim})
    t0 = time.perf_counter()
    r = s.run()
    wall = time.perf_counter() - t0
    t, com = np.asarray(r["t"]), np.asarray(r["robot.com"])
    late = t >= t[-1] / 2
    v = np.hypot(*(np.polyfit(t[late], com[late, j], 1)[0] for j in range(2)))
    return float(v), wall, r.summary["completed"]


def climb(duration, **sim):
    s = load_session("mini-eels-pipe-climb", sim_overrides={"duration": duration, **sim})
    t0 = time.perf_counter()
    r = s.run()
    wall = time.perf_counter() - t0
    return r.summary["reports"]["evaluation"]["vertical_distance"]["net_m"], wall, r.summary["completed"]


@click.command()
@click.option("--duration-crawl", type=float, default=6.0)
@click.option("--duration-climb", type=float, default=4.0)
def main(duration_crawl, duration_climb):
    for name, fn, d, unit, cases in [
        ("mini-eels-crawl", crawl, duration_crawl, "m/s",
         [("rk4", 5e-4), ("rk4", 1e-3), ("rosenbrock_w", 1e-3), ("rosenbrock_w", 2e-3), ("rosenbrock_w", 5e-3)]),
        ("mini-eels-pipe-climb", climb, duration_climb, "m",
         [("rk4", 5e-4), ("rk4", 1e-3), ("rosenbrock_w", 1e-3), ("rosenbrock_w", 2e-3)])]:
        print(f"{name} ({d:g} s simulated): result in {unit}")
        ref = ref_wall = None
        for integ, dt in cases:
            try:
                val, wall, ok = fn(d, integrator=integ, dt=dt)
            except Exception as e:            # an unstable step ends the run: say so
                print(f"  {integ:13s} {dt * 1e3:4.1f} ms  failed: {e}")
                continue
            if ref is None:
                ref, ref_wall = val, wall
            print(f"  {integ:13s} {dt * 1e3:4.1f} ms  {val:8.4f} {unit}  {'' if ok else '(stopped early) '}"
                  f"wall {wall:6.2f} s ({ref_wall / wall:4.2f}x RK4 0.5 ms)  deviation {100 * (val / ref - 1):+6.1f} %")


if __name__ == "__main__":
    main()
