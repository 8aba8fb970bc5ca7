"""The reference brace-and-climb controller (components/control/brace_climb.py): its regulation law, and
walls-brace-climb.yaml, EELS 1.5 braced between the 0.35 m walls in one run at rosenbrock_w's 10 ms step:
static balance of the hold from the recorded contact forces, the evaluation's table, the failure variant."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.control.brace_climb import BraceClimb
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness
from snakesim.framework.session import load_session

ROBOT = RobotModel.load(design="eels-1.5")


def _ctrl(**params):
    return Harness(BraceClimb, {"target": 100.0, "gain": 0.5, "max_rate": 0.4, "amplitude_max": 1.0,
                                "pattern": {"bend_0[12]": 1.0}, "torque_pattern": {"bend_02": 30.0},
                                "climb_start": 1.0, "speed": 2.0,
                                "climb_signs": {"screw_front_00": -1.0, "screw_*": 1.0}, **params},
                   rate=100.0, uses={"robot": ROBOT})


def test_amplitude_follows_the_load_error_within_its_rate_and_limits():
    h = _ctrl()
    h.inputs.loads = np.full(4, 50.0)                 # mean 50 N: error 0.5 -> 0.25 rad/s
    h.update(0.0)
    out = h.outputs(0.01)
    assert out["amplitude"][0] == pytest.approx(0.0025)
    sp = out["setpoint"]
    j = list(ROBOT.joints)
    assert sp[j.index("bend_01")] == sp[j.index("bend_02")] == pytest.approx(0.0025)
    assert sp[j.index("bend_00")] == 0.0 and out["tau_ff"][j.index("bend_02")] == pytest.approx(0.075)
    h.inputs.loads = np.array([100.0, 100.0, 100.0, 5.0])   # one screw off the wall: regulate on the min
    h.update(0.01)
    assert h.outputs()["amplitude"][0] == pytest.approx(0.0025 + 0.004)      # rate-limited at 0.4 rad/s
    h.inputs.loads = np.full(4, 1000.0)
    for k in range(200):
        h.update(0.02 + 0.01 * k)
    assert h.outputs()["amplitude"][0] == 0.0                                 # clipped at amplitude_min


def test_screws_braked_then_climb_at_the_signed_speed_and_the_input_overrides():
    h = _ctrl()
    h.inputs.loads = np.full(4, 100.0)
    h.update(0.5)
    screws = [i for i, k in enumerate(ROBOT.joint_kinds) if k == "screw"]
    assert (h.outputs()["setpoint"][screws] == 0.0).all() and h.outputs()["phase"][0] == 0.0
    h.update(1.0)
    np.testing.assert_allclose(h.outputs()["setpoint"][screws], [-2.0, 2.0, 2.0, 2.0])
    h.inputs.climb_speed = np.array([-1.0])                                    # e.g. a ROS 2 command: descend
    np.testing.assert_allclose(h.outputs()["setpoint"][screws], [1.0, -1.0, -1.0, -1.0])
    h.inputs.target_force = np.array([200.0])
    a0 = h.outputs()["amplitude"][0]
    h.update(1.01)
    assert h.outputs()["amplitude"][0] > a0                                    # 100 N is below the new target


@pytest.fixture(scope="module")
def hold():
    s = load_session("walls-brace-climb")
    r = s.run()
    mass = sum(l.mass for l in s.plan.components["robot"].robot.tree.links)
    return s, r, mass


def test_hold_static_balance_friction_along_gravity_carries_the_weight(hold):
    """Field test step 2: Σ friction along gravity = weight within 2 %, from the recorded contact forces.
    The walls push along ±y, so the contact forces' z components are the friction along gravity."""
    s, r, mass = hold
    assert r.summary["completed"], r.summary["stop_reason"]
    T = r["t"]
    W = np.asarray(r["contact.wrenches"]).reshape(len(T), -1, 6)
    fz = W[:, :, 2].sum(axis=1)
    mg = mass * 9.81
    late = T >= 1.0                                   # after the brace's first second
    err = np.abs(fz[late] - mg) / mg
    assert err.max() < 0.02, err.max()
    Fn = np.asarray(r["contact.screw_normal_force"])
    assert Fn[T >= 8.0].mean(axis=1) == pytest.approx(100.0, rel=0.1)          # the brace's target, regulated
    assert (Fn[late] > 0).all()                                                # every screw on a wall
    z = np.asarray(r["robot.com"])[:, 2]
    assert abs(z[-1] - z[late][0]) < 5e-3


def test_hold_evaluation_table(hold):
    _, r, _ = hold
    rep = r.summary["reports"]["evaluation"]
    assert rep["contact"]["made"] and rep["contact"]["time_s"] == 0.0
    assert rep["hold"]["achieved"] and rep["hold"]["longest_s"] >= 10.0
    assert rep["failure"]["failed"] is False
    assert rep["vertical_distance"]["down_m"] < 5e-3 and rep["max_tilt_deg"] < 60.0


def test_too_little_squeeze_fails_and_the_evaluation_says_why():
    r = load_session("walls-brace-climb-fail").run()
    sm = r.summary
    assert not sm["completed"] and "slid down out of the walls" in sm["stop_reason"]
    rep = sm["reports"]["evaluation"]
    assert not rep["hold"]["achieved"] and rep["vertical_distance"]["down_m"] > 1.0
    assert rep["failure"]["failed"] and rep["failure"]["reason"] == sm["stop_reason"]
