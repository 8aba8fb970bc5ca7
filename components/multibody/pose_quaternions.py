"""Rotation matrices of the link poses' unit quaternions [qx, qy, qz, qw] (the LINK_POSES port's layout,
components/port_roles.py; Pinocchio's and ROS's order): the one place the formula is written.

    R = [[1 - 2(y² + z²),  2(xy - zw),      2(xz + yw)    ],
         [2(xy + zw),      1 - 2(x² + z²),  2(yz - xw)    ],
         [2(xz - yw),      2(yz + xw),      1 - 2(x² + y²)]]

:func:`quaternion_matrix` writes it for one quaternion, inlined into the numba kernels that call it
(the multibody's root pose; :func:`pose_rotation` reads a link-poses row); :func:`rotation_matrices`
is the same for an array of quaternions, from Python.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def quaternion_matrix(x, y, z, w, R):
    """Write the rotation matrix of the unit quaternion [x, y, z, w] into R (3, 3)."""
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - z * w)
    R[0, 2] = 2 * (x * z + y * w)
    R[1, 0] = 2 * (x * y + z * w)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - x * w)
    R[2, 0] = 2 * (x * z - y * w)
    R[2, 1] = 2 * (y * z + x * w)
    R[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True, inline="always")
def pose_rotation(poses, row, R):
    """Write the rotation of link-poses row ``row`` ([x, y, z, qx, qy, qz, qw]) into R (3, 3)."""
    quaternion_matrix(poses[row, 3], poses[row, 4], poses[row, 5], poses[row, 6], R)


@njit(cache=True)
def _rotations(q, out):
    for i in range(q.shape[0]):
        quaternion_matrix(q[i, 0], q[i, 1], q[i, 2], q[i, 3], out[i])


def rotation_matrices(q) -> np.ndarray:
    """(..., 4) quaternions [x, y, z, w] -> (..., 3, 3) rotation matrices (unit quaternions assumed)."""
    q = np.asarray(q, dtype=float)
    flat = np.ascontiguousarray(q.reshape(-1, 4))
    out = np.empty((flat.shape[0], 3, 3))
    _rotations(flat, out)
    return out.reshape(q.shape[:-1] + (3, 3))
