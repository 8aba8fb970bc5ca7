"""Cleaning a cloud before reconstruction: statistical outliers, voxel downsampling, spacing and the
density check.

Statistical outlier removal (Open3D's ``remove_statistical_outlier``, PCL's filter): a point whose mean
distance to its ``k`` nearest neighbours is more than ``std`` standard deviations above the cloud's
mean is dropped: the isolated returns of dust, rope and spray.

Voxel downsampling keeps one point per cube of edge ``voxel`` (m): the mean of its points, and the mean
of every per-point attribute (scanner positions, normals) with it. Open3D's ``voxel_down_sample``
averages only its own fields, so the binning is done here (np.unique on the voxel index, then
per-voxel sums by np.add.at): the same means, any attribute.

Spacing: the mean distance from a point to its nearest neighbour (m), what the reconstructions scale
with (ball radii, Poisson depth, the trimming gap).
"""

from __future__ import annotations

import numpy as np

from .errors import ScanError
from .open3d_loader import import_open3d

#: points across the scan's second-largest extent a reconstruction needs at least (so a shaft's
#: section is resolved by ~60 points around its circumference)
MIN_POINTS_ACROSS = 20
MIN_POINTS = 100


def point_cloud(points: np.ndarray, normals: np.ndarray | None = None):
    """An Open3D PointCloud of ``points`` (and ``normals``)."""
    o3d = import_open3d()
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(points, dtype=np.float64)))
    if normals is not None:
        cloud.normals = o3d.utility.Vector3dVector(np.ascontiguousarray(normals, dtype=np.float64))
    return cloud


def outlier_mask(points: np.ndarray, k: int, std: float) -> np.ndarray:
    """True for the points statistical outlier removal keeps (module docstring)."""
    if len(points) <= k:
        return np.ones(len(points), dtype=bool)
    _, kept = point_cloud(points).remove_statistical_outlier(nb_neighbors=int(k), std_ratio=float(std))
    mask = np.zeros(len(points), dtype=bool)
    mask[np.asarray(kept, dtype=np.int64)] = True
    return mask


def voxel_downsample(points: np.ndarray, voxel: float, *attributes):
    """(points, *attributes) averaged per voxel of edge ``voxel`` m; an attribute None stays None."""
    cell = np.floor((points - points.min(axis=0)) / voxel).astype(np.int64)
    _, group, count = np.unique(cell, axis=0, return_inverse=True, return_counts=True)
    group = group.reshape(-1)

    def mean(a):
        if a is None:
            return None
        s = np.zeros((len(count), a.shape[1]))
        np.add.at(s, group, a)
        return s / count[:, None]

    return (mean(points),) + tuple(mean(a) for a in attributes)


def mean_spacing(points: np.ndarray) -> float:
    """Mean nearest-neighbour distance, m."""
    d = np.asarray(point_cloud(points).compute_nearest_neighbor_distance())
    return float(d.mean())


def check_density(path, points: np.ndarray, spacing: float) -> None:
    """A ScanError when the cloud is too sparse to reconstruct: fewer than MIN_POINTS points, or a mean
    spacing above 1/MIN_POINTS_ACROSS of its second-largest extent (principal axes)."""
    if len(points) < MIN_POINTS:
        raise ScanError(path, f"only {len(points)} points after cleaning: too sparse to reconstruct a surface "
                              f"(needs at least {MIN_POINTS})")
    centred = points - points.mean(axis=0)
    axes = np.linalg.svd(centred[:: max(1, len(points) // 20000)], full_matrices=False)[2]
    proj = centred @ axes.T
    extent = np.sort(proj.max(axis=0) - proj.min(axis=0))[::-1]
    need = extent[1] / MIN_POINTS_ACROSS
    if spacing > need:
        raise ScanError(path, f"the cloud is too sparse to reconstruct: mean point spacing {spacing * 1e3:.3g} mm "
                              f"(about {1 / spacing ** 2:.3g} points/m²) over a scan {extent[1]:.3g} m across; "
                              f"the reconstruction needs a spacing of at most {need * 1e3:.3g} mm (about "
                              f"{1 / need ** 2:.3g} points/m², {MIN_POINTS_ACROSS} points across): scan denser "
                              f"or use a smaller --voxel")
