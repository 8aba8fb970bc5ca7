"""terrain_clearance: how deep links without a contact model went into the terrain, against placements of
known depth (a box's face samples include its corners, so its depth is exact)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.monitors.terrain_clearance import TerrainClearance
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
PLANE = load_terrain({"kind": "plane"})          # z = 0, solid below


def _poses(z_of: dict, rest_z: float = 1.0, quat=(0.0, 0.0, 0.0, 1.0)):
    p = np.zeros((ROBOT.nl, 7))
    p[:, 2], p[:, 3:] = rest_z, quat
    for name, z in z_of.items():
        p[ROBOT.link_index(name), 2] = z
    return p


def _clearance(**params):
    h = Harness(TerrainClearance, params, rate=10.0, uses={"robot": ROBOT})
    h.inputs.terrain = PLANE
    return h


def test_deepest_depth_per_link_and_the_first_intrusion():
    h = _clearance(tolerance=0.01)
    # t = 0: all clear; t = 0.1: the cross bar (box 0.2 x 0.4 x 0.04 about its origin + (0.1, 0, 0)) with its
    # origin 0.1 m below the ice: its lower face 0.12 m deep; t = 0.2: the tail's cylinder (r 0.0525, axis x)
    # with its axis 3 mm below the surface -> 55.5 mm minus at most the sampling sag; the cross bar back up
    script = [(0.0, {}), (0.1, {"cross_bar": -0.1}), (0.2, {"tail": -0.003})]
    for t, z in script:
        h.inputs.link_poses = _poses(z)
        h.update(t)
    r = h.c.report(h.u.cache, {"completed": True})
    assert list(r["inside"]) == ["cross_bar", "tail"]
    assert r["inside"]["cross_bar"] == pytest.approx(0.12, abs=1e-12)
    sag = 0.0525 * (1 - math.cos(math.pi / 11))            # ≥ 11 samples around at 3 cm spacing
    assert 0.0555 - sag <= r["inside"]["tail"] <= 0.0555 + 1e-9
    assert r["first"] == {"time_s": pytest.approx(0.1), "link": "cross_bar", "depth_m": pytest.approx(0.12)}
    assert r["max_depth_m"] == pytest.approx(0.12)
    assert "screw_front_link_00" not in r["watched"] and "tail" in r["watched"]
    assert h.outputs(0.2)["max_depth"] == pytest.approx(0.12)
    assert "cross_bar 120 mm, tail" in TerrainClearance.format_report(r)[0]
    assert h.c._stop.reason is None                            # a watch by default, not a stop


def test_stop_on_intrusion_names_link_and_depth():
    h = _clearance(stop_on_intrusion=True, exclude=["cross_bar"])
    h.inputs.link_poses = _poses({"cross_bar": -0.1, "avionics_box": -0.05})
    h.update(0.0)
    assert "avionics_box is" in h.c._stop.reason and "mm inside the terrain" in h.c._stop.reason


def test_clear_run_reports_nothing_inside():
    h = _clearance()
    h.inputs.link_poses = _poses({})
    h.update(0.0)
    r = h.c.report(h.u.cache, {"completed": True})
    assert r["inside"] == {} and "first" not in r
    assert "no watched link" in TerrainClearance.format_report(r)[0]


def test_needs_a_rate():
    with pytest.raises(ValueError, match="rate"):
        Harness(TerrainClearance, {}, uses={"robot": ROBOT})
