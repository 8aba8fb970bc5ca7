"""brace_climb's friction descent (components/control/brace_climb.py) on scripted inputs: the velocity-form PI
A_{k+1} = A_k + k_p (e_k − e_{k−1}) + T k_i e_k, e = −v_z − v*, inside the window; the re-grip hand-over to the
load law once the slide has stopped; the command input; clear errors. The scene is tested in
tests/validation/test_tube_body_brace_descend.py."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.control.brace_climb import BraceClimb
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
KP, KI, V, T = 0.5, 2.0, 0.05, 0.01


def _ctrl(**params):
    base = {"target": 100.0, "gain": 0.5, "max_rate": 0.4, "amplitude0": 0.8, "amplitude_min": 0.3,
            "amplitude_max": 1.0, "pattern": {}, "torque_pattern": {"bend_02": 30.0}, "descent_speed": V,
            "descend_start": 1.0, "descend_stop": 2.0, "descent_kp": KP, "descent_ki": KI}
    h = Harness(BraceClimb, {**base, **params}, rate=1.0 / T, uses={"robot": ROBOT})
    h.inputs.loads = np.full(4, 100.0)            # at the target: the load law keeps A
    return h


def _vz(h, vz):
    lv = np.zeros((ROBOT.nl, 6))
    lv[ROBOT.link_row["tail"], 2] = vz
    h.inputs.link_velocities = lv


def _A(h):
    return float(h.outputs()["amplitude"][0])


def test_pi_on_the_descent_speed_inside_the_window():
    h = _ctrl()
    _vz(h, 0.0)
    h.update(0.5)
    assert _A(h) == pytest.approx(0.8)                                  # hold: the load law, at its target
    h.update(1.0)                                                        # enter: e = −V, e_prev = 0
    assert _A(h) == pytest.approx(0.8 + KP * (-V) + T * KI * (-V))
    a = _A(h)
    h.update(1.01)                                                       # still stuck: the integral relaxes
    assert _A(h) == pytest.approx(a + T * KI * (-V))
    a = _A(h)
    _vz(h, -0.08)                                                        # slipped, 8 cm/s: squeeze
    h.update(1.02)
    assert _A(h) == pytest.approx(a + KP * (0.08 - V - (-V)) + T * KI * (0.08 - V))


def test_regrip_keeps_the_pi_until_stopped_then_the_load_law():
    h = _ctrl()
    _vz(h, -V)
    h.update(1.5)
    a = _A(h)
    _vz(h, -0.01)                                                        # window over, still sliding 1 cm/s
    h.update(2.0)
    assert _A(h) == pytest.approx(a + KP * (0.01 - 0.0) + T * KI * 0.01)
    a = _A(h)
    _vz(h, -0.001)                                                       # below stopped_speed: the load law
    h.inputs.loads = np.full(4, 50.0)
    h.update(2.01)
    assert _A(h) == pytest.approx(a + T * 0.5 * 0.5)                     # gain × relative error, < max_rate


def test_command_input_overrides_the_window_and_default_is_the_load_law():
    h = _ctrl(descent_speed=0.0)
    h.inputs.loads = np.full(4, 50.0)
    h.update(1.5)                                                        # no descent configured, nothing wired
    assert _A(h) == pytest.approx(0.8 + T * 0.25)
    h = _ctrl()
    _vz(h, 0.0)
    h.inputs.descent_speed = np.array([0.02])                            # outside the window: descend at 2 cm/s
    h.update(0.2)
    assert _A(h) == pytest.approx(0.8 + KP * (-0.02) + T * KI * (-0.02))


def test_bad_input_is_named():
    h = _ctrl()
    with pytest.raises(ValueError, match="link_velocities"):
        h.update(1.0)
    with pytest.raises(ValueError, match="descent_link 'nose'"):
        _ctrl(descent_link="nose").update(0.0)
    with pytest.raises(ValueError, match="descend_start < descend_stop"):
        _ctrl(descend_start=3.0).update(0.0)
    h = _ctrl()
    _vz(h, 0.0)
    h.inputs.descent_speed = np.array([-0.01])                           # never clamped: named
    with pytest.raises(ValueError, match=r"descent_speed input = -0.01 m/s: a descent speed is >= 0"):
        h.update(0.2)
