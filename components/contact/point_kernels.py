"""numba kernels placing points and directions fixed in links: o_l + R_l p_B for a point per link
(link_fixed_points: screw centres, body pieces' bounding spheres) and for the samples of the active
screws or pieces (sample_points); R_l a_B for an axis (world_axis: a screw's, a body piece's skin axis).
Shared by the screw (sdf_kernels.py) and body (body_kernels.py) contact steps and their Jacobians.

Frames: link_poses rows are [x, y, z, qx, qy, qz, qw] (world); points in the link frame B.
"""

from __future__ import annotations

from numba import njit

from ..multibody.pose_quaternions import pose_rotation


@njit(cache=True)
def place_point(poses, b, R, p_B, i, out, row):
    """out[row] = o_b + R p_B[i]: point i of a link-frame table on link b (R its rotation, from
    pose_rotation), in world coordinates."""
    for j in range(3):
        out[row, j] = poses[b, j] + R[j, 0] * p_B[i, 0] + R[j, 1] * p_B[i, 1] + R[j, 2] * p_B[i, 2]


@njit(cache=True)
def link_fixed_points(poses, link_row, p_B, R, out):
    """World position of points fixed in links: o_l + R_l p_B for point k on link link_row[k]
    (a screw's centre, a body piece's bounding-sphere centre). R is (3,3) scratch."""
    for k in range(link_row.shape[0]):
        b = link_row[k]
        pose_rotation(poses, b, R)
        place_point(poses, b, R, p_B, k, out, k)


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
            place_point(poses, b, R, points_B, i, out_points, m)
            out_sample[m] = i
            out_owner[m] = s
            m += 1
    return m


@njit(cache=True)
def world_axis(R, axis_B, s):
    """R axis_B[s] as three floats: row s of a table of link-frame directions, in world axes (R the
    link's rotation, from pose_rotation)."""
    return (R[0, 0] * axis_B[s, 0] + R[0, 1] * axis_B[s, 1] + R[0, 2] * axis_B[s, 2],
            R[1, 0] * axis_B[s, 0] + R[1, 1] * axis_B[s, 1] + R[1, 2] * axis_B[s, 2],
            R[2, 0] * axis_B[s, 0] + R[2, 1] * axis_B[s, 1] + R[2, 2] * axis_B[s, 2])
