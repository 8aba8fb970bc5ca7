"""Screw–soil kernels of the terramechanics contact (contact.py has the model; this file the loops).

One call evaluates every screw against the deformable terrain's nodes (components/terrain/
deformable_kernels.py) and, with ``commit``, writes the step's plastic sinkage into the terrain state.
Per screw s the arrays are (ScrewGeometry, contact.py):

    rows[s]  = (parent_row, screw_row, spin_dof)             int64
    geo[s]   = (radius, length, lead_angle, hand, spin_mult)  float64
    mount_R[s] (3, 3) column 0 the spin axis in the parent frame; mount_p[s] (3,) the centre there

Outputs: ``wrenches`` (nl, 6) [f, τ about the screw link's origin], world, added to; ``per_screw``
(ns, 5): sinkage m, slip 1, thrust N, normal force N, contacts (node count); ``totals`` [ΣF_n, contacts].

Per node: the pressure acts along the base's normal N (ẑ on a plane base) on A = cell² / N_z, the soil
surface the node's cell stands for; the sinkage is taken along N (terrain/deformable_kernels.py).

With ``jac`` the same pass also fills the per-link 6×6 blocks a linearly implicit integrator reads
(multibody/linearization.py, LinkWrenchJacobian): per node the force's velocity derivative

    ∂F/∂v = ∂s_c/∂v_x ê_x ê_xᵀ + ∂s_c/∂v_h ê_x ê_hᵀ + ∂s_h/∂v_h ê_h ê_hᵀ (− R A N Nᵀ loaded)
    s_c = −A τ_max (1 − e^(−j/K)) sgn v_x,  j = |v_x| ℓ / √(v_h² + v_ε²):
        ∂s_c/∂v_x = −A τ_max e^(−j/K) ℓ / (K √(v_h² + v_ε²))      (finite at v_x = 0: a viscous slope)
        ∂s_c/∂v_h =  A τ_max e^(−j/K) sgn v_x · j v_h / (K (v_h² + v_ε²))
    s_h = −ρ A τ_max (1 − e^(−ℓ/K)) v_h / √(v_h² + v_ε²):   ∂s_h/∂v_h = −ρ A τ_max (1 − e^(−ℓ/K)) v_ε² / (…)^(3/2)

and its height derivative (the sinkage s = N_z (h − z) falls as the node's contact point rises): ∂F/∂z =
−σ'(s) N_z (A N + F_shear tan φ / τ_max), σ' the slope of the branch a further load follows (add_height_slope:
K_e below the node's yield memory, Bekker's n σ / s at or past it, as a commit leaves it); both moved to
the screw link's origin as X_cᵀ D X_c (contact/jacobian_kernels.py: the point velocity is X_c of the screw
link's twist, the link's origin being on the spin axis). Left out: the patch's b, ℓ and the contact set
moving with the pose (lower order; a W-method keeps its order with any matrix).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from snakesim.components.contact.jacobian_kernels import add_lever_quadratic, add_lever_rank1
from snakesim.components.terrain.deformable_kernels import (GCELL, GDRES, GNX, GNY, GSLOPE, GX0, GY0, SC, SDAMP, SKE,
                                                           SKJ, SN, STANPHI, base_height, base_normal, bekker,
                                                           node_normal, node_state, node_virgin, pressure)
from snakesim.components.terrain.bulldozing_kernels import commit_logged

# per-screw output columns
SINKAGE, SLIP, THRUST, NORMAL, NODES = range(5)
# scratch columns per contact node: i, j, the contact point P (x, y, z; m), s_ax (along the axis), u (arc round
# the envelope from its bottom), the sinkage along the base normal, the base normal N there
_I, _J, _PX, _PY, _ZB, _SAX, _U, _SINK, _N0, _N1, _N2 = range(11)
SCRATCH_COLUMNS = 11


@njit(cache=True, inline="always")
def quat_rotate(q, v0, v1, v2):
    """R(q) v for q = (x, y, z, w) unit."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    # v + 2w (q × v) + 2 q × (q × v)
    cx = y * v2 - z * v1
    cy = z * v0 - x * v2
    cz = x * v1 - y * v0
    dx = y * cz - z * cy
    dy = z * cx - x * cz
    dz = x * cy - y * cx
    return v0 + 2.0 * (w * cx + dx), v1 + 2.0 * (w * cy + dy), v2 + 2.0 * (w * cz + dz)


