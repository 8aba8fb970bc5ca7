"""Link kinematics, momentum and the external-wrench convention against Pinocchio.

The component computes every URDF link's pose, velocity and acceleration with
its own kernels on the unmerged link tree; the reference is Pinocchio's mimic
model (which moves the rear screws with their front screws) evaluated with
Pinocchio's own frame algorithms.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from snake_models import coordinate_maps, make_harness, random_state, reference_model, set_state, snake_urdf
from snakesim.robots import load_robot

CASES = {
    "snake_twist_pairs_head": lambda: snake_urdf(modules=3, screws="pair", twist=True, head_mass=1.5),
    "snake_front_screws": lambda: snake_urdf(modules=2, screws="front"),
    "eels-1.0": lambda: load_robot("eels-1.0", modules=2).urdf,
    "eels-1.5": lambda: load_robot("eels-1.5", modules=3).urdf,
}


@pytest.mark.parametrize("case", list(CASES))
def test_link_kinematics_match_pinocchio(case):
    urdf = CASES[case]()
    h = make_harness(urdf, gravity_input="vector")
    model, data = reference_model(urdf)
    qmap, vmap = coordinate_maps(h, model)
    rng = np.random.default_rng(7)
    for _ in range(3):
        q, v = random_state(model, rng)
        set_state(h, q[qmap], v[vmap], tau=rng.standard_normal(len(h.c.robot.joints)), gravity=[0.0, 0.0, -9.81])
        out = h.outputs()
        a = np.empty(model.nv)
        a[vmap] = out["a"]
        pin.forwardKinematics(model, data, q, v, a)
        pin.updateFramePlacements(model, data)
        for row, name in enumerate(h.c.robot.links):
            fid = model.getFrameId(name, pin.FrameType.BODY)
            m = data.oMf[fid]
            np.testing.assert_allclose(out["link_poses"][row, :3], m.translation, atol=1e-12)
            np.testing.assert_allclose(out["link_rotations"][row], m.rotation, atol=1e-12)
            quat = pin.Quaternion(m.rotation).coeffs()
            assert min(np.abs(out["link_poses"][row, 3:] - quat).max(), np.abs(out["link_poses"][row, 3:] + quat).max()) < 1e-12
            vel = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(out["link_velocities"][row], np.r_[vel.linear, vel.angular], atol=1e-10)
            acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            scale = 1.0 + np.abs(out["a"]).max()
            np.testing.assert_allclose(out["link_accelerations"][row], np.r_[acc.linear, acc.angular],
                                       atol=1e-11 * scale)
        hg = pin.computeCentroidalMomentum(model, data, q, v)
        com = data.com[0]
        np.testing.assert_allclose(out["com"], com, atol=1e-12)
        np.testing.assert_allclose(out["momentum"][:3], hg.linear, atol=1e-10)
        np.testing.assert_allclose(out["momentum"][3:], hg.angular + np.cross(com, hg.linear), atol=1e-10)


@pytest.mark.parametrize("case", ["snake_twist_pairs_head", "eels-1.0"])
def test_external_wrench_is_world_axes_about_link_origin(case):
    """a(W) - a(0) = M⁻¹ Σ J_lᵀ W_l with J_l the LOCAL_WORLD_ALIGNED Jacobian of link l's frame."""
    urdf = CASES[case]()
    h = make_harness(urdf, screw_pairs="mimic_crba")
    model, data = reference_model(urdf)
    qmap, vmap = coordinate_maps(h, model)
    model.armature[vmap] = h.c.dyn.model.armature
    rng = np.random.default_rng(11)
    q, v = random_state(model, rng)
    W = rng.standard_normal((len(h.c.robot.links), 6))
    set_state(h, q[qmap], v[vmap], wrenches=np.zeros_like(W))
    a0, a1 = np.empty(model.nv), np.empty(model.nv)
    a0[vmap] = h.derivative()[model.nv:]
    h.inputs.wrenches = W
    a1[vmap] = h.derivative()[model.nv:]
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    gen = np.zeros(model.nv)
    for row, name in enumerate(h.c.robot.links):
        J = pin.getFrameJacobian(model, data, model.getFrameId(name, pin.FrameType.BODY), pin.LOCAL_WORLD_ALIGNED)
        gen += J.T @ W[row]
    M = pin.crba(model, data, q)
    np.testing.assert_allclose(a1 - a0, np.linalg.solve(M, gen), atol=1e-10 * (1 + np.abs(a1).max()))


def test_energy_is_kinetic_plus_potential():
    """Kinetic energy = ½ vᵀ M v (armature included), potential = -Σ m g·c = -M_total g·com."""
    urdf = snake_urdf(modules=3, screws="pair", twist=True, head_mass=1.0)
    h = make_harness(urdf, screw_pairs="mimic_crba", gravity=(0.3, -0.2, -9.7))
    model, data = reference_model(urdf)
    qmap, vmap = coordinate_maps(h, model)
    model.armature[vmap] = h.c.dyn.model.armature
    q, v = random_state(model, np.random.default_rng(2))
    set_state(h, q[qmap], v[vmap])
    out = h.outputs()
    M = pin.crba(model, data, q)
    np.testing.assert_allclose(out["energy"][0], 0.5 * v @ M @ v, rtol=1e-12)
    mass = pin.computeTotalMass(model)
    np.testing.assert_allclose(out["energy"][1], -mass * np.array([0.3, -0.2, -9.7]) @ pin.centerOfMass(model, data, q),
                               rtol=1e-12)


def test_dexp_inv_maps_body_velocity_to_the_start_chart():
    """d/dε (x0 ⊕ (u + ε k̃)) = body velocity ξ at x0 ⊕ u, for k̃ = dexp_inv(u, ξ)."""
    urdf = snake_urdf(modules=2)
    h = make_harness(urdf)
    model = h.c.dyn.model
    rng = np.random.default_rng(5)
    x0 = h.x.copy()
    x0[:model.nq] = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    nv = model.nv
    u = rng.standard_normal(2 * nv) * 0.6
    xi = rng.standard_normal(2 * nv)
    k = xi.copy()
    h.c.dexp_inv(x0, u, k)
    eps = 1e-6
    xa, xb = np.empty_like(x0), np.empty_like(x0)
    h.c.integrate(x0, u + eps * k, xa)
    h.c.integrate(x0, u, xb)
    rate = pin.difference(model, xb[:model.nq], xa[:model.nq]) / eps
    np.testing.assert_allclose(rate, xi[:nv], atol=1e-6)
