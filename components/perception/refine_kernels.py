"""Compiled hit refinement: height fields (DEM, ``DemRefiner``: the exact crossing of the bilinear
surface, in the section at the end) and the Fourier-cylinder terrains (tube, rough tube, moulin): the
Newton iteration of .ray_caster (f(t) = d(o + t·r), t ← t − f/f', f' = n·r, until the error
left is below the tolerance, a grazing or too long step keeps the mesh hit) with the terrain's distance written out per
point instead of NumPy passes over (rays × modes) arrays. The distance is the terrain's
own (components/terrain/analytic.py, ``FourierCylinder`` and ``Moulin``):

    loc = Rᵀ(x − origin) = (u, v, s),  r = √(u² + v²),  e^{iθ} = (u + iv)/r
    r_s = R + slope·s + Σ_j A_j cos(m_j θ + k_j s + φ_j)
    ∇g_s = −r̂ + (∂r_s/∂θ / r_s) θ̂ + (∂r_s/∂s) ŝ
    d = (r_s − r)/‖∇g_s‖,   n = ∇g_s/‖∇g_s‖
    moulin: d = max(d, z − top) (the ice surface above, normal +z, region 1)

The angular orders m_j are integers (the wall closes), so e^{i m θ} comes from powers of
e^{iθ} = (u + iv)/r, with no trigonometric call; e^{i(k s + φ)} comes from a table over s
(spacing h = 0.1 / max|k|, built once over the axial span of the terrain's mesh) turned by
e^{i k (s − s_g)} from the nearest node s_g, a Taylor series in |k (s − s_g)| <= 0.05 to
seventh order (error < 1e-15): no trigonometric call either (a sine and a cosine per mode
cost ~20 ns here, the whole rotation ~5). Off the table (a point past the mesh's span) the
sine and cosine are called.

A hit nearer than a sensor's minimum range only blocks its beam: ``newton`` keeps such a mesh
hit when the point at that range along the ray is inside the terrain (the true surface was
crossed before it), which takes r_s alone, its modes added largest first until the rest
(Σ|A_j| of the modes left) cannot change the side (``_beyond_wall``).

The kernels take the terrain as one argument record (``FourierWall``, components/kernel_args.py, built
once per refiner) and read its arrays into locals once per call; the per-point functions (``_distance``,
``_beyond_wall``: one point, called in the loops) keep those locals as plain arguments, as the contact
law's point functions do (a record field read per point would cost a reference count each).

tests/perception/test_refine_kernels.py checks the distance and normal against the terrain's
query, the inside test against its sign, and the refined hits against the NumPy iteration.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernel_args import record

#: largest angular order written as powers (the spec's m_max is small; larger falls back to NumPy)
MAX_ORDER = 64
#: largest |k (s − s_g)| turned by the Taylor series (sets the table's spacing)
TAYLOR_REACH = 0.05
#: table nodes at most (a longer span keeps the calls beyond it)
MAX_NODES = 200_000

#: one Fourier-cylinder terrain, as the kernels read it (FourierRefiner's arrays; ``order`` = max m)
FourierWall = record("FourierWall", ("origin", "R", "radius", "slope", "A", "m", "k", "phase", "Am", "Ak", "by_size",
                                     "tail", "order", "table", "s0", "h", "surface", "top", "region_material"))


class FourierRefiner:
    """The compiled refinement of one Fourier-cylinder terrain: what ``FourierCylinder.refiner`` and
    ``Moulin.refiner`` return (other kinds return None and keep the NumPy iteration)."""

    def __init__(self, shaft, surface: bool, top: float, region_material, span=(0.0, 0.0)):
        self.origin = np.asarray(shaft.origin, dtype=np.float64)
        self.R = np.ascontiguousarray(shaft.R, dtype=np.float64)
        self.radius, self.slope = float(shaft.radius), float(shaft.slope)
        modes = np.asarray(shaft.modes, dtype=np.float64).reshape(-1, 4)
        self.A, self.k, self.phase = modes[:, 0].copy(), modes[:, 2].copy(), modes[:, 3].copy()
        self.m = modes[:, 1].astype(np.int64)
        self.surface, self.top = bool(surface), float(top)
        self.region_material = np.asarray(region_material, dtype=np.int64)
        # e^{i(k s_g + φ)} at nodes s_g = s0 + g·h over the span (s along the axis)
        kmax = float(np.abs(self.k).max(initial=0.0))
        self.h = TAYLOR_REACH / kmax if kmax > 0 else 1.0
        nodes = min(MAX_NODES, int(np.ceil((span[1] - span[0]) / self.h)) + 2) if len(self.k) else 0
        self.m = self.m if len(self.m) else np.zeros(0, dtype=np.int64)
        self.s0 = float(span[0])
        arg = (self.s0 + self.h * np.arange(nodes))[:, None] * self.k + self.phase
        self.table = np.ascontiguousarray(np.stack([np.cos(arg), np.sin(arg)]))     # (2, G, J)
        self.Am, self.Ak = self.A * self.m, self.A * self.k
        # modes largest first, and what the rest can add (_beyond_wall stops once it cannot matter)
        self.by_size = np.argsort(-np.abs(self.A), kind="stable").astype(np.int64)
        self.tail = np.r_[np.cumsum(np.abs(self.A)[self.by_size][::-1])[::-1], 0.0]
        self.wall = FourierWall(origin=self.origin, R=self.R, radius=self.radius, slope=self.slope, A=self.A, m=self.m,
                                k=self.k, phase=self.phase, Am=self.Am, Ak=self.Ak, by_size=self.by_size,
                                tail=self.tail, order=int(self.m.max(initial=0)), table=self.table, s0=self.s0,
                                h=self.h, surface=self.surface, top=self.top, region_material=self.region_material)

    @staticmethod
    def for_terrain(terrain, vertices=None, margin: float = 1.0) -> "FourierRefiner | None":
        """The compiled refiner of ``terrain`` (its kind's ``Terrain.refiner``; None: the generic Newton
        iteration), its table spanning the axial extent of ``vertices`` (world, the sensor mesh) plus
        ``margin`` m."""
        return terrain.refiner(vertices, margin)

    @staticmethod
    def for_shaft(shaft, surface: bool, top: float, region_material, vertices=None,
                  margin: float = 1.0) -> "FourierRefiner | None":
        """The refiner of a Fourier-cylinder wall ``shaft`` (a tube, or a moulin's shaft with its ice
        ``surface`` at z = ``top``); None where an angular order is not an integer in [0, MAX_ORDER]."""
        m = np.asarray(shaft.modes, dtype=np.float64).reshape(-1, 4)[:, 1]
        if not np.all((m == np.round(m)) & (m >= 0) & (m <= MAX_ORDER)):
            return None
        span = (0.0, 0.0)
        if vertices is not None and len(vertices):
            s = (np.asarray(vertices, dtype=np.float64) - shaft.origin) @ shaft.R[:, 2]
            span = (float(s.min()) - margin, float(s.max()) + margin)
        return FourierRefiner(shaft, surface, top, region_material, span)

    def refine(self, o, d, rays, iterations: int, tolerance: float, grazing: float, limit: float, albedo_m, color_m,
               distance, normal, albedo, color, material, near: float = 0.0):
        """Newton from the mesh hits (``distance``) of rays ``rays`` of (o, d (n, 3)); in place where it
        converges; mesh hits nearer than ``near`` that the ray has passed by then are kept (``newton``)."""
        newton(self.wall, o, d, rays, iterations, tolerance, grazing, limit, float(near), albedo_m, color_m, distance,
               normal, albedo, color, material)

    def beyond_wall(self, points) -> np.ndarray:
        """(n,) whether world points are inside the terrain (its distance < 0), as ``newton`` tells
        a hit that only blocks (``_beyond_wall``)."""
        p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        out = np.empty(len(p), dtype=np.bool_)
        beyond_points(self.wall, p, out)
        return out

    def query(self, points):
        """(distance (n,), normal (n, 3), material (n,)) at world points: the terrain's query."""
        n = len(points)
        dist, nrm, mat = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64)
        query_points(self.wall, np.ascontiguousarray(points, dtype=np.float64), dist, nrm, mat)
        return dist, nrm, mat


@njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _distance(x, y, z, origin, R, radius, slope, A, m, k, phase, Am, Ak, order, powers, table, s0, h, surface, top, n):
    """Signed distance at (x, y, z) and the unit normal into n (3,); -> (distance, region).
    ``powers`` scratch (4, max(order + 1, J)), order = max m."""
    px, py, pz = x - origin[0], y - origin[1], z - origin[2]
    u = R[0, 0] * px + R[1, 0] * py + R[2, 0] * pz
    v = R[0, 1] * px + R[1, 1] * py + R[2, 1] * pz
    s = R[0, 2] * px + R[1, 2] * py + R[2, 2] * pz
    r = math.hypot(u, v)
    if r > 0.0:
        ct, st = u / r, v / r
    else:
        ct, st = 1.0, 0.0          # θ = atan2(0, 0) = 0, as the terrain's
    # e^{i m θ}, m = 0 .. M, by powers of e^{iθ} (rows 0, 1: real, imaginary), then per mode (rows 2, 3)
    J = A.shape[0]
    powers[0, 0], powers[1, 0] = 1.0, 0.0
    for q in range(1, order + 1):
        a, b = powers[0, q - 1], powers[1, q - 1]
        powers[0, q], powers[1, q] = a * ct - b * st, a * st + b * ct
    for j in range(J):
        powers[2, j], powers[3, j] = powers[0, m[j]], powers[1, m[j]]
    cm, sm = powers[2], powers[3]
    rs, drs_t, drs_s = radius + slope * s, 0.0, slope
    g = int(math.floor((s - s0) / h + 0.5))
    if 0 <= g < table.shape[1]:
        ds = s - (s0 + g * h)
        tc, ts = table[0, g], table[1, g]
        for j in range(J):
            # e^{i(k s_g + φ)} · e^{i k ds}, |k ds| <= TAYLOR_REACH
            e = k[j] * ds
            e2 = e * e
            ce = 1.0 - e2 * (0.5 - e2 * (1.0 / 24.0 - e2 * (1.0 / 720.0)))
            se = e * (1.0 - e2 * (1.0 / 6.0 - e2 * (1.0 / 120.0 - e2 * (1.0 / 5040.0))))
            cw = tc[j] * ce - ts[j] * se
            sw = ts[j] * ce + tc[j] * se
            sn = sm[j] * cw + cm[j] * sw              # sin(mθ + ks + φ)
            rs += A[j] * (cm[j] * cw - sm[j] * sw)    # cos(mθ + ks + φ)
            drs_t -= Am[j] * sn
            drs_s -= Ak[j] * sn
    else:
        for j in range(J):
            ks = k[j] * s + phase[j]
            cw, sw = math.cos(ks), math.sin(ks)
            sn = sm[j] * cw + cm[j] * sw
            rs += A[j] * (cm[j] * cw - sm[j] * sw)
            drs_t -= Am[j] * sn
            drs_s -= Ak[j] * sn
    gt = drs_t / rs
    n0, n1, n2 = -ct - gt * st, -st + gt * ct, drs_s
    norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    dist = (rs - r) / norm
    n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
    for a in range(3):
        n[a] = R[a, 0] * n0 + R[a, 1] * n1 + R[a, 2] * n2
    if surface and z - top > dist:
        n[0], n[1], n[2] = 0.0, 0.0, 1.0
        return z - top, 1
    return dist, 0