@njit(cache=True, inline="always")
def cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def cylinder_underside(cx, cy, cz, a0, a1, a2, r, x, y):
    """Height of the lower side of the infinite cylinder (centre c, unit axis a, radius r) above (x, y),
    and its axial coordinate there; (nan, 0) when the vertical line misses it. Solves
    |d|² − (d·a)² = r² for d = (x − cx, y − cy, z − cz), a quadratic in z; the lower root."""
    dx, dy = x - cx, y - cy
    # d = (dx, dy, w) with w = z − cz:  (1 − a2²) w² + 2 w (−(dx a0 + dy a1) a2) + dx² + dy² − (dx a0 + dy a1)² − r² = 0
    da = dx * a0 + dy * a1
    A = 1.0 - a2 * a2
    B = -da * a2
    C = dx * dx + dy * dy - da * da - r * r
    disc = B * B - A * C
    if disc < 0.0 or A < 1e-9:
        return math.nan, 0.0
    w = (-B - math.sqrt(disc)) / A
    return cz + w, da + w * a2


@njit(cache=True, inline="always")
def _band(coef, off, half):
    """The interval of dy where |off + coef·dy| ≤ half ((−∞, ∞) or empty when coef ≈ 0)."""
    if abs(coef) < 1e-12:
        return (-1e300, 1e300) if abs(off) <= half else (1e300, -1e300)
    a, b = (-half - off) / coef, (half - off) / coef
    return (a, b) if a <= b else (b, a)


@njit(cache=True)
def cylinder_along_normal(cx, cy, cz, a0, a1, a2, r, sx, sy, sz, n0, n1, n2):
    """Where the line S + t N (S a surface point, N the unit base normal there) enters the infinite cylinder
    (centre c, unit axis a, radius r) from below: (t, axial coordinate of the point); (nan, 0) when it misses.
    Solves |d + t N|² − ((d + t N)·a)² = r², d = S − c, for its lower root."""
    d0, d1, d2 = sx - cx, sy - cy, sz - cz
    da = d0 * a0 + d1 * a1 + d2 * a2
    na = n0 * a0 + n1 * a1 + n2 * a2
    A = 1.0 - na * na
    B = d0 * n0 + d1 * n1 + d2 * n2 - da * na
    C = d0 * d0 + d1 * d1 + d2 * d2 - da * da - r * r
    disc = B * B - A * C
    if disc < 0.0 or A < 1e-9:
        return math.nan, 0.0
    t = (-B - math.sqrt(disc)) / A
    return t, da + t * na


