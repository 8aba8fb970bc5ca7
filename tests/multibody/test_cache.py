"""The multibody's per-run cache (make_cache): derivative() reuses what output() solved, the
kinematics follow the state they belong to, gravity follows its input, and two builds share nothing."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.multibody import Multibody
from snakesim.framework import Harness
from snakesim.framework.session import load_session

ROBOT = {"design": "eels-1.0", "modules": 2}


def harness(**params):
    h = Harness(Multibody, {**ROBOT, **params})
    rng = np.random.default_rng(3)
    nq = h.c.robot.nq
    h.x[7:nq] += 0.1 * rng.standard_normal(nq - 7)
    h.x[nq:] = 0.2 * rng.standard_normal(h.c.robot.nv)
    return h, rng


def fresh_derivative(h, **inputs):
    """The same component state and inputs in a new harness: nothing cached from before."""
    g = Harness(Multibody, h.c.p.model_dump())
    g.x[:] = h.x
    for name, value in inputs.items():
        g.set_input(name, value)
    return g.derivative()


def test_derivative_follows_a_changed_input_between_two_calls():
    h, rng = harness()
    nl, nj = h.c.robot.nl, h.c.robot.nj
    W = rng.standard_normal((nl, 6))
    h.inputs.wrenches = W
    for _ in range(2):
        tau = rng.standard_normal(nj)
        h.inputs.tau = tau
        np.testing.assert_array_equal(h.derivative(), fresh_derivative(h, tau=tau, wrenches=W))


def test_derivative_follows_a_changed_state_and_its_kinematics():
    """Wrenches act through the link kinematics: after the state moves (in place, as integrators
    move it) the solve must not reuse the kinematics of the old state, even when output() runs
    before the state outputs (the Harness's order)."""
    h, rng = harness()
    nl, nq = h.c.robot.nl, h.c.robot.nq
    W = rng.standard_normal((nl, 6))
    h.inputs.wrenches = W
    before = h.derivative()
    h.x[7:nq] += 0.05
    after = h.derivative()
    assert not np.array_equal(before, after)
    np.testing.assert_array_equal(after, fresh_derivative(h, wrenches=W))
    # and the accelerations output agrees with the derivative's
    np.testing.assert_array_equal(h.outputs()["a"], after[h.c.robot.nv:])


def test_gravity_follows_its_input_and_back_to_the_parameter():
    h, _ = harness(gravity_input="vector")
    g0 = h.derivative()
    h.inputs.gravity = [0.0, 0.0, 0.0]
    free = h.derivative()
    assert not np.array_equal(free, g0)
    np.testing.assert_array_equal(free, fresh_derivative(h, gravity=[0.0, 0.0, 0.0]))
    h.inputs.gravity = [np.nan] * 3                   # unconnected: the parameter's gravity again
    np.testing.assert_array_equal(h.derivative(), g0)


def test_each_build_has_its_own_cache_and_the_component_keeps_no_run_state():
    a = load_session("robot-zero-g", sim_overrides={"duration": 0.01})
    b = load_session("robot-zero-g", sim_overrides={"duration": 0.01})
    ca, cb = a.plan.caches["robot"], b.plan.caches["robot"]
    assert ca is not cb and ca.model is not cb.model
    robot = a.plan.components["robot"]
    before = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(robot).items()}
    x1 = a.run() and a.plan.X.copy()
    x2 = a.run() and a.plan.X.copy()
    np.testing.assert_array_equal(x1, x2)
    for k, v in vars(robot).items():                # parameters and constants only: a run changes none
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(v, before[k], err_msg=k)


def test_evaluating_at_another_state_array_says_to_write_into_the_cached_one():
    """The cache holds views of the state it was made for (the plan's; a Harness's h.x), so a copy
    passed in would be silently ignored: it is refused instead."""
    h, _ = harness()
    for method in (h.c.calc_state, h.c.output):
        with pytest.raises(ValueError, match="write the state into that array"):
            method(0.0, h.x.copy(), h.u, h.y)
