"""Obstacle field: flat ground with blocks (oriented boxes) and rocks (spheres) on it,
the perception obstacle course (paper fig. 12).

World frame, metres, radians. The solid is the union of

    ground   the half-space z <= h                              (h = ``ground_height``)
    blocks   boxes: centre c, full edge lengths (sx, sy, sz), orientation roll, pitch, yaw
             (fixed axes x, y, z as in URDF rpy: R = Rz(yaw)·Ry(pitch)·Rx(roll), local -> world)
    rocks    spheres: centre c, radius r; a centre below h gives a half-buried boulder

Signed distance: d(p) = min_i d_i(p) over the solids' exact signed distances

    ground   d = z − h
    block    q = Rᵀ(p − c), e = |q| − s/2 (per axis):  d = ‖max(e, 0)‖ + min(max_k e_k, 0)
    rock     d = ‖p − c‖ − r

Outside the union (d > 0) this is the exact distance to the union, and the closest point is
the winning solid's closest point. Inside (d < 0) it is the depth in the solid that holds the
point deepest, a lower bound of the true depth (to get out one may have to cross other solids
too): the usual bound of a union of distance fields. It is 1-Lipschitz either way.

Buried faces. A block face that lies wholly at or below the ground with its normal pointing
down (the bottom of a block resting on the ground) is not part of the union's surface, so a
block is queried as the prism extended through such faces to infinity (for the union this is
the same solid). Inside a resting block the depth is then measured to its sides and top, and
a point just inside its foot is pushed out sideways, never down into the ground.

Normal: the gradient of the winning solid's distance: +z for the ground, (p − c)/‖p − c‖ for a
rock; for a block outside, the direction from its closest point (face, edge or corner) to p;
inside, the normal of the nearest face. Regions: ground, blocks, rocks (the winning solid's).

Queries run in one numba kernel (obstacle_kernels.py) over the obstacles packed into arrays
once: per point the ground, then the blocks and rocks in index order, keeping the least distance
(ties go to the earlier solid). An exact broad phase skips the obstacles whose bounding sphere is
farther than the best distance so far (a robot on the ice only pays for the obstacles near it);
``broad_phase = False`` evaluates every obstacle for every point (the reference).

:func:`scatter_obstacles` draws a reproducible course of random blocks and rocks (seeded),
without overlaps and outside a keep-clear disc around the robot's start.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from .base import Bounds, Terrain
from .obstacle_kernels import obstacle_query


def rpy_matrix(roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """Rotation local -> world for fixed-axis roll, pitch, yaw (URDF): Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


