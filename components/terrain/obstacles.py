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

Queries are vectorised over points × obstacles in blocks of at most ``PAIRS_PER_BLOCK`` pairs,
so memory stays a few MB whatever the number of points. A broad phase drops, per block, the
obstacles whose bounding sphere is farther from every point than the ground (a robot on the ice
only pays for the obstacles near it).

:func:`scatter_obstacles` draws a reproducible course of random blocks and rocks (seeded),
without overlaps and outside a keep-clear disc around the robot's start.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from .base import Bounds, Terrain, unit

_Z = np.array([0.0, 0.0, 1.0])
#: point·obstacle pairs per vectorised block (~30 floats of temporaries each: a few MB)
PAIRS_PER_BLOCK = 1 << 15


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
        self._box_center = np.array([b.center for b in self.blocks], dtype=float).reshape(-1, 3)
        self._box_half = 0.5 * np.array([b.size for b in self.blocks], dtype=float).reshape(-1, 3)
        self._box_rot = np.array([b.rotation for b in self.blocks]).reshape(-1, 3, 3)
        self._box_side = np.array([buried_sides(b, self.ground_height) for b in self.blocks]).reshape(-1, 3)
        # local = Rᵀ(p − c) for every block in one product: p @ [R_1 R_2 ...] − (Rᵀc per block)
        self._box_rot_cols = np.concatenate(list(self._box_rot), axis=1) if self.blocks else np.zeros((3, 0))
        self._box_center_local = np.einsum("mi,mij->mj", self._box_center, self._box_rot)
        self._rock_center = np.array([r.center for r in self.rocks], dtype=float).reshape(-1, 3)
        self._rock_radius = np.array([r.radius for r in self.rocks], dtype=float)
        self._box_reach = np.linalg.norm(self._box_half, axis=1)          # bounding sphere radius
        self._box_extended = (self._box_side != 0).any(axis=1)

    def bounds(self):
        # below the ground everything is solid, so the surface starts at the ground
        tops = [b.corners()[:, 2].max() for b in self.blocks] + [r.center[2] + r.radius for r in self.rocks]
        h = self.ground_height
        return Bounds(np.array([-np.inf, -np.inf, h]), np.array([np.inf, np.inf, max([h, *tops])]))

    def _query(self, p):
        n = len(p)
        d, normal, region = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64)
        step = max(1, PAIRS_PER_BLOCK // max(1, len(self.blocks) + len(self.rocks)))
        for s in range(0, n, step):
            sl = slice(s, s + step)
            d[sl], normal[sl], region[sl] = self._query_block(p[sl])
        return d, normal, region

    #: skip, per block of points, the obstacles whose bounding sphere is farther than the ground
    #: from every point (they cannot win); False evaluates every obstacle (the reference)
    broad_phase: bool = True

    def _query_block(self, p):
        """The candidate solids' distances for these points, then the winner's normal and region."""
        k = len(p)
        above = p[:, 2] - self.ground_height                   # the ground's distance
        bi, ri = self._near(p, above)
        candidates = [above[:, None]]
        if len(bi):
            every = len(bi) == len(self.blocks)                  # nothing dropped: no need to gather
            pick = (lambda a: a) if every else (lambda a: a[bi])  # noqa: E731
            rot_cols = self._box_rot_cols if every else self._box_rot_cols.reshape(3, -1, 3)[:, bi].reshape(3, -1)
            local = (p @ rot_cols).reshape(k, len(bi), 3) - pick(self._box_center_local)
            # per axis, the face on this side of the centre; through a buried face, always the other one
            box_side = pick(self._box_side)
            side = np.where(box_side != 0, box_side, np.where(local >= 0, 1.0, -1.0))
            excess = side * local - pick(self._box_half)         # > 0 on the axes where p is beyond a face
            beyond = np.maximum(excess, 0.0)
            candidates.append(np.sqrt(np.einsum("kmj,kmj->km", beyond, beyond)) + np.minimum(excess.max(axis=2), 0.0))
        if len(ri):
            every = len(ri) == len(self.rocks)
            offset = p[:, None, :] - (self._rock_center if every else self._rock_center[ri])
            radius = self._rock_radius if every else self._rock_radius[ri]
            candidates.append(np.sqrt(np.einsum("kmj,kmj->km", offset, offset)) - radius)
        dist = np.concatenate(candidates, axis=1)
        winner = dist.argmin(axis=1)                               # ties go to the ground, then blocks
        d = dist[np.arange(k), winner]
        normal = np.broadcast_to(_Z, (k, 3)).copy()
        region = np.full(k, self.GROUND, dtype=np.int64)
        nb = len(bi)
        on_block = (winner >= 1) & (winner <= nb)
        if on_block.any():
            j = winner[on_block] - 1
            n_local = box_normal(side[on_block, j], excess[on_block, j])
            normal[on_block] = np.einsum("kij,kj->ki", self._box_rot[bi[j]], n_local)
            region[on_block] = self.BLOCKS
        on_rock = winner > nb
        if on_rock.any():
            j = winner[on_rock] - 1 - nb
            normal[on_rock] = unit(offset[on_rock, j])
            region[on_rock] = self.ROCKS
        return d, normal, region

    def _near(self, p, above):
        """Indices of the blocks and rocks that may be nearer than the ground to some point: by
        bounding spheres, except that under the ground a block extended through a buried face
        (unbounded downwards) always may."""
        every = np.arange(len(self.blocks)), np.arange(len(self.rocks))
        if not self.broad_phase:
            return every
        ceiling = above[:, None] + 1e-6            # the sphere distances below lose ~1e-7 to rounding
        pp = np.einsum("kj,kj->k", p, p)[:, None]
        out = []
        for centers, radius, always in ((self._box_center, self._box_reach, self._box_extended),
                                        (self._rock_center, self._rock_radius, None)):
            gap = np.sqrt(np.maximum(pp - 2 * p @ centers.T + np.einsum("mj,mj->m", centers, centers), 0.0)) - radius
            keep = (gap < ceiling).any(axis=0)
            if always is not None and (above < 0).any():
                keep |= always
            out.append(np.flatnonzero(keep))
        return tuple(out)


def box_normal(side: np.ndarray, excess: np.ndarray) -> np.ndarray:
    """Gradient of a box's distance in its frame, for points with per-axis ``excess`` (k, 3) =
    side·local − half size beyond the face on ``side`` (±1): outside, the unit vector from the
    closest point (on a face, edge or corner) to the point; inside or on the surface, the normal
    of the nearest face."""
    outside = excess.max(axis=1) > 0
    out = unit(side * np.maximum(excess, 0.0))
    rows, face = np.arange(len(side)), excess.argmax(axis=1)
    inside = np.zeros_like(side)
    inside[rows, face] = side[rows, face]
    return np.where(outside[:, None], out, inside)


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
