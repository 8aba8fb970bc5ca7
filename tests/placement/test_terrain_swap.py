"""--terrain on a surface scene puts the robot on the new terrain (placement/terrain_swap.py), or refuses.

Tolerances from the model (eels-1.0-front, 6 modules: m = 50 kg on 6 screws × 3 contact rings, ice
k = 1e5 N/m per contact): on a slope θ the rings' equilibrium penetration is δ = m g cos θ / (k N) = 0.26 mm,
the gap each seated screw may have. A robot let go touching (no drop) loads its contacts to at most
2 m g cos θ (an undamped spring released at zero compression overshoots to twice its static load), while a
drop of h = 1 cm lands at sqrt(2 g h) = 0.44 m/s and loads them to m g cos θ (1 + sqrt(1 + 2 h k N / (m g cos θ)))
≈ 10 m g cos θ; the placement before this one dropped the slope's far end 1.4 m.
"""

from __future__ import annotations

import copy
import csv
import math

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from snakesim.components.placement.terrain_swap import (TerrainPlacementError, place_on_terrain,
                                                         vertical_rest_shift)
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework.cli import cli, install_plugin_cli

G = 9.81
ROBOT = ["robot.name=eels-1.0-front", "robot.modules=6"]
RINGS = 3            # the default scene's contact rings per screw
DROP = 0.01          # m, the drop the seated start is compared with


def _mass_and_screws() -> tuple[float, int]:
    import pinocchio as pin

    from snakesim.components.contact.robot_screws import screw_layout
    from snakesim.components.multibody.robot_model import RobotModel

    robot = RobotModel.load(design="eels-1.0-front", modules=6)
    model = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer())
    return sum(inertia.mass for inertia in model.inertias), robot.derived(screw_layout).ns


def _run(tmp_path, terrain, duration=0.04, extra=()):
    install_plugin_cli()
    out = tmp_path / terrain
    # a contact deeper than 5 mm stops the run: the first contact depths are a few mm at most
    res = CliRunner().invoke(cli, ["run", "--robot", "eels-1.0-front", "--modules", "6", "--terrain", terrain,
                                   "--duration", str(duration), "--set", "components.contact.params.max_depth=0.005",
                                   *extra, "--out", str(out)])
    return res, out


def _signals(out) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader((out / "signals.csv").open()))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.mark.parametrize("terrain, tilt", [("fractal-dem", 0.0), ("tilted-plane-20deg", math.radians(20.0))])
def test_terrain_option_places_the_robot_on_it(tmp_path, terrain, tilt):
    """The first 0.3 s from the placement, recorded at 200 Hz: no impact (module docstring)."""
    res, out = _run(tmp_path, terrain, 0.3, ["--dt", "0.005", "--set", "sim.record_rate=200",
                                             "--set", "record=[contact.normal_force, robot.link_velocities]"])
    assert res.exit_code == 0, res.output
    assert f"--terrain {terrain}: robot placed on it (base raised" in res.output
    summary = yaml.safe_load((out / "summary.json").read_text())
    assert summary["outcome"] == "success" and summary["sim_time_s"] > 0.29, summary
    base = yaml.safe_load((out / "config.yaml").read_text())["components"]["robot"]["params"]["base_position"]
    assert base[2] > 0.0898 + 0.01          # raised from the scene's flat-ice placement, and kept in config.yaml

    m, ns = _mass_and_screws()
    weight = m * G * math.cos(tilt)         # on a DEM the mean slope is a few degrees: cos ≈ 1 bounds it
    k_all = 1.0e5 * RINGS * ns
    drop_peak = weight * (1 + math.sqrt(1 + 2 * DROP * k_all / weight))
    names, rows = _signals(out)
    fn = rows[:, names.index("contact.normal_force[0]")]
    assert fn.max() <= 2.0 * weight < drop_peak / 4, (fn.max(), weight, drop_peak)
    # no link moves along the surface normal faster than half a 1 cm drop's landing speed (sliding down the
    # ice slope, μ = 0.1 < tan 20°, is along the surface)
    n = np.array([-math.sin(tilt), 0.0, math.cos(tilt)])
    vz = [i for i, c in enumerate(names) if c.startswith("robot.link_velocities.") and c.endswith(".vz")]
    v_n = rows[:, [i - 2 for i in vz]] * n[0] + rows[:, vz] * n[2]
    assert np.abs(v_n).max() <= 0.5 * math.sqrt(2 * G * DROP), np.abs(v_n).max()


