"""groove_drag: no force within the thread depth; beyond it a regularised Coulomb force across the screw
axis, whose declared velocity slope matches finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.thermal import GrooveDrag
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5", modules=4)
LAY = ROBOT.derived(screw_layout)


def drag(penetration, v_screw0, normal=None):
    h = Harness(GrooveDrag, {"wall_strength": 1e6, "thread_depth": 0.0175, "v_eps": 1e-3}, rate=100.0,
                uses={"robot": ROBOT})
    if normal is not None:
        h.xd[:3] = normal                                  # screw 0's sampled wall normal
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 6] = 1.0                                    # every link unrotated: axes are the mount frames'
    vel = np.zeros((ROBOT.nl, 6))
    vel[LAY.screw_row[0], :3] = v_screw0
    h.inputs.link_poses = poses
    h.inputs.link_velocities = vel
    h.inputs.penetration = penetration
    return h


def test_no_force_within_the_thread_depth():
    h = drag([0.017, 0.0, 0.0, 0.0], [0.0, 0.0, 0.1])
    out = h.outputs()
    assert not out["wrenches"].any()
    assert out["travel_speed"][0] > 0


def test_wall_force_opposes_motion_across_the_axis_with_the_wall_strength():
    a = LAY.mount_R[0][:, 0]
    v = np.array([0.02, -0.03, 0.05])
    h = drag([0.0205, 0.0, 0.0, 0.0], v)
    out = h.outputs()
    vp = v - (v @ a) * a
    F = 1e6 * LAY.length[0] * 0.003                      # σ_w L (δ − h_t)
    f = out["wrenches"][LAY.screw_row[0]]
    assert f[:3] == pytest.approx(-F * vp / np.sqrt(vp @ vp + 1e-6), rel=1e-12)
    assert f[:3] @ a == pytest.approx(0.0, abs=1e-9) and not f[3:].any()
    assert out["travel_speed"][0] == pytest.approx(np.linalg.norm(vp), rel=1e-12)


def test_motion_into_or_out_of_the_wall_is_not_resisted_nor_counted_as_travel():
    a = LAY.mount_R[0][:, 0]
    n = np.cross(a, [0.3, 0.4, 0.5])
    n /= np.linalg.norm(n)                                 # a wall normal across the screw axis
    h = drag([0.03, 0.0, 0.0, 0.0], 0.01 * n, normal=n)
    out = h.outputs()
    assert np.abs(out["wrenches"]).max() < 1e-9 and out["travel_speed"][0] < 1e-15
    t = np.cross(n, a)                                     # along the wall, across the axis
    out = drag([0.03, 0.0, 0.0, 0.0], 0.01 * n + 0.02 * t, normal=n).outputs()
    F = 1e6 * LAY.length[0] * (0.03 - 0.0175)
    assert out["wrenches"][LAY.screw_row[0], :3] == pytest.approx(-F * 0.02 * t / np.sqrt(0.02 ** 2 + 1e-6), rel=1e-9)
    assert out["travel_speed"][0] == pytest.approx(0.02, rel=1e-9)


@pytest.mark.parametrize("with_normal", [False, True])
def test_declared_velocity_slope_matches_finite_differences(with_normal):
    row = LAY.screw_row[0]
    v = np.array([3e-4, -2e-4, 5e-4])                    # inside the regularisation: the slope matters most
    a = LAY.mount_R[0][:, 0]
    n = np.cross(a, [0.3, -0.4, 0.5])
    n = n / np.linalg.norm(n) if with_normal else None
    h = drag([0.019, 0.0, 0.0, 0.0], v, normal=n)
    h.outputs()
    jac = h.c.port_jacobian("wrenches", 0.0, None, h.u, h.y)
    assert list(jac.rows) == [row]
    fd = np.zeros((3, 3))
    eps = 1e-8
    for j in range(3):
        for s in (1, -1):
            dv = v.copy()
            dv[j] += s * eps
            fd[:, j] += s * drag([0.019, 0.0, 0.0, 0.0], dv, normal=n).outputs()["wrenches"][row, :3] / (2 * eps)
    assert jac.d_twist[row, :3, :3] == pytest.approx(fd, rel=1e-5, abs=1e-3)


class CurvedWall:
    """A terrain stand-in whose normal at p is p's direction from the origin (a sphere's), counting queries."""

    def __init__(self):
        self.queries = 0

    def query(self, points):
        from types import SimpleNamespace
        self.queries += 1
        p = np.asarray(points, float)
        return SimpleNamespace(normal=p / np.linalg.norm(p, axis=1, keepdims=True))


def test_wall_normal_is_sampled_again_once_a_screw_has_moved_normal_distance():
    h = drag([0.02, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    wall = CurvedWall()
    h.inputs.terrain = wall
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 6], poses[:, 0] = 1.0, 1.0                  # every link 1 m out along x
    h.inputs.link_poses = poses
    h.update(0.0)
    assert wall.queries == 1 and h.xd[:3] == pytest.approx([1.0, 0.0, 0.0])
    poses[LAY.screw_row[0], 1] = 0.004                   # 4 mm along y: within 5 mm, the held normal stays
    h.inputs.link_poses = poses
    h.update(0.01)
    assert wall.queries == 1 and h.xd[:3] == pytest.approx([1.0, 0.0, 0.0])
    poses[LAY.screw_row[0], 1] = 0.006                   # 6 mm from where it was sampled: asked again
    h.inputs.link_poses = poses
    h.update(0.02)
    assert wall.queries == 2 and h.xd[1] == pytest.approx(0.006 / np.hypot(1.0, 0.006))
