"""fts_wall_loads: per-segment external forces from the FTS array by Newton (static), against scripted sensor
readings with an exact answer, and in the body-respecting brace against the screws' wall loads."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors.fts_wall_loads import FtsWallLoads
from snakesim.framework import Harness
from snakesim.framework.assembly import ComponentSpec

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
from validation_scenes import run  # noqa: E402

ROBOT = RobotModel.load(design="eels-1.5")
G = np.array([0.0, 0.0, -9.81])


def _segment_masses():
    tree = ROBOT.tree
    mass = {ln.name: ln.mass for ln in tree.links}
    beyond = [set(tree.subtree(f"fts_{k:02d}")) for k in (1, 2, 3)]
    segs = [set(ROBOT.links) - beyond[0], beyond[0] - beyond[1], beyond[1] - beyond[2], beyond[2]]
    return np.array([sum(mass[n] for n in s) for s in segs])


def test_segment_forces_from_scripted_readings_are_exact():
    h = Harness(FtsWallLoads, {"component": "total"}, uses={"robot": ROBOT})
    # sensor frames turned 90° about z (x -> y): a reading f in the sensor frame is (−f_y, f_x, f_z) in the world
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 5], poses[:, 6] = np.sin(np.pi / 4), np.cos(np.pi / 4)
    f = np.array([[10.0, 0, 50], [0, 20, 30], [5, 5, 10]])
    h.inputs.link_poses = poses
    h.inputs.wrench = np.hstack([f, np.zeros((3, 3))])
    out = h.outputs()
    fw = np.stack([-f[:, 1], f[:, 0], f[:, 2]], axis=1)
    m = _segment_masses()
    want = np.array([fw[0], fw[1] - fw[0], fw[2] - fw[1], -fw[2]]) - m[:, None] * G
    np.testing.assert_allclose(out["forces"], want, atol=1e-12)
    np.testing.assert_allclose(out["loads"], np.linalg.norm(want, axis=1), atol=1e-12)
    assert m.sum() == pytest.approx(sum(ln.mass for ln in ROBOT.tree.links))     # the segments cover the robot


def test_across_gravity_drops_the_vertical_part():
    h = Harness(FtsWallLoads, {}, uses={"robot": ROBOT})
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 6] = 1.0
    h.inputs.link_poses = poses
    w = np.zeros((3, 6))
    w[0, :3] = [3.0, 4.0, 100.0]
    h.inputs.wrench = w
    out = h.outputs()
    assert out["loads"][0] == pytest.approx(5.0) and out["loads"][1] == pytest.approx(5.0)


def test_sensors_out_of_chain_order_are_refused():
    with pytest.raises(ValueError, match="follow one another along the chain"):
        Harness(FtsWallLoads, {"cuts": ["fts_joint_03", "fts_joint_01"]}, uses={"robot": ROBOT})


def _with_estimator(resolved):
    resolved.components["fts"] = ComponentSpec(type="force_torque_sensors")
    resolved.components["walls"] = ComponentSpec(type="fts_wall_loads")
    resolved.connections += [("robot.joint_wrenches", "fts.joint_wrenches", None), ("fts.wrench", "walls.wrench", None),
                             ("robot.link_poses", "walls.link_poses", None)]
    resolved.record += [("walls.loads", None)]


def test_braced_estimate_is_each_screws_wall_load():
    """walls-body-brace: one screw per segment, vertical walls, friction carrying the weight along gravity and the
    brace static (its inertia < 1 % of the loads, tests/validation/test_fts_braced.py): the part of each segment's
    external force across gravity is its screw's normal load, to 1 % (screw 1 touches nothing: 0)."""
    s, r = run("walls-body-brace", [], {"duration": 3.0}, patch=_with_estimator)
    assert r.summary["completed"], r.summary
    late = r["t"] >= 1.0
    est, N = r["walls.loads"][late], r["contact.screw_normal_force"][late]
    np.testing.assert_allclose(est, N, rtol=0.01, atol=0.5)
    assert N[:, [0, 2, 3]].min() > 50.0                 # a real brace: the estimate is of loads, not of zeros


def test_along_normal_is_the_projection_and_needs_a_normal():
    h = Harness(FtsWallLoads, {"component": "along_normal", "normal": (0.0, 2.0, 0.0)}, uses={"robot": ROBOT})
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 6] = 1.0
    w = np.zeros((3, 6))
    w[1, :3] = [30.0, -40.0, 100.0]           # friction in the wall plane (x, z) does not count
    h.inputs.link_poses, h.inputs.wrench = poses, w
    assert h.outputs()["loads"][1:3] == pytest.approx([40.0, 40.0])
    with pytest.raises(ValueError, match="needs a non-zero `normal`"):
        Harness(FtsWallLoads, {"component": "along_normal"}, uses={"robot": ROBOT})
