"""numba kernels of the screw–SDF contact step (screw_sdf.py): broad-phase spheres, sample
kinematics, and forces reduced to link wrenches. All write into preallocated arrays.

Frames: link_poses rows are [x, y, z, qx, qy, qz, qw] (world), link_velocities rows
[v of the link origin, ω] (world axes), as the multibody outputs them. Sample
quantities in the body frame B (the screw's parent link): points_B, ringc_B (centre of
the sample's ring, on the axis), radial_B; per screw axis_B and mount_p (screw centre).

Material table ``mats`` (nm, 5): columns k N/m, c N·s/m, μ, ev_a, ev_b 1/N; row = the
terrain's material index of the sample.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernel_args import record
from ..multibody.pose_quaternions import pose_rotation
from .jacobian_kernels import contact_jacobian_blocks
from .kernels_numba import add_wrench, point_contact_force

K, C, MU, EV_A, EV_B = range(5)


@njit(cache=True)
def link_fixed_points(poses, link_row, p_B, R, out):
    """World position of points fixed in links: o_l + R_l p_B for point k on link link_row[k]
    (a screw's centre, a body piece's bounding-sphere centre). R is (3,3) scratch."""
    for k in range(link_row.shape[0]):
        b = link_row[k]
        pose_rotation(poses, b, R)
        for i in range(3):
            out[k, i] = poses[b, i] + R[i, 0] * p_B[k, 0] + R[i, 1] * p_B[k, 1] + R[i, 2] * p_B[k, 2]


@njit(cache=True)
def sample_points(poses, active, n_active, start, points_B, parent_row, R, out_points, out_sample, out_owner):
    """World position of every sample of the active screws, written compactly to rows 0..m-1
    (out_sample = row in points_B, out_owner = screw index); returns m."""
    m = 0
    for a in range(n_active):
        s = active[a]
        b = parent_row[s]
        pose_rotation(poses, b, R)
        for i in range(start[s], start[s + 1]):
            for j in range(3):
                out_points[m, j] = poses[b, j] + R[j, 0] * points_B[i, 0] + R[j, 1] * points_B[i, 1] \
                    + R[j, 2] * points_B[i, 2]
            out_sample[m] = i
            out_owner[m] = s
            m += 1
    return m


@njit(cache=True)
def contact_wrenches(m, distance, normal, material, sample, owner, poses, vels, joint_v, ringc_B, radial_B, axis_B,
                     parent_row, screw_row, radius, lead_angle, hand, spin_dof, spin_mult, mats, v_eps, mode,
                     ev_floor, near, R, out_point, out_vel, out_force, out_fn, out_wrench, out_screw_fn):
    """Forces on the first m samples and their wrenches about each screw link's origin o_S.

    A sample in contact (φ < 0) gives the depth d = −φ and the terrain normal n̂. The
    screw's envelope is a surface of revolution, so the force acts where the envelope
    faces the terrain in the sample's ring: ê_c = unit(−n̂ + (n̂·â)â) (the sample's own
    radial if n̂ ∥ â), p_c = c_ring + r ê_c. There

        v    = v_B + ω_B × (p_c − o_B) + ω_s r â × ê_c        (spin slides along the surface:
                                                              no normal component, magnitude ω_s r)
        ê_v  = cos λ â − h sin λ (â × ê_c)                   (normal to the thread line)
        F_n  = max(0, k d − c v·n̂);  F_t by eq. 6 (kernels.py)

    so the sampling sets only where and how deep the contact is, never a spurious
    normal velocity or spin torque from a sample that lies off the envelope's lowest line.
    Wrench [f, (p_c − o_S) × f] into out_wrench[screw_row[s]] (zeroed first). Writes
    out_point (p_c), out_vel, out_force, out_fn for samples in contact, and p_c and v (no force) for samples
    within ``near`` of the surface (the implicit step's look-ahead: jacobian_kernels.contact_jacobian_blocks);
    zeros elsewhere. Returns the number of samples in contact.
    """
    out_wrench[:, :] = 0.0
    out_screw_fn[:] = 0.0
    n_contact = 0
    last = -1                  # rows come grouped by screw: its rotation, axis and thread once per screw
    b = 0
    ax = ay = az = cl = sl = 0.0
    for i in range(m):
        d = -distance[i]
        if not d > -near:
            out_fn[i] = 0.0
            for j in range(3):
                out_force[i, j] = 0.0
                out_vel[i, j] = 0.0
                out_point[i, j] = 0.0
            continue
        s = owner[i]
        q = sample[i]
        if s != last:
            last = s
            b = parent_row[s]
            pose_rotation(poses, b, R)
            ax = R[0, 0] * axis_B[s, 0] + R[0, 1] * axis_B[s, 1] + R[0, 2] * axis_B[s, 2]
            ay = R[1, 0] * axis_B[s, 0] + R[1, 1] * axis_B[s, 1] + R[1, 2] * axis_B[s, 2]
            az = R[2, 0] * axis_B[s, 0] + R[2, 1] * axis_B[s, 1] + R[2, 2] * axis_B[s, 2]
            cl, sl = math.cos(lead_angle[s]), hand[s] * math.sin(lead_angle[s])
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        na = nx * ax + ny * ay + nz * az
        ux, uy, uz = -(nx - na * ax), -(ny - na * ay), -(nz - na * az)
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        if un > 1e-9:
            ux, uy, uz = ux / un, uy / un, uz / un
        else:                                           # terrain normal along the axis: a screw end
            ux = R[0, 0] * radial_B[q, 0] + R[0, 1] * radial_B[q, 1] + R[0, 2] * radial_B[q, 2]
            uy = R[1, 0] * radial_B[q, 0] + R[1, 1] * radial_B[q, 1] + R[1, 2] * radial_B[q, 2]
            uz = R[2, 0] * radial_B[q, 0] + R[2, 1] * radial_B[q, 1] + R[2, 2] * radial_B[q, 2]
        r = radius[s]
        # contact point p_c, relative to the body origin
        rx = R[0, 0] * ringc_B[q, 0] + R[0, 1] * ringc_B[q, 1] + R[0, 2] * ringc_B[q, 2] + r * ux
        ry = R[1, 0] * ringc_B[q, 0] + R[1, 1] * ringc_B[q, 1] + R[1, 2] * ringc_B[q, 2] + r * uy
        rz = R[2, 0] * ringc_B[q, 0] + R[2, 1] * ringc_B[q, 1] + R[2, 2] * ringc_B[q, 2] + r * uz
        px, py, pz = poses[b, 0] + rx, poses[b, 1] + ry, poses[b, 2] + rz
        # â × ê_c: the circumferential direction at p_c
        cx, cy, cz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
        wr = spin_mult[s] * joint_v[spin_dof[s]] * r
        wx, wy, wz = vels[b, 3], vels[b, 4], vels[b, 5]
        vx = vels[b, 0] + (wy * rz - wz * ry) + wr * cx
        vy = vels[b, 1] + (wz * rx - wx * rz) + wr * cy
        vz = vels[b, 2] + (wx * ry - wy * rx) + wr * cz
        out_point[i, 0], out_point[i, 1], out_point[i, 2] = px, py, pz
        out_vel[i, 0], out_vel[i, 1], out_vel[i, 2] = vx, vy, vz
        if not d > 0.0:                                 # near, not touching: no force
            out_fn[i] = 0.0
            out_force[i, 0], out_force[i, 1], out_force[i, 2] = 0.0, 0.0, 0.0
            continue
        n_contact += 1
        mat = material[i]
        # ê_v: normal to the thread line at p_c (lead angle, hand; cl, sl above), projected in the kernel
        fn, fx, fy, fz = point_contact_force(
            d, nx, ny, nz, vx, vy, vz, cl * ax - sl * cx, cl * ay - sl * cy, cl * az - sl * cz,
            mats[mat, K], mats[mat, C], mats[mat, MU], mats[mat, EV_A], mats[mat, EV_B], v_eps, mode, ev_floor)
        out_fn[i] = fn
        out_force[i, 0], out_force[i, 1], out_force[i, 2] = fx, fy, fz
        out_screw_fn[s] += fn
        o = screw_row[s]
        add_wrench(out_wrench, o, px - poses[o, 0], py - poses[o, 1], pz - poses[o, 2], fx, fy, fz)
    return n_contact


@njit(cache=True)
def plane_query(m, points, origin, n, out_distance, out_normal, out_material):
    """PlaneTerrain.query without allocation: φ = (p − o)·n̂, normal n̂, material region 0 (row given)."""
    for i in range(m):
        out_distance[i] = (points[i, 0] - origin[0]) * n[0] + (points[i, 1] - origin[1]) * n[1] \
            + (points[i, 2] - origin[2]) * n[2]
        out_normal[i, 0], out_normal[i, 1], out_normal[i, 2] = n[0], n[1], n[2]
        out_material[i] = 0


# -- exact ring contact (``ring_contact="extremal"``): each ring meets the terrain at its deepest point ----------
#
# Rows of the per-contact arrays: 0..m-1 the samples of the active screws (as before), m..m+nr-1 one row per
# ring of those screws (its centre c, then its extremal point). The terrain is queried at c for the local
# normal n̂_c; the ring's point extremal along −n̂_c is p* = c + r ê_c, ê_c = unit(−n̂_c + (n̂_c·â)â); the
# terrain queried at p* gives the ring's contact (depth −φ(p*), normal, material). A sample keeps its own
# contact only where it meets another surface than the ring's (its ê_i from its own normal more than
# ``sep`` rad from ê_c, or along the axis: a screw end), so a ring in a channel's corner keeps both
# contacts and no surface is counted twice. Where ê_c is ill-defined (n̂_c ∥ â) the ring has no row in
# contact and its samples act as before.

@njit(cache=True)
def ring_rows(poses, active, n_active, start, points_B, ring_start, ring_first, ringc_B, parent_row, R, out_points,
              out_sample, out_owner, out_ring_row):
    """Sample rows (as sample_points) then one row per ring (its world centre; sample = the ring's first
    sample, owner = the screw); out_ring_row[row] = the row of the sample's ring. Returns (m, nr)."""
    m = 0
    for a in range(n_active):
        s = active[a]
        m += start[s + 1] - start[s]
    k = m
    row = 0
    for a in range(n_active):
        s = active[a]
        b = parent_row[s]
        pose_rotation(poses, b, R)
        for g in range(ring_start[s], ring_start[s + 1]):
            q = ring_first[g]
            for j in range(3):
                out_points[k, j] = poses[b, j] + R[j, 0] * ringc_B[q, 0] + R[j, 1] * ringc_B[q, 1] \
                    + R[j, 2] * ringc_B[q, 2]
            out_sample[k] = q
            out_owner[k] = s
            out_ring_row[k] = k
            q_end = ring_first[g + 1] if g + 1 < ring_first.shape[0] else points_B.shape[0]
            for i in range(q, q_end):
                for j in range(3):
                    out_points[row, j] = poses[b, j] + R[j, 0] * points_B[i, 0] + R[j, 1] * points_B[i, 1] \
                        + R[j, 2] * points_B[i, 2]
                out_sample[row] = i
                out_owner[row] = s
                out_ring_row[row] = k
                row += 1
            k += 1
    return m, k - m


@njit(cache=True)
def ring_extremal(m, nr, points, distance, normal, owner, poses, axis_B, parent_row, radius, R, ring_dir,
                  ext_points, ext_row):
    """Per ring row k (centre queried: distance, normal): ê_c into ring_dir[k] (zeros where n̂_c ∥ â) and,
    where the ring can reach the terrain (φ(c) < r), its extremal point p* = c + r ê_c into ext_points with
    its row in ext_row. Every ring row is marked out of contact (+inf) until finish_extremal fills it.
    Returns the number of extremal points to query."""
    ne = 0
    for k in range(m, m + nr):
        s = owner[k]
        b = parent_row[s]
        pose_rotation(poses, b, R)
        ax = R[0, 0] * axis_B[s, 0] + R[0, 1] * axis_B[s, 1] + R[0, 2] * axis_B[s, 2]
        ay = R[1, 0] * axis_B[s, 0] + R[1, 1] * axis_B[s, 1] + R[1, 2] * axis_B[s, 2]
        az = R[2, 0] * axis_B[s, 0] + R[2, 1] * axis_B[s, 1] + R[2, 2] * axis_B[s, 2]
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        na = nx * ax + ny * ay + nz * az
        ux, uy, uz = na * ax - nx, na * ay - ny, na * az - nz
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        r = radius[s]
        if un > 1e-9:
            ux, uy, uz = ux / un, uy / un, uz / un
            ring_dir[k, 0], ring_dir[k, 1], ring_dir[k, 2] = ux, uy, uz
            if distance[k] < r:
                ext_points[ne, 0] = points[k, 0] + r * ux
                ext_points[ne, 1] = points[k, 1] + r * uy
                ext_points[ne, 2] = points[k, 2] + r * uz
                ext_row[ne] = k
                ne += 1
        else:
            ring_dir[k, 0], ring_dir[k, 1], ring_dir[k, 2] = 0.0, 0.0, 0.0
        distance[k] = math.inf
    return ne


@njit(cache=True)
def finish_extremal(m, ne, ext_row, ext_distance, ext_normal, ext_material, distance, normal, material, owner,
                    ring_row, ring_dir, poses, axis_B, parent_row, cos_sep, R):
    """The extremal points' queries into their ring rows; samples in contact with the surface their ring
    already meets (ê_i within ``sep`` of ê_c) are taken out of contact (+inf)."""
    for e in range(ne):
        k = ext_row[e]
        distance[k] = ext_distance[e]
        normal[k, 0], normal[k, 1], normal[k, 2] = ext_normal[e, 0], ext_normal[e, 1], ext_normal[e, 2]
        material[k] = ext_material[e]
    for i in range(m):
        if not distance[i] < 0.0:
            continue
        k = ring_row[i]
        cx, cy, cz = ring_dir[k, 0], ring_dir[k, 1], ring_dir[k, 2]
        if cx == 0.0 and cy == 0.0 and cz == 0.0:
            continue                                    # the ring has no extremal point: samples act
        s = owner[i]
        pose_rotation(poses, parent_row[s], R)
        ax = R[0, 0] * axis_B[s, 0] + R[0, 1] * axis_B[s, 1] + R[0, 2] * axis_B[s, 2]
        ay = R[1, 0] * axis_B[s, 0] + R[1, 1] * axis_B[s, 1] + R[1, 2] * axis_B[s, 2]
        az = R[2, 0] * axis_B[s, 0] + R[2, 1] * axis_B[s, 1] + R[2, 2] * axis_B[s, 2]
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        na = nx * ax + ny * ay + nz * az
        ux, uy, uz = na * ax - nx, na * ay - ny, na * az - nz
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        if un > 1e-9 and (ux * cx + uy * cy + uz * cz) > cos_sep * un:
            distance[i] = math.inf                      # the ring's own contact covers this surface


@njit(cache=True)
def plane_active(centres, radii, origin, n, out_active):
    """Broad phase against a plane (exact distance, Lipschitz 1): screws whose sphere reaches it."""
    k = 0
    for s in range(centres.shape[0]):
        d = (centres[s, 0] - origin[0]) * n[0] + (centres[s, 1] - origin[1]) * n[1] + (centres[s, 2] - origin[2]) * n[2]
        if d - radii[s] <= 0.0:
            out_active[k] = s
            k += 1
    return k


@njit(cache=True)
def plane_contact_step(broad_phase, origin, n, region_material, sphere_r, start, points_B, mount_p, active, centres,
                       points, distance, normal, material, sample, owner, poses, vels, joint_v, ringc_B, radial_B, axis_B,
                       parent_row, screw_row, radius, lead_angle, hand, spin_dof, spin_mult, mats, v_eps, mode,
                       ev_floor, R, out_point, out_vel, out_force, out_fn, out_wrench, out_screw_fn):
    """One contact evaluation against a plane in one call (the screw_sdf hot path, one dispatch):
    broad phase (link_fixed_points + plane_active, or every screw), sample_points, plane_query and
    contact_wrenches, exactly as the component calls them one by one for other terrains.
    Returns (screws tested, samples queried m, samples in contact)."""
    ns = parent_row.shape[0]
    if broad_phase:
        link_fixed_points(poses, parent_row, mount_p, R, centres)
        n_active = plane_active(centres, sphere_r, origin, n, active)
    else:
        for s in range(ns):
            active[s] = s
        n_active = ns
    m = 0
    if n_active:
        m = sample_points(poses, active, n_active, start, points_B, parent_row, R, points, sample, owner)
        plane_query(m, points, origin, n, distance, normal, material)
        for i in range(m):
            material[i] = region_material
    n_contact = contact_wrenches(m, distance, normal, material, sample, owner, poses, vels, joint_v, ringc_B,
                                 radial_B, axis_B, parent_row, screw_row, radius, lead_angle, hand, spin_dof,
                                 spin_mult, mats, v_eps, mode, ev_floor, 0.0, R, out_point, out_vel, out_force,
                                 out_fn, out_wrench, out_screw_fn)
    return n_active, m, n_contact


@njit(cache=True)
def plane_rings(poses, active, n_active, start, points_B, ring_start, ring_first, ringc_B, axis_B, parent_row, radius,
                origin, n, near, R, out_points, out_distance, out_normal, out_sample, out_owner):
    """Exact rings against a plane, without querying the samples: a plane's normal is the same
    everywhere, so every sample of a ring meets the surface its extremal point does (finish_extremal
    would drop them all) unless n̂ ∥ â, where the ring's samples act. Rows: the extremal point of each
    ring that reaches the plane (φ(c) < r: depth r |n̂ − (n̂·â)â| − φ(c)), or the samples of a ring
    whose axis is along n̂; a ring whose extremal point is within ``near`` above the plane is a row too
    (not touching: the Jacobian's look-ahead). Returns the number of rows."""
    k = 0
    for a in range(n_active):
        s = active[a]
        b = parent_row[s]
        pose_rotation(poses, b, R)
        ax = R[0, 0] * axis_B[s, 0] + R[0, 1] * axis_B[s, 1] + R[0, 2] * axis_B[s, 2]
        ay = R[1, 0] * axis_B[s, 0] + R[1, 1] * axis_B[s, 1] + R[1, 2] * axis_B[s, 2]
        az = R[2, 0] * axis_B[s, 0] + R[2, 1] * axis_B[s, 1] + R[2, 2] * axis_B[s, 2]
        na = n[0] * ax + n[1] * ay + n[2] * az
        ux, uy, uz = na * ax - n[0], na * ay - n[1], na * az - n[2]
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        r = radius[s]
        for g in range(ring_start[s], ring_start[s + 1]):
            q = ring_first[g]
            cx = poses[b, 0] + R[0, 0] * ringc_B[q, 0] + R[0, 1] * ringc_B[q, 1] + R[0, 2] * ringc_B[q, 2]
            cy = poses[b, 1] + R[1, 0] * ringc_B[q, 0] + R[1, 1] * ringc_B[q, 1] + R[1, 2] * ringc_B[q, 2]
            cz = poses[b, 2] + R[2, 0] * ringc_B[q, 0] + R[2, 1] * ringc_B[q, 1] + R[2, 2] * ringc_B[q, 2]
            if un > 1e-9:
                phi = (cx - origin[0]) * n[0] + (cy - origin[1]) * n[1] + (cz - origin[2]) * n[2]
                if phi < r + near:
                    px, py, pz = cx + r * ux / un, cy + r * uy / un, cz + r * uz / un
                    out_points[k, 0], out_points[k, 1], out_points[k, 2] = px, py, pz
                    out_distance[k] = (px - origin[0]) * n[0] + (py - origin[1]) * n[1] + (pz - origin[2]) * n[2]
                    out_normal[k, 0], out_normal[k, 1], out_normal[k, 2] = n[0], n[1], n[2]
                    out_sample[k] = q
                    out_owner[k] = s
                    k += 1
            else:
                q_end = ring_first[g + 1] if g + 1 < ring_first.shape[0] else points_B.shape[0]
                for i in range(q, q_end):
                    for j in range(3):
                        out_points[k, j] = poses[b, j] + R[j, 0] * points_B[i, 0] + R[j, 1] * points_B[i, 1] \
                            + R[j, 2] * points_B[i, 2]
                    out_distance[k] = (out_points[k, 0] - origin[0]) * n[0] + (out_points[k, 1] - origin[1]) * n[1] \
                        + (out_points[k, 2] - origin[2]) * n[2]
                    out_normal[k, 0], out_normal[k, 1], out_normal[k, 2] = n[0], n[1], n[2]
                    out_sample[k] = i
                    out_owner[k] = s
                    k += 1
    return k


@njit(cache=True)
def plane_extremal_step(samples, work, ports, surface):
    """plane_contact_step with exact rings (ring_contact="extremal"): broad phase, plane_rings, then
    contact_wrenches, in one call."""
    s, w, io, f = samples, work, ports, surface
    ns = s.parent_row.shape[0]
    if s.broad_phase:
        link_fixed_points(io.poses, s.parent_row, s.mount_p, w.R, w.centres)
        n_active = plane_active(w.centres, s.sphere_r, f.origin, f.n, w.active)
    else:
        for a in range(ns):
            w.active[a] = a
        n_active = ns
    m = 0
    if n_active:
        m = plane_rings(io.poses, w.active, n_active, s.start, s.points_B, s.ring_start, s.ring_first, s.ringc_B,
                        s.axis_B, s.parent_row, s.radius, f.origin, f.n, s.near, w.R, w.points, w.distance, w.normal,
                        w.sample, w.owner)
        for i in range(m):
            w.material[i] = f.region_material
    n_contact = contact_wrenches(m, w.distance, w.normal, w.material, w.sample, w.owner, io.poses, io.vels,
                                 io.joint_v, s.ringc_B, s.radial_B, s.axis_B, s.parent_row, s.screw_row, s.radius,
                                 s.lead_angle, s.hand, s.spin_dof, s.spin_mult, f.mats, s.v_eps, s.mode, s.ev_floor,
                                 s.near, w.R, w.point, w.vel, w.force, w.fn, io.wrenches, io.screw_fn)
    _finish(w, io, n_active, m, n_contact)


@njit(cache=True)
def _block_sum(a, lo, n):
    """NumPy's pairwise_sum for n <= 128: a plain loop below 8, else 8 partial sums."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def np_sum(a):
    """``a.sum()`` of a contiguous float64 vector, bit for bit: NumPy's pairwise summation (blocks of
    up to 128 summed by _block_sum, longer runs halved at a multiple of 8 and the halves added).
    NumPy recurses; numba's disk cache cannot load a self-recursive function, so the same tree is
    walked with an explicit stack (post-order: a node adds its two halves once both are summed).
    tests/contact/test_sdf_kernels.py checks it against NumPy."""
    lo_s = np.empty(128, np.int64)         # 2 frames per halving level: room for 2**63 elements
    n_s = np.empty(128, np.int64)
    done = np.empty(128, np.bool_)
    vals = np.empty(128)
    top, nv = 0, 0
    lo_s[0], n_s[0], done[0] = 0, a.size, False
    while top >= 0:
        lo, n = lo_s[top], n_s[top]
        if n <= 128:
            vals[nv] = _block_sum(a, lo, n)
            nv += 1
            top -= 1
        elif done[top]:
            vals[nv - 2] = vals[nv - 2] + vals[nv - 1]
            nv -= 1
            top -= 1
        else:
            n2 = n // 2 - (n // 2) % 8
            done[top] = True
            lo_s[top + 1], n_s[top + 1], done[top + 1] = lo + n2, n - n2, False      # right half, summed second
            lo_s[top + 2], n_s[top + 2], done[top + 2] = lo, n2, False               # left half, summed first
            top += 2
    return 0.0 + vals[0]       # the reduction starts from the identity: -0.0 sums to 0.0


# -- the component's kernels, on argument records (kernel_args.py) ----------------------------------
#   samples  Samples        the sample tables and contact parameters (built once per component)
#   work     SdfWork        this run's per-sample scratch, the counters and what the last evaluation saw
#   ports    SdfPorts       this run's input views and output buffers (or scratch outputs)
#   surface  Surface        per terrain object: the material table and, for a plane, its origin,
#                           normal and material
# work.counts: [evaluations, screws tested, samples queried, active screws, samples m of the last
# evaluation]; the generic path (Terrain.query in Python) sets the active screws and m there.

Samples = record("Samples", ("broad_phase", "sphere_r", "start", "points_B", "mount_p", "ringc_B", "radial_B",
                             "axis_B", "parent_row", "screw_row", "radius", "lead_angle", "hand", "spin_dof",
                             "spin_mult", "v_eps", "mode", "ev_floor", "ring_start", "ring_first", "cos_sep",
                             "near", "lookahead_time"))
SdfWork = record("SdfWork", ("active", "centres", "points", "distance", "normal", "material", "sample", "owner", "R",
                             "point", "vel", "force", "fn", "counts", "track", "seen_poses", "seen_vels",
                             "seen_joint_v", "ring_row", "ring_dir", "ext_points", "ext_row", "ext_distance",
                             "ext_normal", "ext_material"))
SdfPorts = record("SdfPorts", ("poses", "vels", "joint_v", "wrenches", "screw_fn", "normal_force", "contacts"))
Surface = record("Surface", ("origin", "n", "region_material", "mats"))


@njit(cache=True)
def _finish(work, ports, n_active, m, n_contact):
    c = work.counts
    c[0] += 1
    c[1] += n_active
    c[2] += m
    c[3] = n_active
    c[4] = m
    ports.contacts[0] = n_contact
    ports.normal_force[0] = np_sum(ports.screw_fn)
    if work.track:          # what this evaluation saw, so the contact set can tell whether it describes its inputs
        work.seen_poses[:] = ports.poses
        work.seen_vels[:] = ports.vels
        work.seen_joint_v[:] = ports.joint_v


@njit(cache=True)
def plane_step(samples, work, ports, surface):
    """One evaluation against a plane (plane_contact_step), outputs and counters included."""
    s, w, io, f = samples, work, ports, surface
    n_active, m, n_contact = plane_contact_step(
        s.broad_phase, f.origin, f.n, f.region_material, s.sphere_r, s.start, s.points_B, s.mount_p, w.active,
        w.centres, w.points, w.distance, w.normal, w.material, w.sample, w.owner, io.poses, io.vels, io.joint_v,
        s.ringc_B, s.radial_B, s.axis_B, s.parent_row, s.screw_row, s.radius, s.lead_angle, s.hand, s.spin_dof,
        s.spin_mult, f.mats, s.v_eps, s.mode, s.ev_floor, w.R, w.point, w.vel, w.force, w.fn, io.wrenches,
        io.screw_fn)
    _finish(w, io, n_active, m, n_contact)


@njit(cache=True)
def centres_step(samples, work, ports):
    """Broad phase, generic terrain: every screw's centre into work.centres."""
    link_fixed_points(ports.poses, samples.parent_row, samples.mount_p, work.R, work.centres)


