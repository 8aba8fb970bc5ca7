"""The reference brace-and-climb controller (components/control/brace_climb.py): its regulation law and drive
ramp on scripted inputs, and walls-brace-climb.yaml, EELS 1.5 braced between the 0.35 m walls, holding, climbing
and holding again in one run at rosenbrock_w's 10 ms step: static balance from the recorded contact forces, the
climb's rolling kinematics, the evaluation's table, the failure variant."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.control.brace_climb import BraceClimb, drive_ramp
from snakesim.components.monitors.vertical_mobility import quat_axes
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
    h.inputs.target_force = np.array([200.0])
    a0 = h.outputs()["amplitude"][0]
    h.update(1.01)                                                             # spin_up 0: a step, at the sample
    np.testing.assert_allclose(h.outputs()["setpoint"][screws], [1.0, -1.0, -1.0, -1.0])
    assert h.outputs()["amplitude"][0] > a0                                    # 100 N is below the new target


def test_a_commanded_speed_is_reached_at_the_slew_rate():
    # spin_up 0.5 s to 2 rad/s: the default slew is 4 rad/s², 0.04 rad/s per 10 ms sample
    h = _ctrl(spin_up=0.5)
    h.inputs.loads = np.full(4, 100.0)
    screws = [i for i, k in enumerate(ROBOT.joint_kinds) if k == "screw"]
    sign = np.array([-1.0, 1.0, 1.0, 1.0])
    h.update(2.0)
    np.testing.assert_allclose(h.outputs(2.0)["setpoint"][screws], 2.0 * sign)
    h.inputs.climb_speed = np.array([1.0])
    for k in range(1, 30):
        h.update(2.0 + 0.01 * k)
        out = h.outputs(2.0 + 0.01 * k)
        np.testing.assert_allclose(out["setpoint"][screws], max(2.0 - 0.04 * k, 1.0) * sign, atol=1e-12)
    h = _ctrl(spin_up=0.5, speed_slew=50.0)                                    # explicit: 0.5 rad/s per sample
    h.inputs.loads = np.full(4, 100.0)
    h.update(2.0)
    h.inputs.climb_speed = np.array([1.0])
    h.update(2.01)
    np.testing.assert_allclose(h.outputs(2.01)["setpoint"][screws], 1.5 * sign)


def test_drive_ramp_up_hold_down_and_phase():
    assert drive_ramp(0.9, 1.0, 5.0, 2.0) == 0.0
    assert drive_ramp(1.5, 1.0, 5.0, 2.0) == pytest.approx(0.25)
    assert drive_ramp(4.0, 1.0, 5.0, 2.0) == 1.0
    assert drive_ramp(6.0, 1.0, 5.0, 2.0) == pytest.approx(0.5)
    assert drive_ramp(7.5, 1.0, 5.0, 2.0) == 0.0
    assert drive_ramp(3.0, 1.0, float("inf"), 0.0) == 1.0 and drive_ramp(5.0, 1.0, 5.0, 0.0) == 0.0
    h = _ctrl(climb_start=1.0, climb_stop=2.0, spin_up=0.5)
    h.inputs.loads = np.full(4, 100.0)
    screws = [i for i, k in enumerate(ROBOT.joint_kinds) if k == "screw"]
    for t, phase, r in [(0.5, 0, 0.0), (1.25, 1, 0.5), (2.25, 1, 0.5), (2.6, 2, 0.0)]:
        h.update(t)
        out = h.outputs(t)
        assert out["phase"][0] == phase
        np.testing.assert_allclose(out["setpoint"][screws], r * 2.0 * np.array([-1.0, 1.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="climb_start < climb_stop"):
        _ctrl(climb_start=2.0, climb_stop=1.0)


def test_load_screws_select_the_screws_the_brace_regulates_on():
    h = _ctrl(load_screws=[0, 3], regulate="min")
    h.inputs.loads = np.array([50.0, 0.0, 0.0, 100.0])     # middle screws free: not "lost", not in the min
    h.update(0.0)
    assert h.outputs()["load"][0] == 50.0 and h.outputs()["amplitude"][0] == pytest.approx(0.0025)
    h.inputs.loads = np.array([50.0, 0.0])
    with pytest.raises(ValueError, match="index past the 2 loads"):
        h.update(0.01)
    with pytest.raises(ValueError, match="distinct indices"):
        _ctrl(load_screws=[1, 1])


@pytest.fixture(scope="module", params=["walls-brace-climb", "walls-brace-climb-down"])
def climb(request):
    s = load_session(request.param)
    r = s.run()
    mass = sum(l.mass for l in s.plan.components["robot"].robot.tree.links)
    return s, r, mass


def _params(s):
    return s.plan.components["brace"].p


def test_hold_and_rehold_carry_the_weight_by_wall_friction(climb):
    """Field test step 2, before and after the screws turn: Σ friction along gravity = weight within 2 %, from
    the recorded contact forces (the walls push along ±y, so the contact forces' z components are the friction
    along gravity). Not checked while rolling: the centre of mass moves at constant speed there (1e-4), but the
    wall loads shift and the sampled regularised friction (v_eps 5e-5 m/s) is not the implicit step's impulse to
    2 % (3 % seen on the down-climb); the rolling test below checks that phase by its kinematics."""
    s, r, mass = climb
    p = _params(s)
    assert r.summary["completed"], r.summary["stop_reason"]
    T = r["t"]
    W = np.asarray(r["contact.wrenches"]).reshape(len(T), -1, 6)
    fz = W[:, :, 2].sum(axis=1)
    mg = mass * 9.81
    windows = {"hold": (T >= 1.0) & (T < p.climb_start),
               "re-hold": T >= p.climb_stop + p.spin_up + 0.5}
    for name, w in windows.items():
        assert w.sum() > 20, name
        err = np.abs(fz[w] - mg) / mg
        assert err.max() < 0.02, (name, err.max())
    Fn = np.asarray(r["contact.screw_normal_force"])
    late = T >= 1.0
    assert (Fn[late] > p.lost_fraction * p.target).all()                      # every screw kept on its wall
    hold = windows["hold"] & (T >= 8.0)
    assert Fn[hold].min(axis=1).mean() == pytest.approx(p.target, rel=0.1)    # the least load, regulated


def test_climb_rolls_along_the_brace_plane_normal_at_the_screw_surface_speed(climb):
    """Tilted brace: every screw's surface direction â × ê_c is normal to the brace plane (â in it, ê_c = ±y in
    it), so with the two walls' screws turning in opposite senses the robot translates along that normal at
    ω r (rolling; creep ~ v_eps is 1e-4 of it)."""
    s, r, _ = climb
    p = _params(s)
    T = r["t"]
    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    P = np.asarray(r["robot.link_poses"]).reshape(len(T), -1, 7)
    axes = quat_axes(P[0], np.array([1.0, 0.0, 0.0]))
    n = np.cross(axes[names.index("module_00")], axes[names.index("module_02")])
    n /= np.linalg.norm(n)
    assert abs(n[1]) < 1e-3                                                    # the plane contains the wall normal
    w = (T >= p.climb_start + p.spin_up + 0.3) & (T < p.climb_stop)
    com = np.asarray(r["robot.com"])
    V = np.polyfit(T[w], com[w], 1)[0]                                         # m/s, least-squares slope
    r_screw = float(ROBOT.metadata["screws"][0]["radius"])                   # m, the envelope radius
    assert np.linalg.norm(V) == pytest.approx(abs(p.speed) * r_screw, rel=0.03)
    assert np.degrees(np.arccos(abs(V @ n) / np.linalg.norm(V))) < 2.0
    assert np.sign(V[2]) == np.sign(p.speed)                                   # up, or down for the down-climb


def test_climb_evaluation_table(climb):
    s, r, _ = climb
    rep = r.summary["reports"]["evaluation"]
    assert rep["contact"]["made"] and rep["contact"]["time_s"] == 0.0
    assert rep["hold"]["achieved"] and rep["hold"]["longest_s"] >= 10.0
    assert rep["hold"]["to_s"] <= _params(s).climb_start + 0.5                # the hold is the one before the climb
    vd = rep["vertical_distance"]
    if _params(s).speed > 0:
        assert vd["up_m"] >= 1.0 and vd["down_m"] < 5e-3                      # issue 15: climbs >= 1 m
    else:
        assert vd["down_m"] >= 1.5 and vd["up_m"] < 5e-3                      # down-climbs >= 1.5 m
    assert rep["failure"]["failed"] is False and rep["max_tilt_deg"] < 60.0


UPRIGHT = "pose={position: [-1e-06, 0.279571, 0.073544], quaternion: [0.583061, -0.5830591, 0.4000527, 0.4000498]}"


def test_upright_brace_rolls_about_the_vertical_instead_of_climbing():
    """Why the scene tilts its brace: in the placed (upright) C every screw's surface direction â × ê_c is
    horizontal, so screws turning the same way make the two walls' frictions a yaw couple; the robot rolls
    about the vertical like a log between the walls, at Ω = ω r / (gap/2) when the contacts roll, and does
    not rise. (Nor does it slide: converged, the centre of mass sinks ~2 mm in the 1.5 s, rosenbrock_w at fixed
    0.25 ms and under error control alike; fixed 10 ms steps slid it 12 cm, which this test once asserted.)"""
    w, gap = 0.5, 0.35
    s = load_session("walls-brace-climb", sim_overrides={"duration": 1.5}, overrides=[
        UPRIGHT, "climb_start=1.0", f"climb_speed={w}", "spin_up=0.0",
        "climb_signs={screw_front_00: 1.0, screw_front_01: 1.0, screw_front_02: 1.0, screw_front_03: 1.0}"])
    r = s.run()
    T = np.asarray(r["t"])
    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    P = np.asarray(r["robot.link_poses"]).reshape(len(T), -1, 7)
    psi = []
    for k in range(len(T)):
        ax = quat_axes(P[k], np.array([1.0, 0.0, 0.0]))
        n = np.cross(ax[names.index("module_00")], ax[names.index("module_02")])
        psi.append(np.arctan2(n[1], n[0]))                                     # brace plane's heading
    psi = np.unwrap(np.array(psi))
    w_roll = (T >= 1.2)
    rate = abs(np.polyfit(T[w_roll], psi[w_roll], 1)[0])
    r_screw = float(ROBOT.metadata["screws"][0]["radius"])
    assert rate == pytest.approx(w * r_screw / (gap / 2), rel=0.25)
    assert abs(psi[T < 1.0] - psi[0]).max() < 1e-3                             # braked: no roll
    z = np.asarray(r["robot.com"])[:, 2]
    assert z.max() - z[0] < 1e-3 and z[0] - z[-1] < 1e-2


def test_too_little_squeeze_fails_and_the_evaluation_says_why():
    r = load_session("walls-brace-climb-fail").run()
    sm = r.summary
    assert not sm["completed"] and "slid down out of the walls" in sm["stop_reason"]
    rep = sm["reports"]["evaluation"]
    assert not rep["hold"]["achieved"] and rep["vertical_distance"]["down_m"] > 1.0
    assert rep["failure"]["failed"] and rep["failure"]["reason"] == sm["stop_reason"]
