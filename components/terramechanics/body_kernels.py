"""Body-link–soil kernel of the soil body contact (body_contact.py has the model; this file the loop).

One call evaluates every cylinder piece of the selected links against the deformable terrain's nodes,
with the screws' node search (kernels.cylinder_nodes) and the soil law (terrain/deformable_kernels.py);
with ``commit`` it writes the step's plastic sinkage into the terrain state. Per piece k:

    piece_link[k]   link row                               int64
    piece_geo[k]    (radius, length, along, across)        float64 (along/across: the shear's factors)
    piece_R[k]      (3, 3) the cylinder's frame in the link (column 2 its axis); piece_p[k] (3,) its centre

Outputs: ``wrenches`` (nl, 6) [f, τ about the link origin], world, added to; ``per_link`` (nl, 3): normal
force N, deepest sinkage m, contact nodes; ``totals`` [ΣF_n, contacts].

With ``jac`` the same pass fills the per-link 6×6 blocks a linearly implicit integrator reads (as the
screws', kernels.py): per node the pressure acts along the base normal N on A = cell² / N_z (ẑ and cell² on
a plane base), the shear f = −τ A P t / ρ (t = T u the slip in the base's tangent plane, T = I − N Nᵀ; P =
across I + (along − across) ĥĥᵀ, ĥ the link's axis in that plane; ρ = √(|t|² + v_ε²)) has ∂f/∂u = −τ A (P T / ρ
− (P t) tᵀ / ρ³) (finite at rest: τ A P / v_ε, the slope that sets an explicit step), the damping −R A N Nᵀ
while loaded; the height derivative is the pressure's, −σ'(s) N_z (A N + f tan φ / τ_max), σ' the slope of the
branch a further load follows: K_e below the node's yield memory, Bekker's n σ / s at or past it
(add_height_slope). Both moved to the link origin as X_cᵀ D X_c. Left out: b, j and the contact set
following the pose (lower order).
"""

from __future__ import annotations

import math

from numba import njit

from snakesim.components.contact.jacobian_kernels import add_lever_quadratic

from snakesim.components.terrain.bulldozing_kernels import commit_logged
from snakesim.components.terrain.deformable_kernels import SC, base_normal, node_state, pressure

from .kernels import (_I, _J, _N0, _N1, _N2, _PX, _PY, _SINK, _ZB, add_height_slope, add_normal_damping, add_wrench,
                      cross, cylinder_nodes, patch_chord, quat_rotate, soil_kernel_start, soil_top)

# per-link output columns
L_NORMAL, L_SINKAGE, L_NODES = range(3)


