"""numba kernels of the screw–SDF contact step (screw_sdf.py) on a generic terrain, queried in Python
between them (Terrain.query): broad-phase centres, sample rows, exact rings, forces, and what the last
evaluation saw; all on argument records (kernel_args.py) and writing into preallocated arrays.

The kernels they build on live by job: point_kernels.py (points fixed in links), ring_kernels.py
(exact rings), screw_contact_kernels.py (the forces on samples, the records, the end of an evaluation),
plane_kernels.py (the plane's one-call fast path), ../kernel_reductions.py (np_sum, least_distance).
They are re-exported here, as is the material table's column order (materials.py).
"""

from __future__ import annotations

from numba import njit

from ..kernel_reductions import least_distance, np_sum, same_bits  # noqa: F401  (np_sum, least_distance re-exported)
from ..materials import EV_A, EV_B, MU, C, K  # noqa: F401  (re-exported)
from .jacobian_kernels import contact_jacobian_blocks
from .plane_kernels import (plane_active, plane_contact_step, plane_extremal_step, plane_query,  # noqa: F401
                            plane_rings, plane_step)
from .point_kernels import link_fixed_points, sample_points
from .ring_kernels import finish_extremal, ring_extremal, ring_rows
from .screw_contact_kernels import (Samples, SdfPorts, SdfWork, Surface,  # noqa: F401  (re-exported)
                                    contact_wrenches, finish_evaluation)


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
    finish_extremal(samples, work, ports)


@njit(cache=True)
def wrench_step(samples, work, ports, surface):
    """Forces and wrenches of the m samples queried (distance, normal, material filled in), outputs
    and counters."""
    m = work.counts[4]
    n_contact = contact_wrenches(samples, work, ports, surface.mats, samples.near, m)
    finish_evaluation(work, ports, work.counts[3], m, n_contact)


@njit(cache=True)
def seen_step(work, ports):
    """True if the last evaluation saw exactly these inputs (bit for bit)."""
    return same_bits(work.seen_poses, ports.poses) and same_bits(work.seen_vels, ports.vels) \
        and same_bits(work.seen_joint_v, ports.joint_v)


@njit(cache=True)
def jacobian_step(samples, work, ports, surface, d_twist, d_pose, on_link):
    """jacobian_kernels.contact_jacobian_blocks on the last evaluation's contacts (work), from the records
    (one bound call instead of twenty arguments typed per call). Returns the number of links marked."""
    return contact_jacobian_blocks(samples, work, ports, surface.mats, work.counts[4], d_twist, d_pose, on_link)
