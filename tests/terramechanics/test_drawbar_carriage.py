"""drawbar_carriage alone (components/terramechanics/drawbar_carriage.py), on the drawbar test's specimen:
the slide's wrench against its closed form (towed, driven, held on its side), its declared slopes against
finite differences of it, the report's slip and drawbar pull on a prescribed track, and the bad settings
named (a link that is not the robot's, a carriage both towed and driven, a rest attitude that is no
rotation)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terramechanics.drawbar_carriage import DrawbarCarriage
from snakesim.framework import Harness

URDF = Path(__file__).resolve().parents[2] / "robots" / "specimens" / "eels-1.0-module.urdf"
K, C, TOW = 2.0e4, 2.0e3, 25.0


@pytest.fixture(scope="module")
def robot():
    return RobotModel.load(urdf=str(URDF))


def carriage(robot, **params):
    return Harness(DrawbarCarriage, {"link": "module", "tow": TOW, "stiffness": K, "damping": C, **params},
                   uses={"robot": robot})


def quat(rotvec) -> np.ndarray:
    """(x, y, z, w) of a rotation vector."""
    a = float(np.linalg.norm(rotvec))
    axis = np.asarray(rotvec) / a if a > 0 else np.zeros(3)
    return np.array([*(math.sin(a / 2) * axis), math.cos(a / 2)])


def quat_mul(a, b) -> np.ndarray:
    (ax, ay, az, aw), (bx, by, bz, bw) = a, b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def state(robot, p, rotvec, twist):
    poses, vels = np.zeros((robot.nl, 7)), np.zeros((robot.nl, 6))
    poses[:, 6] = 1.0
    row = robot.links.index("module")
    poses[row, :3], poses[row, 3:] = p, quat(rotvec)
    vels[row] = twist
    return poses, vels, row


def test_the_slide_tows_holds_and_leaves_x_and_z_free(robot):
    h = carriage(robot)
    theta = np.array([2e-3, -1e-3, 3e-3])            # small: W's rotation part is −k θ to O(θ³)
    poses, vels, row = state(robot, [0.4, 0.01, -0.03], theta, [0.1, 0.02, -0.05, 0.1, -0.2, 0.3])
    h.inputs.link_poses, h.inputs.link_velocities = poses, vels
    w = h.outputs()["wrenches"]
    expected = [-TOW, -K * 0.01 - C * 0.02, 0.0, *(-K * theta - C * np.array([0.1, -0.2, 0.3]))]
    np.testing.assert_allclose(w[row], expected, rtol=1e-5)
    assert not np.delete(w, row, axis=0).any()        # every other link untouched


def test_the_driven_slide_holds_x_to_its_rail(robot):
    # driven at V from x0: f_x = −k (x − x0 − V t) − c (v_x − V), the rest as towed; no tow
    V, x0, t = 0.1, 0.05, 2.0
    h = carriage(robot, tow=0.0, speed=V, x0=x0)
    poses, vels, row = state(robot, [0.3, 0.0, 0.0], [0, 0, 0], [0.12, 0, 0, 0, 0, 0])
    h.inputs.link_poses, h.inputs.link_velocities = poses, vels
    w = h.outputs(t)["wrenches"]
    assert w[row, 0] == pytest.approx(-K * (0.3 - x0 - V * t) - C * (0.12 - V))
    assert w[row, 1:].tolist() == [0.0] * 5


ON_ITS_SIDE = tuple(quat([math.pi / 2, 0.0, 0.0]))      # rolled 90° about x, as the robot scenes lie


def test_a_link_held_on_its_side_and_off_the_axis_rests_there(robot):
    # held at q0 (rolled 90°) and y0: no wrench there but the tow; turned by δ about world z from q0 (E = R R0ᵀ
    # = Rz(δ)): the yaw spring's −k δ (to O(δ³)), whatever q0 is
    h = carriage(robot, rest_quaternion=ON_ITS_SIDE, y0=0.3)
    poses, vels, row = state(robot, [0.0, 0.3, 0.02], [0, 0, 0], np.zeros(6))
    poses[row, 3:] = ON_ITS_SIDE
    h.inputs.link_poses, h.inputs.link_velocities = poses, vels
    np.testing.assert_allclose(h.outputs()["wrenches"][row], [-TOW, 0, 0, 0, 0, 0], atol=1e-9)
    delta = 2e-3
    poses[row, 3:] = quat_mul(quat([0.0, 0.0, delta]), np.array(ON_ITS_SIDE))
    h.inputs.link_poses = poses
    np.testing.assert_allclose(h.outputs()["wrenches"][row, 3:], [0.0, 0.0, -K * delta], atol=K * delta ** 3)


def test_a_rest_quaternion_that_is_not_a_rotation_is_named(robot):
    with pytest.raises(ValueError, match=r"rest_quaternion \[0.0, 0.0, 0.0, 2.0\] is not a unit quaternion"):
        carriage(robot, rest_quaternion=(0.0, 0.0, 0.0, 2.0))


@pytest.mark.parametrize("mode", [{}, {"tow": 0.0, "speed": 0.07}, {"rest_quaternion": ON_ITS_SIDE}],
                         ids=["towed", "driven", "on-its-side"])
def test_declared_slopes_are_the_wrenchs_derivatives(robot, mode):
    h = carriage(robot, **mode)
    poses, vels, row = state(robot, [0.2, 0.005, 0.01], [1e-3, 2e-3, -1e-3], [0.05, 0.01, 0.0, 0.02, 0.0, -0.1])
    q0 = np.array(mode.get("rest_quaternion", (0.0, 0.0, 0.0, 1.0)))
    poses[row, 3:] = quat_mul(poses[row, 3:], q0)          # the same small error, from the held attitude
    h.inputs.link_poses, h.inputs.link_velocities = poses, vels
    jac = h.c.port_jacobian("wrenches", 0.0, None, h.u, None)
    assert list(jac.rows) == [row]
    base, eps = h.outputs()["wrenches"][row], 1e-6
    for k in range(6):
        # a twist along k; a displacement along k (world axes: δp, then δθ applied on the left)
        dv = vels.copy()
        dv[row, k] += eps
        h.inputs.link_velocities = dv
        np.testing.assert_allclose((h.outputs()["wrenches"][row] - base) / eps, jac.d_twist[row][:, k], atol=1e-3)
        h.inputs.link_velocities = vels
        dp = poses.copy()
        if k < 3:
            dp[row, k] += eps
        else:
            dp[row, 3:] = quat_mul(quat(eps * np.eye(3)[k - 3]), poses[row, 3:])
        h.inputs.link_poses = dp
        # the declared slope is the small-angle one, −k I: at θ off level the vee's own slope is I − [θ]×/2 + …,
        # so off by k|θ|/2 (~25 N·m/rad of 2e4 here)
        np.testing.assert_allclose((h.outputs()["wrenches"][row] - base) / eps, jac.d_pose[row][:, k],
                                   atol=K * np.linalg.norm([1e-3, 2e-3, -1e-3]) / 2 + 1e-2)
        h.inputs.link_poses = poses


def test_report_is_the_slip_of_the_track_it_sampled(robot):
    # the module travels at v while its screws turn at ω: slip = 1 − v / (ω r tan λ), r 0.09 m, λ 0.35 rad
    # (the sidecar's); only the window's samples count: a first second at another speed is left out
    h = carriage(robot, steady_window=1.0)
    v, omega, dt = 0.05, 3.0, 0.01
    spin = robot.joints.index("screw_front")
    joint_v = np.zeros(len(robot.joints))
    joint_v[spin] = omega
    h.inputs.joint_v = joint_v
    x = 0.0
    for i in range(201):
        t = i * dt
        x += (0.2 if t <= 1.0 else v) * dt if i else 0.0
        poses, vels, row = state(robot, [x, 0.0, 0.02 - 0.001 * (t > 1.0 - 1e-9)], [0, 0, 0], np.zeros(6))
        h.inputs.link_poses = poses
        h.c.check(t, h.u, i == 0)
    rep = h.c.report(h.u.cache, {})
    nut = omega * 0.09 * math.tan(0.35)
    assert rep["window_s"] == pytest.approx([1.0, 2.0])
    assert rep["travel_speed_m_s"] == pytest.approx(v, rel=1e-9)
    assert rep["nut_speed_m_s"] == pytest.approx(nut, rel=1e-12)
    assert rep["slip"] == pytest.approx(1.0 - v / nut, rel=1e-9)
    assert rep["settled_m"] == pytest.approx(0.001, rel=1e-6)
    assert rep["drawbar_pull_N"] == TOW
    assert DrawbarCarriage.format_report(rep)[0].startswith("drawbar: tow 25 N, travel 50.0 mm/s")


def test_driven_report_pull_is_the_rails_mean_force(robot):
    # the module 2 mm ahead of its rail throughout the window: pull = k · 2 mm (the damper's mean is zero, the
    # mean velocity being the rail's), whatever the velocities read at the ticks
    V, x0 = 0.06, 0.1
    h = carriage(robot, tow=0.0, speed=V, x0=x0, steady_window=1.0)
    for i in range(201):
        t = i * 0.01
        poses, vels, row = state(robot, [x0 + V * t + (0.002 if t >= 1.0 - 1e-9 else 0.0), 0.0, 0.0], [0, 0, 0],
                                 [V + 0.003 * (-1) ** i, 0, 0, 0, 0, 0])
        h.inputs.link_poses, h.inputs.link_velocities = poses, vels
        h.c.check(t, h.u, i == 0)
    rep = h.c.report(h.u.cache, {})
    assert rep["mode"] == "driven" and rep["speed_set_m_s"] == V
    assert rep["travel_speed_m_s"] == pytest.approx(V, rel=1e-9)
    assert rep["drawbar_pull_N"] == pytest.approx(K * 0.002, rel=1e-6)
    assert "drawbar pull 40.00 N" in DrawbarCarriage.format_report(rep)[0]


def test_a_carriage_both_towed_and_driven_is_refused_naming_both(robot):
    with pytest.raises(ValueError, match=r"tow = 25 N and speed = 0.05 m/s.*not both"):
        carriage(robot, speed=0.05)


def test_a_link_the_robot_does_not_have_is_named_with_the_valid_ones(robot):
    with pytest.raises(Exception) as err:
        carriage(robot, link="chassis")
    msg = str(err.value)
    assert "chassis" in msg and "module" in msg and "screw_front_link" in msg


@pytest.mark.slow
@pytest.mark.parametrize("campaign, column, values", [("drawbar-pull", "tow", [0.0, 10.0]),
                                                      ("drawbar-slip", "speed", [0.11824, 0.09854])])
def test_the_shipped_sweeps_tabulate_slip_against_pull(tmp_path, campaign, column, values):
    # campaigns/dispersions/*.yaml on the scene, their first two points, short runs: every metric a number,
    # and the second point (towed harder, or driven slower) slips more at a larger pull
    import csv
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "sweep"
    done = subprocess.run([sys.executable, "-c", "from snakesim.framework.cli import main; main()", "sweep",
                           "snow-drawbar-pull", "--dispersions", str(root / f"campaigns/dispersions/{campaign}.yaml"),
                           "-n", "2", "--duration", "0.4", "--workers", "1", "--no-plots", "--quiet", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    with open(out / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r[column]) for r in rows] == values
    for r in rows:
        assert all(math.isfinite(float(r[k])) for k in ("slip", "drawbar_pull", "nut_speed", "sinkage_front"))
    assert float(rows[1]["slip"]) > float(rows[0]["slip"])
    assert float(rows[1]["drawbar_pull"]) > float(rows[0]["drawbar_pull"])
