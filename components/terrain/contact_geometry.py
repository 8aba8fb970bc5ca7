"""Each built-in kind's geometry for the hull contact back end (``Terrain.contact_parts``).

    plane           one half-space (exact)
    parallel_walls  two half-spaces (exact)
    u_channel       walls: two half-spaces |y| ≥ w/2 (exact: below the axis they lie
                    inside the solid too); floor: the half-cylinder triangulated
    tube            the wall r = r_s(θ, s) (smooth or rough) triangulated
    dem             the height grid triangulated (two triangles per cell, the
                    bilinear patch's diagonal split); no contact beyond the grid
    mesh            the imported mesh itself (SdfGrid.source)
    moulin, obstacles  none yet (NotImplementedError: a shaft through a plane has no convex
                    part and needs a holed surface mesh)
    any other kind  the triangles of its display mesh (Terrain.contact_parts)

Unbounded surfaces (u-channel floor, tube) are meshed over |s| ≤ ``extent`` along their axis
around the terrain origin, ``segments`` around and ``resolution`` m along the axis (chord
error r(1 − cos(π/segments)), 0.36 mm for a 0.3 m tube at 64). components/contact/hull
turns these records into coal geometry.
"""

from __future__ import annotations

import numpy as np

from .base import HalfSpace, Triangles


def grid_triangles(nu: int, nv: int, wrap_v: bool = False) -> np.ndarray:
    """Faces (2·(nu−1)·nv', 3) of a grid of nu × nv vertices (index i·nv + j); wrap_v closes v."""
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv if wrap_v else nv - 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    jn = (j + 1) % nv
    a, b, c, d = i * nv + j, i * nv + jn, (i + 1) * nv + jn, (i + 1) * nv + j
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def _axial(extent, resolution):
    return np.linspace(-extent, extent, max(2, int(np.ceil(2 * extent / resolution)) + 1))


def plane_parts(t) -> list:
    return [HalfSpace(np.asarray(t.n, float), float(t.n @ t.origin))]


def walls_parts(t) -> list:
    o = t.lat @ t.origin
    return [HalfSpace(np.asarray(-t.lat, float), float(-(o + 0.5 * t.gap))),
            HalfSpace(np.asarray(t.lat, float), float(o - 0.5 * t.gap))]


def u_channel_parts(t, extent, segments, resolution) -> list:
    o, w = t.lat @ t.origin, 0.5 * t.width
    a = np.cross(t.lat, t.up)
    phi = np.linspace(0.0, np.pi, segments // 2 + 1)                    # floor: below the axis
    s = _axial(extent, resolution)
    ring = w * (np.cos(phi)[:, None] * t.lat - np.sin(phi)[:, None] * t.up)
    verts = (t.origin + s[:, None, None] * a + ring[None]).reshape(-1, 3)
    return [HalfSpace(np.asarray(-t.lat, float), float(-(o + w))), HalfSpace(np.asarray(t.lat, float), float(o - w)),
            Triangles(verts, grid_triangles(len(s), len(phi)))]


def cylinder_parts(t, extent, segments, resolution) -> list:
    theta = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    s = _axial(extent, resolution)
    TH, S = np.meshgrid(theta, s, indexing="xy")          # rows: s, columns: θ
    r, _, _ = t.wall_radius(TH.ravel(), S.ravel()) if len(t.modes) or t.slope else (np.full(TH.size, t.radius), 0, 0)
    local = np.stack([r * np.cos(TH.ravel()), r * np.sin(TH.ravel()), S.ravel()], 1)
    return [Triangles(t.origin + local @ t.R.T, grid_triangles(len(s), len(theta), wrap_v=True))]


def height_field_parts(t) -> list:
    ny, nx = t.z.shape
    X, Y = np.meshgrid(t.x0 + t.res * np.arange(nx), t.y0 + t.res * np.arange(ny))
    verts = np.stack([X.ravel(), Y.ravel(), t.z.ravel()], 1)
    return [Triangles(verts, grid_triangles(ny, nx))]


def mesh_file_parts(t) -> list:
    from .mesh import load_mesh

    m = load_mesh(t.source)
    return [Triangles(np.asarray(m.vertices), np.asarray(m.faces))]