@njit(cache=True, nogil=True)
def _beyond_wall(x, y, z, origin, R, radius, slope, A, m, k, phase, by_size, tail, order, powers, table, s0, h,
                 surface, top):
    """Whether (x, y, z) is inside the terrain (signed distance < 0: r > r_s, and below the top
    where there is a surface), from r_s alone (no derivatives): the modes are added largest
    first (``by_size``) and the sum stops once the rest (``tail[q]`` = Σ|A| of the modes from
    the q-th on) cannot change the side of r − (R + slope·s) it is on."""
    if surface and z >= top:
        return False
    px, py, pz = x - origin[0], y - origin[1], z - origin[2]
    u = R[0, 0] * px + R[1, 0] * py + R[2, 0] * pz
    v = R[0, 1] * px + R[1, 1] * py + R[2, 1] * pz
    s = R[0, 2] * px + R[1, 2] * py + R[2, 2] * pz
    r = math.hypot(u, v)
    gap = r - (radius + slope * s)
    if gap > tail[0]:
        return True
    if gap < -tail[0]:
        return False
    if r > 0.0:
        ct, st = u / r, v / r
    else:
        ct, st = 1.0, 0.0
    powers[0, 0], powers[1, 0] = 1.0, 0.0
    for q in range(1, order + 1):
        a, b = powers[0, q - 1], powers[1, q - 1]
        powers[0, q], powers[1, q] = a * ct - b * st, a * st + b * ct
    wall = 0.0
    g = int(math.floor((s - s0) / h + 0.5))
    on_table = 0 <= g < table.shape[1]
    ds = s - (s0 + g * h)
    for q in range(by_size.shape[0]):
        j = by_size[q]
        if on_table:
            e = k[j] * ds
            e2 = e * e
            ce = 1.0 - e2 * (0.5 - e2 * (1.0 / 24.0 - e2 * (1.0 / 720.0)))
            se = e * (1.0 - e2 * (1.0 / 6.0 - e2 * (1.0 / 120.0 - e2 * (1.0 / 5040.0))))
            cw = table[0, g, j] * ce - table[1, g, j] * se
            sw = table[1, g, j] * ce + table[0, g, j] * se
        else:
            ks = k[j] * s + phase[j]
            cw, sw = math.cos(ks), math.sin(ks)
        wall += A[j] * (powers[0, m[j]] * cw - powers[1, m[j]] * sw)
        if gap - wall > tail[q + 1]:
            return True
        if wall - gap > tail[q + 1]:
            return False
    return gap > wall


