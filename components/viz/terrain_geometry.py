"""A terrain as a triangle mesh for display, from the parameters of its kind.

Every kind the terrain library has, drawn from the same numbers the contact
model queries (so what you see is the surface the robot touches):

    plane           a square of 2·extent around the centre, in the plane
    dem             the height grid itself (every sample, or every k-th above 256 per side)
    parallel_walls  the two walls, 2·extent long, ±extent/2 high about the origin
    u_channel       the U cross-section (walls up to max(width, 0.5 m) above the axis,
                    half-round floor) swept 2·extent along the channel
    tube            the wall r_s(θ, s), roughness included, 2·extent long around the centre
    moulin          the shaft wall r_s(θ, s) from the surface down 2·extent, and the
                    surface square with the shaft's mouth cut out
    mesh (SdfGrid)  the imported mesh file the grid was computed from; without one,
                    the zero level set of the grid as voxel faces

Unbounded kinds are cut to ``extent`` (m) around ``center`` (the robot's
start). Surfaces are a checkerboard of ``cell``-sized quads so motion reads
in the viewer. Enclosing kinds (tube, moulin shaft, walls) are cut away on
the side facing ``cutaway`` (a direction from the terrain's axis towards the
viewer; None keeps everything), so the robot inside stays visible.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from snakesim.components.terrain import (FourierCylinder, HeightField, Moulin, ParallelWalls, PlaneTerrain,
                                         SdfGrid, Terrain, UChannel)

ICE = np.array([[214, 232, 244], [186, 212, 232]], dtype=np.uint8)   # checker tones, RGB
DEM_LOW, DEM_HIGH = np.array([120, 160, 200.0]), np.array([240, 248, 255.0])
MAX_DEM_SIDE = 256
_Z = np.array([0.0, 0.0, 1.0])


@dataclasses.dataclass(frozen=True)
class TerrainMesh:
    """vertices (n, 3) m, faces (m, 3), normals (n, 3), colors (n, 4) uint8; world frame."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    colors: np.ndarray


def terrain_mesh(terrain: Terrain, center=(0.0, 0.0, 0.0), extent: float = 4.0, cell: float = 0.25,
                 cutaway=(0.0, -0.6, 0.8)) -> TerrainMesh:
    """Display mesh of ``terrain``; see the module docstring for each kind."""
    c = np.asarray(center, dtype=float)
    cut = None if cutaway is None else np.asarray(cutaway, dtype=float) / np.linalg.norm(cutaway)
    if isinstance(terrain, PlaneTerrain):
        return _plane(terrain, c, extent, cell)
    if isinstance(terrain, HeightField):
        return _dem(terrain)
    if isinstance(terrain, ParallelWalls):
        return _walls(terrain, c, extent, cell, cut)
    if isinstance(terrain, UChannel):
        return _u_channel(terrain, c, extent, cell)
    if isinstance(terrain, Moulin):
        return _moulin(terrain, c, extent, cell, cut)
    if isinstance(terrain, FourierCylinder):
        return _cylinder(terrain, c, extent, cell, cut, s_range=None)
    if isinstance(terrain, SdfGrid):
        return _sdf(terrain)
    raise TypeError(f"no display mesh for terrain kind '{terrain.kind}' ({type(terrain).__name__}); "
                    "known: plane, dem, parallel_walls, u_channel, tube, moulin, mesh")


# -- building blocks -------------------------------------------------------------------

def _quads(P: np.ndarray, keep: np.ndarray | None = None, tones: np.ndarray | None = None,
           flip: bool = False) -> TerrainMesh:
    """Checkerboard quads of a grid of points P (nu+1, nv+1, 3), one flat-shaded
    quad per cell (own vertices, so colours and creases stay crisp). Faces wind
    counter-clockwise about (dP/du x dP/dv), or the reverse with ``flip``: the
    caller picks the side facing free space."""
    if flip:
        P = P[:, ::-1]
        keep = None if keep is None else keep[:, ::-1]
        tones = None if tones is None else tones[:, ::-1]
    nu, nv = P.shape[0] - 1, P.shape[1] - 1
    a, b, c, d = P[:-1, :-1], P[1:, :-1], P[1:, 1:], P[:-1, 1:]
    n = np.cross(c - a, d - b)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
    iu, iv = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    col = ICE[(iu + iv) % 2] if tones is None else tones
    sel = np.ones((nu, nv), bool) if keep is None else keep
    a, b, c, d, n, col = a[sel], b[sel], c[sel], d[sel], n[sel], col[sel]
    m = len(a)
    verts = np.stack([a, b, c, d], axis=1).reshape(-1, 3)
    base = 4 * np.arange(m)[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]]).astype(np.uint32)
    normals = np.repeat(n, 4, axis=0)
    rgba = np.concatenate([np.repeat(col, 4, axis=0), np.full((4 * m, 1), 255, np.uint8)], axis=1)
    return TerrainMesh(verts.astype(np.float32), faces, normals.astype(np.float32), rgba.astype(np.uint8))


