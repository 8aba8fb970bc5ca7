"""The contact law record's inputs and outputs (contact_law.py) on the screw and body back ends.

* μ scale: the normal forces stay, every friction force scales by it exactly (eq. 6 is linear in μ).
* ‖e_v‖ scale: 1/ev_a on a load-independent thread (ev_b = 0) makes the law isotropic, eq. 1: friction
  anti-parallel to the slip with magnitude μ F_n ‖v_t‖ / sqrt(‖v_t‖² + v_ε²).
* sinkage s: at rest (no damper force) each contact pushes k (d − s), or nothing where d ≤ s.
* slip power and speed: the contact set's −F_t·v_t and F_n-weighted ‖v_t‖ per screw; a box sliding to a
  stop dissipates through friction exactly the kinetic energy it loses (energy balance over a run).
* the Jacobian the implicit step reads takes the same scaled law (central differences).
* out-of-range inputs stop the run naming the screw and the value.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from snakesim.components.contact import ScrewSdfContact
from snakesim.components.contact.body_contact import BodyContact
from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.components.terrain.source import TerrainSource
from snakesim.framework import Builder, Harness

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
from jacobian_check import analytic_and_fd_jacobian  # noqa: E402
from screw_scenes import SCREW_RADIUS, plane, screw_scene  # noqa: E402

ROBOT = {"design": "eels-1.0", "modules": 2, "head": False}
MODEL = RobotModel.load(**ROBOT)
NS = MODEL.derived(screw_layout).ns
K, C, MU, EV_A = 1.0e5, 1.0e3, 0.3, 3.0
ICE = {"kind": "plane", "materials": [{"name": "ice", "k": K, "c": C, "mu": MU, "ev_a": EV_A, "ev_b": 0.0}]}
V_EPS = 1e-3                # m/s, the component's default regularisation width


def robot_out(z=0.0885, moving=True):
    """Multibody outputs of a 2-module eels-1.0 lying ~1 mm into z = 0, sliding and spinning or at rest."""
    vel = (0.05, 0.01, 0.0, 0.1, 0.0, 0.05) if moving else (0.0,) * 6
    v0 = {"screw_front_00": 2.0, "screw_front_01": -3.0} if moving else {}
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, z), base_velocity=vel,
                                 q0={"twist_00": 0.05, "bend_01": 0.1}, v0=v0))
    return mb.outputs()


def screw_contact(out, **inputs):
    h = Harness(ScrewSdfContact, {}, name="contact", uses={"robot": MODEL})
    h.inputs.terrain = load_terrain(ICE)
    h.inputs.link_poses, h.inputs.link_velocities, h.inputs.joint_v = (out["link_poses"], out["link_velocities"],
                                                                       out["joint_v"])
    for name, value in inputs.items():
        setattr(h.inputs, name, np.asarray(value, dtype=float))
    return h, h.outputs()


def tangential(v, n):
    return v - (v * n).sum(axis=1)[:, None] * n


def test_mu_scale_scales_every_friction_force_and_leaves_the_normal_forces():
    out = robot_out()
    _, base = screw_contact(out)
    _, half = screw_contact(out, screw_mu_scale=np.full(NS, 0.5))
    a, b = base["contact_set"], half["contact_set"]
    assert len(a) >= 4 and len(a) == len(b)
    np.testing.assert_array_equal(a.normal_force, b.normal_force)
    ft_a, ft_b = tangential(a.forces, a.normals), tangential(b.forces, b.normals)
    assert np.abs(ft_a).max() > 1.0                          # friction there is, to be scaled
    np.testing.assert_allclose(ft_b, 0.5 * ft_a, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(half["screw_slip_power"], 0.5 * base["screw_slip_power"], rtol=1e-12, atol=1e-12)


def test_ev_scale_of_one_over_ev_a_gives_isotropic_friction():
    out = robot_out()
    _, y = screw_contact(out, screw_ev_scale=np.full(NS, 1.0 / EV_A))
    cs = y["contact_set"]
    vt = tangential(cs.slip, cs.normals)
    speed = np.linalg.norm(vt, axis=1)
    expected = -(MU * cs.normal_force / np.sqrt(speed ** 2 + V_EPS ** 2))[:, None] * vt
    np.testing.assert_allclose(tangential(cs.forces, cs.normals), expected, rtol=1e-9, atol=1e-9)
    # and without the scale the thread's anisotropy is there: friction not anti-parallel to the slip
    _, y1 = screw_contact(out)
    c1 = y1["contact_set"]
    assert np.abs(tangential(c1.forces, c1.normals) - expected).max() > 1.0


def test_sinkage_lowers_the_surface_under_each_screw():
    out = robot_out(moving=False)
    h, y0 = screw_contact(out)
    lay = h.c.screws
    cs = y0["contact_set"]
    owner = {row: s for s, row in enumerate(lay.screw_row)}
    depth_by_screw = [cs.depth[[owner[int(r)] == s for r in cs.link]] for s in range(lay.ns)]
    assert all(len(d) for d in depth_by_screw)                 # every screw touches
    assert lay.ns == 4
    sink = np.array([0.0, 0.3e-3, 0.6e-3, depth_by_screw[3].max() + 1e-4])   # none, part, more, below them all
    _, y = screw_contact(out, screw_sinkage=sink)
    expected = [K * np.clip(d - s, 0.0, None).sum() for d, s in zip(depth_by_screw, sink)]
    np.testing.assert_allclose(y["screw_normal_force"], expected, rtol=1e-9, atol=1e-9)
    assert y["screw_normal_force"][-1] == 0.0
    np.testing.assert_allclose(np.sort(y["contact_set"].depth),
                               np.sort(np.concatenate([d[d > s] - s for d, s in zip(depth_by_screw, sink)])),
                               rtol=0, atol=1e-15)


def test_slip_outputs_are_the_contact_sets_per_screw():
    out = robot_out()
    h, y = screw_contact(out)
    cs, lay = y["contact_set"], h.c.screws
    vt = tangential(cs.slip, cs.normals)
    power = -(tangential(cs.forces, cs.normals) * vt).sum(axis=1)
    assert np.all(power >= 0.0)                                # friction never feeds energy
    for s in range(lay.ns):
        on = cs.link == lay.screw_row[s]
        assert y["screw_slip_power"][s] == pytest.approx(power[on].sum(), rel=1e-12, abs=1e-12)
        fn = cs.normal_force[on]
        speed = (fn * np.linalg.norm(vt[on], axis=1)).sum() / fn.sum() if fn.sum() > 0 else 0.0
        assert y["screw_slip_speed"][s] == pytest.approx(speed, rel=1e-12, abs=1e-15)
    assert y["screw_slip_power"].sum() > 0.01


BOX = """<robot name="box"><link name="box">
  <inertial><mass value="2.0"/><inertia ixx="0.002" iyy="0.015" izz="0.016" ixy="0" ixz="0" iyz="0"/></inertial>
  <collision><geometry><box size="0.3 0.1 0.05"/></geometry></collision></link></robot>"""


def test_a_sliding_box_dissipates_by_friction_the_kinetic_energy_it_loses():
    """2 kg box at 1 m/s on ice (μ 0.3), resting on its face: until it stops (0.34 s) friction takes
    ∫ slip power dt = ΔKE; the normal damper takes only the settling of the weight's 5 µm (< 1e-4 J). RK4 at
    50 µs: converged (the face's 55 dampers make a 2.7e4 s⁻¹ mode), the record every step (trapezoid)."""
    b = Builder(dt=5e-5, duration=0.25, integrator="rk4", record_rate=20000)
    ground = b.add(TerrainSource("terrain", spec={"kind": "plane", "materials": [
        {"name": "ice", "k": K, "c": C, "mu": MU}]}))
    box = b.add(Multibody("robot", urdf=BOX, base_position=(0.0, 0.0, 0.025 - 5e-6),
                          base_velocity=(1.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
    touch = b.add(BodyContact("contact"))
    b.connect(ground.out.terrain, touch.inp.terrain)
    b.connect(box.out.link_poses, touch.inp.link_poses)
    b.connect(box.out.link_velocities, touch.inp.link_velocities)
    b.connect(touch.out.wrenches, box.inp.wrenches)
    b.record(box.out.energy, touch.out.link_slip_power)
    r = b.build().run()
    assert r.summary["completed"], r.summary
    t, ke, power = np.asarray(r["t"]), np.asarray(r["robot.energy"])[:, 0], np.asarray(r["contact.link_slip_power"])[:, 0]
    lost = ke[0] - ke[-1]
    assert lost > 0.5                                          # it did slow down: 1 J → 0.33 J
    dissipated = np.trapezoid(power, t)
    assert dissipated == pytest.approx(lost, rel=2e-4)


def test_the_jacobian_takes_the_scaled_law():
    """The screw pair spinning on ice with μ scale 0.6, ‖e_v‖ scale 1.3 and 0.2 mm sinkage: the plan's
    analytic Jacobian (the contact's port_jacobian) against central differences of f, to the bounds of the
    unscaled law's test (test_implicit_contact.py): ∂v̇/∂v to 1e-3 of its scale, ∂v̇/∂q to 3e-2. A
    Jacobian of the unscaled law would be off by 40 % in the friction slopes."""
    b = Builder(dt=5e-4, duration=0.3, integrator="rk4")
    body, touch = screw_scene(b, terrain=plane(mu=0.3), robot={"base_position": [0.0, 0.0, SCREW_RADIUS - 2e-4]},
                              omega=2.0)
    b.connect(touch.out.wrenches, body.inp.wrenches)
    b.open(touch.inp.screw_mu_scale, touch.inp.screw_ev_scale, touch.inp.screw_sinkage)
    sim = b.build()
    sim.set_input(touch.inp.screw_mu_scale, np.full(NS, 0.6))
    sim.set_input(touch.inp.screw_ev_scale, np.full(NS, 1.3))
    sim.set_input(touch.inp.screw_sinkage, np.full(NS, 2e-4))
    sim.advance_to(0.3)
    J, Jfd, qs, vs = analytic_and_fd_jacobian(sim.plan, 0.3)

    def rel(rows, cols):
        return np.abs(J[rows, cols] - Jfd[rows, cols]).max() / np.abs(Jfd[rows, cols]).max()

    assert np.abs(Jfd[vs, vs]).max() > 1e3              # stiff: the contact's slopes
    assert rel(vs, vs) < 1e-3
    assert rel(vs, qs) < 3e-2


@pytest.mark.parametrize("name, value, shown", [("screw_mu_scale", -0.5, "screw_mu_scale = -0.5"),
                                                ("screw_ev_scale", 0.0, "screw_ev_scale = 0"),
                                                ("screw_sinkage", float("nan"), "screw_sinkage = nan")])
def test_an_out_of_range_law_input_stops_the_run_naming_the_screw(name, value, shown):
    out = robot_out()
    h = Harness(ScrewSdfContact, {}, name="contact", uses={"robot": MODEL})
    h.inputs.terrain = load_terrain(ICE)
    h.inputs.link_poses, h.inputs.link_velocities, h.inputs.joint_v = (out["link_poses"], out["link_velocities"],
                                                                       out["joint_v"])
    bad = np.full(h.c.screws.ns, 1.0 if name != "screw_sinkage" else 0.0)
    bad[1] = value
    setattr(h.inputs, name, bad)
    h.outputs()
    reason = h.c._stop.reason
    assert reason is not None and h.c.screws.names[1] in reason and shown in reason, reason
    assert "valid: mu_scale ≥ 0, ev_scale > 0, sinkage ≥ 0 m" in reason