@njit(cache=True, nogil=True)
def beyond_points(wall, p, out):
    """out[i]: whether point p[i] is inside the terrain ``wall`` (FourierWall), by _beyond_wall."""
    origin, R, radius, slope, A, m, k, phase = wall.origin, wall.R, wall.radius, wall.slope, wall.A, wall.m, wall.k, \
        wall.phase
    by_size, tail, order, table, s0, h, surface, top = wall.by_size, wall.tail, wall.order, wall.table, wall.s0, \
        wall.h, wall.surface, wall.top
    powers = np.empty((4, max(order + 1, A.shape[0])))
    for i in range(p.shape[0]):
        out[i] = _beyond_wall(p[i, 0], p[i, 1], p[i, 2], origin, R, radius, slope, A, m, k, phase, by_size, tail,
                              order, powers, table, s0, h, surface, top)


@njit(cache=True, nogil=True)
def query_points(wall, p, dist, normal, material):
    """The terrain ``wall``'s (FourierWall) distance, normal and material at points p, by _distance."""
    origin, R, radius, slope, A, m, k, phase = wall.origin, wall.R, wall.radius, wall.slope, wall.A, wall.m, wall.k, \
        wall.phase
    Am, Ak, order, table, s0, h, surface, top = wall.Am, wall.Ak, wall.order, wall.table, wall.s0, wall.h, \
        wall.surface, wall.top
    region_material = wall.region_material
    powers = np.empty((4, max(order + 1, A.shape[0])))
    for i in range(p.shape[0]):
        dist[i], region = _distance(p[i, 0], p[i, 1], p[i, 2], origin, R, radius, slope, A, m, k, phase, Am, Ak,
                                    order, powers, table, s0, h, surface, top, normal[i])
        material[i] = region_material[region]


@njit(cache=True, nogil=True)
def newton(wall, o, d, rays, iterations, tolerance, grazing, limit, near, albedo_m, color_m, distance, normal, albedo,
           color, material):
    """On the terrain ``wall`` (FourierWall), the NumPy iteration of .ray_caster.StaticTerrainScene._refine, written out, for the rays
    ``rays`` of (o, d) from their mesh hits ``distance`` (at most ``iterations`` steps, done once
    the error left is below ``tolerance`` m: .ray_caster.REFINE_TOLERANCE): where it converges, the
    refined distance,
    normal facing the ray, material and its albedo and colour (albedo_m, color_m per material)
    replace the mesh hit's in place. A mesh hit nearer than ``near`` m whose ray is inside the
    terrain at ``near`` (the true surface crossed before it: ``_beyond_wall``) is kept as it is:
    a sensor only needs to know it is nearer (a lidar's minimum range)."""
    origin, R, radius, slope, A, m, k, phase = wall.origin, wall.R, wall.radius, wall.slope, wall.A, wall.m, wall.k, \
        wall.phase
    Am, Ak, by_size, tail, order, table = wall.Am, wall.Ak, wall.by_size, wall.tail, wall.order, wall.table
    s0, h, surface, top, region_material = wall.s0, wall.h, wall.surface, wall.top, wall.region_material
    powers = np.empty((4, max(order + 1, A.shape[0])))
    n = np.empty(3)
    for q in range(rays.shape[0]):
        i = rays[q]
        t0 = distance[i]
        if t0 < near and _beyond_wall(o[i, 0] + near * d[i, 0], o[i, 1] + near * d[i, 1], o[i, 2] + near * d[i, 2],
                                      origin, R, radius, slope, A, m, k, phase, by_size, tail, order, powers, table,
                                      s0, h, surface, top):
            continue
        t = t0
        good = True
        slope_r = 0.0
        region = 0
        last = 0.0
        for _ in range(iterations):
            dist, region = _distance(o[i, 0] + t * d[i, 0], o[i, 1] + t * d[i, 1], o[i, 2] + t * d[i, 2], origin, R,
                                     radius, slope, A, m, k, phase, Am, Ak, order, powers, table, s0, h, surface,
                                     top, n)
            slope_r = n[0] * d[i, 0] + n[1] * d[i, 1] + n[2] * d[i, 2]
            if abs(slope_r) <= grazing:
                good = False
                break
            step = dist / slope_r
            t = t - step
            a = abs(step)
            if a < tolerance or a * a * a < tolerance * last * last:      # error left ≈ a³/last² (``done``)
                break
            last = a
        if not (good and abs(t - t0) < limit):
            continue
        distance[i] = t
        # normal and material from the last query, one Newton step before t
        sign = -1.0 if slope_r > 0 else 1.0
        for a in range(3):
            normal[i, a] = n[a] * sign
        mat = region_material[region]
        material[i] = mat
        albedo[i] = albedo_m[mat]
        for c in range(3):
            color[i, c] = color_m[mat, c]


