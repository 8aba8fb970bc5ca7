"""Contact onset at the step a user gets: the default scene's robot dropped onto the ice (issue 24).

A drop must never inject energy (the centre of mass never rises above where it was released: the ice's
spring-damper only takes energy out once the robot lands) and must come to rest where a converged RK4 run
(0.2 ms) does. Before error control the default 10 ms step threw the robot 1.7 m from a 1 cm drop.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
from event_scenes import drop, reference_drop, rest_offset, rise_above_start  # noqa: E402

from snakesim.components.contact.jacobian_kernels import point_jacobian  # noqa: E402


@pytest.mark.parametrize("height", [0.01, 0.05])
def test_a_drop_at_the_default_settings_lands_and_rests_where_rk4_does(height):
    r = drop(height)
    ref = reference_drop(height)
    assert r.summary["completed"], r.summary["stop_reason"]
    assert r.summary["integrator"]["name"] == "rosenbrock_w"
    assert rise_above_start(r) < 1e-4            # m; the resting robot itself breathes by ~30 µm
    assert rest_offset(r, ref) < 5e-3
    assert r.summary["integrator"]["rejected"] > 0   # the landing was found by the error estimate


def test_the_lookahead_lets_fixed_steps_meet_the_ice_implicitly():
    """At fixed 10 ms steps with J every step, a ring about to touch puts the ice's spring-damper in the step's
    matrix (lookahead_time): a 1 cm drop lands. Without the look-ahead the step that makes contact takes
    k = 1e5 N/m and c = 1e3 N·s/m explicitly (c h / m ≈ 3 per ring) and throws the robot: the multibody's
    blow-up guard stops that run as a failure at the landing step."""
    fixed = {"name": "rosenbrock_w", "params": {"method": "ros2", "step_control": "fixed", "jacobian_every": 1}}
    with_lookahead = drop(0.01, fixed, dt=0.01)
    without = drop(0.01, fixed, dt=0.01, sets=["components.contact.params.lookahead_time=0.0"])
    assert with_lookahead.summary["completed"] and rise_above_start(with_lookahead) < 1e-4
    assert without.summary["failure_kind"] == "blow_up" or rise_above_start(without) > 0.1, without.summary


def _limit_jacobian(depth, ahead, vn=-0.3):
    n = np.array([0.0, 0.0, 1.0])
    v = np.array([0.05, -0.02, vn])
    e = np.array([1.0, 0.0, 0.0])
    Dv, Dp, W, gk = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3, 3)), np.zeros(3)
    on = point_jacobian(depth, n, v, e, 1e5, 1e3, 0.3, 2.0, 0.0, 1e-3, 0, 0.05, ahead, Dv, Dp, W, gk)
    return on, Dv, Dp


def test_a_point_ahead_declares_the_spring_damper_it_meets_on_touching():
    """A point not yet touching, declared ahead, gives the slopes of the same point at the moment of touching
    (depth → 0⁺ while approaching, where F_n → 0⁺): ∂F/∂v = −c g n̂ᵀ and ∂F/∂p = −k g n̂ᵀ with g = ∂F/∂F_n
    (the friction that grows with F_n included), and no friction slope (μF_n = 0). Not ahead: nothing."""
    on, Dv, Dp = _limit_jacobian(-0.002, True)
    touching, Dv1, Dp1 = _limit_jacobian(1e-12, False, vn=-1e-12)   # touching, F_n = k d − c v·n̂ → 0⁺
    assert on and touching
    np.testing.assert_allclose(Dp, Dp1, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Dv, Dv1, rtol=1e-9, atol=1e-6)
    assert np.abs(Dp[:, 2]).max() > 1e4             # the ice's k is there …
    assert not _limit_jacobian(-0.002, False)[0]     # … and only for a point declared ahead
