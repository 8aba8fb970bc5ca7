"""Shortest path on the cost map: Dijkstra over the 8-connected grid (scipy.sparse.csgraph).

Edge (a -> b) between neighbouring cells costs its length (res or res·√2, m) times the mean of the
two cells' costs per m (:meth:`cost_map.CostMap.cost`); edges touching a lethal cell are absent. The
search runs from the start cell over the whole graph once (vectorised in scipy, no Python per cell),
so an A* heuristic would buy little at this size (~30 000 cells). The robot's own cells (``clear``
m around the start) are never lethal: the map may hold returns from the body itself.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

_STEPS = ((1, 0), (0, 1), (1, 1), (1, -1))           # each undirected neighbour pair once


def grid_graph(cost: np.ndarray, resolution: float):
    """Sparse symmetric matrix of edge costs between 8-neighbours (lethal/inf cells left out)."""
    nx, ny = cost.shape
    idx = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, w = [], [], []
    for di, dj in _STEPS:
        a = idx[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
        b = idx[max(0, di):nx + min(0, di) or None, max(0, dj):ny + min(0, dj) or None]
        ca, cb = cost.ravel()[a.ravel()], cost.ravel()[b.ravel()]
        ok = np.isfinite(ca) & np.isfinite(cb)
        length = resolution * np.hypot(di, dj)
        rows += [a.ravel()[ok], b.ravel()[ok]]
        cols += [b.ravel()[ok], a.ravel()[ok]]
        w += [length * 0.5 * (ca[ok] + cb[ok])] * 2
    rows, cols, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(w)
    return coo_matrix((w, (rows, cols)), shape=(nx * ny, nx * ny)).tocsr()


def plan(cost_map, cost: np.ndarray, start_xy, goal_xy, clear: float = 0.25) -> np.ndarray | None:
    """Waypoints [k, 2] (m, world) from start to the goal, or None when no path exists. The goal cell
    is the free cell nearest to ``goal_xy`` when that one is lethal."""
    cost = cost.copy()
    res = cost_map.p.resolution
    si, sj, s_in = cost_map.cell(np.asarray(start_xy, dtype=float)[None])
    gi, gj, g_in = cost_map.cell(np.asarray(goal_xy, dtype=float)[None])
    if not (s_in[0] and g_in[0]):
        raise ValueError(f"start {start_xy} or goal {goal_xy} is outside the cost map")
    ii, jj = np.indices(cost.shape)
    near_start = np.hypot(ii - si[0], jj - sj[0]) * res <= clear
    cost[near_start & ~np.isfinite(cost)] = 1.0
    free = np.isfinite(cost)
    if not free[gi[0], gj[0]]:
        d = np.where(free, np.hypot(ii - gi[0], jj - gj[0]), np.inf)
        gi[0], gj[0] = np.unravel_index(np.argmin(d), d.shape)
    graph = grid_graph(cost, res)
    ny = cost.shape[1]
    start, goal = si[0] * ny + sj[0], gi[0] * ny + gj[0]
    dist, pred = dijkstra(graph, directed=False, indices=start, return_predecessors=True)
    if not np.isfinite(dist[goal]):
        return None
    path = [goal]
    while path[-1] != start:
        path.append(pred[path[-1]])
    path = np.array(path[::-1])
    return cost_map.center(path // ny, path % ny)
