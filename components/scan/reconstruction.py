"""Surface reconstruction: registered reconstructors, each points + void-facing normals → triangles, then
the same trimming for all.

    poisson        Screened Poisson (Kazhdan & Hoppe 2013, Open3D's ``create_from_point_cloud_poisson``):
                   an indicator function whose gradient fits the normals, its level set the surface.
                   ``depth``: octree depth (cells of extent·1.1/2^depth; default: cells ≈ 2 point
                   spacings). It closes every hole and caps open ends with invented surface; those
                   vertices have a low sample density, and the ``trim_quantile`` lowest are removed.
    ball_pivoting  Bernardini et al. 1999 (Open3D's ``create_from_point_cloud_ball_pivoting``): balls of
                   radii BALL_RADII point spacings roll over the points; surface only where points are,
                   holes wherever a ball falls through (more of them than Poisson leaves on noisy scans).

Trimming after either (both leave surface far from any point: Poisson over holes and beyond the ends,
ball pivoting rarely): faces whose centre is more than ``max_gap`` (default GAP_SPACINGS spacings) from
the nearest point, faces outside the points' bounding box grown by ``margin`` (default 2 spacings), and
connected pieces under MIN_PIECE of the area (islands the trimming leaves). Faces are then wound so
their normals agree with the points' (into the void), by majority.

Poisson runs on one thread: Open3D's multi-threaded Poisson segfaults at random under load
(isl-org/Open3D#6828, #7229; seen here at depth 7 on a 2-core machine), and one thread is as fast at
these sizes. A reconstructor is registered with :func:`register` (name → function(points, normals,
settings) → (vertices, faces, notes)).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from .cleaning import point_cloud
from .open3d_loader import import_open3d

#: the trimming gap in mean spacings: a random (Poisson-disc-free) cloud has empty circles of ~4 spacings
#: often enough that 4 cut spurious ~0.1 m holes into the test shaft; 5 did not, and still opens a 0.3 m hole
GAP_SPACINGS = 5.0
MIN_PIECE = 0.01
#: ball radii in mean spacings: the mean nearest-neighbour distance of a random cloud is about half its
#: typical gap; at 1.5, 3, 6 balls fell through ~600 gaps of the noisy test shaft (15k points), at 4, 8 only 12
BALL_RADII = (4.0, 8.0)


@dataclasses.dataclass(frozen=True)
class ReconstructionSettings:
    """spacing: mean point spacing, m; depth: Poisson octree depth (None: from the spacing);
    trim_quantile: Poisson vertices of the lowest density removed (0..1); max_gap, margin: m (None: from
    the spacing)."""

    spacing: float
    depth: int | None = None
    trim_quantile: float = 0.02
    max_gap: float | None = None
    margin: float | None = None


RECONSTRUCTORS: dict[str, Callable] = {}


def register(name: str):
    """Decorator: add a reconstructor under ``name``."""
    def add(fn):
        RECONSTRUCTORS[name] = fn
        return fn
    return add


def poisson_depth(points: np.ndarray, spacing: float) -> int:
    """Octree depth whose cells are about two point spacings (5..10)."""
    extent = float(np.ptp(points, axis=0).max()) * 1.1
    return int(np.clip(round(math.log2(max(extent / (2 * spacing), 1.0))), 5, 10))


@register("poisson")
def _poisson(points, normals, s: ReconstructionSettings):
    o3d = import_open3d()
    depth = s.depth or poisson_depth(points, s.spacing)
    mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
        point_cloud(points, normals), depth=int(depth), n_threads=1)
    density = np.asarray(density)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    notes = [f"poisson depth {depth}"]
    if s.trim_quantile > 0:
        low = density < np.quantile(density, s.trim_quantile)
        f = f[~low[f].any(axis=1)]
        notes.append(f"density trim at the {s.trim_quantile:g} quantile")
    return v, f, notes


@register("ball_pivoting")
def _ball_pivoting(points, normals, s: ReconstructionSettings):
    o3d = import_open3d()
    radii = [k * s.spacing for k in BALL_RADII]
    mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(
        point_cloud(points, normals), o3d.utility.DoubleVector(radii))
    return (np.asarray(mesh.vertices), np.asarray(mesh.triangles),
            [f"ball radii {', '.join(f'{r * 1e3:.3g}' for r in radii)} mm"])


def reconstruct(name: str, points: np.ndarray, normals: np.ndarray, s: ReconstructionSettings):
    """(vertices (n, 3), faces (m, 3), notes) of reconstructor ``name``, trimmed and wound into the void;
    a ValueError naming the registered reconstructors for an unknown name."""
    if name not in RECONSTRUCTORS:
        raise ValueError(f"reconstruction '{name}' is not registered; valid: {', '.join(RECONSTRUCTORS)}")
    v, f, notes = RECONSTRUCTORS[name](points, normals, s)
    v, f = np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64).reshape(-1, 3)
    if len(f):
        v, f = trim(v, f, points, normals, s)
    return v, f, notes


def trim(v, f, points, normals, s: ReconstructionSettings):
    """Faces far from the points, outside their box, in small pieces removed; winding into the void."""
    from scipy.spatial import cKDTree

    gap = s.max_gap if s.max_gap is not None else GAP_SPACINGS * s.spacing
    margin = s.margin if s.margin is not None else 2 * s.spacing
    centre = v[f].mean(axis=1)
    dist, nearest = cKDTree(points).query(centre)
    lo, hi = points.min(axis=0) - margin, points.max(axis=0) + margin
    inside = ((v[f] >= lo) & (v[f] <= hi)).all(axis=(1, 2))
    keep = inside & (dist <= gap if gap > 0 else True)
    f, nearest = f[keep], nearest[keep]
    f, nearest = _drop_small_pieces(v, f, nearest)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    if np.sum(np.sign(np.einsum("ij,ij->i", face_n, normals[nearest]))) < 0:
        f = f[:, ::-1]
    return compact(v, f)


def _drop_small_pieces(v, f, nearest):
    if len(f) == 0:
        return f, nearest
    o3d = import_open3d()
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f.astype(np.int32)))
    piece, _, area = mesh.cluster_connected_triangles()
    piece, area = np.asarray(piece), np.asarray(area)
    keep = area[piece] >= MIN_PIECE * area.sum()
    return f[keep], nearest[keep]


def compact(v: np.ndarray, f: np.ndarray):
    """(vertices, faces) with the vertices no face uses removed."""
    used = np.unique(f)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return v[used], remap[f]