@njit(cache=True)
def body_soil(grid, base_z, soil, tile_of, plastic, yield_p, lift, used, piece_link, piece_geo, piece_R, piece_p,
              poses, vels, v_eps, walls, commit, log, log_n, scratch, wrenches, per_link, totals, jac, d_twist, d_pose,
              on_link):
    """Every piece against the soil (module docstring; the model: body_contact.py). ``walls`` [γ N/m³, K_p]:
    the rut walls' passive pressure (γ = 0: off; ``rut_wall``); ``log``, ``log_n``: the commit's log for
    bulldozing (terrain/bulldozing_kernels.py; empty: none). Returns the nodes a commit made flow (0
    without ``commit``), −1 when the terrain's tile pool is full. With ``jac``: the links' blocks into
    ``d_twist``, ``d_pose`` (nl, 6, 6), those with one marked in ``on_link`` (cleared first)."""
    cell, cell_area, c_coh, tan_phi, kj, damp, D, rc, gk, mk = soil_kernel_start(grid, soil, jac, on_link, d_twist,
                                                                                d_pose, totals)
    flows = 0
    for k in range(per_link.shape[0]):
        for c in range(per_link.shape[1]):
            per_link[k, c] = 0.0
    for k in range(piece_link.shape[0]):
        row = piece_link[k]
        r, L, along, across = piece_geo[k, 0], piece_geo[k, 1], piece_geo[k, 2], piece_geo[k, 3]
        q = poses[row, 3:7]
        a0, a1, a2 = quat_rotate(q, piece_R[k, 0, 2], piece_R[k, 1, 2], piece_R[k, 2, 2])
        m0, m1, m2 = quat_rotate(q, piece_p[k, 0], piece_p[k, 1], piece_p[k, 2])
        px, py, pz = poses[row, 0], poses[row, 1], poses[row, 2]
        cx, cy, cz = px + m0, py + m1, pz + m2
        if abs(a2) > 0.98:
            continue                             # standing on its end: not modelled
        if cz - r * math.sqrt(1.0 - a2 * a2) - 0.5 * L * abs(a2) > soil_top(grid, base_z, cx, cy, 0.5 * L + r):
            continue                             # wholly above the virgin surface
        m, s_lo, s_hi = cylinder_nodes(grid, base_z, tile_of, plastic, yield_p, lift, cx, cy, cz, a0, a1, a2, r, L,
                                       scratch)
        if m == 0:
            continue
        deepest, b = patch_chord(scratch, m, r, cell, s_lo, s_hi)      # Bekker's b, as the screws'
        vx, vy, vz = vels[row, 0], vels[row, 1], vels[row, 2]
        wx, wy, wz = vels[row, 3], vels[row, 4], vels[row, 5]
        # the sliding direction: the piece centre's horizontal velocity; j runs from the patch's upstream edge
        wc0, wc1, _ = cross(wx, wy, wz, m0, m1, m2)
        sx, sy = vx + wc0, vy + wc1
        sn = math.sqrt(sx * sx + sy * sy)
        sx, sy = (sx / sn, sy / sn) if sn > 1e-12 else (0.0, 0.0)
        lead = 1e300
        for n in range(m):
            lead = min(lead, scratch[n, _PX] * sx + scratch[n, _PY] * sy)
        fx = fy = fz = tx = ty = tz = fnormal = 0.0
        for n in range(m):
            i, j = int(scratch[n, _I]), int(scratch[n, _J])
            X, Y, zb, sink = scratch[n, _PX], scratch[n, _PY], scratch[n, _ZB], scratch[n, _SINK]   # sink: along N
            N0, N1, ca = scratch[n, _N0], scratch[n, _N1], scratch[n, _N2]
            area = cell_area / ca             # the soil surface the node's cell stands for, m²
            s_p, s_y = node_state(tile_of, plastic, yield_p, i, j)
            s_p = ca * s_p
            sigma = pressure(soil, b, sink, s_p, s_y)[0]
            rx, ry, rz = X - px, Y - py, zb - pz
            w0, w1, w2 = cross(wx, wy, wz, rx, ry, rz)
            u0, u1, u2 = vx + w0, vy + w1, vz + w2           # the link's material point (the soil at rest)
            un = N0 * u0 + N1 * u1 + ca * u2
            sig = max(0.0, sigma - damp * un)
            fn = sig * area
            # the slip in the base's tangent plane, and the link's axis there (the skin's along; across is
            # its normal in the plane): on a plane base, the horizontal parts
            t0, t1, t2 = u0 - un * N0, u1 - un * N1, u2 - un * ca
            ad = a0 * N0 + a1 * N1 + a2 * ca
            h0, h1, h2 = a0 - ad * N0, a1 - ad * N1, a2 - ad * ca
            ah = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
            h0, h1, h2 = h0 / ah, h1 / ah, h2 / ah
            # Janosi–Hanamoto along the sliding direction, the soil sheared since the patch's upstream edge
            ell = X * sx + Y * sy - lead + 0.5 * cell
            tau_max = c_coh + sigma * tan_phi
            tau = tau_max * (1.0 - math.exp(-ell / kj)) * area
            rh = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2 + v_eps * v_eps)
            ua = t0 * h0 + t1 * h1 + t2 * h2                   # along the link's axis, and across it
            pu0 = along * ua * h0 + across * (t0 - ua * h0)    # P u
            pu1 = along * ua * h1 + across * (t1 - ua * h1)
            pu2 = along * ua * h2 + across * (t2 - ua * h2)
            f0 = fn * N0 - tau * pu0 / rh
            f1 = fn * N1 - tau * pu1 / rh
            f2 = fn * ca - tau * pu2 / rh
            fx += f0
            fy += f1
            fz += f2
            fnormal += fn
            c0, c1, c2 = cross(rx, ry, rz, f0, f1, f2)
            tx += c0
            ty += c1
            tz += c2
            if jac:
                # ∂f/∂u = −τA (P T / ρ − (P t) tᵀ / ρ³), T = I − N Nᵀ the tangent projector
                # (P T = across T + (along − across) ĥĥᵀ, ĥ in the plane)
                g = tau / rh
                g3 = tau / (rh * rh * rh)
                dp = along - across
                nv, hv, tv, pv = (N0, N1, ca), (h0, h1, h2), (t0, t1, t2), (pu0, pu1, pu2)
                for a in range(3):
                    for c in range(3):
                        proj = (1.0 if a == c else 0.0) - nv[a] * nv[c]
                        D[a, c] = -g * (across * proj + dp * hv[a] * hv[c]) + g3 * pv[a] * tv[c]
                if sig > 0.0:
                    add_normal_damping(D, damp * area, N0, N1, ca)
                rc[0], rc[1], rc[2] = rx, ry, rz
                add_lever_quadratic(rc, D, d_twist[row])
                if sig > 0.0 and sink > s_p:
                    add_height_slope(soil, b, sink, s_p, s_y, tau_max, area, N0, N1, ca, -tau * pu0 / rh,
                                     -tau * pu1 / rh, -tau * pu2 / rh, rc, gk, mk, d_pose[row])
                on_link[row] = True
            if commit:
                f = commit_logged(grid, soil, tile_of, plastic, yield_p, used, i, j, sink, b, ca, log, log_n, k)
                if f < 0:
                    return -1
                flows += f
        add_wrench(wrenches[row], fx, fy, fz, tx, ty, tz)
        if walls[0] > 0.0:
            rut_wall(grid, base_z, soil, walls, cx, cy, m0, m1, m2, a0, a1, a2, r, deepest, s_hi - s_lo + cell,
                     vx, vy, vz, wx, wy, wz, v_eps, wrenches[row], jac, d_twist[row])
        per_link[row, L_NORMAL] += fnormal
        per_link[row, L_SINKAGE] = max(per_link[row, L_SINKAGE], deepest)
        per_link[row, L_NODES] += m
        totals[0] += fnormal
        totals[1] += m
    return flows


