"""How well the imported mesh represents the scan: distances, coverage and holes.

    rms, max         m, distance from each input point (after cleaning) to the mesh: Open3D's
                     RaycastingScene.compute_distance, exact point–triangle distance (float32, hence
                     coordinates near the origin: frames.py removes a georeferenced offset first)
    points covered   fraction of input points within ``tolerance`` of the mesh (what the mesh misses:
                     trimmed holes, cropped ends)
    mesh covered     fraction of the mesh's area within ``tolerance`` of an input point (what the mesh
                     invents: a surface bridging a hole, a cap), from MESH_SAMPLES area-uniform samples
                     of the mesh (seeded) against a k-d tree of the points
    holes            holes.py's boundary loops

``tolerance`` defaults to two mean point spacings: a mesh sample on a well-covered surface is within
~0.7 spacings of a point, one over an unscanned hole is not.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .holes import Hole
from .open3d_loader import import_open3d

MESH_SAMPLES = 50_000


@dataclasses.dataclass(frozen=True)
class ImportReport:
    points: int
    spacing: float
    vertices: int
    faces: int
    rms: float
    max: float
    tolerance: float
    points_covered: float
    mesh_covered: float
    holes: tuple[Hole, ...]
    notes: tuple[str, ...] = ()

    @property
    def interior_holes(self) -> tuple[Hole, ...]:
        return tuple(h for h in self.holes if not h.rim)

    def summary_lines(self, max_holes: int = 10) -> list[str]:
        """The report as aligned text lines (what the CLI prints and the terrain file's comment holds)."""
        rims = [h for h in self.holes if h.rim]
        lines = [f"points            {self.points} (mean spacing {self.spacing * 1e3:.3g} mm)",
                 f"mesh              {self.vertices} vertices, {self.faces} faces",
                 f"distance          rms {self.rms * 1e3:.3g} mm, max {self.max * 1e3:.3g} mm (points to mesh)",
                 f"coverage          {self.points_covered:.1%} of points and {self.mesh_covered:.1%} of the mesh "
                 f"within {self.tolerance * 1e3:.3g} mm",
                 f"holes             {len(self.interior_holes)} interior, {len(rims)} outer rim(s)"]
        if self.holes:
            lines.append(f"  {'kind':<5} {'perimeter m':>11} {'area m²':>9} {'centre x, y, z m':>26}")
            for h in self.holes[:max_holes]:
                c = ", ".join(f"{x:.3f}" for x in h.centre)
                lines.append(f"  {h.kind:<5} {h.perimeter:>11.3f} {h.area:>9.4f} {c:>26}")
            if len(self.holes) > max_holes:
                lines.append(f"  ... {len(self.holes) - max_holes} more (smallest)")
        return lines


def mesh_distances(v: np.ndarray, f: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Unsigned distance from each point to the mesh, m."""
    o3d = import_open3d()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
    return scene.compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy().astype(np.float64)


def mesh_coverage(v: np.ndarray, f: np.ndarray, points: np.ndarray, tolerance: float, seed: int = 0) -> float:
    """Fraction of the mesh's area within ``tolerance`` of a point (area-uniform samples)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    pick = rng.choice(len(f), size=MESH_SAMPLES, p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(MESH_SAMPLES)), rng.random(MESH_SAMPLES)
    t = tri[pick]
    samples = (1 - r1)[:, None] * t[:, 0] + (r1 * (1 - r2))[:, None] * t[:, 1] + (r1 * r2)[:, None] * t[:, 2]
    d, _ = cKDTree(points).query(samples, distance_upper_bound=tolerance * 1.0001)
    return float(np.mean(d <= tolerance))


def make_report(v, f, points, spacing, holes, tolerance=None, notes=()) -> ImportReport:
    tol = 2 * spacing if tolerance is None else float(tolerance)
    d = mesh_distances(v, f, points)
    return ImportReport(len(points), spacing, len(v), len(f), float(np.sqrt(np.mean(d ** 2))), float(d.max()),
                        tol, float(np.mean(d <= tol)), mesh_coverage(v, f, points, tol), tuple(holes), tuple(notes))
