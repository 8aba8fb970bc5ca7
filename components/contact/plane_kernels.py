"""numba kernels of the screw–SDF contact against a plane, its fast path: the plane's query and broad
phase without allocation (plane_query, plane_active, also the body contact's), and one call per
evaluation (plane_contact_step, plane_rings with exact rings), on argument records (plane_step,
plane_extremal_step).
"""

from __future__ import annotations

import math

from numba import njit

from ..multibody.pose_quaternions import pose_rotation
from .point_kernels import link_fixed_points, place_point, sample_points, world_axis
from .screw_contact_kernels import contact_wrenches, finish_evaluation


@njit(cache=True)
def plane_query(m, points, origin, n, out_distance, out_normal, out_material):
    """PlaneTerrain.query without allocation: φ = (p − o)·n̂, normal n̂, material region 0 (row given)."""
    for i in range(m):
        out_distance[i] = (points[i, 0] - origin[0]) * n[0] + (points[i, 1] - origin[1]) * n[1] \
            + (points[i, 2] - origin[2]) * n[2]
        out_normal[i, 0], out_normal[i, 1], out_normal[i, 2] = n[0], n[1], n[2]
        out_material[i] = 0


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
def plane_broad_phase(broad_phase, poses, owner_link, centre_B, radii, origin, n, R, centres, active):
    """The owners (screws, body pieces) whose bounding sphere (centre_B fixed in link owner_link, radius
    radii) reaches the plane, into active; every owner without ``broad_phase``. Returns how many."""
    if broad_phase:
        link_fixed_points(poses, owner_link, centre_B, R, centres)
        return plane_active(centres, radii, origin, n, active)
    for k in range(owner_link.shape[0]):
        active[k] = k
    return owner_link.shape[0]


@njit(cache=True)
def plane_contact_step(samples, work, ports, surface):
    """One contact evaluation against a plane in one call (the screw_sdf hot path, one dispatch), on the
    records (screw_contact_kernels: Samples, SdfWork, SdfPorts, Surface): broad phase (link_fixed_points +
    plane_active, or every screw), sample_points, plane_query and contact_wrenches, exactly as the component
    calls them one by one for other terrains. Returns (screws tested, samples queried m, samples in contact)."""
    origin, n, region_material, mats = surface.origin, surface.n, surface.region_material, surface.mats
    active, centres, points, R = work.active, work.centres, work.points, work.R
    distance, normal, material, sample, owner = work.distance, work.normal, work.material, work.sample, work.owner
    poses, start, points_B, parent_row = ports.poses, samples.start, samples.points_B, samples.parent_row
    n_active = plane_broad_phase(samples.broad_phase, poses, parent_row, samples.mount_p, samples.sphere_r, origin, n,
                                 R, centres, active)
    m = 0
    if n_active:
        m = sample_points(poses, active, n_active, start, points_B, parent_row, R, points, sample, owner)
        plane_query(m, points, origin, n, distance, normal, material)
        for i in range(m):
            material[i] = region_material
    n_contact = contact_wrenches(samples, work, ports, mats, 0.0, m)
    return n_active, m, n_contact


@njit(cache=True)
def plane_rings(samples, work, ports, surface, n_active):
    """Exact rings of the first n_active screws of work.active against the plane ``surface``, into work's
    rows (points, distance, normal, sample, owner), without querying the samples: a plane's normal is the same
    everywhere, so every sample of a ring meets the surface its extremal point does (finish_extremal
    would drop them all) unless n̂ ∥ â, where the ring's samples act. Rows: the extremal point of each
    ring that reaches the plane (φ(c) < r: depth r |n̂ − (n̂·â)â| − φ(c)), or the samples of a ring
    whose axis is along n̂; a ring whose extremal point is within ``near`` above the plane is a row too
    (not touching: the Jacobian's look-ahead). Returns the number of rows."""
    poses, active, R, origin, n, near = ports.poses, work.active, work.R, surface.origin, surface.n, samples.near
    start, points_B, ring_start, ring_first = samples.start, samples.points_B, samples.ring_start, samples.ring_first
    ringc_B, axis_B, parent_row, radius = samples.ringc_B, samples.axis_B, samples.parent_row, samples.radius
    out_points, out_distance, out_normal = work.points, work.distance, work.normal
    out_sample, out_owner = work.sample, work.owner
    k = 0
    for a in range(n_active):
        s = active[a]
        b = parent_row[s]
        pose_rotation(poses, b, R)
        ax, ay, az = world_axis(R, axis_B, s)
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
                    place_point(poses, b, R, points_B, i, out_points, k)
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
    n_active = plane_broad_phase(s.broad_phase, io.poses, s.parent_row, s.mount_p, s.sphere_r, f.origin, f.n, w.R,
                                 w.centres, w.active)
    m = 0
    if n_active:
        m = plane_rings(s, w, io, f, n_active)
        material = w.material
        for i in range(m):
            material[i] = f.region_material
    n_contact = contact_wrenches(s, w, io, f.mats, s.near, m)
    finish_evaluation(w, io, n_active, m, n_contact)


@njit(cache=True)
def plane_step(samples, work, ports, surface):
    """One evaluation against a plane (plane_contact_step), outputs and counters included."""
    n_active, m, n_contact = plane_contact_step(samples, work, ports, surface)
    finish_evaluation(work, ports, n_active, m, n_contact)