# --- height fields (DEM) -----------------------------------------------------------------------------
#
# A DEM's sensor mesh is its grid cut into two triangles a cell; the contact touches the bilinear
# surface (components/terrain/dem.py, ``HeightField.height``). In the cell (i, j), with u, v in [0, 1]
# the position in the cell (x = x0 + (j + u)·res, y = y0 + (i + v)·res),
#
#     h = a + b·u + c·v + e·u·v,   a = z00, b = z01 − z00, c = z10 − z00, e = z00 − z01 − z10 + z11
#
# (z00 = z[i, j], z01 = z[i, j + 1], z10 = z[i + 1, j], z11 = z[i + 1, j + 1]), so it departs from
# either triangle by e·v·(1 − u) (or e·u·(1 − v)): up to |e|/4 above or below the mesh, inside a
# cell. Along a ray (u, v and z linear in t) f(t) = z_ray − h is a quadratic in t, solved exactly
# per cell. The bilinear surface may rise above the mesh in a cell the ray passes over before its
# mesh hit (a grazing ray skimming a ridge), so the first crossing is searched from the ray's
# origin, not near the mesh hit: a 2-D DDA over the cells the ray crosses (Amanatides & Woo), a
# cell skipped without solving when the ray is above its highest corner all through it (a bilinear
# patch lies within its corners' range), and the same first over blocks of BLOCK x BLOCK cells; the
# walk starts where the ray is inside the grid and below its highest sample, and ends ``limit`` past
# the mesh hit (beyond it the mesh hit is kept, as the Newton refiners keep theirs). The grid's flat
# extension past its edges (``HeightField.height``) has no mesh and is not searched.
# tests/perception/test_dem_hits.py checks the hits against the contact's height query.

#: one height field, as ``dem_hits`` reads it: z (ny, nx) m, its cells' highest corners (ny − 1, nx − 1),
#: the grid's highest sample, origin and spacing (m), and the surface's material index
DemGrid = record("DemGrid", ("z", "cell_max", "block_max", "top", "x0", "y0", "res", "material"))

#: cells a side of the walk's blocks (a block's highest corner lets a ray high above it skip its
#: cells at once)
BLOCK = 8
#: cells past the grid's edges the walk still takes as on it (the patch's extension there is off
#: the flat extension by |slope|·EDGE·res at most: 1e-10 m at 5 cm cells and slope 2); a direction
#: crossing fewer cells than this over the walk is held along the grid's lines
EDGE = 1e-9

#: dem_hits' codes for a ray that meets no surface in its walk, or starts below it
NO_CROSSING, STARTS_INSIDE = -1.0, -2.0


