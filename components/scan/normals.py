"""Normals of a cloud, estimated and oriented to point into the void (towards free space).

Estimation: Open3D's PCA of each point's ``k`` nearest neighbours (the plane fit's smallest axis). A PCA
normal has no sign; the sign is chosen, in this order of preference:

1. **Scanner positions known** (per point): each normal points towards the position it was seen from,
   n · (s − p) > 0. A line of sight crosses free space, so this is exact for every point a scanner saw.
2. **The file's own normals** (PLY/PCD/XYZ with nx ny nz): each estimated normal takes their sign.
3. **Neither**: Open3D's ``orient_normals_consistent_tangent_plane`` (Hoppe et al. 1992: signs
   propagated along a minimum spanning tree of the k-nearest-neighbour graph) makes the signs agree
   with each other; the whole set is then flipped if most normals point away from the cloud's
   principal axis. That is the **void-axis rule**: a shaft, moulin or tunnel scanned from inside is
   long along its principal axis, the axis runs through the void, and the wall's free side faces it.
   The rule is wrong for a scan of a convex object from outside (a boulder): give scanner positions
   or normals for those.
"""

from __future__ import annotations

import numpy as np

from .cleaning import point_cloud
from .open3d_loader import import_open3d

NEIGHBOURS = 20


def principal_axis(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centroid, unit direction) of the cloud's largest principal axis."""
    c = points.mean(axis=0)
    sample = points[:: max(1, len(points) // 20000)] - c
    return c, np.linalg.svd(sample, full_matrices=False)[2][0]


def toward_axis(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """n · (foot of the principal axis − p) per point: > 0 where a normal faces the axis."""
    c, u = principal_axis(points)
    rel = points - c
    to_axis = np.outer(rel @ u, u) - rel
    return np.einsum("ij,ij->i", normals, to_axis)


def estimate_normals(points: np.ndarray, scanner: np.ndarray | None = None, hint: np.ndarray | None = None,
                     k: int = NEIGHBOURS) -> tuple[np.ndarray, str]:
    """(unit normals (n, 3) pointing into the void, the rule used: 'scanner', 'file normals' or 'void axis')."""
    cloud = point_cloud(points)
    cloud.estimate_normals(import_open3d().geometry.KDTreeSearchParamKNN(int(k)))
    if scanner is None and hint is None:
        cloud.orient_normals_consistent_tangent_plane(int(k))
    n = np.asarray(cloud.normals, dtype=np.float64).copy()
    if scanner is not None:
        flip, rule = np.einsum("ij,ij->i", n, scanner - points) < 0, "scanner"
    elif hint is not None:
        flip, rule = np.einsum("ij,ij->i", n, hint) < 0, "file normals"
    else:
        flip, rule = np.full(len(n), np.sum(np.sign(toward_axis(points, n))) < 0), "void axis"
    n[flip] *= -1
    return n, rule
