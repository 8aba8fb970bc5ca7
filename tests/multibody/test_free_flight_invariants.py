"""A free robot with every joint moving keeps its invariants (issue 24, part 3).

``robot-zero-g`` (no gravity, no torque, no contact, no PID: every joint is free) set moving in every
joint: ``v0 = {bend_*: 0.6, twist_*: -0.4, screw_*: 5}``, ``q0 = {bend_*: 0.1, twist_*: -0.2}`` and
``base_velocity = [0.1, 0, 0, 0.2, -0.1, 0.3]``. Nothing external acts, so the kinetic energy, the
linear momentum P and the angular momentum about the centre of mass L_G (world axes) are constant;
the goal is a drift within 0.1 %/s of each (max |I(t) − I(0)| / |I(0)| over the run, per second of
it) at the default settings.

Why the implicit step's drift is a step-size effect and not a defect of its free base (measured, the
report of issue 24): in free flight no component declares a force slope, so the W-method's matrix is
W = [[I, −γhI], [0, I]] (the multibody's M cancels from M k_v = M r_v, which
:func:`test_free_flight_w_solve_is_independent_of_the_jacobian_age` checks), and ROS2 is then a
2nd-order explicit scheme; with J = 0 it would be Heun's method exactly. Its invariant drift falls as
h², is 5-17x Heun's because of γ = 1 + 1/√2 (it grows monotonically with γ: 0, 0.29, 0.5, 1.71), is
not reduced by the exact Jacobian (ROS2 on a finite-difference J drifts as much or more: the Coriolis
and gyroscopic slopes are not the cause), and is unchanged within 5 % without the Munthe-Kaas stage
correction (which matches finite differences of log6(exp6(u) exp6(εξ))). ROS34PW2 or an error
controlled step meets the goal: rosenbrock_w's default tolerances are set so that it does.

Linear momentum is *not* kept to round-off by any of the framework's integrators, RK4 included (its
drift falls as h⁴: 6.5e-7/s at 10 ms, 6.9e-11/s at 1 ms): P is linear in the world-frame centre-of-mass
velocity, but the state carries the base twist in the tail frame and the orientation as a quaternion,
in which P = R(q)·(…)(q, v) is not linear, and Runge-Kutta and W-methods conserve only invariants
linear in their own coordinates. It is held to the same 0.1 %/s accuracy bound instead.

``SETTINGS`` names each integrator setting; ``rosenbrock_w-defaults-10ms`` is what a user gets from
``--integrator rosenbrock_w --dt 0.01``, ``default-scene`` whatever the default scene
(``surface-screw-traverse``) runs, at its dt, so this test follows it. A setting that does not yet
meet the goal is a strict xfail with the measured drift as its reason: when it starts to pass, the
xfail must go.
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.framework.assembly import resolve
from snakesim.framework.cli import default_registry
from snakesim.framework.session import load_session

LIVELY = ['components.robot.params.v0={"bend_*": 0.6, "twist_*": -0.4, "screw_*": 5}',
          'components.robot.params.q0={"bend_*": 0.1, "twist_*": -0.2}',
          'components.robot.params.base_velocity=[0.1, 0, 0, 0.2, -0.1, 0.3]',
          'record=[robot.momentum, robot.energy, robot.com, robot.q, robot.v]']
DURATION = 2.0
BOUND = 1e-3            # 0.1 %/s


def _fixed(**params):
    return {"name": "rosenbrock_w", "params": {**params, "step_control": "fixed"}}


def _default_setting():
    """(integrator spec, dt) of the default scene."""
    reg = default_registry()
    sim = resolve(reg.default_assembly(), search_path=reg.assembly_paths()).sim
    return sim.integrator.model_dump(), sim.dt


def _rosenbrock_w_defaults():
    """What `--integrator rosenbrock_w --dt 0.01` gives: every parameter at its default (error control at
    atol_q 3e-4 m, atol_v 3e-3 m/s, rtol 3e-3)."""
    return {"name": "rosenbrock_w", "params": {}}, 0.01


# name -> () -> (integrator spec, dt). Measured drifts over 2 s (%/s of E, P, L_G) in the comments.
SETTINGS = {
    "rosenbrock_w-defaults-10ms": pytest.param(_rosenbrock_w_defaults),                  # 0.013, 0.064, 0.084
    # the default scene's own setting (a robot on the ground: looser tolerances, 20 ms base step, for speed)
    "default-scene": pytest.param(_default_setting, marks=pytest.mark.xfail(
        strict=True, reason="the default scene's tolerances (atol_q 3e-3, atol_v 3e-2, rtol 3e-2) are set for a "
                            "robot on the ice and drift 0.14 %/s in energy and 0.45 %/s in angular momentum on "
                            "the lively free robot; rosenbrock_w's defaults meet the bound")),
    "rk4-10ms": pytest.param(lambda: ("rk4", 0.01)),                                    # 4e-5, 6e-5, 5e-5
    "ros2-fixed-10ms": pytest.param(lambda: (_fixed(method="ros2"), 0.01), marks=pytest.mark.xfail(
        strict=True, reason="ROS2 at a fixed 10 ms: 0.35 %/s energy, 1.2 %/s angular momentum (h² truncation "
                            "error, gamma = 1 + 1/sqrt(2); not a defect of the free base)")),
    "ros2-fixed-2ms": pytest.param(lambda: (_fixed(method="ros2"), 0.002)),             # 0.009, 0.041, 0.053
    "ros34pw2-fixed-10ms": pytest.param(lambda: (_fixed(method="ros34pw2"), 0.01)),     # 0.027, 0.023, 0.026
}


def run_lively(integrator, dt, duration=DURATION):
    session = load_session("robot-zero-g", overrides=LIVELY, registry=default_registry(),
                           sim_overrides={"dt": dt, "duration": duration, "integrator": integrator})
    result = session.run()
    assert result.summary["completed"], result.summary
    return session, result


def invariants(result):
    """(kinetic energy, P, L_G) per recorded row: L_G about the centre of mass, world axes."""
    h, c = result["robot.momentum"], result["robot.com"]
    P = h[:, :3]
    return result["robot.energy"].sum(axis=1), P, h[:, 3:] - np.cross(c, P)


def drift_per_second(values, duration):
    values = values.reshape(len(values), -1)
    return np.linalg.norm(values - values[0], axis=1).max() / np.linalg.norm(values[0]) / duration


@pytest.mark.parametrize("setting", SETTINGS.values(), ids=SETTINGS.keys())
def test_lively_free_robot_keeps_energy_and_momentum(setting):
    integrator, dt = setting()
    session, result = run_lively(integrator, dt)
    energy, P, L = invariants(result)
    # the motion is lively: every joint moves, the base tumbles
    assert np.linalg.norm(L[0]) > 100.0 and np.linalg.norm(P[0]) > 100.0 and energy[0] > 500.0
    T = result.summary["sim_time_s"]
    drift = {name: drift_per_second(v, T) for name, v in (("energy", energy), ("P", P), ("L_G", L))}
    assert max(drift.values()) < BOUND, drift


def test_momentum_output_is_pinocchios_centroidal_momentum():
    """The invariants above come from the multibody's own outputs: the same as Pinocchio's centroidal
    momentum (about the centre of mass, world axes) of the recorded state."""
    import pinocchio as pin

    session, result = run_lively("rk4", 0.01, duration=0.2)
    model = session.plan.components["robot"].dyn.model
    data = model.createData()
    _, P, L = invariants(result)
    q, v = result["robot.q"], result["robot.v"]
    for i in (0, len(q) - 1):
        hg = pin.computeCentroidalMomentum(model, data, q[i], v[i]).vector
        np.testing.assert_allclose(hg[:3], P[i], rtol=0, atol=1e-9 * np.linalg.norm(P[i]))
        np.testing.assert_allclose(hg[3:], L[i], rtol=0, atol=1e-9 * np.linalg.norm(L[i]))


def test_free_flight_w_solve_is_independent_of_the_jacobian_age():
    """With no force slope declared, W k_v = M r_v must give k_v = r_v whatever configuration M was
    factorised at: the factorisation and the right-hand side use the same (possibly stale) M. A W from
    eight steps ago and one from every step give the same trajectory to round-off."""
    states = []
    for every in (1, 8):
        _, result = run_lively(_fixed(method="ros2", jacobian_every=every), 0.01, duration=0.3)
        states.append(np.hstack([result["robot.q"], result["robot.v"]]))
    np.testing.assert_allclose(states[1], states[0], rtol=0, atol=1e-10)
