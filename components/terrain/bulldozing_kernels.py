"""Kernels of the deformable soil's bulldozing (bulldozing.py has the model): the commit's log of contact nodes,
and the step's soil heaped on each contact patch's rim and eroded to the angle of repose.

The log (``entries`` (cap, 4): i, j, the volume the node's commit pressed out (m³, its plastic sinkage's
growth × cell²), the patch; ``count`` [entries, overflow]) is written by the contact kernels' commit
(``commit_logged``) and read once per commit by ``bulldoze``. ``mark`` (the tile pool's shape, int8) tags
nodes during one ``bulldoze``: 1 in contact, 2 rim, 3 reached by erosion; it is all zero between calls.
Soil put on a node refills its rut first and then raises its virgin level (``lift``, deformable_kernels.py);
soil taken off comes from what was heaped first, then deepens the rut (``add_soil``, ``remove_soil``), so
``lift`` and ``plastic`` do not both grow where soil is pushed to and fro. Heights are compared as relief on
the base (lift − plastic), so a DEM's own slopes never erode.
"""

from __future__ import annotations

from numba import njit

from .deformable_kernels import GCELL, GNX, GNY, TILE, commit_node, node_state, slot_for

_NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1))


@njit(cache=True)
def commit_logged(grid, soil, tile_of, plastic, yield_p, used, i, j, s, b, ca, entries, count, patch):
    """commit_node (deformable_kernels.py), and with a log (``entries`` not empty) the node and the volume its
    commit pressed out, for ``bulldoze``."""
    if entries.shape[0] == 0:
        return commit_node(grid, soil, tile_of, plastic, yield_p, used, i, j, s, b, ca)
    before = node_state(tile_of, plastic, yield_p, i, j)[0]
    f = commit_node(grid, soil, tile_of, plastic, yield_p, used, i, j, s, b, ca)
    if f < 0:
        return f
    n = count[0]
    if n >= entries.shape[0]:
        count[1] = 1
        return f
    entries[n, 0], entries[n, 1] = i, j
    entries[n, 2] = (node_state(tile_of, plastic, yield_p, i, j)[0] - before) * grid[GCELL] * grid[GCELL]
    entries[n, 3] = patch
    count[0] = n + 1
    return f


@njit(cache=True, inline="always")
def add_soil(plastic, yield_p, lift, k, a, b, t):
    """Put a layer t (m, ≥ 0) of loose soil on node (k, a, b): it refills the node's rut first, then raises
    its virgin level; the node's top is loose again (its yield memory cleared)."""
    refill = min(t, plastic[k, a, b])
    plastic[k, a, b] -= refill
    lift[k, a, b] += t - refill
    yield_p[k, a, b] = 0.0


@njit(cache=True, inline="always")
def remove_soil(plastic, lift, k, a, b, t):
    """Take a layer t (m, ≥ 0) off node (k, a, b): from what was heaped on it first, then from below its
    virgin level (a deeper rut)."""
    cut = min(t, lift[k, a, b])
    lift[k, a, b] -= cut
    plastic[k, a, b] += t - cut


@njit(cache=True)
def _slot(grid, tile_of, used, i, j):
    """(slot, a, b) of node (i, j), its tile given one on first touch; slot −2 outside the patch, −1 when the
    tile pool is full."""
    if i < 0 or j < 0 or i >= grid[GNX] or j >= grid[GNY]:
        return -2, 0, 0
    return slot_for(tile_of, used, i, j), i % TILE, j % TILE


@njit(cache=True)
def bulldoze(grid, tile_of, plastic, yield_p, lift, used, entries, count, mark, queue, flow_factor, tan_repose,
             iterations):
    """Heap each patch's pressed-out volume on its rim, then erode (bulldozing.py). Returns the number of rim
    nodes raised, −1 when the tile pool ran out. Empties the log."""
    n = count[0]
    count[0] = 0
    cell = grid[GCELL]
    area = cell * cell
    for e in range(n):
        k, a, b = _slot(grid, tile_of, used, int(entries[e, 0]), int(entries[e, 1]))
        if k == -1:
            return -1
        mark[k, a, b] = 1
    # the rim of each patch (the log holds a patch's nodes together): its nodes' 4-neighbours not in contact
    nq = 0
    raised = 0
    e = 0
    while e < n:
        patch, e0, vol = entries[e, 3], e, 0.0
        while e < n and entries[e, 3] == patch:
            vol += entries[e, 2]
            e += 1
        q0 = nq
        for e1 in range(e0, e):
            i, j = int(entries[e1, 0]), int(entries[e1, 1])
            for d in _NEIGHBOURS:
                k, a, b = _slot(grid, tile_of, used, i + d[0], j + d[1])
                if k == -1:
                    return -1
                if k < 0 or mark[k, a, b] != 0 or nq >= queue.shape[0]:
                    continue
                mark[k, a, b] = 2
                queue[nq, 0], queue[nq, 1] = i + d[0], j + d[1]
                nq += 1
        if nq > q0 and vol > 0.0:
            dz = flow_factor * vol / ((nq - q0) * area)
            for q in range(q0, nq):
                k, a, b = _slot(grid, tile_of, used, queue[q, 0], queue[q, 1])
                add_soil(plastic, yield_p, lift, k, a, b, dz)
            raised += nq - q0
    # erosion: soil slides from a queued node to a neighbour out of contact while their relief differs by
    # more than the repose slope allows over one cell (half the excess per move: the pair ends at the limit);
    # neighbours that receive soil join the queue (the heap spreads outwards one ring an iteration)
    limit = cell * tan_repose
    for _ in range(iterations):
        end = nq
        moved = False
        for q in range(end):
            i, j = queue[q, 0], queue[q, 1]
            k, a, b = _slot(grid, tile_of, used, i, j)
            for d in _NEIGHBOURS:
                k2, a2, b2 = _slot(grid, tile_of, used, i + d[0], j + d[1])
                if k2 == -1:
                    return -1
                if k2 < 0 or mark[k2, a2, b2] == 1:
                    continue
                excess = (lift[k, a, b] - plastic[k, a, b]) - (lift[k2, a2, b2] - plastic[k2, a2, b2]) - limit
                if excess <= 0.0:
                    continue
                moved = True
                remove_soil(plastic, lift, k, a, b, 0.5 * excess)
                add_soil(plastic, yield_p, lift, k2, a2, b2, 0.5 * excess)
                if mark[k2, a2, b2] == 0 and nq < queue.shape[0]:
                    mark[k2, a2, b2] = 3
                    queue[nq, 0], queue[nq, 1] = i + d[0], j + d[1]
                    nq += 1
        if not moved:
            break                            # every pair within the repose slope: settled
    for e in range(n):
        k, a, b = _slot(grid, tile_of, used, int(entries[e, 0]), int(entries[e, 1]))
        mark[k, a, b] = 0
    for q in range(nq):
        k, a, b = _slot(grid, tile_of, used, queue[q, 0], queue[q, 1])
        mark[k, a, b] = 0
    return raised
