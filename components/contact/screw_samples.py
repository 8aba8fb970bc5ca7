"""Contact samples on a screw's envelope cylinder, thread direction ê_v, and body wrenches.

Screw frame S: the screw axis is S's x axis through S's origin; S sits on the module
body B at (mount_R, mount_p): p_B = mount_R p_S + mount_p. Samples are rings of points on
the envelope cylinder of radius r:

    p_S(j, i) = (x_j, r cos φ_i, r sin φ_i),   x_j evenly spread over the screw length,
                                               φ_i = phase + 2π i / per_ring

They are fixed in B (the module body), NOT in the spinning screw, so they do not depend
on the spin angle: the envelope of a screw is the same whatever its angle, and the
threads' effect enters only through ê_v and the slip velocity. The material point of the
screw under a sample moves with the body plus the spin ω_s about the axis:

    v_point = v_B + ω_B × (p − o_B) + ω_s â × (p − axis point)      (world frame)

Thread direction. With lead angle λ (angle between the thread helix and the plane normal
to the axis; tan λ = lead / (2π r)) and hand h = +1 (right) or −1 (left), the helix at a
sample has tangent t = cos λ ê_φ + h sin λ ê_x, where ê_x is the axis and
ê_φ = ê_x × ê_r the circumferential direction. ê_v is tangent to the cylinder and normal
to the thread line:

    ê_v = cos λ ê_x − h sin λ ê_φ                 (ê_v · t = 0, ‖ê_v‖ = 1)

(ê_v's sign does not matter: eq. 6 is even in ê_v.)
"""

from __future__ import annotations

import numpy as np


def thread_direction(radial, axis, lead_angle, hand=1):
    """ê_v (n,3) at samples with outward radial unit vectors ``radial`` (n,3) on a screw with
    unit ``axis`` (3,), lead angle λ (rad) and ``hand`` +1 right / −1 left."""
    if hand not in (1, -1):
        raise ValueError(f"hand must be +1 (right) or -1 (left), got {hand!r}")
    radial = np.atleast_2d(np.asarray(radial, float))
    axis = np.asarray(axis, float)
    e_phi = np.cross(axis[None, :], radial)
    return np.cos(lead_angle) * axis[None, :] - hand * np.sin(lead_angle) * e_phi


class ScrewContactSamples:
    """Rings of contact samples on one screw's envelope, in the module body frame.

    radius m, length m, rings ≥ 1, per_ring ≥ 1, lead_angle rad in (0, π/2), hand ±1,
    mount_R (3,3) / mount_p (3,) place the screw frame in the body frame, phase rad
    rotates the rings about the axis.

    Attributes (body frame): points (n,3), radial (n,3) outward unit, axis (3,),
    thread_dir (n,3) ê_v, axis_point (3,).
    """

    def __init__(self, radius, length, rings=3, per_ring=8, lead_angle=np.radians(20.0), hand=1,
                 mount_R=None, mount_p=None, phase=0.0):
        if radius <= 0 or length < 0:
            raise ValueError(f"radius must be > 0 and length ≥ 0, got radius={radius}, length={length}")
        if int(rings) < 1 or int(per_ring) < 1:
            raise ValueError(f"rings and per_ring must be ≥ 1, got rings={rings}, per_ring={per_ring}")
        if not 0.0 < lead_angle < np.pi / 2:
            raise ValueError(f"lead_angle must be in (0, π/2) rad, got {lead_angle}")
        self.radius, self.length = float(radius), float(length)
        self.rings, self.per_ring = int(rings), int(per_ring)
        self.lead_angle, self.hand = float(lead_angle), int(hand)
        R = np.eye(3) if mount_R is None else np.asarray(mount_R, float)
        p = np.zeros(3) if mount_p is None else np.asarray(mount_p, float)
        x = np.linspace(-0.5 * length, 0.5 * length, self.rings) if self.rings > 1 else np.zeros(1)
        phi = phase + 2.0 * np.pi * np.arange(self.per_ring) / self.per_ring
        X, PHI = np.meshgrid(x, phi, indexing="ij")
        X, PHI = X.ravel(), PHI.ravel()
        radial_s = np.stack([np.zeros_like(PHI), np.cos(PHI), np.sin(PHI)], axis=1)
        points_s = radial_s * self.radius
        points_s[:, 0] = X
        self.axis = R[:, 0].copy()
        self.axis_point = p.copy()
        self.points = points_s @ R.T + p
        self.radial = radial_s @ R.T
        self.thread_dir = thread_direction(self.radial, self.axis, self.lead_angle, self.hand)

    def __len__(self):
        return self.points.shape[0]

    def world_points(self, R_wb, p_wb):
        """Sample positions (n,3) in the world for body pose (R_wb, p_wb)."""
        return self.points @ np.asarray(R_wb, float).T + np.asarray(p_wb, float)

    def world_directions(self, R_wb):
        """(radial, thread_dir, axis) rotated into the world."""
        R = np.asarray(R_wb, float)
        return self.radial @ R.T, self.thread_dir @ R.T, R @ self.axis

    def slip_velocity(self, R_wb, p_wb, v_wb, omega_wb, spin_rate):
        """World velocity (n,3) of the screw's material point at each sample.

        v_wb: velocity of the body origin (world), omega_wb: body angular velocity (world),
        spin_rate: screw spin rate about its axis relative to the body, rad/s.
        """
        R = np.asarray(R_wb, float)
        r_body = (self.points) @ R.T                          # p − o_B, world
        r_axis = (self.points - self.axis_point) @ R.T        # p − axis point, world
        v = np.asarray(v_wb, float) + np.cross(np.asarray(omega_wb, float), r_body)
        return v + np.cross(spin_rate * (R @ self.axis), r_axis)


def body_wrench(points, forces, origin):
    """Wrench (6,) = [Σ f, Σ (p − o) × f] of point forces about ``origin`` (all world)."""
    forces = np.asarray(forces, float)
    r = np.asarray(points, float) - np.asarray(origin, float)
    return np.concatenate([forces.sum(axis=0), np.cross(r, forces).sum(axis=0)])


def body_wrenches(points, forces, origins, body_index):
    """Wrenches (nb,6) of point forces grouped by ``body_index`` (n,) about each body's
    origin ``origins`` (nb,3), world frame; vectorised with np.add.at."""
    forces = np.asarray(forces, float)
    origins = np.asarray(origins, float)
    body_index = np.asarray(body_index, int)
    r = np.asarray(points, float) - origins[body_index]
    w = np.zeros((origins.shape[0], 6))
    np.add.at(w, body_index, np.concatenate([forces, np.cross(r, forces)], axis=1))
    return w