@dataclasses.dataclass(frozen=True)
class Block:
    """An oriented box: ``center`` (m), full edge lengths ``size`` (m), roll, pitch, yaw (rad)."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0

    @property
    def rotation(self) -> np.ndarray:
        return rpy_matrix(self.roll, self.pitch, self.yaw)

    def corners(self) -> np.ndarray:
        """The 8 corners (world, m), index bits (x, y, z) = (i & 1, i >> 1 & 1, i >> 2 & 1): + if set."""
        sign = np.array([[1 if i & 1 else -1, 1 if i >> 1 & 1 else -1, 1 if i >> 2 & 1 else -1] for i in range(8)])
        return np.asarray(self.center) + (0.5 * sign * np.asarray(self.size)) @ self.rotation.T

    def footprint_radius(self) -> float:
        """Radius about the centre's (x, y) of a disc holding the block's footprint on any ground."""
        c = self.corners()
        return float(np.hypot(*(c[:, :2] - np.asarray(self.center)[:2]).T).max())


@dataclasses.dataclass(frozen=True)
class Rock:
    """A sphere: ``center`` (m), ``radius`` (m)."""

    center: tuple[float, float, float]
    radius: float

    def footprint_radius(self, ground_height: float) -> float:
        """Radius of the widest horizontal section above the ground (the base of a buried rock)."""
        below = ground_height - self.center[2]
        return self.radius if below <= 0 else float(np.sqrt(max(self.radius ** 2 - below ** 2, 0.0)))


def _check_obstacles(blocks: Sequence[Block], rocks: Sequence[Rock]):
    for i, b in enumerate(blocks):
        v = np.array([*b.center, *b.size, b.yaw, b.roll, b.pitch], dtype=float)
        if not np.isfinite(v).all() or min(b.size) <= 0:
            raise ValueError(f"block {i}: center {list(b.center)} m, size {list(b.size)} m, "
                             f"rpy {[b.roll, b.pitch, b.yaw]} rad: need finite values and every edge > 0")
    for i, r in enumerate(rocks):
        if not np.isfinite([*r.center, r.radius]).all() or r.radius <= 0:
            raise ValueError(f"rock {i}: center {list(r.center)} m, radius {r.radius} m: "
                             f"need finite values and radius > 0")


class ObstacleField(Terrain):
    """Ground plane z = ``ground_height`` united with ``blocks`` and ``rocks``; see the module doc.

    Regions: ground, blocks, rocks.
    """

    kind = "obstacles"
    regions = ("ground", "blocks", "rocks")
    GROUND, BLOCKS, ROCKS = range(3)

    def __init__(self, ground_height: float = 0.0, blocks: Sequence[Block] = (), rocks: Sequence[Rock] = (),
                 **kw):
        super().__init__(**kw)
        if not np.isfinite(ground_height):
            raise ValueError(f"ground_height = {ground_height} m must be a finite number")
        _check_obstacles(blocks, rocks)
        self.ground_height = float(ground_height)
        self.blocks, self.rocks = tuple(blocks), tuple(rocks)
        # packed once for the kernel (obstacle_kernels.py)
        self._box_center = np.array([b.center for b in self.blocks], dtype=float).reshape(-1, 3)
        self._box_half = 0.5 * np.array([b.size for b in self.blocks], dtype=float).reshape(-1, 3)
        self._box_rot = np.array([b.rotation for b in self.blocks], dtype=float).reshape(-1, 3, 3)
        self._box_side = np.array([buried_sides(b, self.ground_height) for b in self.blocks],
                                  dtype=float).reshape(-1, 3)
        self._box_reach = np.linalg.norm(self._box_half, axis=1)          # bounding sphere radius
        self._box_extended = (self._box_side != 0).any(axis=1)
        deep = [deep_sphere(b, side, self.ground_height) for b, side in zip(self.blocks, self._box_side)]
        self._deep_center = np.array([c for c, _ in deep], dtype=float).reshape(-1, 3)
        self._deep_radius = np.array([r for _, r in deep], dtype=float)
        self._rock_center = np.array([r.center for r in self.rocks], dtype=float).reshape(-1, 3)
        self._rock_radius = np.array([r.radius for r in self.rocks], dtype=float)

    def bounds(self):
        # below the ground everything is solid, so the surface starts at the ground
        tops = [b.corners()[:, 2].max() for b in self.blocks] + [r.center[2] + r.radius for r in self.rocks]
        h = self.ground_height
        return Bounds(np.array([-np.inf, -np.inf, h]), np.array([np.inf, np.inf, max([h, *tops])]))

    #: skip the obstacles that cannot win (bounding spheres, see obstacle_kernels.py); False
    #: evaluates every obstacle for every point (the reference)
    broad_phase: bool = True
    #: consecutive points sharing one broad-phase candidate list (a screw's samples lie together)
    CHUNK = 32

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _obstacles

        return _obstacles(self, center, extent, cell)

    def sensor_cell(self, extent, cell):
        return extent / 4          # the cell only sets the ground's checkerboard; rocks follow SPHERE_CHORD

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        raise NotImplementedError("blocks and rocks on a ground plane have no coal representation yet")

    @property
    def part_count(self) -> int:
        return len(self.blocks) + len(self.rocks)

    def parts(self, points):
        """Blocks in their order, then rocks (block b: part b, rock k: part nb + k); −1 on the ground plane
        (within 1e-6 m, relative beyond 1 m of height), else the obstacle whose surface is nearest."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        part = np.full(len(p), -1, dtype=np.int64)
        h = self.ground_height
        above = np.abs(p[:, 2] - h) > 1e-6 * max(1.0, abs(h))
        if self.part_count and above.any():
            part[above] = np.argmin(np.abs(self._obstacle_distances(p[above])), axis=1)
        return part

    def _obstacle_distances(self, p: np.ndarray) -> np.ndarray:
        """(n, nb + nr) signed distance (m) of points p (n, 3) to each block (plain box) and rock (sphere)."""
        cols = []
        for b in self.blocks:
            q = np.abs((p - np.asarray(b.center)) @ b.rotation) - 0.5 * np.asarray(b.size)
            cols.append(np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0))
        for r in self.rocks:
            cols.append(np.linalg.norm(p - np.asarray(r.center), axis=1) - r.radius)
        return np.stack(cols, axis=1)

    def _query(self, p):
        n = len(p)
        d, normal, region = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64)
        obstacle_query(p, self.ground_height, self._box_center, self._box_rot, self._box_half, self._box_side,
                       self._box_extended, self._box_reach, self._deep_center, self._deep_radius,
                       self._rock_center, self._rock_radius, bool(self.broad_phase), self.CHUNK, d, normal, region)
        return d, normal, region


