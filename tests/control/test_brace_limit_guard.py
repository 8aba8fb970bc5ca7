"""brace_climb's limit guard (``limit_margin``): a soft stop k_l·(excess past limit − margin) on the bend and
twist joints, added to the feed-forward; off by default (the existing brace scenes are unchanged)."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.control.brace_climb import BraceClimb
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
J = list(ROBOT.joints)


def _ctrl(**params):
    return Harness(BraceClimb, {"target": 100.0, "amplitude0": 1.0, "amplitude_max": 2.0,
                                "torque_pattern": {"bend_03": -50.0}, **params}, rate=100.0, uses={"robot": ROBOT})


def test_guard_pushes_back_only_past_the_margin():
    lo, hi = ROBOT.position_limits()
    h = _ctrl(limit_margin=0.03, limit_stiffness=2000.0)
    h.inputs.loads = np.full(4, 100.0)                      # at target: A stays 1
    q = np.zeros(ROBOT.nj)
    b3, b1, s0 = J.index("bend_03"), J.index("bend_01"), J.index("screw_front_00")
    q[b3] = lo[b3] + 0.01                                   # 0.02 rad inside the margin band
    q[b1] = hi[b1] - 0.05                                   # outside the band: no push
    q[s0] = 123.0                                           # screws are never guarded
    h.inputs.joint_q = q
    h.update(0.0)
    tau = h.outputs(0.01)["tau_ff"]
    assert tau[b3] == pytest.approx(-50.0 + 2000.0 * 0.02)  # pattern + the spring back towards the range
    assert tau[b1] == 0.0 and tau[s0] == 0.0


def test_guard_off_by_default_and_needs_joint_q_when_on():
    h = _ctrl()
    h.inputs.loads = np.full(4, 100.0)
    h.update(0.0)
    assert h.outputs(0.01)["tau_ff"][J.index("bend_03")] == -50.0
    g = _ctrl(limit_margin=0.03)
    g.inputs.loads = np.full(4, 100.0)
    with pytest.raises(ValueError, match="wire the multibody's joint_q"):
        g.update(0.0)
