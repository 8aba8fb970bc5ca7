"""Contact back ends on one static scene: convex hulls with coal (hull_contact) vs SDF samples
(screw_sdf_contact).

    .venv/bin/python bench/contact_backends.py [--design eels-1.0] [--modules 4] [--json FILE]

Scene: the robot straight and level on flat ice (terrains/flat-ice.yaml, k = 1e5 N/m per
contact), no motion. For each back end the base height z at which Σ F_n equals the robot's
weight m g is found by bisection (the static equilibrium in z; both use eq. 2, k per
contact), then reported:

  contacts        active contacts at equilibrium
  sink mm         screw radius − z: the static deflection, W / (n k) per contact when all
                  n contacts share the load equally
  ΣFn/W           at the hull back end's equilibrium height (the cross-check: the same pose
                  loaded by the other back end)
  CoP−CoM mm      x of the centre of pressure minus x of the centre of mass (0 for moment
                  balance about y when the robot is level)
  x span          first and last contact x (m): where the load is carried
  µs/call         one output() evaluation (best of repeats, autoranged), in contact, and
                  with the robot 1 m above the ice (broad phase only)

Back ends: hull (envelope cylinders, cylinder_slices 3), hull-blades (8 convex hulls of
each screw's blade mesh, spin-dependent), sdf (3 rings × 8 samples per screw).
"""

from __future__ import annotations

import json
import platform
import timeit

import click
import numpy as np

from snakesim.components.contact.hull import HullContact
from snakesim.components.multibody import Multibody
from snakesim.components.terrain import load_terrain
from snakesim.framework.harness import Harness


def _best(fn, repeat=5):
    t = timeit.Timer(fn)
    number, _ = t.autorange()
    return min(t.repeat(repeat=repeat, number=number)) / number


def backends():
    from snakesim.components.contact.screw_sdf import ScrewSdfContact

    return {
        "hull": (HullContact, dict(cylinder_slices=3)),
        "hull-blades": (HullContact, dict(screw_geometry="blades", blade_hulls=8)),
        "sdf": (ScrewSdfContact, dict(rings=3, per_ring=8)),
    }


@click.command()
@click.option("--design", default="eels-1.0", show_default=True)
@click.option("--modules", default=4, show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="Also write the results here.")
def main(design, modules, json_path):
    mb = Harness(Multibody, {"design": design, "modules": modules})
    robot = mb.c.robot                      # the RobotModel every back end is handed
    o = mb.outputs()
    poses0, vel = o["link_poses"].copy(), np.zeros_like(o["link_velocities"])
    tree = robot.tree
    mass = sum(ln.mass for ln in tree.links)
    com_x = sum(ln.mass * (poses0[i, 0] + ln.com[0]) for i, ln in enumerate(tree.links)) / mass
    weight = mass * 9.81
    terrain = load_terrain("flat-ice")
    radius = max(s["radius"] for s in robot.metadata["screws"])

    def make(cls, params):
        h = Harness(cls, params, uses={"robot": robot})
        h.inputs.terrain = terrain
        h.inputs.link_velocities = vel
        return h

    def at(h, z):
        p = poses0.copy()
        p[:, 2] += z
        h.inputs.link_poses = p
        return h.outputs()

    def contact_points(h):
        c = getattr(h.c, "last", None)
        if c is not None:
            return c["point"], c["fn"]
        cs = h.outputs()["contact_set"]
        return cs.points, cs.normal_force

    rows, z_hull = [], None
    for name, (cls, params) in backends().items():
        h = make(cls, params)
        lo, hi = radius - 0.01, radius            # Σ F_n falls from ≫ W to 0 over [lo, hi]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if at(h, mid)["normal_force"][0] > weight else (lo, mid)
        z = 0.5 * (lo + hi)
        y = at(h, z)
        z_hull = z if name == "hull" else z_hull
        pts, fn = contact_points(h)
        on = fn > 0
        cop = float((pts[on, 0] * fn[on]).sum() / fn[on].sum())
        t_contact = _best(lambda: h.c.output(0.0, None, h.u, h.y))
        at(h, 1.0)
        t_free = _best(lambda: h.c.output(0.0, None, h.u, h.y))
        rows.append({"backend": name, "contacts": int(on.sum()), "z_eq_m": z, "sink_mm": (radius - z) * 1e3,
                     "normal_force_N": float(y["normal_force"][0]), "cop_minus_com_mm": (cop - com_x) * 1e3,
                     "x_first_m": float(pts[on, 0].min()), "x_last_m": float(pts[on, 0].max()),
                     "us_per_call_contact": t_contact * 1e6, "us_per_call_free": t_free * 1e6})
    for r, (name, (cls, params)) in zip(rows, backends().items()):
        r["fn_over_weight_at_hull_z"] = float(at(make(cls, params), z_hull)["normal_force"][0] / weight)

    click.echo(f"{design}, {modules} modules, mass {mass:.2f} kg, weight {weight:.1f} N, flat ice k = "
               f"{terrain.materials[0].k:g} N/m per contact; CoM x = {com_x:.4f} m")
    click.echo(f"{'back end':<12} {'contacts':>8} {'sink mm':>8} {'ΣFn/W @hull z':>14} {'CoP−CoM mm':>11} "
               f"{'x first..last m':>16} {'µs/call':>9} {'µs free':>8}")
    for r in rows:
        click.echo(f"{r['backend']:<12} {r['contacts']:>8d} {r['sink_mm']:>8.4f} {r['fn_over_weight_at_hull_z']:>14.4f} "
                   f"{r['cop_minus_com_mm']:>11.3f} {r['x_first_m']:>7.3f}..{r['x_last_m']:<7.3f} "
                   f"{r['us_per_call_contact']:>9.1f} {r['us_per_call_free']:>8.1f}")
    if json_path:
        with open(json_path, "w") as f:
            json.dump({"design": design, "modules": modules, "mass_kg": mass, "weight_N": weight, "com_x_m": com_x,
                       "machine": platform.processor() or platform.machine(), "python": platform.python_version(),
                       "rows": rows}, f, indent=2)


if __name__ == "__main__":
    main()
