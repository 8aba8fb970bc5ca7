"""Holes a reconstruction left: the mesh's boundary loops, measured and told apart.

A boundary edge is used by one face only; boundary edges that share vertices form a loop (connected
components of the boundary-edge graph; two loops touching at a vertex count as one). Each loop is
reported with

    perimeter   m, the sum of its edge lengths
    centre      m, the length-weighted mean of its edge midpoints
    area        m², the norm of its vector area ½ Σ (a − c) × (b − c) over its edges a → b, taken in the
                winding of their faces: exact for a planar loop, the area of the projection on the
                best plane for a curved one (a hole in a shaft's wall, the section of its mouth)

A loop is an **outer rim** (where the scan ends: a shaft's mouth and bottom, the edge of a patch) when it
reaches within ``band`` of either end of the scan's extent along the points' principal axis; every
other loop is an **interior hole** (occlusion shadows, dropouts) inside the scanned length.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .normals import principal_axis


@dataclasses.dataclass(frozen=True)
class Hole:
    perimeter: float
    centre: tuple[float, float, float]
    area: float
    edges: int
    rim: bool

    @property
    def kind(self) -> str:
        return "rim" if self.rim else "hole"


def boundary_edges(f: np.ndarray) -> np.ndarray:
    """Directed edges (k, 2) used by one face only, in their face's winding."""
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[count[inv.reshape(-1)] == 1]


def find_holes(v: np.ndarray, f: np.ndarray, points: np.ndarray, band: float) -> list[Hole]:
    """Boundary loops of the mesh (v, f), largest perimeter first; rims by the points' extent (docstring)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e = boundary_edges(f)
    if len(e) == 0:
        return []
    graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(v), len(v)))
    _, label = connected_components(graph, directed=False)
    loop = np.unique(label[e[:, 0]], return_inverse=True)[1].reshape(-1)
    n = loop.max() + 1
    a, b = v[e[:, 0]], v[e[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    perimeter = np.bincount(loop, length, n)
    centre = np.stack([np.bincount(loop, length * (a[:, k] + b[:, k]) / 2, n) for k in range(3)], axis=1)
    centre /= perimeter[:, None]
    cross = np.cross(a - centre[loop], b - centre[loop])
    area = 0.5 * np.linalg.norm(np.stack([np.bincount(loop, cross[:, k], n) for k in range(3)], axis=1), axis=1)
    c0, u = principal_axis(points)
    t_pts = (points - c0) @ u
    t = (a - c0) @ u
    t_lo, t_hi = np.full(n, np.inf), np.full(n, -np.inf)
    np.minimum.at(t_lo, loop, t)
    np.maximum.at(t_hi, loop, t)
    rim = (t_lo <= t_pts.min() + band) | (t_hi >= t_pts.max() - band)
    edges = np.bincount(loop, minlength=n)
    holes = [Hole(float(perimeter[i]), tuple(float(x) for x in centre[i]), float(area[i]), int(edges[i]),
                  bool(rim[i])) for i in range(n)]
    return sorted(holes, key=lambda h: -h.perimeter)