@njit(cache=True)
def sample_step(samples, work, ports):
    """World points of the active screws' samples (work.active[:counts[3]]) into work.points;
    sets and returns m."""
    n_active = work.counts[3]
    m = 0
    if n_active:
        m = sample_points(ports.poses, work.active, n_active, samples.start, samples.points_B, samples.parent_row,
                          work.R, work.points, work.sample, work.owner)
    work.counts[4] = m
    return m


@njit(cache=True)
def ring_sample_step(samples, work, ports):
    """sample_step with exact rings: sample rows then ring-centre rows (ring_rows); sets counts[4] to all
    rows and returns it (all are queried)."""
    n_active = work.counts[3]
    m, nr = 0, 0
    if n_active:
        m, nr = ring_rows(ports.poses, work.active, n_active, samples.start, samples.points_B, samples.ring_start,
                          samples.ring_first, samples.ringc_B, samples.parent_row, work.R, work.points, work.sample,
                          work.owner, work.ring_row)
    work.counts[4] = m + nr
    work.counts[5] = m
    return m + nr


@njit(cache=True)
def ring_extremal_step(samples, work, ports):
    """After the rows' query: the rings' extremal points into work.ext_points; returns how many (also
    counts[6])."""
    m = work.counts[5]
    ne = ring_extremal(m, work.counts[4] - m, work.points, work.distance, work.normal, work.owner, ports.poses,
                       samples.axis_B, samples.parent_row, samples.radius, work.R, work.ring_dir, work.ext_points,
                       work.ext_row)
    work.counts[6] = ne
    return ne


