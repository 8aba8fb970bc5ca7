"""IMU: at rest it reads +g upward and no rotation, in free fall nothing, on a spinning arm the
centripetal acceleration; noise is seeded and needs a rate."""

from __future__ import annotations

import numpy as np
import pytest

from hanging import G, equilibrium, imu_at
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors import Imu
from snakesim.framework import Harness

EELS_15 = {"robot": RobotModel.load(design="eels-1.5")}


def test_at_rest_reads_g_upward_and_zero_rate():
    eq = equilibrium("tether")
    imu = imu_at(eq, "module_02", offset=(0.1, 0.02, -0.03))
    out = imu.outputs()
    R = eq["out"]["link_rotations"][eq["links"].index("module_02")]
    np.testing.assert_allclose(R @ out["specific_force"], -G, atol=1e-9)     # +9.81 m/s² up, in the world
    np.testing.assert_allclose(out["angular_rate"], 0.0, atol=1e-12)
    np.testing.assert_allclose(out["orientation"], eq["out"]["link_poses"][eq["links"].index("module_02"), 3:])


def test_free_fall_reads_zero():
    eq = equilibrium("tether")
    robot = eq["robot"]
    robot.inputs.wrenches = np.zeros_like(eq["out"]["link_poses"][:, :6])
    robot.inputs.tau = np.zeros(robot.c.robot.nj)
    eq["out"] = robot.outputs()
    out = imu_at(eq, "module_01", offset=(0.2, 0.0, 0.05)).outputs()
    np.testing.assert_allclose(out["specific_force"], 0.0, atol=1e-9)


def test_spinning_arm_reads_centripetal_acceleration_and_body_rate():
    w = 3.0
    h = Harness(Imu, {"link": "module_00", "offset": (0.2, 0.0, 0.0)}, uses=EELS_15)
    nl = h.infos["link_poses"].shape[0]
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])                  # link yawed 0.7 rad
    h.inputs.link_rotations = np.broadcast_to(R, (nl, 3, 3))
    poses = np.zeros((nl, 7))
    poses[:, 6] = 1.0
    h.inputs.link_poses = poses
    vel = np.zeros((nl, 6))
    vel[:, 5] = w
    h.inputs.link_velocities = vel
    h.inputs.gravity = [0.0]                                             # gravity switched off
    out = h.outputs()
    np.testing.assert_allclose(out["specific_force"], [-w * w * 0.2, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(out["angular_rate"], [0.0, 0.0, w], atol=1e-12)


def test_noise_is_seeded_held_per_sample_and_needs_a_rate():
    def make(seed):
        h = Harness(Imu, {"link": "tail", "gyro_noise": 0.01, "accel_noise": 0.1, "accel_bias": (0.5, 0.0, 0.0),
                          "seed": seed}, rate=200.0, uses=EELS_15)
        nl = h.infos["link_poses"].shape[0]
        h.inputs.link_rotations = np.broadcast_to(np.eye(3), (nl, 3, 3))
        return h

    a, b, c = make(1), make(1), make(2)
    ra = [a.outputs()["specific_force"].copy()]
    assert np.array_equal(a.outputs()["specific_force"], ra[0])           # held until the next sample
    a.update()
    ra.append(a.outputs()["specific_force"].copy())
    rb = [b.outputs()["specific_force"].copy()]
    b.update()
    rb.append(b.outputs()["specific_force"].copy())
    np.testing.assert_array_equal(ra, rb)
    assert not np.array_equal(ra[0], ra[1]) and not np.array_equal(ra[0], c.outputs()["specific_force"])
    n = 2000
    s = []
    for _ in range(n):
        s.append(c.outputs()["specific_force"] - np.array([0.5, 0.0, 9.81]))
        c.update()
    s = np.array(s)
    assert np.allclose(s.std(axis=0), 0.1, rtol=5 / np.sqrt(2 * n))
    assert np.abs(s.mean(axis=0)).max() < 5 * 0.1 / np.sqrt(n)             # the bias is added, nothing else
    with pytest.raises(ValueError, match="noise needs a sample rate"):
        Imu("imu", {"link": "tail", "gyro_noise": 0.01}, uses=EELS_15)


def test_imu_frame_of_eels_1_0_head_and_unknown_link():
    Imu("imu", {}, uses={"robot": RobotModel.load(design="eels-1.0", modules=2, head=True)})  # default link 'imu'
    with pytest.raises(ValueError, match="matches no name; valid: tail"):
        Imu("imu", {"link": "imu"}, uses=EELS_15)
