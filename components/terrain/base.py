"""The terrain query interface shared by every kind.

    q = terrain.query(points)        # points (n, 3) m, world frame
    q.distance  (n,)   m   signed, > 0 outside the solid (in free space), < 0 = penetration
    q.normal    (n, 3)     unit, pointing out of the solid (towards free space)
    q.closest   (n, 3) m   closest surface point, = points - distance * normal
    q.material  (n,)       index into terrain.materials (per region; Material: snakesim.components.materials)

Analytic kinds are exact where the geometry allows (plane, walls, smooth tube,
U-channel); rough surfaces and height fields use a first-order distance
(documented per kind) whose gradient equals the returned normal on the surface.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from snakesim.components.materials import Material   # re-exported: the terrain's materials are these


@dataclasses.dataclass(frozen=True)
class TerrainQuery:
    """Result of :meth:`Terrain.query` for n points (arrays, SI units)."""

    distance: np.ndarray
    normal: np.ndarray
    closest: np.ndarray
    material: np.ndarray

    def __len__(self) -> int:
        return int(self.distance.shape[0])


@dataclasses.dataclass(frozen=True)
class Bounds:
    """Axis-aligned box (m); ±inf where the terrain is unbounded."""

    lo: np.ndarray
    hi: np.ndarray


def as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"terrain query expects points of shape (n, 3), got {np.shape(points)}")
    return p


def unit(v: np.ndarray, fallback=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Row-normalise v (n, 3); rows of zero length become ``fallback``."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    out = np.where(n > 1e-300, v / np.where(n > 1e-300, n, 1.0), np.asarray(fallback, dtype=float))
    return out


def frame_from_axis(axis) -> np.ndarray:
    """Rotation R (3x3) whose third column is ``axis`` (unit): local -> world is R @ x_local."""
    a = np.asarray(axis, dtype=float)
    n = np.linalg.norm(a) if a.shape == (3,) else 0.0
    if not (np.isfinite(n) and n > 1e-12):
        raise ValueError(f"axis = {a.tolist()}: needs a finite, non-zero 3-vector")
    a = a / n
    ref = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(ref, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return np.column_stack([e1, e2, a])


class Terrain:
    """Base class. Subclasses implement :meth:`_query` on validated (n, 3) points.

    ``materials`` lists the materials; ``regions`` names the surface regions of
    the kind (e.g. floor, walls) and ``region_material[i]`` the material index
    of region i, so ``query().material`` is ``region_material[region_of_point]``.
    """

    kind: str = "terrain"
    regions: tuple[str, ...] = ("surface",)

    def __init__(self, materials=(Material(),), region_material=None, name: str = ""):
        self.materials: tuple[Material, ...] = tuple(materials)
        if not self.materials:
            raise ValueError("a terrain needs at least one material")
        rm = np.zeros(len(self.regions), dtype=np.int64) if region_material is None else \
            np.asarray(region_material, dtype=np.int64)
        if rm.shape != (len(self.regions),) or rm.min() < 0 or rm.max() >= len(self.materials):
            raise ValueError(f"region_material must map {len(self.regions)} regions {self.regions} "
                             f"to indices < {len(self.materials)}, got {rm.tolist()}")
        self.region_material = rm
        self.name = name or self.kind

    # -- the interface --------------------------------------------------------
    def query(self, points) -> TerrainQuery:
        """Signed distance, outward normal, closest point and material of each point."""
        p = as_points(points)
        d, n, region = self._query(p)
        return TerrainQuery(distance=d, normal=n, closest=p - d[:, None] * n,
                            material=self.region_material[region])

    def distance(self, points) -> np.ndarray:
        """Signed distance only (m)."""
        return self.query(points).distance

    def bounds(self) -> Bounds:
        """Axis-aligned box containing the terrain surface (inf where unbounded)."""
        return Bounds(np.full(3, -np.inf), np.full(3, np.inf))

    def distance_lower_bound(self, centers, radii) -> np.ndarray:
        """Broad phase: per sphere, a value <= the least signed distance of any point in it.

        A sphere whose bound is > 0 cannot touch the solid and can be skipped.
        Uses the Lipschitz bound of the returned distance field: d(c) − L·r,
        with L = ``self.lipschitz`` (1 for exact distance fields; for the
        first-order kinds, rough cylinders and DEMs, an estimate from the
        largest wall slope).
        """
        c = as_points(centers)
        r = np.broadcast_to(np.asarray(radii, dtype=float), (c.shape[0],))
        return self.query(c).distance - self.lipschitz * r

    #: upper bound of |∇distance| (1 for exact distance fields)
    lipschitz: float = 1.0

    def _query(self, p: np.ndarray):
        """-> distance (n,), unit normal (n, 3), region index (n,) int."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}>"
