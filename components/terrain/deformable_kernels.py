"""Kernels of the deformable height field (deformable.py): sparse tiled node storage, the surface a
consumer sees, and the soil's pressure–sinkage law with its elastic unloading (SCM).

Storage. Nodes sit at x = x0 + i·cell, y = y0 + j·cell (0 ≤ i < nx, 0 ≤ j < ny). They are grouped in
TILE × TILE tiles; ``tile_of[ti, tj]`` is the slot of tile (ti, tj) in the pool arrays, −1 while no
contact ever touched it (its nodes are then virgin: no sinkage, no yield memory). A tile is given a slot
on its first committed load (``slot_for``); ``used[0]`` counts the slots given, ``used[1]`` is set to 1
when the pool was full (the component stops the run naming the terrain file and ``max_tiles``).

Per node (pool arrays, shape (max_tiles, TILE, TILE)):

    plastic[k, a, b]   m    plastic sinkage s_p: the rut, lasting (the unloaded surface is base + lift − s_p)
    lift[k, a, b]      m    soil heaped on the node by bulldozing (bulldozing.py; 0 without): it raises the
                            node's virgin level, from which the sinkage is measured (SCM's level_initial)
    yield_p[k, a, b]   Pa   the largest pressure the node has carried, σ_y: reloading below it is elastic

Base. The virgin surface is a plane (``grid[GDRES] == 0``: height ``grid[GBASE]``) or a DEM (``base_z``,
rows y, columns x, spacing ``grid[GDRES]`` from ``grid[GDX0], grid[GDY0]``: bilinear with the edge values
extended flat, terrain/dem.py's convention) read at the nodes; ``grid[GSLOPE]`` bounds its |∇h| (the
contact's "wholly above the soil" test). Each node has the base's normal N there (central differences
over one cell, as SCM's grid over a height map) and ca = N_z, the cosine of the base's slope.

Soil law at a node loaded by a body whose underside is at height z_b, along the base normal as in
Chrono's SCM (Bekker 1956; Wong, Theory of Ground Vehicles ch. 2; elasto-plastic split as SCM's, Krenn &
Hirzinger 2009): the sinkage along N is s = ca (h_base + lift − z_b) (z_b on the vertical through the node),
s_p = ca · plastic (``plastic`` is stored vertical: the unloaded surface is h_base + lift − plastic), and

    σ_el = K_e (s − s_p)                 elastic trial (K_e the elastic stiffness per area, Pa/m)
    σ_B  = (k_c / b + k_φ) sⁿ            Bekker–Wong yield (b the patch's smaller dimension, m)
    σ    = min(σ_el, σ_B)                (≤ 0: no contact, the body is above the rut)
    commit when σ_el > σ_B (plastic flow):  σ_y ← σ_B,  plastic ← (s − σ_B / K_e) / ca

so a first pass follows Bekker's curve, unloading rebounds by σ/K_e (the elastic part only), and a
second pass over the rut is elastic up to the pressure that made it (it sinks less). On a plane base
ca = 1 and N = ẑ exactly: the vertical law, bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: nodes per tile side: 32 × 32 nodes of 2 cm is a 0.64 m square, about one screw's footprint
TILE = 32

# grid record: float64 array [x0, y0, cell, base, nx, ny, dem_x0, dem_y0, dem_res, slope] (m, m, m, m, count,
# count, m, m, m (0: the base is the plane z = base), 1 (a bound of the base's |∇h|))
GX0, GY0, GCELL, GBASE, GNX, GNY, GDX0, GDY0, GDRES, GSLOPE = range(10)
# soil record: float64 array [k_c, k_phi, n, cohesion, tan_phi, K_janosi, K_elastic, damping]
SKC, SKPHI, SN, SC, STANPHI, SKJ, SKE, SDAMP = range(8)


@njit(cache=True, inline="always")
def node_slot(tile_of, i, j):
    """Pool slot of node (i, j)'s tile, −1 when virgin; (slot, a, b) with the node's place in its tile."""
    return tile_of[i // TILE, j // TILE], i % TILE, j % TILE


@njit(cache=True)
def node_state(tile_of, plastic, yield_p, i, j):
    """(s_p m, σ_y Pa) of node (i, j); (0, 0) for a virgin node."""
    k, a, b = node_slot(tile_of, i, j)
    if k < 0:
        return 0.0, 0.0
    return plastic[k, a, b], yield_p[k, a, b]


@njit(cache=True)
def slot_for(tile_of, used, i, j):
    """The slot of node (i, j)'s tile, given one from the pool on first touch; −1 (and used[1] = 1) when
    the pool is full."""
    ti, tj = i // TILE, j // TILE
    k = tile_of[ti, tj]
    if k >= 0:
        return k
    if used[0] >= used[2]:          # used[2]: the pool's capacity (max_tiles)
        used[1] = 1
        return -1
    k = used[0]
    used[0] += 1
    tile_of[ti, tj] = k
    return k


@njit(cache=True)
def base_height(grid, base_z, x, y):
    """Virgin surface height at (x, y), m: the plane, or the DEM bilinear with its edges extended flat (the
    same arithmetic as terrain/dem.py's HeightField.height)."""
    res = grid[GDRES]
    if res == 0.0:
        return grid[GBASE]
    ny, nx = base_z.shape
    fx = min(max((x - grid[GDX0]) / res, 0.0), nx - 1.0)
    fy = min(max((y - grid[GDY0]) / res, 0.0), ny - 1.0)
    j = min(int(fx), nx - 2)
    i = min(int(fy), ny - 2)
    tx, ty = fx - j, fy - i
    return ((1 - ty) * ((1 - tx) * base_z[i, j] + tx * base_z[i, j + 1])
            + ty * ((1 - tx) * base_z[i + 1, j] + tx * base_z[i + 1, j + 1]))


@njit(cache=True, inline="always")
def node_base(grid, base_z, i, j):
    """Virgin height (m) at node (i, j)."""
    return base_height(grid, base_z, grid[GX0] + i * grid[GCELL], grid[GY0] + j * grid[GCELL])


@njit(cache=True)
def base_normal(grid, base_z, x, y):
    """The base's unit normal (N_x, N_y, N_z) at (x, y): central differences over one cell, as SCM's grid over
    a height map (ẑ exactly on a plane); N_z is ca, the cosine of the slope the soil law divides by."""
    if grid[GDRES] == 0.0:
        return 0.0, 0.0, 1.0
    c = grid[GCELL]
    gx = base_height(grid, base_z, x - c, y) - base_height(grid, base_z, x + c, y)
    gy = base_height(grid, base_z, x, y - c) - base_height(grid, base_z, x, y + c)
    nz = 2.0 * c
    m = math.sqrt(gx * gx + gy * gy + nz * nz)
    return gx / m, gy / m, nz / m


@njit(cache=True, inline="always")
def node_normal(grid, base_z, i, j):
    """The base's unit normal at node (i, j) (base_normal)."""
    return base_normal(grid, base_z, grid[GX0] + i * grid[GCELL], grid[GY0] + j * grid[GCELL])


@njit(cache=True, inline="always")
def node_pool(grid, tile_of, i, j):
    """(slot, a, b) of node (i, j) in the pool arrays; slot −1 when the node is outside the patch or virgin."""
    if i < 0 or j < 0 or i >= grid[GNX] or j >= grid[GNY]:
        return -1, 0, 0
    return node_slot(tile_of, i, j)


@njit(cache=True)
def node_virgin(grid, base_z, tile_of, lift, i, j):
    """The node's virgin level, m: the base + the soil bulldozing heaped on it (``lift``; bulldozing.py)."""
    k, a, b = node_pool(grid, tile_of, i, j)
    h = node_base(grid, base_z, i, j)
    return h if k < 0 else h + lift[k, a, b]


@njit(cache=True)
def node_height(grid, base_z, tile_of, plastic, lift, i, j):
    """Unloaded surface height at node (i, j), m: base + lift − plastic (the base alone outside the patch)."""
    k, a, b = node_pool(grid, tile_of, i, j)
    h = node_base(grid, base_z, i, j)
    return h if k < 0 else h + lift[k, a, b] - plastic[k, a, b]


@njit(cache=True)
def surface(grid, base_z, tile_of, plastic, lift, x, y):
    """h, ∂h/∂x, ∂h/∂y of the unloaded surface at (x, y): bilinear in the node heights (the base's own
    nodes continue outside the patch)."""
    cell = grid[GCELL]
    fx = (x - grid[GX0]) / cell
    fy = (y - grid[GY0]) / cell
    i = int(math.floor(fx))
    j = int(math.floor(fy))
    tx, ty = fx - i, fy - j
    h00 = node_height(grid, base_z, tile_of, plastic, lift, i, j)
    h10 = node_height(grid, base_z, tile_of, plastic, lift, i + 1, j)
    h01 = node_height(grid, base_z, tile_of, plastic, lift, i, j + 1)
    h11 = node_height(grid, base_z, tile_of, plastic, lift, i + 1, j + 1)
    h = (1 - tx) * ((1 - ty) * h00 + ty * h01) + tx * ((1 - ty) * h10 + ty * h11)
    hx = ((1 - ty) * (h10 - h00) + ty * (h11 - h01)) / cell
    hy = ((1 - tx) * (h01 - h00) + tx * (h11 - h10)) / cell
    return h, hx, hy


@njit(cache=True)
def query_surface(grid, base_z, tile_of, plastic, lift, p, distance, normal):
    """First-order signed distance and outward normal of points p (n, 3) to the unloaded surface (as a DEM:
    d = (z − h) / √(1 + h_x² + h_y²), n = (−h_x, −h_y, 1) / √(…))."""
    for m in range(p.shape[0]):
        h, hx, hy = surface(grid, base_z, tile_of, plastic, lift, p[m, 0], p[m, 1])
        s = math.sqrt(1.0 + hx * hx + hy * hy)
        distance[m] = (p[m, 2] - h) / s
        normal[m, 0] = -hx / s
        normal[m, 1] = -hy / s
        normal[m, 2] = 1.0 / s


@njit(cache=True, inline="always")
def bekker(soil, b, s):
    """Bekker–Wong pressure (k_c / b + k_φ) sⁿ, Pa, at sinkage s > 0 m under a patch of smaller side b m."""
    return (soil[SKC] / b + soil[SKPHI]) * s ** soil[SN]


@njit(cache=True)
def pressure(soil, b, s, s_p, s_y):
    """(σ Pa, yields) at a node of plastic sinkage s_p and yield memory s_y loaded to total sinkage s
    (module docstring); σ = 0 when the body is above the rut (s ≤ s_p)."""
    if s <= s_p:
        return 0.0, False
    el = soil[SKE] * (s - s_p)
    if el <= s_y:
        return el, False
    yb = bekker(soil, b, s)
    if el > yb:
        return yb, True
    return el, False


@njit(cache=True)
def commit_node(grid, soil, tile_of, plastic, yield_p, used, i, j, s, b, ca):
    """Commit a load of sinkage s (m, along the base normal) on node (i, j), whose base has ca = N_z, under a
    patch of smaller side b: plastic flow (a deeper rut, a higher yield memory) where the load yields the
    soil; an elastic load changes nothing. 1: the node flowed, 0: it did not, −1: it would have but the
    tile pool is full."""
    if i < 0 or j < 0 or i >= grid[GNX] or j >= grid[GNY]:
        return 0                        # outside the patch: the base is rigid there
    s_p, s_y = node_state(tile_of, plastic, yield_p, i, j)
    sigma, yields = pressure(soil, b, s, ca * s_p, s_y)
    if not yields:
        return 0
    k = slot_for(tile_of, used, i, j)
    if k < 0:
        return -1
    a, c = i % TILE, j % TILE
    yield_p[k, a, c] = sigma
    plastic[k, a, c] = (s - sigma / soil[SKE]) / ca
    return 1


@njit(cache=True)
def press_nodes(grid, base_z, soil, tile_of, plastic, yield_p, lift, used, ii, jj, z_body, b, commit, sigma):
    """Pressure σ (Pa, into ``sigma``) at nodes (ii, jj) under a body whose underside is at heights
    ``z_body`` (m) on the nodes' verticals, patch side b (m); with ``commit`` the loads are committed
    (plastic flow). Returns the number of nodes that flowed, −1 when the tile pool ran out. The plate
    tests' entry point."""
    flows = 0
    for m in range(ii.shape[0]):
        ca = node_normal(grid, base_z, ii[m], jj[m])[2]
        s = ca * (node_virgin(grid, base_z, tile_of, lift, ii[m], jj[m]) - z_body[m])
        s_p, s_y = node_state(tile_of, plastic, yield_p, ii[m], jj[m])
        sigma[m] = pressure(soil, b, s, ca * s_p, s_y)[0]
        if commit and sigma[m] > 0.0:
            f = commit_node(grid, soil, tile_of, plastic, yield_p, used, ii[m], jj[m], s, b, ca)
            if f < 0:
                return -1
            flows += f
    return flows


def empty_used(max_tiles: int) -> np.ndarray:
    """The pool counter [slots given, pool full flag, capacity]."""
    return np.array([0, 0, int(max_tiles)], dtype=np.int64)
