"""A rigid wheel on the deformable soil: the terramechanics textbook check (Wong, Theory of Ground Vehicles,
ch. 2; Wong & Reece 1967), over the deformable terrain's own soil kernels (terrain/deformable_kernels.py).

Wheel: a rigid cylinder of radius r and width b, no grousers, axis horizontal and ⟂ its heading ψ (the
travel direction ê = (cos ψ, sin ψ, 0)), centre c; slip i = 1 − v / (ω r) (driving i > 0). θ is measured
round the rim from the bottom, positive ahead: the rim point at θ is c + r (sin θ ê − cos θ ẑ).

    entry angle θ1     cos θ1 = 1 − z0 / r, z0 = base − (c_z − r) the sinkage below the virgin surface
    contact nodes      those whose cell centre lies under the rim between θ2 = 0 and θ1 (Wong–Reece: the
                       soil behind the bottom does not rebound) and within the width; a node's y-weight is
                       the part of its cell's width the wheel covers, so the width is exact at any offset
    normal stress      front (θ ≥ θm): the node's own sinkage s = base − z_rim through ``pressure`` (Bekker–Wong
                       with SCM's elastic branch and the node's rut memory); rear (0 ≤ θ < θm): Wong–Reece's
                       mirror, the sinkage at θe = θ1 − (θ/θm)(θ1 − θm), s = r (cos θe − cos θ1) (the
                       peak at θm = (c1 + c2 i) θ1, the stress falling to 0 at the rear)
    Bekker's b         min(b, the chord 2 r sin θ1)
    shear              τ = (c + σ tan φ)(1 − e^(−j/K)),  j(θ) = r [(θ1 − θ) − (1 − i)(sin θ1 − sin θ)]
                       (Janosi–Hanamoto with the shear displacement since the rim point entered the soil)
    per node           the rim element over the node's cell: area A w_y / cos θ (A = Δ² its horizontal
                       projection), stress σ toward the axle (−sin θ ê + cos θ ẑ) and τ along the rim
                       (cos θ ê + sin θ ẑ)

so the sums are Wong's integrals sampled at the nodes: DP = Σ (τ − σ tan θ) A w_y = ∫ (τ cos θ − σ sin θ) r b dθ,
W = Σ (σ + τ tan θ) A w_y = ∫ (σ cos θ + τ sin θ) r b dθ, T = Σ τ r A w_y / cos θ = ∫ τ r² b dθ. With ``commit``
the nodes under the rim are loaded at their true sinkage (``commit_node``: the rut). Units SI, world frame.

Not modelled: grousers, lateral (side-slip) shear, bulldozing at the front, the rear rebound (θ2 = 0); on a
rut, θ1 is still taken from the virgin surface.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from snakesim.components.terrain.deformable_kernels import (GBASE, GCELL, GDRES, GNX, GNY, GX0, GY0, SC, SKJ,
                                                           STANPHI, commit_node, node_state, pressure)

# ``out`` columns: drawbar pull N (along the heading), vertical load N, driving torque N·m, contact nodes, θ1 rad
DP, LOAD, TORQUE, NODES, THETA1 = range(5)


@dataclass(frozen=True)
class RigidWheel:
    """Radius r (m), width b (m), Wong–Reece's c1, c2 (θm = (c1 + c2 i) θ1; Wong's 0.43, 0.32 for sand)."""

    radius: float
    width: float
    c1: float = 0.43
    c2: float = 0.32

    def __post_init__(self):
        if not (self.radius > 0 and self.width > 0):
            raise ValueError(f"RigidWheel: radius = {self.radius} m and width = {self.width} m must be > 0")


@njit(cache=True)
def wheel_soil(grid, soil, tile_of, plastic, yield_p, used, cx, cy, cz, heading, r, width, slip, c1, c2, commit, out):
    """One wheel against the nodes (module docstring): fills ``out`` [DP, W, T, nodes, θ1]; returns the nodes
    a commit made flow, −1 when the tile pool is full."""
    for k in range(out.shape[0]):
        out[k] = 0.0
    cell = grid[GCELL]
    area = cell * cell
    x0, y0, base = grid[GX0], grid[GY0], grid[GBASE]
    nx, ny = int(grid[GNX]), int(grid[GNY])
    z0 = base - (cz - r)
    if z0 <= 0.0:
        return 0
    th1 = math.acos(max(-1.0, 1.0 - z0 / r))
    thm = (c1 + c2 * slip) * th1
    b = min(width, 2.0 * r * math.sin(th1))
    e0, e1 = math.cos(heading), math.sin(heading)
    c_coh, tan_phi, kj = soil[SC], soil[STANPHI], soil[SKJ]
    # footprint box: along the heading 0 … r sin θ1, across ±(b/2 + a cell)
    reach = r * math.sin(th1) + cell
    half = 0.5 * width + cell
    ex = abs(e0) * reach + abs(e1) * half
    ey = abs(e1) * reach + abs(e0) * half
    i_lo, i_hi = max(0, int(math.floor((cx - ex - x0) / cell))), min(nx - 1, int(math.ceil((cx + ex - x0) / cell)))
    j_lo, j_hi = max(0, int(math.floor((cy - ey - y0) / cell))), min(ny - 1, int(math.ceil((cy + ey - y0) / cell)))
    flows = 0
    for i in range(i_lo, i_hi + 1):
        for j in range(j_lo, j_hi + 1):
            dx, dy = x0 + i * cell - cx, y0 + j * cell - cy
            along = dx * e0 + dy * e1
            side = -dx * e1 + dy * e0
            # the part of the node's cell (across the heading) the rim covers
            wy = (min(side + 0.5 * cell, 0.5 * width) - max(side - 0.5 * cell, -0.5 * width)) / cell
            if wy <= 0.0 or along < 0.0 or along >= r:
                continue
            th = math.asin(along / r)
            if th > th1:
                continue
            s = base - (cz - r * math.cos(th))           # the node's sinkage under the rim
            s_p, s_y = node_state(tile_of, plastic, yield_p, i, j)
            if th >= thm:
                sigma = pressure(soil, b, s, s_p, s_y)[0]
            else:                                        # Wong–Reece's rear: the front's stress mirrored
                te = th1 - th / thm * (th1 - thm)
                sigma = pressure(soil, b, r * (math.cos(te) - math.cos(th1)), s_p, s_y)[0]
            jd = r * ((th1 - th) - (1.0 - slip) * (math.sin(th1) - math.sin(th)))
            tau = (c_coh + sigma * tan_phi) * (1.0 - math.exp(-abs(jd) / kj)) * (1.0 if jd >= 0.0 else -1.0)
            aw = area * min(wy, 1.0)
            tn = math.tan(th)
            out[DP] += (tau - sigma * tn) * aw
            out[LOAD] += (sigma + tau * tn) * aw
            out[TORQUE] += tau * r * aw / math.cos(th)
            out[NODES] += 1.0
            if commit and s > s_p:
                f = commit_node(grid, soil, tile_of, plastic, yield_p, used, i, j, s, b, 1.0)
                if f < 0:
                    return -1
                flows += f
    out[THETA1] = th1
    return flows


def wheel_forces(terrain, wheel: RigidWheel, centre, heading: float, slip: float, commit: bool = False):
    """The wheel at ``centre`` (m, world) heading ``heading`` (rad) at slip ``slip`` on ``terrain`` (a
    DeformableTerrain): a dict of drawbar pull (N), vertical load (N), driving torque (N·m), contact nodes and
    the entry angle θ1 (rad); with ``commit`` the rut is pressed (and the terrain's version bumped)."""
    if terrain.grid[GDRES] != 0.0:
        raise ValueError(f"terrain '{terrain.source}': the rigid wheel (Wong–Reece) is for level ground; this "
                         f"soil lies on a height-field base")
    if terrain.bulldozing is not None:
        raise ValueError(f"terrain '{terrain.source}': the rigid wheel does not bulldoze; give the terrain no "
                         f"bulldozing")
    st = terrain.state
    out = np.zeros(5)
    flows = wheel_soil(terrain.grid, terrain.soil, st.tile_of, st.plastic, st.yield_p, st.used, float(centre[0]),
                       float(centre[1]), float(centre[2]), float(heading), wheel.radius, wheel.width, float(slip),
                       wheel.c1, wheel.c2, bool(commit), out)
    if flows < 0:
        raise RuntimeError(f"terrain '{terrain.source}': all {terrain.max_tiles} tiles (max_tiles) are in use")
    if flows > 0:
        st.changed()
    return {"drawbar_pull": out[DP], "load": out[LOAD], "torque": out[TORQUE], "nodes": int(out[NODES]),
            "theta1": out[THETA1]}
