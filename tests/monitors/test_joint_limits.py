"""joint_limits: joints past their URDF <limit>, against scripted angles (EELS 1.5: bends ±π/4, twists ±π/2,
continuous screws without stops)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.monitors.joint_limits import JointLimits
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
J = {n: k for k, n in enumerate(ROBOT.joints)}


def _watch(**params):
    return Harness(JointLimits, params, rate=10.0, uses={"robot": ROBOT})


def test_limits_are_the_urdf_ones_and_screws_have_none():
    lo, hi = ROBOT.position_limits()
    assert hi[J["bend_01"]] == pytest.approx(math.pi / 4) and lo[J["bend_01"]] == pytest.approx(-math.pi / 4)
    assert hi[J["twist_01"]] == pytest.approx(math.pi / 2)
    assert np.isinf(hi[J["screw_front_01"]]) and np.isinf(lo[J["screw_front_01"]])


def test_worst_excess_per_joint_and_the_first_violation():
    h = _watch(tolerance=0.01)
    script = [(0.0, {"bend_01": 0.5}), (0.1, {"bend_02": -1.0, "screw_front_00": 3.0}),
              (0.2, {"bend_02": -0.9, "bend_01": math.pi / 4 + 0.005}), (0.3, {"twist_00": 2.0})]
    for t, angles in script:
        q = np.zeros(ROBOT.nj)
        for n, v in angles.items():
            q[J[n]] = v
        h.inputs.joint_q = q
        h.update(t)
    r = h.c.report(h.u.cache, {"completed": True})
    assert list(r["past_limits"]) == ["twist_00", "bend_02"]      # bend_01's 5 mrad is within the tolerance
    assert r["past_limits"]["bend_02"]["angle_rad"] == pytest.approx(-1.0)
    assert r["past_limits"]["bend_02"]["excess_rad"] == pytest.approx(1.0 - math.pi / 4)
    assert r["past_limits"]["twist_00"]["excess_rad"] == pytest.approx(2.0 - math.pi / 2)
    assert r["first"] == {"time_s": pytest.approx(0.1), "joint": "bend_02", "angle_rad": pytest.approx(-1.0)}
    assert h.outputs(0.3)["max_excess"] == pytest.approx(2.0 - math.pi / 2)
    line = JointLimits.format_report(r)[0]
    assert "twist_00 114.6 deg (limit ±90.0)" in line and "bend_02 -57.3 deg (limit ±45.0)" in line
    assert h.c._stop.reason is None


def test_stop_on_violation_names_joint_angle_and_limits():
    h = _watch(stop_on_violation=True)
    q = np.zeros(ROBOT.nj)
    q[J["bend_03"]] = 0.9
    h.inputs.joint_q = q
    h.update(0.0)
    assert "joint bend_03 at 0.9 rad is past its limits [-0.7854, 0.7854]" in h.c._stop.reason


def test_within_limits_reports_nothing():
    h = _watch()
    h.inputs.joint_q = np.zeros(ROBOT.nj)
    h.update(0.0)
    r = h.c.report(h.u.cache, {"completed": True})
    assert r["past_limits"] == {} and "stayed within" in JointLimits.format_report(r)[0]
