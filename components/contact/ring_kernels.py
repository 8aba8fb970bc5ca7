"""numba kernels of the screw–SDF contact's exact rings (``ring_contact="extremal"``) on a generic
terrain: the rows to query (ring_rows), each ring's extremal point (ring_extremal) and the rings'
contacts from its query (finish_extremal). The plane's own version is plane_kernels.plane_rings.
"""

from __future__ import annotations

import math

from numba import njit

from ..multibody.pose_quaternions import pose_rotation
from .point_kernels import place_point, world_axis


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
            place_point(poses, b, R, ringc_B, q, out_points, k)
            out_sample[k] = q
            out_owner[k] = s
            out_ring_row[k] = k
            q_end = ring_first[g + 1] if g + 1 < ring_first.shape[0] else points_B.shape[0]
            for i in range(q, q_end):
                place_point(poses, b, R, points_B, i, out_points, row)
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
        ax, ay, az = world_axis(R, axis_B, s)
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
def finish_extremal(samples, work, ports):
    """The extremal points' queries (work.ext_distance, ext_normal, ext_material: work.counts[6] of them) into
    their ring rows; samples (the first work.counts[5] rows) in contact with the surface their ring already
    meets (ê_i within ``sep`` of ê_c) are taken out of contact (+inf). Records: screw_contact_kernels.Samples,
    SdfWork, SdfPorts."""
    m, ne, ext_row, R = work.counts[5], work.counts[6], work.ext_row, work.R
    ext_distance, ext_normal, ext_material = work.ext_distance, work.ext_normal, work.ext_material
    distance, normal, material, owner = work.distance, work.normal, work.material, work.owner
    ring_row, ring_dir, poses = work.ring_row, work.ring_dir, ports.poses
    axis_B, parent_row, cos_sep = samples.axis_B, samples.parent_row, samples.cos_sep
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
        ax, ay, az = world_axis(R, axis_B, s)
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        na = nx * ax + ny * ay + nz * az
        ux, uy, uz = na * ax - nx, na * ay - ny, na * az - nz
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        if un > 1e-9 and (ux * cx + uy * cy + uz * cz) > cos_sep * un:
            distance[i] = math.inf                      # the ring's own contact covers this surface
