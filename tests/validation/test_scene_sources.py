"""The two small components the scenes add: screw_schedule (speed phases) and planar_pose."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.components.control.screw_schedule import ScrewSchedule
from snakesim.components.monitors.planar_pose import PlanarPose
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework.harness import Harness

ROBOT = RobotModel.load(design="eels-1.0", modules=4, head=False)
USES = {"robot": ROBOT}


def _out(h, t):
    h.c.output(t, h.x, h.u, h.y)
    return h.y


def test_schedule_switches_phases_and_groups_split_the_modules():
    h = Harness(ScrewSchedule, {"hold": {"bend_*": 0.2}, "times": [1.0, 2.0],
                                "speeds": [{"all": 3.0}, {"head_half": 1.0, "tail_half": -1.0}]}, uses=USES)
    names = list(h.c.robot.joints)
    screw = np.array([n.startswith("screw_") for n in names])
    bend = np.array([n.startswith("bend_") for n in names])
    module = np.array([int(n[-2:]) for n in names])
    y = _out(h, 0.5)
    assert (y.setpoint[screw] == 0).all() and (y.setpoint[bend] == 0.2).all() and y.phase[0] == -1
    y = _out(h, 1.0)
    assert (y.setpoint[screw] == 3.0).all() and y.phase[0] == 0
    y = _out(h, 2.5)
    assert (y.setpoint[screw & (module >= 2)] == 1.0).all() and (y.setpoint[screw & (module < 2)] == -1.0).all()
    assert (y.setpoint[bend] == 0.2).all() and (y.rate == 0).all()


@pytest.mark.parametrize("params, message", [
    ({"times": [1.0], "speeds": [{"screw_nothing_*": 1.0}]}, "matches no joint"),
    ({"times": [1.0], "speeds": [{"bend_00": 1.0}]}, "non-screw joints"),
    ({"times": [1.0, 2.0], "speeds": [{"all": 1.0}]}, "times has 2 entries but speeds has 1"),
    ({"times": [2.0, 1.0], "speeds": [{"all": 1.0}, {"all": 2.0}]}, "increase strictly"),
    ({"times": [1.0], "speeds": [{"all": math.inf}]}, "finite"),
    ({"times": [1.0], "speeds": [{"all": 12.0}]}, "at 12 rad/s exceeds its URDF velocity limit 10 rad/s"),
])
def test_schedule_rejects_bad_phases_with_a_clear_error(params, message):
    with pytest.raises((ValueError, ValidationError), match=message):
        ScrewSchedule("phases", params, uses=USES)


def test_planar_pose_reads_the_heading_of_the_body_axis_even_when_rolled():
    h = Harness(PlanarPose, {"link": "tail"}, uses=USES)
    nl = h.u.link_poses.shape[0]
    psi, roll = 0.7, math.pi / 2
    Rz = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)], [0, math.sin(roll), math.cos(roll)]])
    h.inputs.link_rotations = np.broadcast_to(Rz @ Rx, (nl, 3, 3)).copy()
    poses = np.zeros((nl, 7))
    poses[0, :3] = [1.5, -2.0, 0.1]
    h.inputs.link_poses = poses
    pose = h.outputs()["pose"]
    assert pose == pytest.approx([1.5, -2.0, psi])


def test_planar_pose_rejects_an_unknown_link():
    with pytest.raises(ValueError, match="'nose' is not a link"):
        PlanarPose("p", {"link": "nose"}, uses=USES)