@njit(cache=True)
def rut_wall(grid, base_z, soil, walls, cx, cy, m0, m1, m2, a0, a1, a2, r, z, length, vx, vy, vz, wx, wy, wz,
             v_eps, wrench, jac, d_twist):
    """The rut walls' passive resistance on one piece (body_contact.py, "rut walls"): Rankine's passive force
    over the piece's contact length ``length`` and depth ``z`` (m, its deepest sinkage along N),
    P = L (½ γ z² K_p + 2 c z √K_p), against the piece centre's slip across its axis in the base's tangent
    plane, v_a: −P v_a / √(v_a² + v_ε²) along the across direction e = N × ĥ, applied z/3 above the piece's
    bottom (the resultant's depth of the weight's triangular part). (cx, cy) is the centre, m = centre −
    link origin (world). Adds to ``wrench`` (about the link origin) and, with ``jac``, the velocity slope
    −P v_ε² / ρ³ e eᵀ (the slip the centre's, the force at that point) to ``d_twist``; P's dependence on the
    depth is left out."""
    gamma, kp = walls[0], walls[1]
    p_wall = length * (0.5 * gamma * z * z * kp + 2.0 * soil[SC] * z * math.sqrt(kp))
    if p_wall <= 0.0:
        return
    n0, n1, n2 = base_normal(grid, base_z, cx, cy)
    # the axis in the tangent plane, ĥ, and across it, e = N × ĥ
    ad = a0 * n0 + a1 * n1 + a2 * n2
    h0, h1, h2 = a0 - ad * n0, a1 - ad * n1, a2 - ad * n2
    hl = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    h0, h1, h2 = h0 / hl, h1 / hl, h2 / hl
    e0, e1, e2 = cross(n0, n1, n2, h0, h1, h2)
    w0, w1, w2 = cross(wx, wy, wz, m0, m1, m2)
    va = (vx + w0) * e0 + (vy + w1) * e1 + (vz + w2) * e2
    rho = math.sqrt(va * va + v_eps * v_eps)
    f = -p_wall * va / rho
    # where it acts: below the centre, z/3 above the piece's bottom
    depth = r - z / 3.0
    q0, q1, q2 = m0 - depth * n0, m1 - depth * n1, m2 - depth * n2
    wrench[0] += f * e0
    wrench[1] += f * e1
    wrench[2] += f * e2
    t0, t1, t2 = cross(q0, q1, q2, f * e0, f * e1, f * e2)
    wrench[3] += t0
    wrench[4] += t1
    wrench[5] += t2
    if jac:
        # k (X_qᵀ e)(X_mᵀ e)ᵀ: the slip is the centre's (lever m), the force acts at q, z/3 above the bottom;
        # one lever for both (X_qᵀ D X_q) missed ∂f/∂ω by the r − z/3 between them, ~8 % of ∂f_y/∂ω_x
        k = -p_wall * v_eps * v_eps / (rho * rho * rho)
        tq0, tq1, tq2 = cross(q0, q1, q2, e0, e1, e2)
        tm0, tm1, tm2 = cross(m0, m1, m2, e0, e1, e2)
        a = (e0, e1, e2, tq0, tq1, tq2)
        c = (e0, e1, e2, tm0, tm1, tm2)
        for i in range(6):
            for j in range(6):
                d_twist[i, j] += k * a[i] * c[j]