def deep_sphere(block: Block, side: np.ndarray, ground_height: float) -> tuple[np.ndarray, float]:
    """A sphere (centre, radius) holding every point under the ground where the block, extended
    through its buried faces (``side``, see :func:`buried_sides`), is deeper than the ground.

    There d_block < z − h < 0: the point is inside the extended solid and, as d_block >=
    |local_j| − half_j >= −half_j on an axis j not extended, less than D = min half_j deep. The
    extended solid is the box plus the cone of the buried faces' outward normals u_k (u_k,z < 0);
    its part above z = h − D lies in the box plus the simplex {Σ t_k u_k : Σ t_k |u_k,z| <= T},
    T = highest corner − h + D, the hull H of the corners shifted by 0 and by each
    (T / |u_k,z|) u_k. The vertices of H ∩ {h − D <= z <= h} are among H's points in the slab and
    the crossings of the slab's planes by segments between H's points: the sphere bounds these.
    Radius −inf: no such point (the block never beats the ground under it); inf: no bound (every
    axis extended, or a buried face all but vertical). An unextended block: its bounding sphere."""
    center = np.asarray(block.center, dtype=float)
    half = 0.5 * np.asarray(block.size, dtype=float)
    ext = [k for k in range(3) if side[k] != 0]
    if not ext:
        return center, float(np.linalg.norm(half))
    if len(ext) == 3:
        return center, np.inf
    h = ground_height
    depth = min(half[k] for k in range(3) if side[k] == 0)
    R, corners = block.rotation, block.corners()
    reach = max(corners[:, 2].max() - h + depth, 0.0)
    pts = [corners]
    for k in ext:
        u = -side[k] * R[:, k]                   # outward normal of the buried face, u_z < 0
        pts.append(corners + (reach / -u[2]) * u)
    pts = np.vstack(pts)
    if not np.isfinite(pts).all():
        return center, np.inf
    keep = [pts[(pts[:, 2] >= h - depth) & (pts[:, 2] <= h)]]
    a, b = np.triu_indices(len(pts), 1)
    za, zb = pts[a, 2], pts[b, 2]
    for level in (h - depth, h):
        cross = (za - level) * (zb - level) < 0
        t = (level - za[cross]) / (zb[cross] - za[cross])
        at = pts[a[cross]] + t[:, None] * (pts[b[cross]] - pts[a[cross]])
        at[:, 2] = level
        keep.append(at)
    keep = np.vstack(keep)
    if not len(keep):
        return center, -np.inf
    mid = 0.5 * (keep.min(axis=0) + keep.max(axis=0))
    return mid, float(np.linalg.norm(keep - mid, axis=1).max() * (1 + 1e-9) + 1e-12)


