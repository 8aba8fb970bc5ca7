"""screw_sdf_contact through the whole stack (terrain + multibody + drive + contact), checked
against closed forms: the screw-pair steady axial speed (steady_state.py), sticking on a slope
below the friction angle (regularisation creep, kernels.py) and sliding above it.

Robots are eels-1.0 with 2 modules, no head, joints held straight by screw_drive's PD lock.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from snakesim.components.contact import steady_axial_speed
from snakesim.components.multibody.linearization import LinkWrenchJacobian
from snakesim.framework import Builder, Component, Input, Output, Params
from snakesim.framework.linearization import Elementwise

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
from screw_scenes import downhill, on_slope, plane, screw_scene  # noqa: E402

G = 9.81


class RailParams(Params):
    nl: int
    k: float = 2.0e4      # N/m
    c: float = 2.0e3      # N·s/m
    k_roll: float = 200.0   # N·m/rad
    c_roll: float = 20.0    # N·m·s/rad


class Rail(Component[RailParams]):
    """Test only: a frictionless rail along world x. A lateral (y) spring-damper on every link
    origin and a roll (about x) spring-damper on the tail (the drive's PD lock on the twist
joints carries it to every module; a screw link's roll is its spin). It does no work along x; it
    holds the yaw couple of each screw pair (their lateral forces cancel, their moments do
    not) and the roll torque r(F_y,front + F_y,rear) of unequally loaded pairs, so the robot
    translates purely axially: the setting of the steady-state derivation (a rolling robot
    adds r·Ω_x to every screw's lateral slip and shifts u*)."""

    type_name = "test_rail"
    Params = RailParams
    poses = Input(shape=("nl", 7), unit=None)
    vels = Input(shape=("nl", 6), unit=None)
    wrenches = Output(shape=("nl", 6), unit=None, feedthrough=True)

    def port_jacobian(self, port, t, x, u, y):
        """Its spring-dampers' slopes for linearly implicit integrators (small-angle roll)."""
        nl = self.p.nl
        d_pose, d_twist = np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6))
        d_pose[:, 1, 1], d_twist[:, 1, 1] = -self.p.k, -self.p.c
        d_pose[0, 3, 3], d_twist[0, 3, 3] = -self.p.k_roll, -self.p.c_roll
        return LinkWrenchJacobian(rows=np.arange(nl), d_twist=d_twist, d_pose=d_pose, inputs=("poses", "vels"))

    def output(self, t, x, u, y):
        y.wrenches[:] = 0.0
        y.wrenches[:, 1] = -self.p.k * u.poses[:, 1] - self.p.c * u.vels[:, 1]
        roll = 2.0 * u.poses[0, 3] * np.sign(u.poses[0, 6])          # small-angle roll from the quaternion
        y.wrenches[0, 3] = -self.p.k_roll * roll - self.p.c_roll * u.vels[0, 3]


class WrenchSumParams(Params):
    nl: int


class WrenchSum(Component[WrenchSumParams]):
    type_name = "test_wrench_sum"
    Params = WrenchSumParams
    a = Input(shape=("nl", 6), unit=None)
    b = Input(shape=("nl", 6), unit=None, default=0.0)
    y = Output(shape=("nl", 6), unit=None, feedthrough=True)

    def port_jacobian(self, port, t, x, u, y):
        n = 6 * self.p.nl
        i, one = np.arange(n), np.ones(n)
        return Elementwise(n, (("a", i, i, one), ("b", i, i, one)))

    def output(self, t, x, u, y):
        np.add(u.a, u.b, out=y.y)


NL = 9    # eels-1.0, 2 modules, no head: tail + 2 x (knuckle, module, 2 screw links)


def scene(*, terrain, base, omega=0.0, lead=0.35, material=None, duration=1.0, rail=False, v_eps=1e-3,
          integrator="rk4", dt=0.001):
    """The screw pair (screw_scenes.py) on ``terrain``, its base placed by ``base`` (multibody params); with
    ``rail`` the contact's wrenches are summed with a rail's on their way to the robot."""
    b = Builder(dt=dt, duration=duration, integrator=integrator)
    robot, contact = screw_scene(b, terrain=terrain, robot={"robot": {"lead_angle": lead}, **base}, omega=omega,
                                 contact={"v_eps": v_eps, "material": {} if material is None else material})
    if rail:
        rail_, total = b.add(Rail("rail", nl=NL), WrenchSum("sum", nl=NL))
        b.connect(robot.out.link_poses, rail_.inp.poses)
        b.connect(robot.out.link_velocities, rail_.inp.vels)
        b.connect(contact.out.wrenches, total.inp.a)
        b.connect(rail_.out.wrenches, total.inp.b)
        b.connect(total.out.y, robot.inp.wrenches)
    else:
        b.connect(contact.out.wrenches, robot.inp.wrenches)
    b.record(robot.out.com, robot.out.joint_v, robot.out.link_poses, contact.out.normal_force,
             contact.out.screw_normal_force)
    sim = b.build()
    assert sim.plan.components["robot"].robot.nl == NL
    return sim, sim.run()


FLAT = plane(mu=0.1)


