"""Deskew a spinning lidar's scan: each return placed in the world from the pose its beam fired at.

A spinning unit sweeps once per period T; the driver stamps the cloud at the sweep's end t and gives each
point its firing time τ ∈ [−T, 0] relative to it (PointCloud2 field ``t``, seconds, as Velodyne's and
Ouster's drivers do), and the point is in the lidar frame of its own instant. Placing every point with the
pose at t is off by what the lidar turned in the meantime: r·Δψ at range r, 30 cm at 5 m for a head
swinging at 1 rad/s. The pose at t + τ is interpolated between the /tf of the mount link at the sweep's
start t₀ and at its end t₁ (tf2's own rule: the geodesic for the rotation, a straight line for the
origin), u = (t + τ − t₀)/(t₁ − t₀):

    R(u) = R₀ · Exp(u · Log(R₀ᵀ R₁))       p(u) = p₀ + u·(p₁ − p₀)
    x_world = R(u) · (R_ls x + p_ls) + p(u)          (R_ls, p_ls: the lidar frame on its link, /tf_static)

computed once per distinct firing time (a grid's 1024 columns), then applied to the points.
"""

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


def deskew(points: np.ndarray, tau: np.ndarray, stamp: float, before: tuple, after: tuple,
           mount: tuple) -> np.ndarray:
    """World positions [n, 3] (m) of ``points`` [n, 3] (each in the lidar frame at its firing time
    ``stamp + tau``, tau [n] in s) from the link's world poses ``before`` = (t₀, R₀, p₀) and ``after`` =
    (t₁, R₁, p₁) and the lidar's ``mount`` = (R_ls, p_ls) on that link."""
    (t0, R0, p0), (t1, R1, p1) = before, after
    times, which = np.unique(np.asarray(tau, dtype=float), return_inverse=True)
    u = np.clip((stamp + times - t0) / (t1 - t0), 0.0, 1.0)    # float32 times may step a hair outside
    rotations = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([R0, R1])))(u).as_matrix()
    origins = p0 + np.outer(u, np.asarray(p1) - p0)
    on_link = np.asarray(points, dtype=float) @ np.asarray(mount[0]).T + mount[1]
    return np.einsum("nij,nj->ni", rotations[which], on_link) + origins[which]