@njit(cache=True)
def cylinder_nodes(grid, base_z, tile_of, plastic, yield_p, lift, cx, cy, cz, a0, a1, a2, r, L, scratch):
    """The nodes whose unloaded surface a finite cylinder (centre c, unit axis a, radius r, length L) presses,
    into ``scratch`` rows (the columns above: the contact point P where the node's line along the base normal
    enters the cylinder, vertical on a plane base; u + towards a × e_down); (count, least and largest s_ax).
    Shared by the screws and the body links (body_kernels.py); patch_chord reads the patch off the rows."""
    cell = grid[GCELL]
    x0, y0 = grid[GX0], grid[GY0]
    nx, ny = int(grid[GNX]), int(grid[GNY])
    plane = grid[GDRES] == 0.0
    # footprint box of the cylinder in x, y; on a sloped base the normal lines lean: up to the cylinder's
    # diameter times the sine of the steepest slope further
    lean = 0.0 if plane else 2.0 * r * grid[GSLOPE] / math.sqrt(1.0 + grid[GSLOPE] * grid[GSLOPE])
    ex = abs(a0) * 0.5 * L + r * math.sqrt(max(0.0, 1.0 - a0 * a0)) + lean
    ey = abs(a1) * 0.5 * L + r * math.sqrt(max(0.0, 1.0 - a1 * a1)) + lean
    i_lo = max(0, int(math.ceil((cx - ex - x0) / cell)))
    i_hi = min(nx - 1, int(math.floor((cx + ex - x0) / cell)))
    j_lo = max(0, int(math.ceil((cy - ey - y0) / cell)))
    j_hi = min(ny - 1, int(math.floor((cy + ey - y0) / cell)))
    # the screw frame on the ground: e_down ⟂ a, towards −N (the base's normal under the centre; −z on a
    # plane base); e_side = a × e_down (the arc coordinate's +)
    N0, N1, N2 = base_normal(grid, base_z, cx, cy)
    ad = a0 * N0 + a1 * N1 + a2 * N2
    dn0, dn1, dn2 = ad * a0 - N0, ad * a1 - N1, ad * a2 - N2
    dl = math.sqrt(dn0 * dn0 + dn1 * dn1 + dn2 * dn2)
    dn0, dn1, dn2 = dn0 / dl, dn1 / dl, dn2 / dl
    sd0, sd1, sd2 = cross(a0, a1, a2, dn0, dn1, dn2)
    # per row of nodes, only the j where the vertical line can meet the finite cylinder: its footprint
    # lies in the strip |n̂_h·d| ≤ r about the projected axis (n̂_h horizontal, ⟂ the axis) and within
    # |ĥ·d| ≤ (L/2)|a_h| + r|a_z| along it (ĥ the axis's horizontal direction); the box alone holds ~3×
    # the nodes for a screw at 45° in yaw. The normal lines of a sloped base: both widened by their lean
    ah = math.sqrt(a0 * a0 + a1 * a1)
    h0, h1 = a0 / ah, a1 / ah
    half_ax = 0.5 * L * ah + r * abs(a2) + 1e-9 + lean
    half_across = r + 1e-9 + lean
    m = 0
    s_lo, s_hi = 1e300, -1e300
    for i in range(i_lo, i_hi + 1):
        x = x0 + i * cell
        ddx = x - cx
        lo1, hi1 = _band(h0, -h1 * ddx, half_across)            # n̂_h·d = −h1 dx + h0 dy
        lo2, hi2 = _band(h1, h0 * ddx, half_ax)                 # ĥ·d = h0 dx + h1 dy
        lo, hi = max(lo1, lo2), min(hi1, hi2)
        if lo > hi:
            continue
        f_lo, f_hi = (cy + lo - y0) / cell, (cy + hi - y0) / cell      # clamped before int(): ±1e300
        jj_lo = j_lo if f_lo <= j_lo else int(math.ceil(f_lo))
        jj_hi = j_hi if f_hi >= j_hi else int(math.floor(f_hi))
        for j in range(jj_lo, jj_hi + 1):
            y = y0 + j * cell
            s_p, s_y = node_state(tile_of, plastic, yield_p, i, j)
            hb = node_virgin(grid, base_z, tile_of, lift, i, j)
            m0, m1, m2 = 0.0, 0.0, 1.0
            if plane:                        # the vertical through the node
                px, py = x, y
                zb, sax = cylinder_underside(cx, cy, cz, a0, a1, a2, r, x, y)
                if not (zb == zb) or abs(sax) > 0.5 * L:
                    continue
                top = hb - s_p
                if zb >= top:
                    continue                 # above the (rutted) surface
                sink = hb - zb
            else:                            # the line along the base normal through the node's surface point
                m0, m1, m2 = node_normal(grid, base_z, i, j)
                t, sax = cylinder_along_normal(cx, cy, cz, a0, a1, a2, r, x, y, hb, m0, m1, m2)
                if not (t == t) or abs(sax) > 0.5 * L:
                    continue
                sink = -t
                if sink - m2 * s_p <= 0.0:
                    continue                 # above the rut (s_p deep vertically, N_z s_p along N)
                px, py, zb = x + t * m0, y + t * m1, hb + t * m2
            if m >= scratch.shape[0]:
                break
            # outward radial unit n_c at the contact point; arc coordinate u = r·atan2(n·e_side, n·e_down)
            n0 = (px - cx - sax * a0) / r
            n1 = (py - cy - sax * a1) / r
            n2 = (zb - cz - sax * a2) / r
            u = r * math.atan2(n0 * sd0 + n1 * sd1 + n2 * sd2, n0 * dn0 + n1 * dn1 + n2 * dn2)
            scratch[m, _I], scratch[m, _J], scratch[m, _ZB] = i, j, zb
            scratch[m, _PX], scratch[m, _PY], scratch[m, _SINK] = px, py, sink
            scratch[m, _SAX], scratch[m, _U] = sax, u
            scratch[m, _N0], scratch[m, _N1], scratch[m, _N2] = m0, m1, m2
            s_lo, s_hi = min(s_lo, sax), max(s_hi, sax)
            m += 1
    return m, s_lo, s_hi