class DemRefiner:
    """The exact hits of a height field's bilinear surface: what ``HeightField.refiner`` returns.
    ``refine`` has FourierRefiner's arguments (the Newton ones are not used: the root is solved, not
    iterated)."""

    def __init__(self, dem):
        z = np.ascontiguousarray(dem.z, dtype=np.float64)
        corners = np.maximum(np.maximum(z[:-1, :-1], z[:-1, 1:]), np.maximum(z[1:, :-1], z[1:, 1:]))
        self.z, self.cell_max = z, np.ascontiguousarray(corners)
        # blocks of BLOCK x BLOCK cells (the last ones partial): their cells' highest corner
        pad = -(-np.array(corners.shape) // BLOCK) * BLOCK - corners.shape
        padded = np.pad(corners, ((0, pad[0]), (0, pad[1])), constant_values=-np.inf)
        blocks = padded.reshape(padded.shape[0] // BLOCK, BLOCK, padded.shape[1] // BLOCK, BLOCK).max(axis=(1, 3))
        self.block_max = np.ascontiguousarray(blocks)
        self.grid = DemGrid(z=self.z, cell_max=self.cell_max, block_max=self.block_max, top=float(z.max()),
                            x0=float(dem.x0), y0=float(dem.y0), res=float(dem.res),
                            material=int(dem.region_material[0]))

    def refine(self, o, d, rays, iterations: int, tolerance: float, grazing: float, limit: float, albedo_m, color_m,
               distance, normal, albedo, color, material, near: float = 0.0):
        """The first crossing of the bilinear surface of rays ``rays`` of (o, d (n, 3)), searched up to
        ``limit`` m past their mesh hits (``distance``); in place where one is found (``dem_hits``)."""
        dem_hits(self.grid, o, d, rays, float(limit), float(near), albedo_m, color_m, distance, normal, albedo,
                 color, material)

    def first_crossing(self, o, d, t_end) -> np.ndarray:
        """(n,) the first t in [0, t_end] (m, per ray) where rays o + t·d (n, 3) meet the surface inside
        the grid; NO_CROSSING where none, STARTS_INSIDE where a ray starts below it (``_crossing``)."""
        o = np.ascontiguousarray(o, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(d, dtype=np.float64).reshape(-1, 3)
        t = np.broadcast_to(np.asarray(t_end, dtype=np.float64), (len(o),)).copy()
        crossings(self.grid, o, d, t)
        return t


@njit(cache=True, nogil=True)
def _bilinear_below(z, x0, y0, res, x, y, zp):
    """Whether the point (x, y, zp) is below the bilinear surface (flat past the grid's edges, as
    ``HeightField.height``)."""
    ny, nx = z.shape
    fx = min(max((x - x0) / res, 0.0), nx - 1.0)
    fy = min(max((y - y0) / res, 0.0), ny - 1.0)
    j = min(int(fx), nx - 2)
    i = min(int(fy), ny - 2)
    u, v = fx - j, fy - i
    h = (1 - v) * ((1 - u) * z[i, j] + u * z[i, j + 1]) + v * ((1 - u) * z[i + 1, j] + u * z[i + 1, j + 1])
    return zp < h


@njit(cache=True, nogil=True)
def _cell_root(z, i, j, ua, va, za, gdx, gdy, dz, length, first):
    """The smallest s in [0, length] where za + s·dz meets the cell (i, j)'s bilinear patch along
    u = ua + s·gdx, v = va + s·gdy (s from the ray's entry into the cell); -1 where none, −2 where
    the ray enters the first cell walked below the surface."""
    a = z[i, j]
    b = z[i, j + 1] - a
    c = z[i + 1, j] - a
    e = a - z[i, j + 1] - z[i + 1, j] + z[i + 1, j + 1]
    # f(s) = z_ray − h = A s² + B s + C
    A = -e * gdx * gdy
    B = dz - b * gdx - c * gdy - e * (ua * gdy + va * gdx)
    C = za - (a + b * ua + c * va + e * ua * va)
    if C <= 0.0:
        # at the entry already at or below: the root is the entry (a crossing on the cell's border
        # rounded into this cell), unless this is where the walk starts (the ray starts inside)
        return -2.0 if first and C < 0.0 else 0.0
    best = -1.0
    if A == 0.0:
        if B < 0.0:
            best = -C / B
    else:
        disc = B * B - 4.0 * A * C
        if disc >= 0.0:
            # the stable pair: q = −(B + sign(B)√disc)/2, roots q/A and C/q
            q = -0.5 * (B + math.copysign(math.sqrt(disc), B))
            r1 = q / A
            r2 = C / q if q != 0.0 else r1
            lo, hi = min(r1, r2), max(r1, r2)
            best = lo if lo >= 0.0 else hi
    return best if 0.0 <= best <= length else -1.0


@njit(cache=True, nogil=True, inline="always")
def _walk_start(gx0, gy0, gdx, gdy, lo, ncols, nrows):
    """A 2-D DDA's start over a grid of ncols × nrows units, the ray at g0 + t·gd (grid units): the unit
    (column j, row i) it is in at t = lo, its steps (sx, sy), and for the far borders column j + bx,
    row i + by, reached at t = (border)·inverse, the offsets (bx, by) and inverses (ix, iy; 0 where the
    ray runs along the axis)."""
    gx, gy = gx0 + lo * gdx, gy0 + lo * gdy
    j, i = int(math.floor(gx)), int(math.floor(gy))
    if gdx < 0.0 and j == gx:          # on a border going down: the unit below it
        j -= 1
    if gdy < 0.0 and i == gy:
        i -= 1
    j, i = min(max(j, 0), ncols - 1), min(max(i, 0), nrows - 1)
    sx = 1 if gdx > 0.0 else -1
    sy = 1 if gdy > 0.0 else -1
    bx, by = (1 if gdx > 0.0 else 0) - gx0, (1 if gdy > 0.0 else 0) - gy0
    ix = 1.0 / gdx if gdx != 0.0 else 0.0
    iy = 1.0 / gdy if gdy != 0.0 else 0.0
    return j, i, sx, sy, bx, by, ix, iy


@njit(cache=True, nogil=True)
def _cells(z, cell_max, gx0, gy0, gdx, gdy, oz, dz, lo, hi, first, hit):
    """The cell walk over t in [lo, hi] (the ray inside the grid there): the first root of
    ``_cell_root`` in the cells the ray crosses, from the one it is in at lo; -> t (hit: row, column,
    u), NO_CROSSING or STARTS_INSIDE (``first``: lo is the start of the whole walk)."""
    ny, nx = z.shape
    j, i, sx, sy, bx, by, ix, iy = _walk_start(gx0, gy0, gdx, gdy, lo, nx - 1, ny - 1)
    ta = lo
    for _ in range(nx + ny + 2):
        tx = (j + bx) * ix if gdx != 0.0 else math.inf
        ty = (i + by) * iy if gdy != 0.0 else math.inf
        tb = max(min(tx, ty, hi), ta)
        # the ray's lowest point in the cell above its highest corner: no crossing here
        if min(oz + ta * dz, oz + tb * dz) <= cell_max[i, j]:
            ua, va = gx0 + ta * gdx - j, gy0 + ta * gdy - i
            s = _cell_root(z, i, j, ua, va, oz + ta * dz, gdx, gdy, dz, tb - ta, first)
            if s == -2.0:
                return STARTS_INSIDE
            if s >= 0.0:
                hit[0], hit[1] = i, j
                hit[2] = ua + s * gdx
                return ta + s
        first = False
        if tb >= hi:
            break
        if tx <= ty:
            j += sx
        else:
            i += sy
        if j < 0 or j > nx - 2 or i < 0 or i > ny - 2:
            break
        ta = tb
    return NO_CROSSING


@njit(cache=True, nogil=True)
def _crossing(z, cell_max, block_max, top, x0, y0, res, ox, oy, oz, dx, dy, dz, t_end, hit):
    """The first t in [0, t_end] where o + t·d meets the bilinear surface inside the grid, and in
    hit (3,) the cell row, column and the crossing's u; -> t, NO_CROSSING or STARTS_INSIDE. The walk
    (module section above) goes over blocks of BLOCK x BLOCK cells first, a block skipped when the
    ray is above its highest corner all through it, the cells of the others walked (``_cells``)."""
    ny, nx = z.shape
    gx0, gy0 = (ox - x0) / res, (oy - y0) / res
    gdx, gdy = dx / res, dy / res
    lo, hi = 0.0, t_end
    # the part of the ray over the grid (widened by EDGE: a ray along an edge, its direction
    # rounded off it, stays on it) ...
    if gdx != 0.0:
        ta, tb = (-EDGE - gx0) / gdx, (nx - 1 + EDGE - gx0) / gdx
        lo, hi = max(lo, min(ta, tb)), min(hi, max(ta, tb))
    elif gx0 < -EDGE or gx0 > nx - 1 + EDGE:
        return NO_CROSSING
    if gdy != 0.0:
        ta, tb = (-EDGE - gy0) / gdy, (ny - 1 + EDGE - gy0) / gdy
        lo, hi = max(lo, min(ta, tb)), min(hi, max(ta, tb))
    elif gy0 < -EDGE or gy0 > ny - 1 + EDGE:
        return NO_CROSSING
    # ... and below its highest sample (nothing above it can be met)
    if dz < 0.0:
        lo = max(lo, (top - oz) / dz)
    elif dz > 0.0:
        hi = min(hi, (top - oz) / dz)
    elif oz > top:
        return NO_CROSSING
    if not lo <= hi:
        return NO_CROSSING
    # a direction that crosses less than EDGE cells over the walk is along the grid's lines (its
    # component is the rounding of a direction on them): held to them, not stepped off an edge
    if abs(gdx) * (hi - lo) < EDGE:
        gdx = 0.0
    if abs(gdy) * (hi - lo) < EDGE:
        gdy = 0.0
    # the block walk: the cells' walk in block units
    nby, nbx = block_max.shape
    bx0, by0, bdx, bdy = gx0 / BLOCK, gy0 / BLOCK, gdx / BLOCK, gdy / BLOCK
    j, i, sx, sy, bx, by, ix, iy = _walk_start(bx0, by0, bdx, bdy, lo, nbx, nby)
    ta = lo
    for _ in range(nbx + nby + 2):
        tx = (j + bx) * ix if bdx != 0.0 else math.inf
        ty = (i + by) * iy if bdy != 0.0 else math.inf
        tb = max(min(tx, ty, hi), ta)
        if min(oz + ta * dz, oz + tb * dz) <= block_max[i, j]:
            t = _cells(z, cell_max, gx0, gy0, gdx, gdy, oz, dz, ta, tb, ta == lo, hit)
            if t != NO_CROSSING:
                return t
        if tb >= hi:
            break
        if tx <= ty:
            j += sx
        else:
            i += sy
        if j < 0 or j >= nbx or i < 0 or i >= nby:
            break
        ta = tb
    return NO_CROSSING


@njit(cache=True, nogil=True)
def crossings(grid, o, d, t):
    """t[k] (in: the walk's end, m) <- the first crossing of ray k (``_crossing``)."""
    z, cell_max, block_max, top = grid.z, grid.cell_max, grid.block_max, grid.top
    x0, y0, res = grid.x0, grid.y0, grid.res
    hit = np.empty(3)
    for k in range(o.shape[0]):
        t[k] = _crossing(z, cell_max, block_max, top, x0, y0, res, o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2],
                         t[k], hit)


@njit(cache=True, nogil=True)
def dem_hits(grid, o, d, rays, limit, near, albedo_m, color_m, distance, normal, albedo, color, material):
    """For the rays ``rays`` of (o, d) with mesh hits ``distance``: the first crossing of the bilinear
    surface (``_crossing``, walked from the origin to ``limit`` m past the mesh hit) replaces the
    mesh hit's distance, normal (the surface's, facing the ray), material, albedo and colour in
    place. Kept as they are: a ray with no crossing there (the mesh hit off the grid's surface by
    more than ``limit``), one that starts below the surface, and a mesh hit nearer than ``near`` m
    whose ray is below the surface at ``near`` (it only blocks: a lidar's minimum range)."""
    z, cell_max, block_max, top = grid.z, grid.cell_max, grid.block_max, grid.top
    x0, y0, res, mat = grid.x0, grid.y0, grid.res, grid.material
    hit = np.empty(3)
    for q in range(rays.shape[0]):
        k = rays[q]
        t0 = distance[k]
        ox, oy, oz, dx, dy, dz = o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2]
        if t0 < near and _bilinear_below(z, x0, y0, res, ox + near * dx, oy + near * dy, oz + near * dz):
            continue
        t = _crossing(z, cell_max, block_max, top, x0, y0, res, ox, oy, oz, dx, dy, dz, t0 + limit, hit)
        if t < 0.0:
            continue
        i, j, u = int(hit[0]), int(hit[1]), hit[2]
        v = (oy + t * dy - y0) / res - i
        u, v = min(max(u, 0.0), 1.0), min(max(v, 0.0), 1.0)
        a = z[i, j]
        e = a - z[i, j + 1] - z[i + 1, j] + z[i + 1, j + 1]
        hx = (z[i, j + 1] - a + e * v) / res
        hy = (z[i + 1, j] - a + e * u) / res
        s = 1.0 / math.sqrt(1.0 + hx * hx + hy * hy)
        nx_, ny_, nz_ = -hx * s, -hy * s, s
        if nx_ * dx + ny_ * dy + nz_ * dz > 0.0:
            nx_, ny_, nz_ = -nx_, -ny_, -nz_
        distance[k] = t
        normal[k, 0], normal[k, 1], normal[k, 2] = nx_, ny_, nz_
        material[k] = mat
        albedo[k] = albedo_m[mat]
        for c in range(3):
            color[k, c] = color_m[mat, c]
