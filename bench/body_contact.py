"""Body contact cost per evaluation (``body_contact``, SDF back end) at 10 and 100 modules.

    .venv/bin/python bench/body_contact.py [--modules 10,100] [--spacing 0.03] [--json FILE]

Per evaluation of the component alone (Harness), the robot lying straight on flat ice with
its body samples pressing it:
  * mini-eels-1.0 (bodies only, r = 0.028 m);
  * eels-1.0 with ``exclude_screws: false`` (bodies and idle screws, as the shape-gait scenes),
    rolled on its side;
and the plane queried in numba (one call) or through ``Terrain.query`` (``fast_plane`` off),
with and without the broad phase; a robot 2 m above the ice shows the broad phase alone.
Reports µs per call, samples, samples queried and in contact, and ns per queried sample.
Best of a 0.3 s budget after a warm-up (numba caches compiled kernels).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import click  # noqa: E402

from snakesim.components.contact.body_contact import BodyContact  # noqa: E402
from snakesim.components.multibody import Multibody  # noqa: E402
from snakesim.components.terrain import load_terrain  # noqa: E402
from snakesim.framework import Harness  # noqa: E402

ICE = {"kind": "plane", "materials": [{"name": "ice", "k": 1.0e5, "c": 1.0e3, "mu": 0.1}]}
ROBOTS = {  # design -> (base height pressing the ice, base quaternion, body_contact params)
    "mini-eels-1.0": (0.0279, (0.0, 0.0, 0.0, 1.0), {}),
    "eels-1.0": (0.0885, (0.7071067812, 0.0, 0.0, 0.7071067812), {"exclude_screws": False}),
}


def _time_call(fn, budget=0.3):
    fn()
    best, t_end = float("inf"), time.perf_counter() + budget
    while time.perf_counter() < t_end:
        t0 = time.perf_counter()
        for _ in range(20):
            fn()
        best = min(best, (time.perf_counter() - t0) / 20)
    return best


def measure(design, modules, spacing, *, fast_plane=True, broad_phase=True, lift=0.0):
    z, q, params = ROBOTS[design]
    mb = Harness(Multibody, {"design": design, "modules": modules, "base_position": (0.0, 0.0, z + lift),
                             "base_quaternion": q})
    o = mb.outputs()
    h = Harness(BodyContact, dict(params, spacing=spacing, broad_phase=broad_phase), uses={"robot": mb.c.robot})
    h.c.fast_plane = fast_plane
    h.inputs.terrain = load_terrain(ICE)
    h.inputs.link_poses, h.inputs.link_velocities = o["link_poses"], o["link_velocities"]
    y = h.outputs()
    before = h.u.cache.stats
    dt = _time_call(lambda: h.c.output(0.0, None, h.u, h.y))
    after = h.u.cache.stats
    calls = after["evaluations"] - before["evaluations"]
    queried = (after["samples_queried"] - before["samples_queried"]) / calls
    return {"design": design, "modules": modules, "fast_plane": fast_plane, "broad_phase": broad_phase,
            "lift_m": lift, "samples": h.c.n_samples, "queried": queried, "in_contact": int(y["contacts"][0]),
            "us_per_call": dt * 1e6, "ns_per_queried_sample": dt * 1e9 / max(queried, 1)}


@click.command()
@click.option("--modules", default="10,100", help="module counts")
@click.option("--spacing", default=0.03, type=float, help="m between samples")
@click.option("--json", "json_path", type=click.Path(), default=None)
def main(modules, spacing, json_path):
    rows = []
    for design in ROBOTS:
        for n in [int(v) for v in modules.split(",")]:
            for fast, broad, lift in ((True, True, 0.0), (True, False, 0.0), (False, True, 0.0), (True, True, 2.0)):
                r = measure(design, n, spacing, fast_plane=fast, broad_phase=broad, lift=lift)
                rows.append(r)
                print(f"{design:14s} {n:4d} modules  plane {'numba' if fast else 'query'}  broad "
                      f"{'on ' if broad else 'off'}  lift {lift:.0f} m: {r['us_per_call']:9.1f} us/call, "
                      f"{r['samples']:6d} samples, {r['queried']:7.0f} queried, {r['in_contact']:5d} in contact, "
                      f"{r['ns_per_queried_sample']:6.1f} ns/queried sample")
    if json_path:
        with open(json_path, "w") as f:
            json.dump({"machine": platform.platform(), "processor": platform.processor(), "spacing": spacing,
                       "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