@pytest.mark.parametrize("integrator, dt", [("rk4", 1e-3), ("rosenbrock_w", 5e-3)])
@pytest.mark.parametrize("lead, k, omega", [(0.35, 4.0, 2.0), (0.6, 2.0, 3.0), (0.25, 8.0, -1.5)])
def test_straight_robot_drives_at_the_steady_axial_speed(lead, k, omega, integrator, dt):
    """u* = ωr(k−1) sinλ cosλ / (1 + (k−1)cos²λ) (steady_state.py) per screw, at its measured spin.

    The velocity servo leaves each module's screws a slightly different spin ω_s (its error
    is load / gain), and a rigid robot has one speed u: from eq. 6 on the bottom line,
    screw s pushes F_x,s = −μ F_n,s g_s (1 + (k−1)cos²λ)(u − u*_s) with g_s = 1/sqrt(u² + ω_s²r²
    + v_ε²), so Σ F_x,s = 0 gives u = Σ w_s u*_s with w_s ∝ F_n,s g_s: the prediction here
    (F_n,s from screw_normal_force, ω_s from joint_v).

    Tolerance: the regularisation enters only through g_s (included); the sampling does not
    enter (on a plane every contact is on the envelope's bottom line, p_c in screw_sdf.py).
    What is left is the transient: the axial speed relaxes with τ = m / Σ ∂F_x,s/∂u ≈ m ωr /
    (n_s μ F_n (1 + (k−1)cos²λ)) ≈ 0.15 s here, and the servo's spin settles with its own
    (slower) time; starting near the steady state leaves a correction of a few 1e-4 of u* at
    the window (t ≥ 0.9 s) at most; 1e-3 relative covers that and the fit. The same holds for the
    linearly implicit step (rosenbrock_w) at 5 ms, the rail's and the sum's slopes declared
    (without them the rail's dampers, c/m ~ 1e3 s⁻¹ on a module, are explicit and blow the step up).
    """
    # start near the steady state (screws spinning, robot moving at the nominal u*): the slow
    # part of the transient is then a small correction
    u0 = steady_axial_speed(omega, 0.09, lead, k)
    base = {"base_position": [0, 0, 0.0898], "base_velocity": [u0, 0, 0, 0, 0, 0], "v0": {"screw_front_*": omega}}
    session, r = scene(terrain=FLAT, base=base, omega=omega,
                       lead=lead, material={"ev_a": k}, duration=1.2, rail=True, integrator=integrator, dt=dt)
    assert r.summary["completed"], r.summary
    t, com = r["t"], r["robot.com"]
    lay = session.plan.components["contact"].screws
    late = t >= 0.9
    u = np.polyfit(t[late], com[late, 0], 1)[0]            # mean axial speed over the window
    spin = (r["robot.joint_v"][late][:, lay.spin_dof] * lay.spin_mult).mean(axis=0)      # (ns,) rad/s
    fn = r["contact.screw_normal_force"][late].mean(axis=0)
    u_star = np.array([steady_axial_speed(w, rad, lam, k, hand=h)
                       for w, rad, lam, h in zip(spin, lay.radius, lay.lead_angle, lay.hand)])
    w = fn / np.sqrt(u * u + (spin * lay.radius) ** 2 + 1e-3 ** 2)
    predicted = float((w * u_star).sum() / w.sum())
    assert abs(u - predicted) <= 1e-3 * abs(predicted), (u, predicted, u_star)
    assert np.sign(u) == np.sign(omega)
    assert u_star.min() - 1e-6 <= u <= u_star.max() + 1e-6
    # the robot rests on the ice: the contact carries its weight
    weight = session.plan.components["robot"]._ta.mass.sum() * G
    assert r["contact.normal_force"][late, 0].mean() == pytest.approx(weight, rel=1e-3)


def test_robot_below_the_friction_angle_creeps_at_the_regularisation_speed():
    """tanθ < μ: isotropic friction holds the robot but for the regularised creep (kernels.py):
    μF_n‖s‖ = W sinθ with ‖s‖ = v/sqrt(v² + v_ε²) gives v_c = v_ε ρ/sqrt(1 − ρ²), ρ = tanθ/μ.
    Drift over Δt is bounded by v_c Δt (+10 % for the settling transient and discretisation),
    and, the model being what we derived, is not much less either (> 0.8 v_c Δt)."""
    theta, mu, v_eps = math.radians(4.0), 0.1, 1e-3
    _, r = scene(terrain=plane(mu, tilt=theta), base=on_slope(theta), material={"ev_a": 1.0},
                 duration=1.5, v_eps=v_eps)
    assert r.summary["completed"], r.summary
    t, s = r["t"], downhill(r["robot.com"], theta)
    rho = math.tan(theta) / mu
    v_c = v_eps * rho / math.sqrt(1 - rho * rho)
    i0, i1 = np.searchsorted(t, 0.5), len(t) - 1
    drift = s[i1] - s[i0]
    dt = t[i1] - t[i0]
    assert drift <= 1.1 * v_c * dt, (drift, v_c * dt)
    assert drift >= 0.8 * v_c * dt, (drift, v_c * dt)


def test_robot_above_the_friction_angle_slides_at_g_sin_minus_mu_cos():
    """tanθ > μ: a = g(sinθ − μ cosθ). Regularisation lowers friction by ‖s‖ = v/sqrt(v² + v_ε²),
    1 − ½(v_ε/v)² ≥ 1 − 2e-5 once v > 0.15 m/s (the fit window); 0.5 % covers the normal-force
    transient and the fit."""
    theta, mu = math.radians(15.0), 0.1
    _, r = scene(terrain=plane(mu, tilt=theta), base=on_slope(theta), material={"ev_a": 1.0},
                 duration=0.8)
    assert r.summary["completed"], r.summary
    t, s = r["t"], downhill(r["robot.com"], theta)
    w = t >= 0.3
    a = 2 * np.polyfit(t[w], s[w], 2)[0]
    expected = G * (math.sin(theta) - mu * math.cos(theta))
    assert a == pytest.approx(expected, rel=5e-3)
