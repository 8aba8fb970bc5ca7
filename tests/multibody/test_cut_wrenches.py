"""Inter-body wrenches across joints and fixed frames (force-torque sensors, paper 2.2.4).

joint_wrenches[l] is the wrench the parent side exerts on everything below
link l (across its parent joint), in link l's frame about its origin. Checks from statics
and from the equations of motion, with references that do not use the
component's kernels (Pinocchio's own URDF model and subtree centres of mass).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from snake_models import HEAD_COM, coordinate_maps, make_harness, random_state, reference_model, set_state, snake_urdf

HEAD_MASS = 2.0


def _urdf():
    return snake_urdf(modules=3, screws="pair", twist=True, head_mass=HEAD_MASS)


def test_free_fall_carries_no_internal_wrench():
    """Uniform gravity accelerates every link alike: at rest and unactuated, no joint transmits anything."""
    urdf = _urdf()
    h = make_harness(urdf, gravity=(1.0, -2.0, -9.81))
    model, _ = reference_model(urdf)
    qmap, _ = coordinate_maps(h, model)
    q, _ = random_state(model, np.random.default_rng(4))
    set_state(h, q[qmap], np.zeros(model.nv))
    w = h.outputs()["joint_wrenches"]
    assert len(h.c.robot.cuts(["*"])[0]) == len(h.c.robot.links) - 1
    weight = HEAD_MASS * 9.81
    assert np.abs(w).max() < 1e-11 * weight


@pytest.mark.parametrize("mode", ["embedded", "mimic_crba"])
def test_held_chain_carries_the_weight_below_each_cut(mode):
    """Tail held by an external wrench, joints by gravity-compensating torques: static equilibrium,
    and each cut carries the weight of the part below it and that weight's moment."""
    urdf = _urdf()
    g = np.array([0.8, -0.5, -9.7])
    cuts = ["bend_01", "twist_02", "head_joint", "sensor_joint_01"]
    h = make_harness(urdf, screw_pairs=mode, gravity=tuple(g))
    model, data = reference_model(urdf)
    model.gravity.linear[:] = g
    qmap, vmap = coordinate_maps(h, model)
    q, _ = random_state(model, np.random.default_rng(8))
    gen = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv))   # generalised gravity
    rot = pin.XYZQUATToSE3(q[:7]).rotation
    W = np.zeros((len(h.c.robot.links), 6))
    W[h.c.link_index("tail")] = np.r_[rot @ gen[:3], rot @ gen[3:6]]      # root rows are tail-frame
    tau = np.array([gen[model.joints[model.getJointId(j)].idx_v] for j in h.c.robot.joints])
    set_state(h, q[qmap], np.zeros(model.nv), tau=tau, wrenches=W)
    out = h.outputs()
    assert np.abs(out["a"]).max() < 1e-9

    pin.centerOfMass(model, data, q)                    # subtree masses, centres of mass (joint frames)
    pin.framesForwardKinematics(model, data, q)
    names, children = h.c.robot.cuts(cuts)
    for cut, link in zip(names, children):
        child = {"bend_01": "knuckle_01", "twist_02": "module_02", "head_joint": "head",
                 "sensor_joint_01": "sensor_01"}[cut]
        frame = data.oMf[model.getFrameId(child, pin.FrameType.BODY)]
        if cut == "head_joint":
            mass, com = HEAD_MASS, frame.act(np.array(HEAD_COM))
        elif cut == "sensor_joint_01":
            mass, com = 0.0, frame.translation                          # a massless frame carries nothing
        else:
            j = model.getJointId(cut)
            mass, com = data.mass[j], data.oMi[j].act(data.com[j])
        f_world = -mass * g
        tau_world = np.cross(com - frame.translation, f_world)
        expect = np.r_[frame.rotation.T @ f_world, frame.rotation.T @ tau_world]
        assert link == child
        np.testing.assert_allclose(out["joint_wrenches"][h.c.link_index(child)], expect, atol=1e-9 * (1 + mass * 9.81))


@pytest.mark.parametrize("mode", ["embedded", "mimic_crba"])
def test_torque_about_a_joint_axis_is_the_motor_torque_less_rotor_and_friction(mode):
    """In motion, with gravity and external wrenches: the axial torque a joint transmits is
    τ - armature·q̈ - damping·q̇ (the rest of the motor torque spins the rotor or is lost)."""
    urdf = _urdf()
    joints = ["bend_00", "twist_00", "bend_02", "twist_02"]
    h = make_harness(urdf, screw_pairs=mode, damping={"bend_*": 0.7, "twist_*": 0.3},
                     gravity=(0.0, 0.0, -9.81))
    rng = np.random.default_rng(9)
    model = h.c.dyn.model
    q, v = random_state(model, rng)
    set_state(h, q, 2.0 * v, tau=5.0 * rng.standard_normal(len(h.c.robot.joints)),
              wrenches=10.0 * rng.standard_normal((len(h.c.robot.links), 6)))
    out = h.outputs()
    for j, link in zip(*h.c.robot.cuts(joints)):
        i = h.c.dof_index(j)
        vi = model.joints[model.getJointId(j)].idx_v
        expect = h.u.tau[i] - h.c.armature_user[j] * out["a"][vi] - h.c.damping_user[j] * out["joint_v"][i]
        axis = 1 if j.startswith("bend") else 0                 # bend about y, twist about x (link frame)
        assert abs(out["joint_wrenches"][h.c.link_index(link), 3 + axis] - expect) < 1e-9 * (1 + abs(expect)), (j, expect)
