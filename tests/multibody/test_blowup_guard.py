"""The multibody's blow-up guard (blowup_guard.py): kinetic energy that nothing in the model supplied.

Each test is a case whose energy balance is known in closed form: a free fall (gravity's work is the
whole gain: exact for RK4, short by ½ m g² h² per step for semi-implicit Euler), a robot driven by its
joint servos in zero gravity (the gain is the servos' work, ≤ h·max end power for a resolved step), a
state edit (the guard restarts), a stiff joint spring trading its energy with the links every step, and
a contact stepped past RK4's stability bound (the energy appears with nothing to supply it).
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from snakesim.components.multibody.component import Multibody
from snakesim.framework import Component, Params
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session

G = 9.81


def scene(tmp_path, text: str, registry=None, name="scene.yaml", **sim):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return load_session(path, registry=registry or build_registry(load_entry_points=False), sim_overrides=sim or None)


@pytest.fixture
def steps(monkeypatch):
    """Every base step's guard terms, as the guard computed them: (t, ΔT, W_gravity, h·max(P0, P1), m)."""
    log = []
    check = Multibody.check

    def logged(self, t, u, restart):
        check(self, t, u, restart)
        if not restart:
            o = u.cache.guard_out
            log.append((t, o[0], o[1], o[2], self._mass))

    monkeypatch.setattr(Multibody, "check", logged)
    return log


FALL = """
sim: {duration: 1.0, dt: 0.01, integrator: INTEGRATOR}
components:
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, base_position: [0, 0, 10]}}
record: [robot.energy, robot.com]
"""


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_free_fall_gains_exactly_gravitys_work_and_is_no_blow_up(tmp_path, steps, integrator):
    """Falling 4.9 m in 1 s the robot gains 48 J/kg of kinetic energy, all of it gravity's work: RK4 integrates
    a constant acceleration exactly; semi-implicit Euler (v first, then x with the new v) gains
    ΔT − W_g = ½ m (v1² − v0²) − m g h v1 = −½ m g² h² per step (it loses energy)."""
    s = scene(tmp_path, FALL.replace("INTEGRATOR", integrator))
    r = s.run()
    assert r.summary["outcome"] == "success", r.summary["stop_reason"]
    t, dke, wg, work, m = np.array(steps).T
    h = 0.01
    assert len(t) == 100 and np.all(work == 0.0)             # no joint torque, no wrench
    assert dke.sum() == pytest.approx(0.5 * m[0] * G ** 2 * 1.0 ** 2, rel=0.02)   # ½ m (g t)²
    expect = 0.0 if integrator == "rk4" else -0.5 * m[0] * G ** 2 * h ** 2
    np.testing.assert_allclose(dke - wg, expect, atol=1e-9 * dke.max())
    # the guard's kinetic energy and centre of mass are the multibody's own outputs
    prev = s.plan.caches["robot"].guard_prev
    assert prev[0] == pytest.approx(r["robot.energy"][-1, 0], rel=1e-12)
    np.testing.assert_allclose(prev[5:8] / prev[8], r["robot.com"][-1], rtol=1e-12)


DRIVEN = """
sim: {duration: 0.6, dt: 0.001, integrator: rk4}
components:
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0]}}
  setpoints: {type: joint_setpoints, params: {hold: {"bend_*": 0.5, "twist_*": -0.3}, screw_speed: 5.0}}
  pid: {type: joint_pid}
connections:
  - setpoints.setpoint -> pid.setpoint
  - setpoints.rate -> pid.rate_ref
  - robot.joint_q -> pid.q
  - robot.joint_v -> pid.v
  - pid.tau -> robot.tau
record: [robot.energy]
"""


def test_a_robot_driven_by_its_servos_gains_only_their_work(tmp_path, steps):
    """In zero gravity the servos (bends to 0.5 rad, twists to −0.3, screws to 5 rad/s) are the only source:
    T(t1) − T(t0) = ∫ τ·q̇ − damping ≤ h·max over the ends of Σ|τ_j q̇_j|, up to the O(h³) curvature
    of the power over a resolved 1 ms step. The guard sees the same and stays silent."""
    s = scene(tmp_path, DRIVEN)
    r = s.run()
    assert r.summary["outcome"] == "success", r.summary["stop_reason"]
    t, dke, wg, work, m = np.array(steps).T
    assert np.all(wg == 0.0) and r["robot.energy"][-1, 0] > 1.0       # J: the servos did real work
    assert np.all(dke <= 1.05 * work + 1e-9)


class Throw(Component[Params]):
    """At t = 0.05 s writes 20 m/s into the robot's base velocity (a state edit: not a blow-up)."""

    type_name = "test_throw"

    def edit_state(self, t, u, edit):
        if abs(t - 0.05) < 1e-9:
            nq = edit.continuous("robot").size // 2 + 1          # [q (nv + 1), v (nv)]: the quaternion's extra
            edit.write("robot", [nq + 2], [20.0])


