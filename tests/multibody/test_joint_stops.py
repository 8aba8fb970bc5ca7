"""Joint stops (components/multibody/joint_stops.py): a one-sided spring-damper past the URDF limits.

A tail and one module joined by a bend joint (limits ±1 rad, effort 100 N·m), floating in zero
gravity: a constant joint torque is internal, so once the stop's damping has taken out the relative
motion everything rests and the joint sits where the stop balances the torque, δ = τ / k.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snake_models import make_harness, snake_urdf

from snakesim.components.multibody import joint_stops as js
from snakesim.components.multibody.urdf import MultibodyModelError

SCENE = """
sim: {{duration: {duration}, dt: {dt}, integrator: {integrator}}}
components:
  torque: {{type: constant, params: {{n: 1, value: {tau}}}}}
  robot:
    type: multibody
    params:
      urdf: snake.urdf
      gravity: [0, 0, 0]
      q0: {{bend_00: {q0}}}
      v0: {{bend_00: {v0}}}
      joint_stops: {stops}
connections:
  - torque.y -> robot.tau
record: [robot.joint_q, robot.joint_v, robot.energy]
"""
K_DEFAULT = 100.0 / 0.02            # effort / default penetration, N·m/rad


def _run(run_scene, *, tau=0.0, q0=0.8, v0=0.0, dt=1e-3, duration=0.5, integrator="rk4",
         stops="{enabled: true}"):
    return run_scene(SCENE.format(tau=tau, q0=q0, v0=v0, dt=dt, duration=duration, integrator=integrator,
                                  stops=stops),
                     **{"snake.urdf": snake_urdf(modules=1, screws="none", frames=False)})


@pytest.mark.parametrize("tau, limit", [(40.0, 1.0), (-30.0, -1.0)])
def test_a_pushed_joint_settles_at_the_static_deflection(run_scene, tau, limit):
    """Both sides: q → limit + τ/k (8 and 6 mrad), at rest; RK4 at 1 ms and rosenbrock_w at 10 ms (the
    stop in its Jacobian) agree with the analytic value to 1e-6 rad."""
    for integrator, dt in (("rk4", 1e-3), ("rosenbrock_w", 1e-2)):
        _, res = _run(run_scene, tau=tau, q0=0.8 * limit, dt=dt, duration=0.6, integrator=integrator)
        assert res.summary["completed"]
        q, v = res["robot.joint_q"][:, 0], res["robot.joint_v"][:, 0]
        assert abs(q[-1] - (limit + tau / K_DEFAULT)) < 1e-6, (integrator, q[-1])
        assert abs(v[-1]) < 1e-5
        # it got there through the stop: past the limit by more than the final deflection at some time
        assert np.sign(tau) * (q.max() if tau > 0 else q.min()) > abs(limit)


def test_an_undamped_stop_is_conservative(run_scene):
    """c = 0: kinetic energy + ½ k δ² is constant through the impact (RK4, 0.1 ms: its error at the
    stop's kink is O(h²) per crossing, measured 7e-7 of E), and the joint comes back out at its speed."""
    _, res = _run(run_scene, q0=0.9, v0=3.0, dt=1e-4, duration=0.1,
                  stops="{enabled: true, damping: {bend_00: 0}}")
    q, v = res["robot.joint_q"][:, 0], res["robot.joint_v"][:, 0]
    E = res["robot.energy"][:, 0] + 0.5 * K_DEFAULT * np.maximum(q - 1.0, 0.0) ** 2
    assert q.max() > 1.01 and q[-1] < 1.0 and v[-1] < 0      # in, and back out
    assert np.abs(E - E[0]).max() < 1e-5 * E[0], (E.max() - E[0], E.min() - E[0])
    # the default (critical) damping takes energy out of the same impact
    _, res = _run(run_scene, q0=0.9, v0=3.0, dt=1e-4, duration=0.1)
    q = res["robot.joint_q"][:, 0]
    E2 = res["robot.energy"][:, 0] + 0.5 * K_DEFAULT * np.maximum(q - 1.0, 0.0) ** 2
    assert E2[-1] < 0.9 * E2[0]


def test_the_stop_pushes_and_never_pulls():
    """On a grid of (δ, q̇) both sides: s·τ ≤ 0 (the torque points out of the stop or is zero), zero
    inside the limits, and −k δ − c q̇ where that pushes."""
    k, c = 5000.0, 60.0
    qi, vi = np.array([0, 0]), np.array([0, 0])
    lim, side = np.array([1.0, -1.0]), np.array([1.0, -1.0])
    for q in np.linspace(-1.1, 1.1, 23):
        for qd in np.linspace(-5, 5, 21):
            T = np.zeros(1)
            js.add_torques(np.array([q]), np.array([qd]), qi, vi, lim, side, np.full(2, k), np.full(2, c), T)
            if abs(q) <= 1.0:
                assert T[0] == 0.0
            else:
                expected = min(0.0, -(k * (q - 1.0) + c * qd)) if q > 1.0 else max(0.0, k * (-1.0 - q) - c * qd)
                assert T[0] == pytest.approx(expected, abs=1e-9)
                assert np.sign(q) * T[0] <= 0.0

def test_the_stop_jacobian_matches_finite_differences(run_scene):
    """The multibody's assembled block (rosenbrock_w's J): ∂Q/∂q and ∂Q/∂q̇ of the bend equal the central
    differences of the generalised force at a pushing state, on the tree solve and on the dense path;
    at a state clear of the stop (and not approaching it) they are zero."""
    from snakesim.framework.linearization import Linearization

    s, _ = _run(run_scene, q0=1.01, v0=0.5, dt=1e-3, duration=1e-3, integrator="rosenbrock_w")
    p = s.plan
    mb = p.components["robot"]
    iq, iv = mb._jq_idx[0], mb._nq + mb._dof_v[0]
    p.X[iq], p.X[iv] = 1.012, -0.3            # past the limit, moving out slowly: k δ + c q̇ > 0
    t = 1e-3

    def force(dx_q=0.0, dx_v=0.0):
        x0q, x0v = p.X[iq], p.X[iv]
        p.X[iq] += dx_q
        p.X[iv] += dx_v
        p.f(t, p.X)
        T = p.io["robot"][1].cache.T[mb._dof_v[0]]
        p.X[iq], p.X[iv] = x0q, x0v
        return T

    e = 1e-6
    dq = (force(dx_q=e) - force(dx_q=-e)) / (2 * e)
    dv = (force(dx_v=e) - force(dx_v=-e)) / (2 * e)
    k, c = mb._stops.k[0], mb._stops.c[0]
    assert dq == pytest.approx(-k, rel=1e-6) and dv == pytest.approx(-c, rel=1e-6)
    p.f(t, p.X)
    j = mb._dof_v[0]
    for structured in (True, False):
        mb.structured_solve = structured
        lin = Linearization(p)
        lin.assemble(t)
        _, Gq, Gv = lin.mech[0][1].blocks()
        assert Gq[j, j] == pytest.approx(dq, rel=1e-6) and Gv[j, j] == pytest.approx(dv, rel=1e-6)
    mb.structured_solve = True
    p.X[iq], p.X[iv] = 0.5, 0.0                 # clear of both stops, at rest
    p.f(t, p.X)
    lin = Linearization(p)
    lin.assemble(t)
    _, Gq, Gv = lin.mech[0][1].blocks()
    assert Gq[j, j] == 0.0 and Gv[j, j] == 0.0


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_stiff_stop_is_stable_implicitly_where_rk4_blows_up(run_scene):
    """k = 5e5 N·m/rad on the bend's 0.21 kg·m²: ω = 1.6e3 rad/s and c/I = 3.1e3 1/s, ω·h = 16 at
    10 ms, far past RK4's 2.83: the step check names the stop, RK4 diverges, rosenbrock_w settles at
    the static deflection τ/k = 0.08 mrad; without the Jacobian's look-ahead (lookahead_steps 0) the step
    that enters the stop is explicit in it and rosenbrock_w diverges too."""
    stops = "{enabled: true, stiffness: {bend_00: 5.0e5}}"
    _, res = _run(run_scene, tau=40.0, q0=0.999, dt=1e-2, duration=1.0, integrator="rk4", stops=stops)
    check = res.summary["step_check"]
    assert check["dt_exceeds_stable_step"] and "joint stop 'bend_00'" in check["mode"]
    inertia = 0.2                                                 # the bend's apparent inertia, about
    assert check["stiffest_mode_rad_s"] > math.sqrt(5e5 / (1.1 * inertia))
    q = res["robot.joint_q"][:, 0]
    assert not res.summary["completed"] or not np.all(np.abs(q) < 2.0)
    _, res = _run(run_scene, tau=40.0, q0=0.999, dt=1e-2, duration=1.0, integrator="rosenbrock_w", stops=stops)
    assert res.summary["completed"]
    q = res["robot.joint_q"][:, 0]
    assert np.all(q < 1.0 + 10 * 40.0 / 5e5)
    assert abs(q[-1] - (1.0 + 40.0 / 5e5)) < 1e-6
    # without the look-ahead a fixed step that meets the stop treats it explicitly: thrown off …
    fixed = "{name: rosenbrock_w, params: {step_control: fixed}}"
    no_lookahead = "{enabled: true, stiffness: {bend_00: 5.0e5}, lookahead_steps: 0}"
    _, res = _run(run_scene, tau=40.0, q0=0.999, dt=1e-2, duration=1.0, integrator=fixed, stops=no_lookahead)
    q = res["robot.joint_q"][:, 0]
    assert not res.summary["completed"] or not np.all(np.abs(q) < 2.0)
    # … while error control (the default) finds the stop by rejecting the step that overshoots it
    _, res = _run(run_scene, tau=40.0, q0=0.999, dt=1e-2, duration=1.0, integrator="rosenbrock_w",
                  stops=no_lookahead)
    assert res.summary["completed"] and res.summary["integrator"]["rejected"] > 0
    assert abs(res["robot.joint_q"][-1, 0] - (1.0 + 40.0 / 5e5)) < 1e-6


def test_stops_are_off_by_default_and_report_their_values():
    urdf = snake_urdf(modules=2, screws="pair", twist=True, frames=False)
    assert make_harness(urdf).c._stops is None
    mb = make_harness(urdf, joint_stops={"enabled": True, "stiffness": {"twist_*": 800.0},
                                         "damping": {"bend_01": 5.0}}).c
    table = mb._stops.table()
    assert set(table) == {"bend_00", "twist_00", "bend_01", "twist_01"}       # screws are continuous: none
    assert table["bend_00"]["k"] == pytest.approx(100.0 / 0.02)
    assert table["twist_00"]["k"] == 800.0 and table["twist_00"]["upper"] == 2.0
    assert table["twist_00"]["lower"] == -2.0
    assert table["bend_01"]["c"] == 5.0
    inertia = mb.joint_inertia()[mb.robot.joints.index("bend_00")]
    assert table["bend_00"]["c"] == pytest.approx(2.0 * math.sqrt(table["bend_00"]["k"] * inertia))


@pytest.mark.parametrize("stops, words", [
    ({"enabled": True, "stiffness": {"bend_*": -5.0}}, ["joint_stops.stiffness", "bend_*", "-5.0", "> 0"]),
    ({"enabled": True, "damping": {"bend_00": -1.0}}, ["joint_stops.damping", "bend_00", ">= 0"]),
    ({"enabled": True, "stiffness": {"elbow": 10.0}}, ["joint_stops.stiffness", "'elbow'", "bend_00"]),
    ({"enabled": True, "stiffness": {"screw_front_*": 10.0}}, ["screw_front_*", "without position limits",
                                                                "bend_00"]),
    ({"stiffness": {"bend_00": 10.0}}, ["enabled is false"]),
])
def test_bad_stop_parameters_are_refused_by_name(stops, words):
    with pytest.raises(MultibodyModelError) as err:
        make_harness(snake_urdf(modules=2, screws="pair", twist=True, frames=False), joint_stops=stops)
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_pydantic_refuses_a_non_positive_penetration():
    with pytest.raises(Exception) as err:
        make_harness(snake_urdf(modules=1, screws="none", frames=False),
                     joint_stops={"enabled": True, "penetration": 0.0})
    assert "penetration" in str(err.value)