@njit(cache=True, inline="always")
def patch_chord(scratch, m, r, cell, s_lo, s_hi):
    """The patch of a cylinder (radius r) on its ``m`` contact nodes in ``scratch``: (d, b), d the deepest
    sinkage below the virgin surface (m), b Bekker's smaller side, the chord 2√(2 r d − d²) or the axial
    extent + one cell if smaller (at least one cell). The sinkage below the virgin surface, not the penetration
    below the rut: a cylinder lying in the groove it pressed fills it wall to wall though it presses only σ/K_e
    (mm) into it; a patch of that elastic depth halved a screw's thrust in its rut
    (tests/terramechanics/test_towed_module.py) and made b shrink at every commit. Continuous in the pose (the
    deepest sinkage is), so the force is: no jumps as nodes enter the patch."""
    d = 0.0
    for q in range(m):
        d = max(d, scratch[q, _SINK])
    pc = min(d, r)
    chord = 2.0 * math.sqrt(max(0.0, 2.0 * r * pc - pc * pc))
    return d, max(cell, min(chord, s_hi - s_lo + cell))


@njit(cache=True, inline="always")
def soil_top(grid, base_z, x, y, reach):
    """An upper bound (m) of the virgin surface within ``reach`` m of (x, y): the base there plus its slope
    bound times the reach (the base itself on a plane)."""
    return base_height(grid, base_z, x, y) + grid[GSLOPE] * reach


@njit(cache=True, inline="always")
def add_normal_damping(D, k, n0, n1, n2):
    """D −= k N Nᵀ: SCM's damping along the base normal (k = R A, N·s/m)."""
    n = (n0, n1, n2)
    for a in range(3):
        for c in range(3):
            D[a, c] -= k * n[a] * n[c]


@njit(cache=True, inline="always")
def add_height_slope(soil, b, sink, s_p, s_y, tau_max, area, n0, n1, n2, f0, f1, f2, rc, gk, mk, block):
    """A loaded node's height derivative, −σ' N_k (A N + f tan φ / τ_max) for a displacement along each axis k
    (∂s/∂p = −N; f the node's shear force, N), moved to the link origin into ``block``; ``gk``, ``mk`` scratch
    (3,). σ' is the slope of the branch a further load follows: K_e strictly below the node's yield memory σ_y
    (unloaded, or back on an old rut), Bekker's n σ_B(s) / s at or past it.

    Why not the tangent of pressure()'s branch: the tick's commit leaves every node it pressed at σ_y (to
    rounding, hence the 1e-6), where the two branches meet and pressure() reads as elastic, while a further load
    follows Bekker's (24× softer on regolith); a large step sinks along it. Declaring K_e there held every
    sinking link as on rock under rosenbrock_w (regolith-sidewinding: 4 cm lateral drift in 5 s at 5 ms with a
    fresh Jacobian each step, 10 cm at 10 ms; then 2.5 and 6 mm, as rk4's own at 5 ms). The other side of the
    kink, a resting link's unloading at K_e, is then the explicit part's: stable for EELS 1.0's links, not for
    Mini EELS's (it bounces at 10 ms)."""
    el = soil[SKE] * (sink - s_p)
    dsig = soil[SKE] if el < s_y * (1.0 - 1e-6) else soil[SN] * bekker(soil, b, sink) / sink
    k_sh = soil[STANPHI] / tau_max
    gk[0] = area * n0 + f0 * k_sh
    gk[1] = area * n1 + f1 * k_sh
    gk[2] = area * n2 + f2 * k_sh
    mk[0], mk[1], mk[2] = -dsig * n0, -dsig * n1, -dsig * n2
    add_lever_rank1(rc, gk, mk, block)