@njit(cache=True)
def ring_finish_step(samples, work, ports):
    """After the extremal points' query (work.ext_distance, ext_normal, ext_material; counts[6] of them):
    the rings' rows."""
    w = work
    finish_extremal(w.counts[5], w.counts[6], w.ext_row, w.ext_distance, w.ext_normal, w.ext_material, w.distance, w.normal,
                    w.material, w.owner, w.ring_row, w.ring_dir, ports.poses, samples.axis_B, samples.parent_row,
                    samples.cos_sep, w.R)


@njit(cache=True)
def wrench_step(samples, work, ports, surface):
    """Forces and wrenches of the m samples queried (distance, normal, material filled in), outputs
    and counters."""
    s, w, io = samples, work, ports
    m = w.counts[4]
    n_contact = contact_wrenches(m, w.distance, w.normal, w.material, w.sample, w.owner, io.poses, io.vels,
                                 io.joint_v, s.ringc_B, s.radial_B, s.axis_B, s.parent_row, s.screw_row, s.radius,
                                 s.lead_angle, s.hand, s.spin_dof, s.spin_mult, surface.mats, s.v_eps, s.mode,
                                 s.ev_floor, s.near, w.R, w.point, w.vel, w.force, w.fn, io.wrenches, io.screw_fn)
    _finish(w, io, w.counts[3], m, n_contact)


