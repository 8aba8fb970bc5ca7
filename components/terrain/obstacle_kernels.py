"""numba kernel of ObstacleField queries (obstacles.py): per point, the ground, then the blocks
and rocks that a broad phase cannot rule out, in index order; the least distance wins (ties go
to the earlier solid: the ground, then blocks, then rocks, as numpy's argmin), and the winner's
normal and region are written.

Arrays, packed once by ObstacleField (nb blocks, nr rocks; obstacle index i < nb is block i,
i >= nb is rock i - nb):

    box_c (nb, 3), box_rot (nb, 3, 3) local -> world, box_half (nb, 3) half edges,
    box_side (nb, 3) per local axis 0 or the sign of the face always measured against (the
    other one is buried), box_ext (nb,) bool: some side is fixed (the block is extended through
    a buried face); box_reach (nb,) bounding-sphere radius about box_c;
    deep_c (nb, 3), deep_r (nb,) for an extended block a sphere holding every point under the
    ground where it can beat the ground (inf: no such bound, -inf: no such point);
    rock_c (nr, 3), rock_r (nr,).

Broad phase, exact (it drops only solids that cannot win; EPS covers rounding):

* per chunk of ``chunk`` consecutive points (a screw's samples, a bundle of rays lie together):
  the axis-aligned box of the points and their largest ground distance A keep the obstacles
  whose bounding sphere comes within A of the box (an extended block: when a point is above
  the ground, so A >= 0, or its deep sphere reaches the box when a point is under the ground);
* per point, over the chunk's obstacles, with ``best`` the least distance so far: skip a rock
  or an unextended block whose bounding-sphere distance g exceeds best (its distance is >= g);
  an extended block above the ground when g > max(best, 0) (outside its bounding sphere it is
  the plain box or, past the buried face, under the ground: distance >= min(g, z - h); inside,
  the extension reaching out of the sphere can make it deeper than g); under the ground when
  the point is outside its deep sphere.

Points with a non-finite coordinate skip the broad phase.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

GROUND, BLOCKS, ROCKS = 0, 1, 2
#: margin of the broad phase's comparisons (m): far above the rounding of the distances
EPS = 1e-9


@njit(cache=True, inline="always")
def _box_excess(px, py, pz, i, box_c, box_rot, box_half, box_side):
    """Per local axis: the side (±1) measured against and the excess beyond that face."""
    dx, dy, dz = px - box_c[i, 0], py - box_c[i, 1], pz - box_c[i, 2]
    l0 = box_rot[i, 0, 0] * dx + box_rot[i, 1, 0] * dy + box_rot[i, 2, 0] * dz
    l1 = box_rot[i, 0, 1] * dx + box_rot[i, 1, 1] * dy + box_rot[i, 2, 1] * dz
    l2 = box_rot[i, 0, 2] * dx + box_rot[i, 1, 2] * dy + box_rot[i, 2, 2] * dz
    s0, s1, s2 = box_side[i, 0], box_side[i, 1], box_side[i, 2]
    if s0 == 0.0:
        s0 = 1.0 if l0 >= 0.0 else -1.0
    if s1 == 0.0:
        s1 = 1.0 if l1 >= 0.0 else -1.0
    if s2 == 0.0:
        s2 = 1.0 if l2 >= 0.0 else -1.0
    return s0, s1, s2, s0 * l0 - box_half[i, 0], s1 * l1 - box_half[i, 1], s2 * l2 - box_half[i, 2]


@njit(cache=True, inline="always")
def _box_distance(e0, e1, e2):
    b0, b1, b2 = max(e0, 0.0), max(e1, 0.0), max(e2, 0.0)
    return math.sqrt(b0 * b0 + b1 * b1 + b2 * b2) + min(max(e0, e1, e2), 0.0)


@njit(cache=True, inline="always")
def _wins(d, best):
    """argmin's rule, visiting in index order: strictly less, or the first NaN."""
    return d < best or (d != d and best == best)


@njit(cache=True, inline="always")
def _aabb_gap2(lo, hi, cx, cy, cz):
    """Squared distance from the point (cx, cy, cz) to the box [lo, hi]."""
    gx = max(lo[0] - cx, 0.0, cx - hi[0])
    gy = max(lo[1] - cy, 0.0, cy - hi[1])
    gz = max(lo[2] - cz, 0.0, cz - hi[2])
    return gx * gx + gy * gy + gz * gz


@njit(cache=True, inline="always")
def _beyond(d2, reach, threshold):
    """Is sqrt(d2) - reach > threshold + EPS (the sphere farther than threshold)?"""
    rhs = threshold + EPS + reach
    return rhs < 0.0 or d2 > rhs * rhs


