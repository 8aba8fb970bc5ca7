"""Screw contact samples: geometry, thread direction, slip velocity with spin, wrenches."""

import numpy as np
import pytest

from snakesim.components.contact import (ScrewContactSamples, body_wrench, body_wrenches, body_wrenches_nb,
                                         thread_direction)


def rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_rings_on_envelope_in_body_frame():
    s = ScrewContactSamples(0.1, 0.4, rings=5, per_ring=6, mount_p=[0, 0.2, 0])
    assert len(s) == 30
    rel = s.points - s.axis_point
    np.testing.assert_allclose(np.linalg.norm(rel[:, 1:], axis=1), 0.1)
    np.testing.assert_allclose(sorted(set(np.round(rel[:, 0], 12))), np.linspace(-0.2, 0.2, 5))
    np.testing.assert_allclose(np.linalg.norm(s.radial, axis=1), 1.0)


@pytest.mark.parametrize("hand", [1, -1])
def test_thread_direction_normal_to_thread_tangent_to_surface(hand):
    lam = 0.3
    s = ScrewContactSamples(0.1, 0.3, rings=2, per_ring=7, lead_angle=lam, hand=hand)
    e_phi = np.cross(s.axis, s.radial)
    helix = np.cos(lam) * e_phi + hand * np.sin(lam) * s.axis
    ev = s.thread_dir
    np.testing.assert_allclose(np.einsum("ij,ij->i", ev, helix), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.einsum("ij,ij->i", ev, s.radial), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(ev, axis=1), 1.0)
    np.testing.assert_allclose(ev @ s.axis, np.cos(lam))
    with pytest.raises(ValueError, match="hand"):
        thread_direction(s.radial, s.axis, lam, hand=0)


def test_samples_do_not_depend_on_spin_angle():
    """No spin-angle input exists; and the envelope + ê_v field is invariant under any spin
    rotation (helical symmetry), so attaching samples to the body loses nothing."""
    s = ScrewContactSamples(0.1, 0.3, rings=3, per_ring=5, lead_angle=0.4, hand=-1)
    R, p = rot_z(0.3), np.array([1.0, 2.0, 0.5])
    a = s.world_points(R, p)
    for spin_angle in (0.0, 0.7, 2.0):
        np.testing.assert_array_equal(s.world_points(R, p), a)
        Q = rot_x(spin_angle)                         # spin rotation about the screw axis
        np.testing.assert_allclose(thread_direction(s.radial @ Q.T, s.axis, 0.4, -1), s.thread_dir @ Q.T, atol=1e-15)


def test_slip_velocity_includes_spin():
    # per_ring 4, phase −π/2: samples at bottom (−z), +y, top, −y
    s = ScrewContactSamples(0.1, 0.0, rings=1, per_ring=4, phase=-np.pi / 2)
    R, p = np.eye(3), np.zeros(3)
    v = s.slip_velocity(R, p, np.zeros(3), np.zeros(3), spin_rate=2.0)
    np.testing.assert_allclose(v, [[0, 0.2, 0], [0, 0, 0.2], [0, -0.2, 0], [0, 0, -0.2]], atol=1e-15)
    # plus body translation and body rotation about z (yaw 1 rad/s) at a mounted offset
    s = ScrewContactSamples(0.1, 0.0, rings=1, per_ring=4, phase=-np.pi / 2, mount_p=[0, 0.5, 0])
    v = s.slip_velocity(R, p, [1.0, 0, 0], [0, 0, 1.0], spin_rate=2.0)
    bottom = s.points[0]                                       # (0, 0.5, −0.1)
    np.testing.assert_allclose(v[0], [1.0, 0, 0] + np.cross([0, 0, 1.0], bottom) + [0, 0.2, 0], atol=1e-15)
    # rotated body: everything rotates
    Rw = rot_z(0.9)
    v0 = s.slip_velocity(np.eye(3), p, [1.0, 0, 0], [0, 0, 1.0], 2.0)
    np.testing.assert_allclose(s.slip_velocity(Rw, p, Rw @ [1.0, 0, 0], [0, 0, 1.0], 2.0), v0 @ Rw.T, atol=1e-14)


def test_body_wrench_by_hand_and_vectorised():
    # 10 N up at (1, 0, 0) about the origin: torque (0, −10, 0)
    np.testing.assert_allclose(body_wrench([[1.0, 0, 0]], [[0, 0, 10.0]], np.zeros(3)), [0, 0, 10, 0, -10, 0])
    rng = np.random.default_rng(5)
    pts, f = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    origins, idx = rng.normal(size=(4, 3)), rng.integers(0, 4, 50)
    w = body_wrenches(pts, f, origins, idx)
    for b in range(4):
        np.testing.assert_allclose(w[b], body_wrench(pts[idx == b], f[idx == b], origins[b]), atol=1e-12)
    out = np.empty((4, 6))
    body_wrenches_nb(pts, f, origins, idx, out)
    np.testing.assert_allclose(out, w, atol=1e-12)