def _join(*meshes: TerrainMesh) -> TerrainMesh:
    offs = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return TerrainMesh(np.vstack([m.vertices for m in meshes]),
                       np.vstack([m.faces + o for m, o in zip(meshes, offs)]).astype(np.uint32),
                       np.vstack([m.normals for m in meshes]), np.vstack([m.colors for m in meshes]))


def _grid(n_cells: float) -> np.ndarray:
    return np.linspace(-1.0, 1.0, max(2, int(np.ceil(n_cells))) + 1)


def _rect(origin, e1, e2, half1, half2, cell) -> np.ndarray:
    u = _grid(2 * half1 / cell) * half1
    v = _grid(2 * half2 / cell) * half2
    return origin + u[:, None, None] * e1 + v[None, :, None] * e2


# -- kinds -----------------------------------------------------------------------------

def _plane(t: PlaneTerrain, c, extent, cell) -> TerrainMesh:
    n = t.n
    e1 = np.cross(n, [0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.cross(n, [1.0, 0.0, 0.0])
    e1 = -e1 / np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    foot = c - ((c - t.origin) @ n) * n          # the centre dropped onto the plane
    return _quads(_rect(foot, e1, e2, extent, extent, cell))


def _dem(t: HeightField) -> TerrainMesh:
    z = t.z
    k = max(1, int(np.ceil(max(z.shape) / MAX_DEM_SIDE)))
    zi = z[::k, ::k]
    ny, nx = zi.shape
    x = t.x0 + k * t.res * np.arange(nx)
    y = t.y0 + k * t.res * np.arange(ny)
    X, Y = np.meshgrid(x, y, indexing="xy")
    P = np.stack([X, Y, zi], axis=-1).transpose(1, 0, 2)        # (nx, ny, 3): u = x, v = y
    zc = 0.25 * (zi[:-1, :-1] + zi[1:, :-1] + zi[:-1, 1:] + zi[1:, 1:]).T
    span = max(float(np.ptp(zi)), 1e-9)
    f = ((zc - zi.min()) / span)[..., None]
    tones = (DEM_LOW + f * (DEM_HIGH - DEM_LOW)).astype(np.uint8)
    iu, iv = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    tones[(iu // 4 + iv // 4) % 2 == 1] = (0.93 * tones[(iu // 4 + iv // 4) % 2 == 1]).astype(np.uint8)
    return _quads(P, tones=tones)


def _channel_axis(lat: np.ndarray) -> np.ndarray:
    a = np.cross(lat, _Z)
    return a / np.linalg.norm(a)


def _walls(t: ParallelWalls, c, extent, cell, cut) -> TerrainMesh:
    lat = t.lat
    a = _channel_axis(lat)
    up = np.cross(a, lat)
    mid = t.origin + ((c - t.origin) @ a) * a
    out = []
    for side in (1.0, -1.0):
        offset = side * 0.5 * t.gap * lat
        if cut is not None and offset @ cut > 1e-12:
            continue
        # a x up = -lat: towards free space for the +lat wall
        out.append(_quads(_rect(mid + offset, a, up, extent, 0.5 * extent, cell), flip=side < 0))
    return _join(*out)


def _u_channel(t: UChannel, c, extent, cell) -> TerrainMesh:
    w = 0.5 * t.width
    H = max(t.width, 0.5)
    a = _channel_axis(t.lat)
    n_wall = max(2, int(np.ceil(H / cell)))
    n_arc = max(8, int(np.ceil(np.pi * w / cell)))
    z_wall = np.linspace(H, 0.0, n_wall + 1)
    phi = np.linspace(np.pi, 2 * np.pi, n_arc + 1)[1:-1]
    ys = np.concatenate([np.full(n_wall + 1, -w), w * np.cos(phi), np.full(n_wall + 1, w)])
    zs = np.concatenate([z_wall, w * np.sin(phi), z_wall[::-1]])
    s = _grid(2 * extent / cell) * extent
    mid = t.origin + ((c - t.origin) @ a) * a
    P = mid + s[:, None, None] * a + ys[None, :, None] * t.lat + zs[None, :, None] * t.up
    return _quads(P)


def _cylinder(t: FourierCylinder, c, extent, cell, cut, s_range) -> TerrainMesh:
    R = t.R
    if s_range is None:
        s_c = (c - t.origin) @ R[:, 2]
        s_range = (s_c - extent, s_c + extent)
    n_theta = max(24, int(np.ceil(2 * np.pi * t.radius / cell)), 4 * int(t.modes[:, 1].max(initial=0)))
    theta = np.linspace(-np.pi, np.pi, n_theta + 1)
    s = np.linspace(s_range[0], s_range[1], max(2, int(np.ceil((s_range[1] - s_range[0]) / cell))) + 1)
    TH, S = np.meshgrid(theta, s, indexing="ij")
    rs, _, _ = t.wall_radius(TH.ravel(), S.ravel())
    rs = rs.reshape(TH.shape)
    loc = np.stack([rs * np.cos(TH), rs * np.sin(TH), S], axis=-1)
    P = t.origin + loc @ R.T
    keep = None
    if cut is not None:
        tm = 0.5 * (theta[:-1] + theta[1:])
        radial = np.cos(tm)[:, None] * R[:, 0] + np.sin(tm)[:, None] * R[:, 1]       # (n_theta, 3)
        keep = np.repeat((radial @ cut <= 1e-9)[:, None], len(s) - 1, axis=1)
    return _quads(P, keep, flip=True)       # dP/dθ x dP/ds points into the ice


def _moulin(t: Moulin, c, extent, cell, cut) -> TerrainMesh:
    shaft = t.shaft
    wall = _cylinder(shaft, c, extent, cell, cut, s_range=(-2 * extent, 0.0))
    if not t.surface:
        return wall
    top = np.array([shaft.origin[0], shaft.origin[1], t.top])
    P = _rect(np.array([c[0], c[1], t.top]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), extent, extent, cell)
    mid = 0.25 * (P[:-1, :-1] + P[1:, :-1] + P[1:, 1:] + P[:-1, 1:]) - top
    r = np.hypot(mid[..., 0], mid[..., 1])
    rs, _, _ = shaft.wall_radius(np.arctan2(mid[..., 1], mid[..., 0]).ravel(), np.zeros(r.size))
    keep = r > rs.reshape(r.shape)
    if cut is not None:
        horiz = np.array([cut[0], cut[1], 0.0])
        keep &= mid @ horiz <= 0.0
    return _join(wall, _quads(P, keep))


def _sdf(t: SdfGrid) -> TerrainMesh:
    src = Path(t.source)
    if src.is_file():
        import trimesh

        m = trimesh.load(src, force="mesh")
        m.unmerge_vertices()                         # flat faces: ice blocks have sharp edges
        v = np.asarray(m.vertices, dtype=np.float32)
        col = np.tile(np.append(ICE[0], 255).astype(np.uint8), (len(v), 1))
        return TerrainMesh(v, np.asarray(m.faces, dtype=np.uint32), np.asarray(m.vertex_normals, np.float32), col)
    return _voxel_faces(t)


def _voxel_faces(t: SdfGrid) -> TerrainMesh:
    """The grid's zero crossing as axis-aligned faces between samples of opposite sign."""
    solid = t.values < 0
    h, lo = t.h, t.lo
    quads, normals = [], []
    for ax in range(3):
        a = np.swapaxes(solid, 0, ax)
        flip = a[1:] != a[:-1]
        idx = np.argwhere(flip)
        if not len(idx):
            continue
        idx = idx.astype(float)
        idx[:, 0] += 0.5                            # the face between sample i and i+1
        e1, e2 = [(ax + 1) % 3, (ax + 2) % 3]
        ctr = np.zeros((len(idx), 3))
        order = [ax] + [i for i in range(3) if i != ax]
        for k, o in enumerate(order):
            ctr[:, o] = idx[:, k]
        ctr = lo + h * ctr
        du, dv = np.zeros(3), np.zeros(3)
        du[e1], dv[e2] = 0.5 * h, 0.5 * h
        q = np.stack([ctr - du - dv, ctr + du - dv, ctr + du + dv, ctr - du + dv], axis=1)
        inside_first = a[:-1][flip]
        nrm = np.zeros((len(idx), 3))
        nrm[:, ax] = np.where(inside_first, 1.0, -1.0)
        quads.append(q)
        normals.append(nrm)
    if not quads:
        raise ValueError(f"terrain grid '{t.source}' has no zero crossing to draw")
    q = np.concatenate(quads)
    n = np.concatenate(normals)
    m = len(q)
    base = 4 * np.arange(m)[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]]).astype(np.uint32)
    col = np.tile(np.append(ICE[0], 255).astype(np.uint8), (4 * m, 1))
    return TerrainMesh(q.reshape(-1, 3).astype(np.float32), faces, np.repeat(n, 4, axis=0).astype(np.float32), col)