@njit(cache=True)
def seen_step(work, ports):
    """True if the last evaluation saw exactly these inputs (bit for bit)."""
    return _same(work.seen_poses, ports.poses) and _same(work.seen_vels, ports.vels) \
        and _same(work.seen_joint_v, ports.joint_v)


@njit(cache=True)
def _same(a, b):
    x, y = a.ravel().view(np.uint64), b.ravel().view(np.uint64)
    for i in range(x.size):
        if x[i] != y[i]:
            return False
    return True


@njit(cache=True)
def jacobian_step(samples, work, ports, surface, d_twist, d_pose, on_link):
    """jacobian_kernels.contact_jacobian_blocks on the last evaluation's contacts (work), from the records
    (one bound call instead of twenty arguments typed per call). Returns the number of links marked."""
    s, w = samples, work
    return contact_jacobian_blocks(w.counts[4], w.distance, w.normal, w.material, w.owner, w.point, w.vel, ports.poses,
                                   s.axis_B, s.screw_row, s.parent_row, s.lead_angle, s.hand, surface.mats, s.v_eps,
                                   s.mode, s.ev_floor, s.near, s.lookahead_time, d_twist, d_pose, on_link)


@njit(cache=True)
def least_distance(distance, counts):
    """``distance[:counts[4]].min()`` as NumPy gives it (NaN if one is NaN), +inf over no rows: the max_depth
    watch on the last evaluation's m rows without a NumPy reduction per evaluation."""
    out = math.inf
    for i in range(counts[4]):
        x = distance[i]
        if x != x:
            return x
        if x < out:
            out = x
    return out
