"""Counter-rotating screw pairs: one DOF, by constraint embedding or by Pinocchio's mimic model.

The reference is Pinocchio's mimic model solved with CRBA + RNEA (external
forces given to Pinocchio in its own joint frames, so the component's wrench
kernels are not part of it). The embedded model must reproduce it exactly
(the embedding is an identity of kinetic energies, not an approximation)
wherever both screws of a pair ride on one rigid body.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from snake_models import coordinate_maps, make_harness, random_state, reference_model, set_state, snake_urdf
from snakesim.components.multibody import MultibodyModelError
from snakesim.components.multibody.model import analyse_mimic_groups, build_dynamics
from snakesim.components.multibody.urdf import parse_urdf
from snakesim.robots import load_robot

PAIRED = {
    "snake_pairs": lambda: snake_urdf(modules=3, screws="pair"),
    "snake_twist_pairs_head": lambda: snake_urdf(modules=3, screws="pair", twist=True, head_mass=2.0),
    "eels-1.0": lambda: load_robot("eels-1.0", modules=3).urdf,
    "eels-concept": lambda: load_robot("eels-concept", modules=3).urdf,
}


def pinocchio_reference(model, data, q, v, tau_v, W, link_names, gravity):
    """Mimic model from Pinocchio's URDF parser, CRBA + RNEA with Pinocchio's own external forces
    (local joint frames)."""
    model.gravity.linear[:] = gravity
    pin.framesForwardKinematics(model, data, q)
    fext = pin.StdVec_Force()
    fext.extend([pin.Force.Zero() for _ in range(model.njoints)])
    for row, name in enumerate(link_names):
        frame = model.frames[model.getFrameId(name, pin.FrameType.BODY)]
        rot = data.oMf[model.getFrameId(name, pin.FrameType.BODY)].rotation
        local = pin.Force(rot.T @ W[row, :3], rot.T @ W[row, 3:])   # link axes, about the link origin
        fext[frame.parentJoint] = fext[frame.parentJoint] + frame.placement.act(local)
    m = pin.crba(model, data, q)
    b = pin.rnea(model, data, q, v, np.zeros(model.nv), fext)
    return np.linalg.solve(m, tau_v - b)


@pytest.mark.parametrize("case", list(PAIRED))
def test_embedded_and_mimic_paths_give_the_same_accelerations(case):
    urdf = PAIRED[case]()
    emb = make_harness(urdf, screw_pairs="auto", gravity_input="vector")
    ref = make_harness(urdf, screw_pairs="mimic_crba", gravity_input="vector")
    assert emb.c.mode == "embedded" and ref.c.mode == "mimic_crba"
    assert emb.c.robot.q_names == ref.c.robot.q_names
    model = ref.c.dyn.model
    pin_model, pin_data = reference_model(urdf)
    qmap, vmap = coordinate_maps(ref, pin_model)
    pin_model.armature[vmap] = model.armature
    rng = np.random.default_rng(1)
    for _ in range(4):
        q, v = random_state(model, rng, spread=3.0)
        v *= 3.0
        tau = 5.0 * rng.standard_normal(len(ref.c.robot.joints))
        W = 20.0 * rng.standard_normal((len(ref.c.robot.links), 6))   # every link, screws included
        g = rng.standard_normal(3) * 5.0
        for h in (emb, ref):
            set_state(h, q, v, tau=tau, wrenches=W, gravity=g)
        a_emb, a_ref = emb.derivative()[model.nv:], ref.derivative()[model.nv:]
        scale = np.abs(a_ref).max()
        assert np.abs(a_emb - a_ref).max() < 1e-10 * scale, (np.abs(a_emb - a_ref).max(), scale)
        tau_v = np.zeros(model.nv)
        tau_v[ref.c._dof_v] = tau
        qp, vp, tp = np.empty(pin_model.nq), np.empty(pin_model.nv), np.empty(pin_model.nv)
        qp[qmap], vp[vmap], tp[vmap] = q, v, tau_v
        a_pin = pinocchio_reference(pin_model, pin_data, qp, vp, tp, W, ref.c.robot.links, g)
        assert np.abs(a_ref - a_pin[vmap]).max() < 1e-10 * scale


PAIR_SCENE = """
sim: {{duration: 0.5, dt: 0.001, integrator: rk4}}
components:
  drive: {{type: sine, params: {{n: {nj}, amplitude: {amp}, frequency: 2.0}}}}
  robot:
    type: multibody
    params: {{urdf: {urdf}, screw_pairs: {mode}, q0: {{"bend_*": 0.3}}, v0: {{"screw_*": 6.0}}}}
