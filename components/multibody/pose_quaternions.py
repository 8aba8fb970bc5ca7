"""Rotation matrices of the link poses' unit quaternions [qx, qy, qz, qw] (the LINK_POSES port's layout,
components/port_roles.py; Pinocchio's and ROS's order)."""

from __future__ import annotations

import numpy as np


def rotation_matrices(q) -> np.ndarray:
    """(..., 4) quaternions [x, y, z, w] -> (..., 3, 3) rotation matrices (unit quaternions assumed)."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)
