"""helical_gait (components/control/helical_gait.py): the rolling-helix joint angles, their rates, the
helix-to-amplitude relation against the chain's forward kinematics, and the parameter checks; the
mini-eels-pipe-climb scene holding Mini EELS 1.0 in the vertical pipe against gravity."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.control.helical_gait import helix_amplitude, ring_centre
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework.session import load_session

from helical_parts import make_gait


class Y:
    def __init__(self, n):
        self.setpoint, self.rate = np.zeros(n), np.zeros(n)


def evaluate(c, t):
    y = Y(c.robot.nj)
    c.output(t, None, None, y)
    return y


def test_rolling_helix_joint_angles_and_rates(mini):
    A, phi, f = 0.8, 0.3, 0.5
    c = make_gait(mini, amplitude=A, phase_step=phi, frequency=f, direction=-1, t_start=1.0)
    names = list(mini.joints)
    pitch = [names.index(f"bend_0{i}") for i in (0, 2, 4, 6, 8)]
    yaw = [names.index(f"bend_0{i}") for i in (1, 3, 5, 7, 9)]
    assert list(c._pitch) == pitch and list(c._yaw) == yaw
    y0 = evaluate(c, 0.5)                       # before t_start: the shape at α = phase, held
    k = np.arange(5)
    assert np.allclose(y0.setpoint[pitch], A * np.sin(k * phi))
    assert np.allclose(y0.setpoint[yaw], A * np.cos(k * phi))
    assert not y0.rate.any()
    t, h = 1.7, 1e-6
    y, y2 = evaluate(c, t), evaluate(c, t + h)
    a = -2 * math.pi * f * (t - 1.0) + k * phi
    assert np.allclose(y.setpoint[pitch], A * np.sin(a)) and np.allclose(y.setpoint[yaw], A * np.cos(a))
    assert np.allclose(y.rate, (y2.setpoint - y.setpoint) / h, atol=1e-5)
    # the curvature vector keeps its magnitude A per pair while it turns
    assert np.allclose(np.hypot(y.setpoint[pitch], y.setpoint[yaw]), A)


def test_helix_amplitude_matches_the_chain_ring(mini):
    """A planar ring (pitch 0) of radius R: A = 2 asin(ℓ/R) puts the yaw joints on the circle (FK)."""
    for R in (0.175, 0.22, 0.3):
        A, phi = helix_amplitude(R, 0.0, 0.09)
        assert phi == 0.0
        centre, radius = ring_centre(mini, A)
        assert radius == pytest.approx(R, rel=1e-9)
    c = make_gait(mini, helix={"radius": 0.2, "pitch": 0.1})
    cc = 0.1 / (2 * math.pi)
    kappa, tau = 0.2 / (0.04 + cc * cc), cc / (0.04 + cc * cc)
    assert c.spacing == pytest.approx(0.09)
    assert c.amplitude == pytest.approx(2 * math.asin(0.09 * kappa)) and c.phase_step == pytest.approx(0.18 * tau)


def test_pipe_climb_scene_places_the_ring_on_the_pipe_axis(mini):
    centre, radius = ring_centre(mini, 1.08)
    assert centre[:2] == pytest.approx([0.06, 0.1501], abs=2e-4)       # the scene's centre_x, centre_y
    assert radius + 0.028 * math.cos(1.08 / 2) < 0.2                     # the shell inside the 0.2 m pipe


@pytest.mark.parametrize("params, message", [
    ({}, "exactly one of 'amplitude'"),
    ({"amplitude": 0.5, "helix": {"radius": 0.2}}, "exactly one of 'amplitude'"),
    ({"amplitude": -0.1}, "amplitude must be >= 0"),
    ({"amplitude": 1.55}, "exceeds joint bend_00's limit"),
    ({"helix": {"radius": 0.05}}, "more than joints 0.09 m apart can bend"),
    ({"helix": {"radius": 0.095}}, "exceeds joint"),
    ({"amplitude": 0.5, "joints": "bend_0[0246]"}, "alternating pitch and yaw"),
    ({"amplitude": 0.5, "frequency": -1.0}, "greater than or equal to 0"),
    ({"amplitude": 0.5, "direction": 2}, "direction"),
    ({"amplitude": float("nan")}, "finite"),
])
def test_parameters_are_checked(mini, params, message):
    with pytest.raises(ValueError, match=message):
        make_gait(mini, **params)


def test_joints_that_are_not_pitch_or_yaw_are_refused():
    eels = RobotModel.load(design="eels-1.0", modules=2)
    with pytest.raises(ValueError, match="neither pitch"):
        make_gait(eels, amplitude=0.3, joints="*")


def test_mini_eels_holds_in_the_pipe_against_gravity():
    """Gravity on at 0.2 s, no rolling (frequency 0; the scene's soft skin, rosenbrock_w at 2 ms): the ring braced on
    the wall (joint PIDs at the 3 N·m limit) carries the 2.95 kg robot. Σ F_n ≈ 57 N with μ = 0.8 gives 45 N of grip
    against 28.9 N of weight (1.5× asserted). The regularised friction (v_ε = 1 mm/s) lets the load through as
    creep, v = v_ε s/sqrt(1 − s²) per contact at s = its share of μF_n: 0.5 mm/s if the 9 contacts shared alike,
    measured 0.9 mm/s (a few carry most): bound 5 mm/s after 1 s and 1.2 cm in 2 s (measured 3.8 mm)."""
    s = load_session("mini-eels-pipe-climb", overrides=["frequency=0.0"], sim_overrides={"duration": 2.0})
    r = s.run()
    assert r.summary["completed"], r.summary
    t, com, fn = r["t"], r["robot.com"], r["contact.normal_force"].ravel()
    late = t > 1.0
    assert com[-1, 2] > com[0, 2] - 0.012
    assert np.polyfit(t[late], com[late, 2], 1)[0] > -0.005
    assert fn[late].min() * 0.8 > 1.5 * 2.95 * 9.81
    assert np.ravel(r["monitor.contact_made"])[-1] == 1.0