def _placed(terrain: str, sets=()):
    """The default scene with the 6-module front robot on ``terrain``, placed; its plan at t = 0."""
    from snakesim.framework.assembly import resolve
    from snakesim.framework.builder import Builder
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    resolved = resolve("surface-screw-traverse", search_path=reg.assembly_paths(),
                       overrides=[*ROBOT, f"terrain={terrain}", *sets])
    before = copy.deepcopy(resolved.components["robot"].params)
    moved = place_on_terrain(resolved, terrain)
    plan = Builder.from_resolved(resolved, reg).plan()
    for fn, x, u, y in plan.once:
        fn(0.0, x, u, y)
    plan.f(0.0, plan.X)
    return resolved, before, moved, plan


def test_every_screw_rests_on_the_slope():
    """Each screw's envelope (a cylinder: radius r, length L about its axis) against the 20° plane, computed
    from the screw's pose alone: gap = min over its axis ends of the plane distance − r·sqrt(1 − (n̂·â)²)."""
    from snakesim.components.contact.robot_screws import screw_layout
    from snakesim.components.multibody.pose_quaternions import rotation_matrices

    tilt = math.radians(20.0)
    _, _, moved, plan = _placed("tilted-plane-20deg")
    assert [(name, round(math.degrees(turn), 6)) for name, _, turn in moved] == [("robot", 20.0)]
    robot = plan.components["robot"].robot
    poses = np.asarray(plan.io["robot"][2].link_poses, dtype=float)
    lay = robot.derived(screw_layout)
    R = rotation_matrices(np.ascontiguousarray(poses[lay.parent_row, 3:]))
    centre = poses[lay.parent_row, :3] + np.einsum("sij,sj->si", R, lay.mount_p)
    axis = np.einsum("sij,sj->si", R, lay.mount_R[:, :, 0])
    n = np.array([-math.sin(tilt), 0.0, math.cos(tilt)])      # the plane through the origin, rising to +x
    ends = [centre + s * axis * lay.length[:, None] / 2 for s in (1, -1)]
    gap = np.minimum(*(e @ n for e in ends)) - lay.radius * np.sqrt(1 - (axis @ n) ** 2)
    m, ns = _mass_and_screws()
    delta = m * G * math.cos(tilt) / (1.0e5 * RINGS * ns)
    assert np.abs(gap).max() <= delta, (gap, delta)


def test_rough_dem_rests_on_supports_with_none_inside():
    """On the fractal DEM the rest turn (module docstring, step 2) leans the robot onto its supports: no
    collision point inside, the lowest touching, and it turned further than the fitted plane alone."""
    from snakesim.components.placement.terrain_swap import TOUCH_TOL, collision_points

    resolved, _, moved, plan = _placed("fractal-dem")
    (name, dz, turn), = moved
    pts = collision_points(plan.components["robot"].robot, np.asarray(plan.io["robot"][2].link_poses))
    d = plan.io["terrain"][2].terrain.distance(pts)
    assert abs(d.min()) <= TOUCH_TOL and turn > 0.0


def test_flat_terrain_keeps_the_scenes_placement_to_the_bit():
    """The default scene's own terrain: nothing is written, so the initial state is the scene's to the bit."""
    resolved, before, moved, _ = _placed("flat-ice")
    assert moved == [] and resolved.components["robot"].params == before


def test_vertical_rest_shift_touches_the_lowest_point():
    dem = load_terrain("fractal-dem")
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50), rng.uniform(-0.3, 0.3, 50)])
    dz = vertical_rest_shift(pts, dem)
    assert abs(dem.distance(pts + [0, 0, dz]).min()) < 5e-4


def test_terrain_that_cannot_carry_the_robot_is_refused(tmp_path):
    walls = load_terrain("parallel-walls-0.35")
    with pytest.raises(TerrainPlacementError, match="cannot place the robot"):
        vertical_rest_shift(np.array([[0.0, 0.5, 0.0]]), walls)
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["check", "--robot", "eels-1.0-front", "--modules", "6",
                                   "--terrain", "parallel-walls-0.35"])
    assert res.exit_code == 1 and "cannot place the robot" in res.output and "Traceback" not in res.output