connections: [drive.y -> robot.tau]
record: [robot.joint_q, robot.link_rotations]
"""


def test_pair_stays_counter_rotating_and_both_paths_move_alike(run_scene, tmp_path):
    urdf = snake_urdf(modules=2, screws="pair", twist=True)
    path = tmp_path / "pair.urdf"
    path.write_text(urdf)
    amp = [2.0, -1.0, 3.0, 1.0, 1.5, -2.0]           # bend, twist, screw per module
    runs = {}
    for mode in ("mimic_crba", "embedded"):
        session, res = run_scene(PAIR_SCENE.format(nj=6, amp=amp, urdf=path, mode=mode))
        robot = session.plan.components["robot"]
        assert robot.mode == mode
        runs[mode] = res
        rot = res["robot.link_rotations"].reshape(len(res["robot.joint_q"]), -1, 3, 3)
        for i in range(2):
            theta = res["robot.joint_q"][:, robot.dof_index(f"screw_front_{i:02d}")]
            body = rot[:, robot.link_index(f"module_{i:02d}")]
            for link, sign in ((f"screw_front_link_{i:02d}", 1.0), (f"screw_rear_link_{i:02d}", -1.0)):
                rel = np.einsum("kji,kjl->kil", body, rot[:, robot.link_index(link)])  # module -> screw
                # a rotation about the module's x axis by ±θ (the screws' joint origins carry no rotation)
                np.testing.assert_allclose(rel[:, 0, 0], 1.0, atol=1e-12)
                np.testing.assert_allclose(np.arctan2(rel[:, 2, 1], rel[:, 1, 1]),
                                           np.angle(np.exp(1j * sign * theta)), atol=1e-9)
        assert np.ptp(res["robot.joint_q"][:, robot.dof_index("screw_front_00")]) > 1.0
    np.testing.assert_allclose(runs["embedded"]["robot.joint_q"], runs["mimic_crba"]["robot.joint_q"], atol=1e-9)


def test_twist_separated_pair_uses_the_mimic_path():
    """A twist joint about the screw axis between the two screws couples the pair to the twist rate:
    the embedding would drop I_a·θ̇·φ̇ terms, so auto falls back and embedded refuses."""
    urdf = snake_urdf(modules=2, screws="pair", separate_pair=True)
    h = make_harness(urdf)
    assert h.c.mode == "mimic_crba"
    assert "aft_twist_00" in h.c.mode_reason
    with pytest.raises(MultibodyModelError, match="aft_twist"):
        make_harness(urdf, screw_pairs="embedded")
    # The spin angle θ is cyclic, so with no screw torque p_θ = (2 I_a + armature) θ̇ - I_a φ̇ is
    # conserved (the rear screw turns at φ̇ - θ̇ about the axis, the front at θ̇, relative to the module):
    # (2 I_a + armature) θ̈ = I_a φ̈. The embedding drops the I_a φ̇ term and would give θ̈ = 0.
    i_a = 0.012 * 1.6                                        # screw moment about its axis (conftest)
    model = h.c.dyn.model
    iv = {j: model.joints[model.getJointId(j)].idx_v for j in ("aft_twist_00", "screw_front_00")}
    arm = model.armature[iv["screw_front_00"]]
    q, v = random_state(model, np.random.default_rng(3))
    tau = np.zeros(model.nv)
    tau[iv["aft_twist_00"]] = 2.0
    tau[iv["screw_front_00"]] = 0.0
    a = h.c.dyn.forward(q, v, tau)
    phi_dd, theta_dd = a[iv["aft_twist_00"]], a[iv["screw_front_00"]]
    assert abs(phi_dd) > 1.0
    np.testing.assert_allclose((2 * i_a + arm) * theta_dd, i_a * phi_dd, rtol=1e-9)
    tree = parse_urdf(urdf)
    groups = [dataclasses.replace(g, exact=True, reason=None) for g in analyse_mimic_groups(tree)]
    forced = build_dynamics(tree, "embedded", h.c.armature_user, groups)
    a_forced = forced.forward(q, v, tau)
    assert a_forced[iv["screw_front_00"]] == pytest.approx(0.0, abs=1e-12)


def test_embedding_refuses_rotors_that_are_not_axisymmetric():
    urdf = snake_urdf(modules=1, screws="pair")
    lopsided = urdf.replace('<link name="screw_rear_link_00"><inertial><origin xyz="0 0 0"/>',
                            '<link name="screw_rear_link_00"><inertial><origin xyz="0 0.01 0"/>')
    (g,) = analyse_mimic_groups(parse_urdf(lopsided))
    assert not g.exact and "off the axis" in g.reason
    unequal = snake_urdf(modules=1, screws="pair", rear_screw_mass=1.2)   # axisymmetric, lighter
    (g,) = analyse_mimic_groups(parse_urdf(unequal))
    assert not g.exact and "do not cancel" in g.reason
    assert make_harness(unequal).c.mode == "mimic_crba"