def test_a_state_edit_restarts_the_guard(tmp_path, steps):
    reg = build_registry(load_entry_points=False)
    reg.add_component(Throw)
    s = scene(tmp_path, """
        sim: {duration: 0.2, dt: 0.01, integrator: rk4}
        components:
          robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0]}}
          throw: {type: test_throw}
        record: [robot.energy]
    """, registry=reg)
    r = s.run()
    assert r.summary["outcome"] == "success" and r.summary["state_edits"] == 1, r.summary["stop_reason"]
    mass = s.plan.components["robot"]._mass
    assert r["robot.energy"][-1, 0] == pytest.approx(0.5 * mass * 20.0 ** 2, rel=1e-9)   # thrown, not a blow-up
    assert not any(abs(t - 0.06) < 1e-9 for t, *_ in steps)            # no step compared across the edit


SPRING = """
sim: {duration: DURATION, dt: DT, integrator: rk4}
components:
  robot:
    type: multibody
    params: {design: eels-1.0, modules: 1, gravity: [0, 0, 0], q0: {bend_00: Q0}, blowup_guard: {enabled: GUARD}}
  spring: {type: joint_spring_damper, params: {stiffness: {bend_00: K}}}
connections: [robot.joint_q -> spring.q, robot.joint_v -> spring.v, spring.tau -> robot.tau]
record: [robot.energy]
"""
K = 2000.0          # N·m/rad
Q0 = 0.01           # rad


def spring(tmp_path, dt, guard, steps_n=200):
    text = (SPRING.replace("DURATION", repr(steps_n * dt)).replace("DT", repr(dt)).replace("GUARD", str(guard).lower())
            .replace("K}", f"{K}}}").replace("Q0}", f"{Q0}}}"))
    return scene(tmp_path, text, name=f"spring-{dt:.6g}-{guard}.yaml")


def test_a_stiff_spring_exchanging_its_energy_within_a_step_is_no_blow_up(tmp_path, steps):
    """bend_00's spring on the free 1-module robot is one mode, ω = √(K / I), I = 1 / (M⁻¹)_jj (the joint's
    apparent inertia with the base and the other joints free, armature included). At ω h = 2, inside RK4's
    bound 2√2 (|R(2i)|² ≈ 0.56: RK4 only damps the mode), each step moves a third of a cycle: the kinetic
    energy swings by a large part of ½ K q0² from one step to the next, all of it the spring's work."""
    probe = spring(tmp_path, 1e-3, True)
    mb = probe.plan.components["robot"]
    omega = math.sqrt(K / mb.joint_inertia()[mb.dof_index("bend_00")])
    r = spring(tmp_path, 2.0 / omega, True).run()
    assert r.summary["outcome"] == "success", r.summary["stop_reason"]
    t, dke, wg, work, m = np.array(steps).T
    assert np.abs(dke[:3]).max() > 0.25 * 0.5 * K * Q0 ** 2    # large exchanges while the mode lasts


def test_a_contact_stepped_past_rk4s_bound_is_a_blow_up_that_names_a_link(tmp_path):
    """Screw contact on the ice at RK4 20 ms: the contact's damping mode is at ω h = 30 (the run's step_check
    says so). A one-sided contact that throws a screw up stops pushing (its power goes to zero) while the
    kinetic energy it injected stays: the guard stops the run, naming the step, a link that carries mass, and
    keeping the state before that step; without it the same run goes on until the contact's depth guard
    (30 mm) or the scene's rule ends it later."""
    def run(guard):
        s = load_session("contact-screw-drive", overrides=["robot.modules=2",
                                                            f"components.robot.params.blowup_guard.enabled={guard}"],
                         sim_overrides={"dt": 0.02, "integrator": "rk4", "duration": 3.0})
        return s, s.run()

    s, r = run("true")
    sm = r.summary
    assert sm["step_check"]["omega_dt"] > 2.0 * 2 ** 0.5
    assert sm["outcome"] == "failure" and sm["failure_kind"] == "blow_up", sm["stop_reason"]
    mb = s.plan.components["robot"]
    link = sm["stop_reason"].split("link '")[1].split("'")[0]
    assert mb._ta.mass[mb.robot.links.index(link)] > 0
    assert r.last_good_state is not None and np.isfinite(r.last_good_state["X"]).all()
    assert r.last_good_state["t"] == pytest.approx(sm["t_end_s"] - 0.02)
    _, off = run("false")
    assert off.summary["outcome"] == "failure" and off.summary["failure_kind"] != "blow_up"
    assert off.summary["t_end_s"] > sm["t_end_s"]


def test_the_guard_is_a_parameter_off_at_no_cost(tmp_path):
    on = spring(tmp_path, 1e-3, True, steps_n=10)
    off = spring(tmp_path, 1e-3, False, steps_n=10)
    assert [fn.__self__.name for fn, _ in on.plan.checks] == ["robot"]
    assert off.plan.checks == () and off.plan.caches["robot"].guard is None