@njit(cache=True, inline="always")
def add_wrench(w, fx, fy, fz, tx, ty, tz):
    """w (6,) += (f, τ)."""
    w[0] += fx
    w[1] += fy
    w[2] += fz
    w[3] += tx
    w[4] += ty
    w[5] += tz


@njit(cache=True)
def clear_outputs(jac, on_link, d_twist, d_pose, totals):
    """Zero ``totals`` and, with ``jac``, the blocks of the links ``on_link`` marks (unmarking them): what a
    soil kernel fills from scratch (this file's and body_kernels.py's)."""
    if jac:
        for k in range(on_link.size):
            if on_link[k]:
                d_twist[k, :, :] = 0.0
                d_pose[k, :, :] = 0.0
                on_link[k] = False
    totals[:] = 0.0


@njit(cache=True, inline="always")
def soil_kernel_start(grid, soil, jac, on_link, d_twist, d_pose, totals):
    """What both soil kernels (this file's and body_kernels.py's) start with: the cell (m) and its area (m²), the
    soil's c (Pa), tan φ, K (m) and damping (Pa·s/m), a node's Jacobian scratch (D 3×3, rc, gk, mk), and the
    outputs they fill from scratch cleared (clear_outputs)."""
    cell = grid[GCELL]
    clear_outputs(jac, on_link, d_twist, d_pose, totals)
    return (cell, cell * cell, soil[SC], soil[STANPHI], soil[SKJ], soil[SDAMP],
            np.zeros((3, 3)), np.zeros(3), np.zeros(3), np.zeros(3))