@njit(cache=True)
def obstacle_query(p, h, box_c, box_rot, box_half, box_side, box_ext, box_reach, deep_c, deep_r, rock_c, rock_r,
                   prune, chunk, out_d, out_normal, out_region):
    """Distance, normal and region of every point p (n, 3) into out_d, out_normal, out_region."""
    n = p.shape[0]
    nb, nr = box_c.shape[0], rock_c.shape[0]
    m = nb + nr
    cand = np.empty(m, dtype=np.int64)
    lo, hi = np.empty(3), np.empty(3)
    for s in range(0, n, chunk):
        e = min(s + chunk, n)
        # -- the chunk's candidates ------------------------------------------------------
        nc = 0
        if prune:
            lo[:] = np.inf
            hi[:] = -np.inf
            top = -np.inf
            any_above, any_below = False, False
            for k in range(s, e):
                x, y, z = p[k, 0], p[k, 1], p[k, 2]
                if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
                    continue
                lo[0], hi[0] = min(lo[0], x), max(hi[0], x)
                lo[1], hi[1] = min(lo[1], y), max(hi[1], y)
                lo[2], hi[2] = min(lo[2], z), max(hi[2], z)
                top = max(top, z - h)
                if z - h < 0.0:
                    any_below = True
                else:
                    any_above = True
            if any_above or any_below:
                for i in range(nb):
                    g2 = _aabb_gap2(lo, hi, box_c[i, 0], box_c[i, 1], box_c[i, 2])
                    if box_ext[i]:
                        keep = any_above and not _beyond(g2, box_reach[i], top)      # top >= 0 here
                        if not keep and any_below:
                            keep = not _beyond(_aabb_gap2(lo, hi, deep_c[i, 0], deep_c[i, 1], deep_c[i, 2]),
                                               deep_r[i], 0.0)
                    else:
                        keep = not _beyond(g2, box_reach[i], top)
                    if keep:
                        cand[nc] = i
                        nc += 1
                for j in range(nr):
                    if not _beyond(_aabb_gap2(lo, hi, rock_c[j, 0], rock_c[j, 1], rock_c[j, 2]), rock_r[j], top):
                        cand[nc] = nb + j
                        nc += 1
        else:
            for i in range(m):
                cand[i] = i
            nc = m
        # -- per point -------------------------------------------------------------------
        for k in range(s, e):
            px, py, pz = p[k, 0], p[k, 1], p[k, 2]
            finite = math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)
            check = prune and finite
            count = nc if (finite or not prune) else m
            best = pz - h
            below = best < 0.0
            win = -1
            for c in range(count):
                i = cand[c] if (finite or not prune) else c
                if i < nb:
                    if check:
                        if box_ext[i]:
                            if below:
                                ox, oy, oz = px - deep_c[i, 0], py - deep_c[i, 1], pz - deep_c[i, 2]
                                if _beyond(ox * ox + oy * oy + oz * oz, deep_r[i], 0.0):
                                    continue
                            else:
                                ox, oy, oz = px - box_c[i, 0], py - box_c[i, 1], pz - box_c[i, 2]
                                if _beyond(ox * ox + oy * oy + oz * oz, box_reach[i], max(best, 0.0)):
                                    continue
                        else:
                            ox, oy, oz = px - box_c[i, 0], py - box_c[i, 1], pz - box_c[i, 2]
                            if _beyond(ox * ox + oy * oy + oz * oz, box_reach[i], best):
                                continue
                    s0, s1, s2, e0, e1, e2 = _box_excess(px, py, pz, i, box_c, box_rot, box_half, box_side)
                    d = _box_distance(e0, e1, e2)
                else:
                    j = i - nb
                    ox, oy, oz = px - rock_c[j, 0], py - rock_c[j, 1], pz - rock_c[j, 2]
                    o2 = ox * ox + oy * oy + oz * oz
                    if check and _beyond(o2, rock_r[j], best):
                        continue
                    d = math.sqrt(o2) - rock_r[j]
                if _wins(d, best):
                    best, win = d, i
            # -- the winner's normal and region --------------------------------------------
            out_d[k] = best
            if win < 0:
                nx, ny, nz = 0.0, 0.0, 1.0
                out_region[k] = GROUND
            elif win < nb:
                s0, s1, s2, e0, e1, e2 = _box_excess(px, py, pz, win, box_c, box_rot, box_half, box_side)
                if max(e0, e1, e2) > 0.0:        # outside: from the closest point (face, edge, corner)
                    a0, a1, a2 = s0 * max(e0, 0.0), s1 * max(e1, 0.0), s2 * max(e2, 0.0)
                    length = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
                    if length > 1e-300:
                        a0, a1, a2 = a0 / length, a1 / length, a2 / length
                    else:
                        a0, a1, a2 = 0.0, 0.0, 1.0
                else:                            # inside: the nearest face (the first of equals)
                    a0, a1, a2 = 0.0, 0.0, 0.0
                    if e0 >= e1 and e0 >= e2:
                        a0 = s0
                    elif e1 >= e2:
                        a1 = s1
                    else:
                        a2 = s2
                R = box_rot[win]
                nx = R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2
                ny = R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2
                nz = R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2
                out_region[k] = BLOCKS
            else:
                j = win - nb
                ox, oy, oz = px - rock_c[j, 0], py - rock_c[j, 1], pz - rock_c[j, 2]
                length = math.sqrt(ox * ox + oy * oy + oz * oz)
                if length > 1e-300:
                    nx, ny, nz = ox / length, oy / length, oz / length
                else:
                    nx, ny, nz = 0.0, 0.0, 1.0
                out_region[k] = ROCKS
            out_normal[k, 0] = nx
            out_normal[k, 1] = ny
            out_normal[k, 2] = nz
