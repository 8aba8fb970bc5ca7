"""PID joint control against closed-form responses of a one-joint robot (zero gravity).

With the hinge robot of conftest, J θ̈ = τ exactly (J = J_eff). Continuous PD
(tf = 0) gives θ̈ + 2ζωn θ̇ + ωn² θ = ωn² θr with ωn = √(kp/J),
ζ = kd/(2√(kp J)); velocity-mode P gives ω = ωr (1 − exp(−kp t / J)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hinge_robot import hinge_robot, hinge_urdf, j_eff
from snakesim.components.control import JointPid
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

KP, ZETA, STEP = 50.0, 0.3, 0.1
EELS_15 = RobotModel.load(design="eels-1.5")


def pd_step(t, J, kp, kd, ref):
    wn = math.sqrt(kp / J)
    z = kd / (2.0 * math.sqrt(kp * J))
    wd = wn * math.sqrt(1 - z * z)
    return ref * (1 - np.exp(-z * wn * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t)))


def scene(urdf_path, gains, rate=None, duration=2.0, step=STEP, extra=""):
    rate_line = f"\n        rate: {rate}" if rate else ""
    return f"""
    sim: {{duration: {duration}, dt: 0.001, integrator: rk4}}
    components:
      robot:
        type: multibody
        params: {{urdf: "{urdf_path}", gravity: [0, 0, 0], armature: {{hinge: 0.0}}}}
      ref:
        type: step
        params: {{value: {step}, t_step: 0.0}}
      pid:
        type: joint_pid
        params: {{gains: {{hinge: {gains}}}{extra}}}{rate_line}
    connections:
      - ref.y -> pid.setpoint
      - robot.joint_q -> pid.q
      - robot.joint_v -> pid.v
      - pid.tau -> robot.tau
    record: [robot.joint_q, robot.joint_v, pid.tau]
    """


@pytest.fixture
def urdf_path(tmp_path):
    p = tmp_path / "hinge.urdf"
    p.write_text(hinge_urdf())
    return p


def _kd(J):
    return 2 * ZETA * math.sqrt(KP * J)


def test_continuous_pd_step_matches_second_order_closed_form(run_scene, urdf_path):
    J = j_eff()
    kd = _kd(J)
    _, res = run_scene(scene(urdf_path, f"{{mode: position, kp: {KP}, ki: 0, kd: {kd}, tf: 0}}"))
    t = res["t"]
    q = res["robot.joint_q"][:, 0]
    expect = pd_step(t, J, KP, kd, STEP)
    # RK4 at ωn·dt = 0.01: global error ~ (ωn dt)^4 relative, far below 1e-6
    assert np.abs(q - expect).max() < 1e-6 * STEP
    assert q.max() > STEP * (1 + 0.5 * math.exp(-math.pi * ZETA / math.sqrt(1 - ZETA ** 2)))  # it does overshoot


def test_discrete_pd_converges_to_continuous_at_first_order_in_the_sample_period(run_scene, urdf_path):
    """Zero-order hold acts like a delay of T/2: the trajectory error is O(T), bounded by ~T·max|θ̇|."""
    J = j_eff()
    kd = _kd(J)
    errs = {}
    for rate in (1000, 250):
        _, res = run_scene(scene(urdf_path, f"{{mode: position, kp: {KP}, ki: 0, kd: {kd}, tf: 0}}", rate=rate))
        t = res["t"]
        q = res["robot.joint_q"][:, 0]
        errs[rate] = np.abs(q - pd_step(t, J, KP, kd, STEP)).max()
        vmax = np.abs(res["robot.joint_v"][:, 0]).max()
        assert errs[rate] < vmax / rate
    assert 3.0 < errs[250] / errs[1000] < 5.0           # first order: 4x the period, ~4x the error


def test_velocity_mode_p_control_is_a_first_order_lag(run_scene, urdf_path):
    J = j_eff()
    kp, wr = 2.0, 3.0
    _, res = run_scene(scene(urdf_path, f"{{mode: velocity, kp: {kp}, ki: 0, kd: 0, tf: 0}}", step=wr, duration=1.0))
    t = res["t"]
    v = res["robot.joint_v"][:, 0]
    np.testing.assert_allclose(v, wr * (1 - np.exp(-kp * t / J)), atol=1e-7 * wr)


def _saturated_run(run_scene, urdf_path, anti_windup):
    gains = "{mode: position, kp: 40, ki: 60, kd: 6, tf: 0, tau_max: 2.0}"
    _, res = run_scene(scene(urdf_path, gains, duration=4.0, step=1.0, extra=f", anti_windup: {anti_windup}"))
    return res["robot.joint_q"][:, 0], res["pid.tau"][:, 0]


def test_saturation_bounds_the_torque_and_clamping_bounds_the_overshoot(run_scene, urdf_path):
    q_c, tau_c = _saturated_run(run_scene, urdf_path, "clamp")
    q_n, tau_n = _saturated_run(run_scene, urdf_path, "none")
    assert np.abs(tau_c).max() <= 2.0 and np.abs(tau_n).max() <= 2.0
    assert np.isclose(np.abs(tau_c).max(), 2.0)            # the limit is reached: the test exercises it
    over_c, over_n = q_c.max() - 1.0, q_n.max() - 1.0
    # Saturated, the fastest the joint can reach 1 rad from rest is bang-bang; the wound-up integrator
    # then keeps pushing past the target. Clamping freezes it: the overshoot must be far smaller.
    assert over_n > 0.2
    assert over_c < 0.35 * over_n


def test_discrete_filtered_derivative_is_the_backward_difference_at_tf_zero(tmp_path):
    h = Harness(JointPid, {"gains": {"hinge": {"mode": "velocity", "kp": 0, "ki": 0, "kd": 2.0, "tf": 0.0}}},
                rate=100.0, uses={"robot": hinge_robot()})
    h.inputs.setpoint = [1.0]
    h.inputs.v = [0.2]
    assert h.outputs()["tau"][0] == 0.0                    # first tick: no derivative kick
    h.update()
    h.inputs.v = [0.5]                                     # e: 0.8 -> 0.5
    np.testing.assert_allclose(h.outputs()["tau"], [2.0 * (0.5 - 0.8) / 0.01])


def test_continuous_joint_position_error_is_wrapped():
    h = Harness(JointPid, {"gains": {"hinge": {"mode": "position", "kp": 1.0, "kd": 0.0}}},
                uses={"robot": hinge_robot(continuous=True)})
    h.inputs.setpoint = [3.0]
    h.inputs.q = [-3.0]                                    # 6 rad apart, but only 2π − 6 the short way
    np.testing.assert_allclose(h.outputs()["error"], [6.0 - 2 * math.pi])


def test_gains_resolve_per_kind_pattern_and_urdf_effort():
    pid = JointPid("pid", {"gains": {"bend_0[12]": {"kp": 7.0}}, "kind_gains": {"screw": {"ki": 3.0}}},
                   uses={"robot": EELS_15})
    assert pid.gains_of("bend_01")["kp"] == 7.0 and pid.gains_of("bend_01")["mode"] == "position"
    assert pid.gains_of("bend_00")["kp"] == 200.0
    assert pid.gains_of("bend_00")["tau_max"] == 80.0                # URDF effort limit
    s = pid.gains_of("screw_front_02")
    assert (s["mode"], s["ki"], s["tau_max"]) == ("velocity", 3.0, 20.0)


@pytest.mark.parametrize("params, message", [
    ({"gains": {"elbow_*": {"kp": 1.0}}}, "matches no name; valid: bend_00"),
    ({"kind_gains": {"wrist": {"kp": 1.0}}}, "unknown joint kind(s) ['wrist']"),
    ({"gains": {"screw_*": {"kd": 1.0, "tf": 0.0}}}, "need a filter time constant"),
])
def test_bad_gains_are_named(params, message):
    with pytest.raises(ValueError) as e:
        JointPid("pid", params, uses={"robot": EELS_15})
    assert message in str(e.value).replace("needs", "need")
