"""Screw contact cost per sample (SDF back end, and `hull_contact` when registered) and the
end-to-end real-time factor of the surface screw-drive scene.

    .venv/bin/python bench/contact.py [--json FILE] [--modules 4,10,30] [--integrator rk4] [--duration 2]

Part 1, per evaluation of the contact component alone (Harness, eels-1.0 with 10 modules
lying on flat ice, screws spinning): µs per call and ns per sample, with the plane
queried in numba (``fast_plane``) and through ``Terrain.query``, with and without the
broad phase, and with the robot 2 m above the ice (broad phase only: next to nothing).
Part 2, assemblies/contact-screw-drive.yaml at dt = 1 ms for each module count: wall
time per simulated second and the real-time factor (sim time / wall time; > 1 is faster
than real time). Best of ``--repeats`` runs after a warm-up (numba caches compiled).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402

from snakesim.components.contact import ScrewSdfContact  # noqa: E402
from snakesim.components.multibody import Multibody  # noqa: E402
from snakesim.components.terrain import load_terrain  # noqa: E402
from snakesim.framework import Harness  # noqa: E402
from snakesim.framework.registry import default_registry  # noqa: E402
from snakesim.framework.session import load_session  # noqa: E402


def _time_call(fn, budget=0.2):
    fn()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < budget:
        fn()
        n += 1
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(max(1, n // 5)):
            fn()
        best = min(best, (time.perf_counter() - t0) / max(1, n // 5))
    return best


def _robot_outputs(modules, z):
    """(the multibody's RobotModel, its outputs) for eels-1.0 + head lying at height z, screws spinning."""
    mb = Harness(Multibody, {"design": "eels-1.0", "modules": modules, "head": True, "base_position": (0, 0, z),
                             "v0": {"screw_front_*": 2.0}})
    return mb.c.robot, mb.outputs()


def evaluation_costs(modules=10, rings=3, per_ring=8):
    terrain = load_terrain("flat-ice")
    rows = []
    for label, z, broad, fast in [("on ice, numba plane", 0.0898, True, True),
                                  ("on ice, Terrain.query", 0.0898, True, False),
                                  ("on ice, no broad phase", 0.0898, False, True),
                                  ("2 m above, broad phase", 2.0, True, True),
                                  ("2 m above, no broad phase", 2.0, False, True)]:
        robot, out = _robot_outputs(modules, z)
        h = Harness(ScrewSdfContact, {"rings": rings, "per_ring": per_ring, "broad_phase": broad},
                    uses={"robot": robot})
        h.c.fast_plane = fast
        h.inputs.terrain = terrain
        h.inputs.link_poses, h.inputs.link_velocities = out["link_poses"], out["link_velocities"]
        h.inputs.joint_v = out["joint_v"]
        c, u, y = h.c, h.u, h.y
        dt = _time_call(lambda: c.output(0.0, None, u, y))
        ns = c.n_samples
        rows.append({"backend": "sdf", "case": label, "samples": ns, "us_per_call": dt * 1e6,
                     "ns_per_sample": dt * 1e9 / ns, "contacts": int(y.contacts[0])})
    return rows


def hull_costs(modules=10):
    reg = default_registry()
    if "hull_contact" not in reg.components:
        return None
    try:
        cls = reg.components["hull_contact"]
        robot, out = _robot_outputs(modules, 0.0898)
        h = Harness(cls, {}, uses={"robot": robot})
        h.inputs.terrain = load_terrain("flat-ice")
        for name, key in (("link_poses", "link_poses"), ("link_velocities", "link_velocities"), ("joint_v", "joint_v")):
            if name in cls.inputs:
                h.set_input(name, out[key])
        c, u, y = h.c, h.u, h.y
        dt = _time_call(lambda: c.output(0.0, None, u, y))
        n = getattr(c, "n_samples", None)
        return [{"backend": "hull", "case": "on ice", "samples": n, "us_per_call": dt * 1e6,
                 "ns_per_sample": dt * 1e9 / n if n else None, "contacts": None}]
    except Exception as e:      # another engineer's component: report, do not fail the bench
        return [{"backend": "hull", "case": f"error: {e}", "samples": None, "us_per_call": None,
                 "ns_per_sample": None, "contacts": None}]


def scene_rtf(modules, integrator, duration, repeats):
    s = load_session("contact-screw-drive", overrides=[f"robot.modules={modules}"],
                     sim_overrides={"duration": duration, "integrator": integrator, "dt": 0.001})
    s.run()     # warm-up
    best = None
    for _ in range(repeats):
        r = s.run()
        if best is None or r.summary["wall_time_s"] < best["wall_time_s"]:
            best = r.summary
    com = r["robot.com"]
    return {"modules": modules, "integrator": integrator, "dt_s": 0.001, "sim_time_s": best["sim_time_s"],
            "wall_time_s": best["wall_time_s"], "real_time_factor": best["real_time_factor"],
            "completed": best["completed"], "com_travel_m": float(np.linalg.norm(com[-1, :2] - com[0, :2]))}


@click.command()
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="write the figures here")
@click.option("--modules", default="4,10,30", help="module counts for the scene")
@click.option("--integrator", default="rk4", help="rk4 or semi_implicit_euler")
@click.option("--duration", default=2.0, help="simulated seconds per scene run")
@click.option("--repeats", default=2, help="timed runs per scene (best kept)")
def main(json_path, modules, integrator, duration, repeats):
    evals = evaluation_costs()
    hull = hull_costs()
    print("contact evaluation, eels-1.0 10 modules + head, 3 rings x 8 per screw, flat ice")
    print(f"{'backend':8s} {'case':28s} {'samples':>8s} {'us/call':>9s} {'ns/sample':>10s} {'contacts':>9s}")
    for r in evals + (hull or []):
        f = lambda v, spec: "-" if v is None else format(v, spec)   # noqa: E731
        print(f"{r['backend']:8s} {r['case']:28s} {f(r['samples'], '8d'):>8s} {f(r['us_per_call'], '9.1f'):>9s} "
              f"{f(r['ns_per_sample'], '10.1f'):>10s} {f(r['contacts'], '9d'):>9s}")
    if hull is None:
        print("hull     not available (no 'hull_contact' component registered)")
    scenes = [scene_rtf(int(m), integrator, duration, repeats) for m in modules.split(",")]
    print(f"\nassemblies/contact-screw-drive.yaml, {integrator} at dt = 1 ms, {duration:g} s simulated")
    print(f"{'modules':>7s} {'wall s':>8s} {'RTF':>7s} {'travel m':>9s}")
    for r in scenes:
        print(f"{r['modules']:7d} {r['wall_time_s']:8.3f} {r['real_time_factor']:7.2f} {r['com_travel_m']:9.3f}"
              + ("" if r["completed"] else "  (did not complete)"))
    if json_path:
        with open(json_path, "w") as fh:
            json.dump({"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
                       "evaluation": evals, "hull": hull if hull is not None else "not available",
                       "scenes": scenes}, fh, indent=2)
        print(f"wrote {json_path}")


if __name__ == "__main__":
    main()
