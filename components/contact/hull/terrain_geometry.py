"""The scene's terrain as coal geometry (built once per Terrain object).

Per kind (components/terrain):

    plane           coal.Halfspace (exact; coal's half-space {x: n·x ≤ d} is the solid)
    parallel_walls  two half-spaces (exact)
    u_channel       walls: two half-spaces |y| ≥ w/2 (exact: below the axis they lie
                    inside the solid too); floor: the half-cylinder triangulated
    tube            the wall r = r_s(θ, s) (smooth or rough) triangulated
    dem             the height grid triangulated (two triangles per cell, the
                    bilinear patch's diagonal split); no contact beyond the grid
    mesh            the imported mesh itself (SdfGrid.source), as a triangle BVH

Triangulated parts are coal BVHModelOBBRSS surfaces: coal tests a convex piece against
each nearby triangle. Unbounded surfaces (u-channel floor, tube) are meshed over
|s| ≤ ``extent`` along their axis around the terrain origin, ``segments`` around and
``resolution`` m along the axis (chord error r(1 − cos(π/segments)), 0.36 mm for a
0.3 m tube at 64). Triangles have no inside, so the component orients their contact
normals with the terrain's own query normal (Terrain.query is the source of truth for
which side is solid). Moulins are not supported yet (a shaft through a plane has no
convex part and needs a holed surface mesh).
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class TerrainPart:
    geom: object          # coal geometry
    transform: object     # coal.Transform3s (world pose of the geometry)
    triangles: bool       # a triangle BVH (normals need orienting, several contacts per piece)


SUPPORTED = ("plane", "parallel_walls", "u_channel", "tube", "dem", "mesh")


def _halfspace(normal, offset):
    import coal

    return TerrainPart(coal.Halfspace(np.asarray(normal, float), float(offset)), coal.Transform3s(), False)


def _bvh(vertices, faces):
    import coal

    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(len(faces), len(vertices))
    bvh.addVertices(np.ascontiguousarray(vertices, dtype=np.float64))
    bvh.addTriangles(np.ascontiguousarray(faces, dtype=np.int64))
    bvh.endModel()
    return TerrainPart(bvh, coal.Transform3s(), True)


def grid_triangles(nu: int, nv: int, wrap_v: bool = False) -> np.ndarray:
    """Faces (2·(nu−1)·nv', 3) of a grid of nu × nv vertices (index i·nv + j); wrap_v closes v."""
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv if wrap_v else nv - 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    jn = (j + 1) % nv
    a, b, c, d = i * nv + j, i * nv + jn, (i + 1) * nv + jn, (i + 1) * nv + j
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def _axial(extent, resolution):
    return np.linspace(-extent, extent, max(2, int(np.ceil(2 * extent / resolution)) + 1))


def terrain_parts(terrain, extent: float = 10.0, segments: int = 64, resolution: float = 0.05) -> list[TerrainPart]:
    """coal parts of ``terrain``; ValueError for a kind without a coal representation."""
    from snakesim.components.terrain import analytic, dem, mesh

    t = terrain
    if isinstance(t, analytic.PlaneTerrain):
        return [_halfspace(t.n, t.n @ t.origin)]
    if isinstance(t, analytic.ParallelWalls):
        o = t.lat @ t.origin
        return [_halfspace(-t.lat, -(o + 0.5 * t.gap)), _halfspace(t.lat, o - 0.5 * t.gap)]
    if isinstance(t, analytic.UChannel):
        o, w = t.lat @ t.origin, 0.5 * t.width
        a = np.cross(t.lat, t.up)
        phi = np.linspace(0.0, np.pi, segments // 2 + 1)                    # floor: below the axis
        s = _axial(extent, resolution)
        ring = w * (np.cos(phi)[:, None] * t.lat - np.sin(phi)[:, None] * t.up)
        verts = (t.origin + s[:, None, None] * a + ring[None]).reshape(-1, 3)
        return [_halfspace(-t.lat, -(o + w)), _halfspace(t.lat, o - w),
                _bvh(verts, grid_triangles(len(s), len(phi)))]
    if isinstance(t, analytic.FourierCylinder):
        theta = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
        s = _axial(extent, resolution)
        TH, S = np.meshgrid(theta, s, indexing="xy")          # rows: s, columns: θ
        r, _, _ = t.wall_radius(TH.ravel(), S.ravel()) if len(t.modes) or t.slope else (np.full(TH.size, t.radius), 0, 0)
        local = np.stack([r * np.cos(TH.ravel()), r * np.sin(TH.ravel()), S.ravel()], 1)
        return [_bvh(t.origin + local @ t.R.T, grid_triangles(len(s), len(theta), wrap_v=True))]
    if isinstance(t, dem.HeightField):
        ny, nx = t.z.shape
        X, Y = np.meshgrid(t.x0 + t.res * np.arange(nx), t.y0 + t.res * np.arange(ny))
        verts = np.stack([X.ravel(), Y.ravel(), t.z.ravel()], 1)
        return [_bvh(verts, grid_triangles(ny, nx))]
    if isinstance(t, mesh.SdfGrid):
        m = mesh.load_mesh(t.source)
        return [_bvh(np.asarray(m.vertices), np.asarray(m.faces))]
    raise ValueError(f"hull_contact: terrain kind '{t.kind}' ({t.name}) has no coal representation; "
                     f"supported kinds: {', '.join(SUPPORTED)} (use the SDF back end for it)")
