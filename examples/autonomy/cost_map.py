"""A 2-D obstacle cost map built from lidar points in the world frame (the node's own map).

Grid: cells of ``resolution`` m over [x0, x1] x [y0, y1] in ``world``, cell (i, j) centred at
(x0 + (i + 0.5)·res, y0 + (j + 0.5)·res). Each scan is judged on its own, then the verdicts add up:

    top, bottom   highest and lowest return of this scan per cell (m, world z)
    step          top − (lowest return of this scan within ground_window m) > max_step
    slope         |∇ top| > tan(max_slope), between neighbouring cells this scan saw
    hits[i, j]   += step | slope;   an obstacle once hits >= min_hits

Heights are compared within one scan and within ``ground_window`` m, never against a global plane or
another scan: a pose error of δ rad tilts returns at range r by r·δ (5 cm at 5 m for 0.01 rad, while
the head rocks), and two scans with different errors, or one scan against a fixed ground plane, would
read the ice as rings of obstacles. Obstacles are inflated by ``inflate`` m (lethal: the robot's
half-width, or its swept half-width when it steers; scipy's Euclidean distance transform) and a soft
cost that falls off linearly over ``soft`` m beyond it, so the planner keeps to the middle of a gap.
Unseen cells cost ``unknown`` extra (free but not preferred). The map never forgets an obstacle (a
static world); points near the robot's own body are dropped by the caller before :meth:`CostMap.add`
(the lidar sees the body behind it).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

LETHAL = np.inf


@dataclass
class CostMapParams:
    x0: float = -5.0          # m, world frame extent
    x1: float = 11.0
    y0: float = -4.5
    y1: float = 4.5
    resolution: float = 0.05  # m per cell
    max_step: float = 0.05    # m above the local ground: an obstacle
    max_slope: float = 0.6    # rad
    ground_window: float = 0.35  # m, square around a cell where its local ground is looked for
    min_hits: int = 2         # scans that must see a step or slope in a cell
    inflate: float = 0.2      # m, lethal radius around an obstacle (robot half-width + margin)
    soft: float = 1.0         # m beyond it over which the cost falls to 0
    soft_weight: float = 4.0  # cost at the edge of the lethal zone (per m travelled, on top of 1)
    unknown: float = 0.5      # extra cost per m through a never-seen cell


class CostMap:
    """Obstacle evidence per cell from lidar scans, and the traversal cost (1 + extra, LETHAL for obstacles)."""

    def __init__(self, p: CostMapParams = CostMapParams()):
        self.p = p
        self.shape = (int(round((p.x1 - p.x0) / p.resolution)), int(round((p.y1 - p.y0) / p.resolution)))
        self.hits = np.zeros(self.shape, dtype=np.int32)   # scans that saw a step or slope here
        self.seen = np.zeros(self.shape, dtype=bool)

    def cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell indices (i, j) of points xy [n, 2] and a mask of those inside the grid."""
        p = self.p
        ij = np.floor((np.asarray(xy)[..., :2] - (p.x0, p.y0)) / p.resolution).astype(int)
        inside = (ij[..., 0] >= 0) & (ij[..., 0] < self.shape[0]) & (ij[..., 1] >= 0) & (ij[..., 1] < self.shape[1])
        return ij[..., 0], ij[..., 1], inside

    def center(self, i, j) -> np.ndarray:
        p = self.p
        return np.stack([p.x0 + (np.asarray(i) + 0.5) * p.resolution, p.y0 + (np.asarray(j) + 0.5) * p.resolution], -1)

    def add(self, points: np.ndarray) -> None:
        """Take one scan's returns [n, 3] (m, world frame)."""
        p = self.p
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        pts = pts[np.isfinite(pts).all(axis=1)]
        i, j, inside = self.cell(pts)
        i, j, z = i[inside], j[inside], pts[inside, 2]
        top = np.full(self.shape, -np.inf)
        bottom = np.full(self.shape, np.inf)
        np.maximum.at(top, (i, j), z)
        np.minimum.at(bottom, (i, j), z)
        seen = np.isfinite(top)
        k = max(1, int(round(p.ground_window / p.resolution)))
        ground = ndimage.minimum_filter(bottom, size=k, mode="constant", cval=np.inf)
        step = seen & (top - ground > p.max_step)
        gx, gy = np.gradient(np.where(seen, top, np.nan), p.resolution)   # NaN beside unseen cells
        slope = np.nan_to_num(np.hypot(gx, gy), nan=0.0) > np.tan(p.max_slope)
        self.hits += step | slope
        self.seen |= seen

    def obstacles(self) -> np.ndarray:
        """Cells holding a step or a slope in at least min_hits scans (bool)."""
        return self.hits >= self.p.min_hits

    def cost(self) -> np.ndarray:
        """Cost per m through each cell: 1 + soft cost + unknown, LETHAL within ``inflate`` of an obstacle."""
        p = self.p
        obstacle = self.obstacles()
        if obstacle.any():
            dist = ndimage.distance_transform_edt(~obstacle) * p.resolution    # m to the nearest obstacle cell
        else:
            dist = np.full(self.shape, np.inf)
        soft = p.soft_weight * np.clip(1.0 - (dist - p.inflate) / p.soft, 0.0, 1.0)
        cost = 1.0 + soft + p.unknown * ~self.seen
        cost[dist <= p.inflate] = LETHAL
        return cost