@njit(cache=True)
def screw_soil(grid, base_z, soil, tile_of, plastic, yield_p, lift, used, rows, geo, mount_R, mount_p, poses, vels,
               joint_v, helix_ratio, v_eps, commit, log, log_n, scratch, wrenches, per_screw, totals, jac, d_twist,
               d_pose, on_link):
    """Every screw against the soil (module docstring; the model: contact.py); ``log``, ``log_n``: the commit's
    log for bulldozing (terrain/bulldozing_kernels.py; empty: none). Returns the number of
    nodes a commit made flow (0 without ``commit``), −1 when it found the terrain's tile pool full. With
    ``jac``: the screw links' blocks into ``d_twist``, ``d_pose`` (nl, 6, 6), the links with one marked in
    ``on_link`` (the blocks of links marked before are cleared first)."""
    cell, cell_area, c_coh, tan_phi, kj, damp, D, rc, gk, mk = soil_kernel_start(grid, soil, jac, on_link, d_twist,
                                                                                d_pose, totals)
    flows = 0
    for s in range(rows.shape[0]):
        for k in range(per_screw.shape[1]):
            per_screw[s, k] = 0.0
        pr, sr, dof = rows[s, 0], rows[s, 1], rows[s, 2]
        r, L, lead, hand, mult = geo[s, 0], geo[s, 1], geo[s, 2], geo[s, 3], geo[s, 4]
        qp = poses[pr, 3:7]
        a0, a1, a2 = quat_rotate(qp, mount_R[s, 0, 0], mount_R[s, 1, 0], mount_R[s, 2, 0])
        m0, m1, m2 = quat_rotate(qp, mount_p[s, 0], mount_p[s, 1], mount_p[s, 2])
        px, py, pz = poses[pr, 0], poses[pr, 1], poses[pr, 2]
        cx, cy, cz = px + m0, py + m1, pz + m2
        vpx, vpy, vpz = vels[pr, 0], vels[pr, 1], vels[pr, 2]
        wpx, wpy, wpz = vels[pr, 3], vels[pr, 4], vels[pr, 5]
        omega = mult * joint_v[dof]
        sl, cl, tl = math.sin(lead), math.cos(lead), math.tan(lead)
        # slip of the screw: its centre's axial speed against the ideal nut speed h ω r tan λ
        wc0, wc1, wc2 = cross(wpx, wpy, wpz, m0, m1, m2)
        v_axis = (vpx + wc0) * a0 + (vpy + wc1) * a1 + (vpz + wc2) * a2
        v_ideal = hand * omega * r * tl
        per_screw[s, SLIP] = 1.0 - v_axis / v_ideal if abs(v_ideal) > 1e-9 else 0.0
        if abs(a2) > 0.98:
            continue                             # standing on its end: not modelled
        if cz - r * math.sqrt(1.0 - a2 * a2) - 0.5 * L * abs(a2) > soil_top(grid, base_z, cx, cy, 0.5 * L + r):
            continue                             # wholly above the virgin surface (ruts only go down)
        m, s_lo, s_hi = cylinder_nodes(grid, base_z, tile_of, plastic, yield_p, lift, cx, cy, cz, a0, a1, a2, r, L,
                                       scratch)
        if m == 0:
            continue
        # the patch (patch_chord): the deepest sinkage below the virgin surface sets Bekker's b and the arc
        # round the envelope, half angle θ0 = acos(1 − d / r) from the bottom, that the thread crosses
        deepest, b = patch_chord(scratch, m, r, cell, s_lo, s_hi)
        pc = min(deepest, r)
        u_hi = r * math.acos(1.0 - pc / r)
        u_lo = -u_hi
        fx = fy = fz = tx = ty = tz = 0.0
        ox, oy, oz = poses[sr, 0], poses[sr, 1], poses[sr, 2]
        for q in range(m):
            i, j = int(scratch[q, _I]), int(scratch[q, _J])
            zb, sax, u = scratch[q, _ZB], scratch[q, _SAX], scratch[q, _U]
            X, Y, sink = scratch[q, _PX], scratch[q, _PY], scratch[q, _SINK]        # sink: along the normal N
            N0, N1, ca = scratch[q, _N0], scratch[q, _N1], scratch[q, _N2]
            area = cell_area / ca             # the soil surface the node's cell stands for, m²
            s_p, s_y = node_state(tile_of, plastic, yield_p, i, j)
            s_p = ca * s_p
            sigma = pressure(soil, b, sink, s_p, s_y)[0]
            # velocity of the screw's surface at the contact point (the soil is at rest)
            rx, ry, rz = X - px, Y - py, zb - pz
            w0, w1, w2 = cross(wpx, wpy, wpz, rx, ry, rz)
            q0, q1, q2 = X - cx, Y - cy, zb - cz
            sp0, sp1, sp2 = cross(a0, a1, a2, q0, q1, q2)
            v0 = vpx + w0 + omega * sp0
            v1 = vpy + w1 + omega * sp1
            v2 = vpz + w2 + omega * sp2
            # SCM's damping along N (sinking adds): on the envelope's motion, not the spin (a turning
            # cylinder's surface moves up and down but its shape in the soil does not)
            sig = max(0.0, sigma - damp * (N0 * (vpx + w0) + N1 * (vpy + w1) + ca * (vpz + w2)))
            fn = sig * area
            # thread directions on the envelope: e_θ = a × n_c, across the thread e_x, along it e_h
            n0, n1, n2 = (q0 - sax * a0) / r, (q1 - sax * a1) / r, (q2 - sax * a2) / r
            et0, et1, et2 = cross(a0, a1, a2, n0, n1, n2)
            ex0, ex1, ex2 = cl * a0 - hand * sl * et0, cl * a1 - hand * sl * et1, cl * a2 - hand * sl * et2
            eh0, eh1, eh2 = hand * sl * a0 + cl * et0, hand * sl * a1 + cl * et1, hand * sl * a2 + cl * et2
            vc = v0 * ex0 + v1 * ex1 + v2 * ex2
            vh = v0 * eh0 + v1 * eh1 + v2 * eh2
            # helix path since the thread entered the patch (upstream edge of the arc), half a cell for the node
            arc = max(u - u_lo if vh >= 0.0 else u_hi - u, 0.0) + 0.5 * cell
            ell = arc / cl
            tau_max = c_coh + sigma * tan_phi
            rh = math.sqrt(vh * vh + v_eps * v_eps)
            j_c = abs(vc) * ell / rh                     # Janosi shear displacement across the thread
            tau_c = tau_max * (1.0 - math.exp(-j_c / kj))
            tau_h = helix_ratio * tau_max * (1.0 - math.exp(-ell / kj)) * vh / rh
            sc = -tau_c * area * (1.0 if vc > 0.0 else -1.0 if vc < 0.0 else 0.0)
            sh = -tau_h * area
            f0 = fn * N0 + sc * ex0 + sh * eh0
            f1 = fn * N1 + sc * ex1 + sh * eh1
            f2 = fn * ca + sc * ex2 + sh * eh2
            fx += f0
            fy += f1
            fz += f2
            c0, c1, c2 = cross(X - ox, Y - oy, zb - oz, f0, f1, f2)
            tx += c0
            ty += c1
            tz += c2
            per_screw[s, NORMAL] += fn
            if jac:
                ek = math.exp(-j_c / kj)
                dcx = -area * tau_max * ek * ell / (kj * rh)
                dch = area * tau_max * ek * (1.0 if vc > 0.0 else -1.0 if vc < 0.0 else 0.0) * j_c * vh / (kj * rh * rh)
                dhh = -area * helix_ratio * tau_max * (1.0 - math.exp(-ell / kj)) * v_eps * v_eps / (rh * rh * rh)
                ex = (ex0, ex1, ex2)
                eh = (eh0, eh1, eh2)
                for a in range(3):
                    for c in range(3):
                        D[a, c] = dcx * ex[a] * ex[c] + dch * ex[a] * eh[c] + dhh * eh[a] * eh[c]
                if sig > 0.0:
                    add_normal_damping(D, damp * area, N0, N1, ca)
                rc[0], rc[1], rc[2] = X - ox, Y - oy, zb - oz
                add_lever_quadratic(rc, D, d_twist[sr])
                if sig > 0.0 and sink > s_p:
                    add_height_slope(soil, b, sink, s_p, s_y, tau_max, area, N0, N1, ca, sc * ex0 + sh * eh0,
                                     sc * ex1 + sh * eh1, sc * ex2 + sh * eh2, rc, gk, mk, d_pose[sr])
                on_link[sr] = True
            if commit:
                f = commit_logged(grid, soil, tile_of, plastic, yield_p, used, i, j, sink, b, ca, log, log_n, s)
                if f < 0:
                    return -1
                flows += f
        add_wrench(wrenches[sr], fx, fy, fz, tx, ty, tz)
        per_screw[s, THRUST] = fx * a0 + fy * a1 + fz * a2
        per_screw[s, SINKAGE] = deepest
        per_screw[s, NODES] = m
        totals[0] += per_screw[s, NORMAL]
        totals[1] += m
    return flows


def scratch_rows(radius: np.ndarray, length: np.ndarray, cell: float) -> int:
    """Nodes a screw's footprint box can hold at any orientation: ((L + 4r)/cell + 2)² (2r more than the
    cylinder for the lean of the normal lines on a sloped base)."""
    side = float(np.max(length + 4.0 * radius)) / cell + 2.0
    return int(side * side) + 1
