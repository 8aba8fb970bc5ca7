"""A terrain as a triangle mesh for display (and for the sensors), from the parameters of its kind.

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
    obstacles       the ground square (2·extent around the centre) with each obstacle's
                    footprint cut out exactly, every block (flat faces, clipped at the ground)
                    and every rock (a UV sphere above the ground, facets within SPHERE_CHORD
                    of the sphere); blocks bluish grey, rocks grey-brown. Watertight where
                    obstacles do not overlap: a rock's rim ring has a vertex wherever a ground
                    grid line crosses it, so ground and rock share their seam and every vertex
                    lies on the surface (where two footprints share a ground cell, the cut of
                    one may put ice vertices inside the other rock's rim by < SPHERE_CHORD/2;
                    overlapping obstacles draw their hidden faces inside each other)
    mesh (SdfGrid)  the imported mesh file the grid was computed from; without one,
                    the zero level set of the grid as voxel faces
    any other kind  its own ``display_mesh``, or by default its zero level set
                    (:func:`level_set_mesh`: a surface net over the signed distance, every
                    vertex a grid cell's centre moved onto the surface)

Unbounded kinds are cut to ``extent`` (m) around ``center`` (the robot's
start); an obstacle field's obstacles are all drawn, only its ground is cut.
Surfaces are a checkerboard of ``cell``-sized quads so motion reads in the
viewer (a rock's tessellation follows SPHERE_CHORD, not ``cell``). Enclosing kinds (tube, moulin shaft, walls) are cut away on
the side facing ``cutaway`` (a direction from the terrain's axis towards the
viewer; None keeps everything), so the robot inside stays visible.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from typing import TYPE_CHECKING

from .base import Terrain, TerrainMesh

if TYPE_CHECKING:
    from .analytic import FourierCylinder, Moulin, ParallelWalls, PlaneTerrain, SlotMoulin, UChannel
    from .dem import HeightField
    from .mesh import SdfGrid
    from .obstacles import Block, ObstacleField, Rock

ICE = np.array([[214, 232, 244], [186, 212, 232]], dtype=np.uint8)   # checker tones, RGB
DEM_LOW, DEM_HIGH = np.array([120, 160, 200.0]), np.array([240, 248, 255.0])
MAX_DEM_SIDE = 256
BLOCK_TONE = np.array([150, 163, 180], dtype=np.uint8)    # bluish grey
ROCK_TONE = np.array([140, 124, 106], dtype=np.uint8)     # grey-brown
SPHERE_CHORD = 1e-3     # m: about the most a rock's facets dip inside its sphere (at their centres)
_Z = np.array([0.0, 0.0, 1.0])


def terrain_mesh(terrain: Terrain, center=(0.0, 0.0, 0.0), extent: float = 4.0, cell: float = 0.25,
                 cutaway=(0.0, -0.6, 0.8)) -> TerrainMesh:
    """Display mesh of ``terrain``: its kind's :meth:`Terrain.display_mesh` (see the module docstring
    for each built-in kind; a kind that does not draw itself gets :func:`level_set_mesh`)."""
    c = np.asarray(center, dtype=float)
    cut = None if cutaway is None else np.asarray(cutaway, dtype=float) / np.linalg.norm(cutaway)
    return terrain.display_mesh(c, float(extent), float(cell), cut)


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


def _slot_moulin(t: SlotMoulin, c, extent, cell, cut) -> TerrainMesh:
    """The slot's wall (SlotMoulin.wall_points) from the surface down 2·extent along the shaft, below the
    surface, cut away towards the viewer; the surface square with the mouth left open."""
    P = t.wall_points((-2 * extent, 0.0), cell)
    mid = 0.25 * (P[:-1, :-1] + P[1:, :-1] + P[1:, 1:] + P[:-1, 1:])
    keep = mid[..., 2] < t.top
    if cut is not None:
        ax = t.R[:, 2]
        radial = mid - t.origin - ((mid - t.origin) @ ax)[..., None] * ax
        keep &= radial @ cut <= 1e-9
    wall = _quads(P, keep, flip=True)       # d(loop) x ds points into the ice
    if not t.surface:
        return wall
    S = _rect(np.array([c[0], c[1], t.top]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), extent, extent, cell)
    smid = 0.25 * (S[:-1, :-1] + S[1:, :-1] + S[1:, 1:] + S[:-1, 1:])
    skeep = t.shaft_distance(smid.reshape(-1, 3)).reshape(smid.shape[:2]) < 0.0
    if cut is not None:
        skeep &= (smid - t.origin) @ np.array([cut[0], cut[1], 0.0]) <= 0.0
    return _join(wall, _quads(S, skeep))


def _obstacles(t: ObstacleField, c, extent, cell) -> TerrainMesh:
    h = t.ground_height
    xs = c[0] + _grid(2 * extent / cell) * extent
    ys = c[1] + _grid(2 * extent / cell) * extent
    parts, holes = [], []
    for b in t.blocks:
        mesh, hole = _block(b, h)
        parts.append(mesh)
        holes.append(hole)
    for r in t.rocks:
        mesh, hole = _rock(r, h, xs, ys)
        parts.append(mesh)
        holes.append(hole)
    ground = _ground_with_holes(xs, ys, h, [x for x in holes if x is not None])
    return _join(ground, *[m for m in parts if m is not None])


def _solid(verts: np.ndarray, faces: np.ndarray, normals: np.ndarray, tone: np.ndarray) -> TerrainMesh:
    rgba = np.tile(np.append(tone, 255).astype(np.uint8), (len(verts), 1))
    return TerrainMesh(verts.astype(np.float32), np.asarray(faces, dtype=np.uint32).reshape(-1, 3),
                       normals.astype(np.float32), rgba)


def _fans(polys: list, normals: list, tone: np.ndarray) -> TerrainMesh:
    """Convex polygons (k_i, 3), each flat-shaded with its own vertices, as triangle fans."""
    verts, faces, nrm, base = [], [], [], 0
    for poly, n in zip(polys, normals):
        k = len(poly)
        verts.append(poly)
        nrm.append(np.tile(n, (k, 1)))
        faces += [[base, base + i, base + i + 1] for i in range(1, k - 1)]
        base += k
    return _solid(np.vstack(verts), np.array(faces), np.vstack(nrm), tone)


def _block(b: Block, h: float, tol: float = 1e-9):
    """A block's faces above the ground (outward winding) and its section at the ground
    (a CCW polygon (k, 2) to cut from the ground, or None)."""
    corners = b.corners()
    if corners[:, 2].max() <= h + tol:
        return None, None                           # buried: all ground
    R, ctr, half = b.rotation, np.asarray(b.center, float), 0.5 * np.asarray(b.size, float)
    polys, normals = [], []
    for k in range(3):
        u, v = (k + 1) % 3, (k + 2) % 3             # e_u x e_v = e_k
        for s in (1.0, -1.0):
            loc = np.zeros((4, 3))
            loc[:, k] = s * half[k]
            loc[:, u] = np.array([-1, 1, 1, -1]) * half[u]
            loc[:, v] = np.array([-1, -1, 1, 1]) * half[v]
            face = _clip_above(ctr + (loc if s > 0 else loc[::-1]) @ R.T, h)
            if len(face) < 3 or face[:, 2].max() <= h + tol:
                continue                            # below or flat on the ground: not surface
            polys.append(face)
            normals.append(s * R[:, k])
    return _fans(polys, normals, BLOCK_TONE), _section(corners, h, tol)


def _clip_above(poly: np.ndarray, h: float) -> np.ndarray:
    """The part z >= h of a convex polygon (k, 3) (Sutherland–Hodgman, one plane)."""
    out = []
    dz = poly[:, 2] - h
    for i in range(len(poly)):
        j = (i + 1) % len(poly)
        if dz[i] >= 0:
            out.append(poly[i])
        if dz[i] * dz[j] < 0:
            p = poly[i] + dz[i] / (dz[i] - dz[j]) * (poly[j] - poly[i])
            p[2] = h
            out.append(p)
    return np.array(out).reshape(-1, 3)


def _section(corners: np.ndarray, h: float, tol: float):
    """A box's section with the plane z = h as a CCW polygon (k, 2), or None if it has no area."""
    dz = corners[:, 2] - h
    pts = [corners[i, :2] for i in range(8) if abs(dz[i]) <= tol]
    for i in range(8):
        for k in range(3):
            j = i | (1 << k)
            if j != i and dz[i] * dz[j] < 0 and abs(dz[i]) > tol and abs(dz[j]) > tol:
                pts.append((corners[i] + dz[i] / (dz[i] - dz[j]) * (corners[j] - corners[i]))[:2])
    if len(pts) < 3:
        return None
    hull = _hull(np.array(pts))
    return hull if len(hull) >= 3 and _area(hull) > 1e-12 else None