def buried_sides(block: Block, ground_height: float, tol: float = 1e-9) -> np.ndarray:
    """Per local axis: 0, or the sign (±1) of the face to measure against for every point
    because the face on the other side is buried (wholly at or below the ground, facing down)."""
    R, corners = block.rotation, block.corners()
    side = np.zeros(3)
    for k in range(3):
        for s in (1.0, -1.0):
            outward = s * R[:, k]
            face = corners[(np.arange(8) >> k & 1) == (s > 0)]
            if outward[2] < 0 and face[:, 2].max() <= ground_height + tol:
                side[k] = -s
    return side


# -- a seeded random course ----------------------------------------------------------------

def scatter_obstacles(count: int, seed: int, area, size, kinds=("box", "sphere"), keep_clear=None,
                      burial=(0.0, 0.5), min_gap: float = 0.0, ground_height: float = 0.0,
                      occupied: Sequence[Block | Rock] = (), max_tries: int = 2000):
    """``count`` random blocks and rocks, reproducible by ``seed`` -> (blocks, rocks).

    Centres are uniform in ``area`` = (xmin, xmax, ymin, ymax) m; each obstacle is a kind drawn
    from ``kinds`` ("box", "sphere"); ``size`` = (min, max) m is the range of a block's edge
    lengths (each edge drawn separately) and of a rock's diameter. Blocks rest on the ground
    with a random yaw; a rock's centre lies f·r below the ground, f uniform in ``burial``.
    Footprints (discs holding each obstacle's section at the ground) stay ``min_gap`` apart,
    apart from the ``occupied`` obstacles (the hand-placed ones) and outside ``keep_clear`` =
    ((x, y), radius), the robot's start. Raises ValueError when an obstacle finds no room in
    ``max_tries`` draws.
    """
    rng = np.random.default_rng(seed)
    xmin, xmax, ymin, ymax = map(float, area)
    lo, hi = map(float, size)
    h = float(ground_height)
    discs = [(b.center[0], b.center[1], b.footprint_radius()) for b in occupied if isinstance(b, Block)]
    discs += [(r.center[0], r.center[1], r.radius) for r in occupied if isinstance(r, Rock)]
    blocks, rocks = [], []
    for i in range(int(count)):
        for _ in range(max_tries):
            kind = kinds[rng.integers(len(kinds))]
            x, y = float(rng.uniform(xmin, xmax)), float(rng.uniform(ymin, ymax))
            if kind == "box":
                edges = tuple(float(e) for e in rng.uniform(lo, hi, 3))
                ob = Block((x, y, h + 0.5 * edges[2]), edges, yaw=float(rng.uniform(0, np.pi)))
                rad = ob.footprint_radius()
            else:
                r = 0.5 * float(rng.uniform(lo, hi))
                ob = Rock((x, y, h - float(rng.uniform(*burial)) * r), r)
                rad = ob.footprint_radius(h)
            if keep_clear is not None and np.hypot(x - keep_clear[0][0], y - keep_clear[0][1]) < keep_clear[1] + rad:
                continue
            if any(np.hypot(x - cx, y - cy) < rad + cr + min_gap for cx, cy, cr in discs):
                continue
            discs.append((x, y, rad))
            (blocks if kind == "box" else rocks).append(ob)
            break
        else:
            raise ValueError(f"placed only {i} of count = {count} random obstacles: no room left for another "
                             f"(size {[lo, hi]} m, min_gap {min_gap} m) in area {[xmin, xmax, ymin, ymax]} m "
                             f"after {max_tries} draws; lower count or size, or enlarge the area")
    return blocks, rocks