def _hull(p: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, CCW, no collinear points (Andrew's monotone chain)."""
    p = p[np.lexsort((p[:, 1], p[:, 0]))]

    def half(points):
        out = []
        for q in points:
            while len(out) >= 2 and _cross(out[-2], out[-1], q) <= 1e-15:
                out.pop()
            out.append(q)
        return out[:-1]

    return np.array(half(p) + half(p[::-1]))


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _rock(r: Rock, h: float, xs: np.ndarray, ys: np.ndarray, tol: float = 1e-9):
    """A rock's sphere above the ground (UV rings, outward winding, radial normals) and its rim
    at the ground (a CCW polygon (k, 2) to cut from the ground, or None)."""
    ctr, rad = np.asarray(r.center, float), float(r.radius)
    if ctr[2] + rad <= h + tol:
        return None, None                           # buried
    # a facet of edge arc Δ dips about rad·Δ²/4 inside the sphere at its centre
    step = min(2.0 * np.sqrt(SPHERE_CHORD / rad), np.pi / 8)
    whole = ctr[2] - rad >= h - tol                 # resting on (or above) the ground: no rim
    theta_max = np.pi if whole else float(np.arccos((h - ctr[2]) / rad))
    phi = np.linspace(-np.pi, np.pi, max(16, int(np.ceil(2 * np.pi / step))), endpoint=False)
    if not whole:
        phi = _with_crossings(phi, ctr[:2], rad * np.sin(theta_max), xs, ys)
    n_ring = max(4, int(np.ceil(theta_max / step)))
    theta = theta_max * np.arange(1, n_ring + 1) / n_ring
    if whole:
        theta = theta[:-1]                          # the bottom pole closes it instead of a ring
    m = len(phi)
    unit_dirs = [np.array([[0.0, 0.0, 1.0]])]
    unit_dirs.append((np.sin(theta)[:, None, None] * np.stack([np.cos(phi), np.sin(phi), np.zeros(m)], -1)
                      + np.cos(theta)[:, None, None] * np.array([0.0, 0.0, 1.0])).reshape(-1, 3))
    ring = lambda k: 1 + k * m + np.arange(m)           # noqa: E731  vertex ids of ring k
    nxt = lambda ids: np.roll(ids, -1)                  # noqa: E731
    faces = [np.column_stack([np.zeros(m, int), ring(0), nxt(ring(0))])]
    for k in range(len(theta) - 1):
        a, b = ring(k), ring(k + 1)
        faces += [np.column_stack([a, b, nxt(b)]), np.column_stack([a, nxt(b), nxt(a)])]
    if whole:
        bottom = 1 + len(theta) * m
        unit_dirs.append(np.array([[0.0, 0.0, -1.0]]))
        last = ring(len(theta) - 1)
        faces.append(np.column_stack([last, np.full(m, bottom), nxt(last)]))
    dirs = np.vstack(unit_dirs)
    verts = ctr + rad * dirs
    if not whole:
        verts[ring(len(theta) - 1), 2] = h          # the rim exactly on the ground
    mesh = _solid(verts, np.vstack(faces), dirs, ROCK_TONE)
    return mesh, None if whole else verts[ring(len(theta) - 1), :2]


def _with_crossings(phi: np.ndarray, c2: np.ndarray, rho: float, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Azimuths ``phi`` plus those where the ground's grid lines cross the rim circle (centre c2,
    radius rho), so the ground's cut edges end on rim vertices; sorted, near-duplicates merged."""
    cross = []
    for lines, a in ((xs, 0), (ys, 1)):
        off = lines - c2[a]
        off = off[np.abs(off) < rho]
        along = np.sqrt(rho ** 2 - off ** 2)
        for o, w in zip(off, along):
            for sgn in (1.0, -1.0):
                dx, dy = (o, sgn * w) if a == 0 else (sgn * w, o)
                cross.append(np.arctan2(dy, dx))
    if not cross:
        return phi
    cross = np.unique(np.round(np.array(cross), 12))
    gap = np.abs((phi[:, None] - cross[None, :] + np.pi) % (2 * np.pi) - np.pi).min(axis=1)
    spacing = 2 * np.pi / len(phi)
    return np.sort(np.concatenate([phi[gap > 0.1 * spacing], cross]))   # no slivers next to a crossing


def _ground_with_holes(xs: np.ndarray, ys: np.ndarray, h: float, holes: list) -> TerrainMesh:
    """The checkerboard ground square with the convex ``holes`` (CCW (k, 2)) cut out exactly:
    untouched cells as quads, touched cells as the convex pieces of cell minus holes."""
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    P = np.stack([X, Y, np.full(X.shape, h)], axis=-1)
    touched = np.zeros((len(xs) - 1, len(ys) - 1), bool)
    hits = {}
    for hole in holes:
        lo, hi = hole.min(axis=0), hole.max(axis=0)
        i0, i1 = np.searchsorted(xs, lo[0], "right") - 1, np.searchsorted(xs, hi[0], "left")
        j0, j1 = np.searchsorted(ys, lo[1], "right") - 1, np.searchsorted(ys, hi[1], "left")
        for i in range(max(i0, 0), min(i1, len(xs) - 1)):
            for j in range(max(j0, 0), min(j1, len(ys) - 1)):
                touched[i, j] = True
                hits.setdefault((i, j), []).append(hole)
    parts = [_quads(P, ~touched)] if (~touched).any() else []
    for (i, j), cell_holes in sorted(hits.items()):
        pieces = [np.array([[xs[i], ys[j]], [xs[i + 1], ys[j]], [xs[i + 1], ys[j + 1]], [xs[i], ys[j + 1]]])]
        for hole in cell_holes:
            pieces = [q for piece in pieces for q in (_minus_convex(piece, hole) if _boxes_meet(piece, hole)
                                                      else [piece])]
        if pieces:
            polys = [np.column_stack([q, np.full(len(q), h)]) for q in pieces]
            parts.append(_fans(polys, [_Z] * len(polys), ICE[(i + j) % 2]))
    return _join(*parts)


def _boxes_meet(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((a.min(axis=0) < b.max(axis=0)).all() and (b.min(axis=0) < a.max(axis=0)).all())


def _minus_convex(poly: np.ndarray, hole: np.ndarray) -> list:
    """Convex polygon minus a convex CCW polygon, as convex pieces: the part outside edge i
    of what is inside edges 0..i-1, for each edge i."""
    pieces, rest = [], poly
    for a, b in zip(hole, np.roll(hole, -1, axis=0)):
        out = _simplify(_clip_side(rest, a, b, left=False))
        if len(out) >= 3 and _area(out) > 1e-14:
            pieces.append(out)
        rest = _clip_side(rest, a, b, left=True)
        if len(rest) < 3:
            break
    return pieces


def _simplify(poly: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    """A convex polygon without repeated or collinear vertices (clipping leaves both; they would
    give zero-area fan triangles)."""
    while len(poly) >= 3:
        prev, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
        a, b = poly - prev, nxt - prev
        turn = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        flat = np.abs(turn) <= tol * max(1.0, float(np.ptp(poly, axis=0).max()) ** 2)
        if not flat.any():
            break
        poly = np.delete(poly, np.flatnonzero(flat)[0], axis=0)
    return poly


def _clip_side(poly: np.ndarray, a, b, left: bool) -> np.ndarray:
    """The part of a convex polygon (k, 2) left (or right) of the line a -> b, boundary included."""
    s = (b[0] - a[0]) * (poly[:, 1] - a[1]) - (b[1] - a[1]) * (poly[:, 0] - a[0])
    s = s if left else -s
    out = []
    for i in range(len(poly)):
        j = (i + 1) % len(poly)
        if s[i] >= 0:
            out.append(poly[i])
        if s[i] * s[j] < 0:
            out.append(poly[i] + s[i] / (s[i] - s[j]) * (poly[j] - poly[i]))
    return np.array(out).reshape(-1, 2)


def _sdf(t: SdfGrid) -> TerrainMesh:
    src = Path(t.source)
    if src.is_file():
        import trimesh

        m = trimesh.load(src, force="mesh")
        # faces drawn facing free space whatever the file's winding (an imported scan's faces face the ice,
        # `inside: free`): a face whose normal leads into less signed distance is turned round
        c, n = m.triangles_center, m.face_normals
        step = 0.25 * t.h
        into_ice = t.query(c + step * n).distance < t.query(c - step * n).distance
        if into_ice.any():
            f = m.faces.copy()
            f[into_ice] = f[into_ice][:, ::-1]
            m = trimesh.Trimesh(m.vertices, f, process=False)
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


# -- any kind: the zero level set of its query -------------------------------------------

#: most grid nodes the generic mesher samples (its spacing grows past ``cell`` to stay within)
LEVEL_SET_NODES = 2_000_000
#: nodes per side of the first, coarse pass that finds where the surface is
COARSE_SIDE = 48
#: steps p <- p - d(p)·n(p) that take a cell's centre onto the zero level set
PROJECTION_STEPS = 6
_QUERY_CHUNK = 200_000


def _distances(terrain: Terrain, points: np.ndarray) -> np.ndarray:
    return np.concatenate([terrain.query(points[i:i + _QUERY_CHUNK]).distance
                           for i in range(0, len(points), _QUERY_CHUNK)]) if len(points) else np.zeros(0)


def _nodes(lo: np.ndarray, hi: np.ndarray, n: np.ndarray) -> tuple[list, np.ndarray]:
    axes = [np.linspace(lo[a], hi[a], int(n[a])) for a in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    return axes, np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


def level_set_mesh(terrain: Terrain, center, extent: float, cell: float) -> TerrainMesh:
    """The surface {query().distance = 0} within ``extent`` m of ``center`` (and the terrain's bounds) as
    a surface net: the distance sampled on a grid of about ``cell`` m (coarser where the box would need
    more than LEVEL_SET_NODES nodes), one quad across every grid edge whose ends lie on opposite sides,
    its corners the four cells' centres moved onto the surface along the query's normal
    (_onto_surface: every vertex is on the surface), wound so that the faces look into free space. A
    first pass on a coarse grid shrinks the box to where the surface is (within the distance's
    Lipschitz bound). Uniform ice tone; the normals are the query's."""
    c = np.asarray(center, dtype=float)
    b = terrain.bounds()
    lo = np.maximum(np.asarray(b.lo, float), c - extent)
    hi = np.minimum(np.asarray(b.hi, float), c + extent)
    if not np.all(hi > lo):
        return _empty_mesh()
    # coarse pass: nodes within reach of the surface bound the box
    n = np.full(3, COARSE_SIDE)
    axes, P = _nodes(lo, hi, n)
    step = (hi - lo) / (n - 1)
    d = _distances(terrain, P)
    near = np.abs(d) <= max(terrain.lipschitz, 1.0) * (0.5 * np.linalg.norm(step)) * (1 + 1e-9)
    if not near.any():
        return _empty_mesh()
    lo, hi = np.maximum(lo, P[near].min(axis=0) - step), np.minimum(hi, P[near].max(axis=0) + step)
    # fine pass
    h = max(float(cell), float(np.prod(hi - lo) / LEVEL_SET_NODES) ** (1 / 3))
    n = np.maximum(2, np.ceil((hi - lo) / h).astype(int) + 1)
    axes, P = _nodes(lo, hi, n)
    solid = (_distances(terrain, P) < 0.0).reshape(tuple(n))
    quads, outward = [], []
    for a in range(3):
        b_, c_ = (a + 1) % 3, (a + 2) % 3
        flip = solid[tuple(slice(0, -1) if k == a else slice(None) for k in range(3))] != \
            solid[tuple(slice(1, None) if k == a else slice(None) for k in range(3))]
        idx = np.argwhere(flip)                         # lower node of each crossing edge
        ok = (idx[:, b_] >= 1) & (idx[:, b_] <= n[b_] - 2) & (idx[:, c_] >= 1) & (idx[:, c_] <= n[c_] - 2)
        idx = idx[ok]
        if not len(idx):
            continue
        cells = []
        for db, dc in ((-1, -1), (0, -1), (0, 0), (-1, 0)):     # counter-clockwise about +e_a
            q = idx.copy()
            q[:, b_] += db
            q[:, c_] += dc
            cells.append(q)
        quads.append(np.stack(cells, axis=1))                  # (k, 4, 3) cell indices
        outward.append(solid[tuple(idx.T)])                    # solid below: the quad faces +e_a
    if not quads:
        return _empty_mesh()
    Q, up = np.concatenate(quads), np.concatenate(outward)
    Q[~up] = Q[~up][:, ::-1]
    m = n - 1
    flat = (Q[..., 0] * m[1] + Q[..., 1]) * m[2] + Q[..., 2]
    used, inverse = np.unique(flat.ravel(), return_inverse=True)
    ijk = np.stack(np.unravel_index(used, tuple(m)), axis=1)
    centres = np.stack([0.5 * (axes[a][ijk[:, a]] + axes[a][ijk[:, a] + 1]) for a in range(3)], axis=1)
    verts, normals = _onto_surface(terrain, centres)
    f = inverse.reshape(-1, 4)
    faces = np.concatenate([f[:, [0, 1, 2]], f[:, [0, 2, 3]]]).astype(np.uint32)
    colors = np.tile(np.append(ICE[0], 255).astype(np.uint8), (len(verts), 1))
    return TerrainMesh(verts.astype(np.float32), faces, normals.astype(np.float32), colors)


def _onto_surface(terrain: Terrain, points: np.ndarray):
    """Points moved onto {distance = 0} by PROJECTION_STEPS steps along the query's normal (one step
    is the closest point where the distance is exact; the others take a first-order distance, or one
    that is only a bound inside the solid, onto its zero level set), and the normals there."""
    p = points.copy()
    n = np.zeros_like(p)
    for i in range(0, len(p), _QUERY_CHUNK):
        part = p[i:i + _QUERY_CHUNK]
        for _ in range(PROJECTION_STEPS):
            part = terrain.query(part).closest
        p[i:i + _QUERY_CHUNK], n[i:i + _QUERY_CHUNK] = part, terrain.query(part).normal
    return p, n


def _empty_mesh() -> TerrainMesh:
    return TerrainMesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), np.zeros((0, 3), np.float32),
                       np.zeros((0, 4), np.uint8))
