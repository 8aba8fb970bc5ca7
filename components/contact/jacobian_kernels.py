"""Derivatives of the screw–SDF contact wrenches for linearly implicit integrators.

One point (kernels_numba.point_contact_force, paper eq. 2 and regularised eq. 6)::

    F   = F_n n̂ + F_t,     F_n = max(0, k d − c v·n̂),     d = −φ(p_s)
    F_t = −μ F_n A s,      A = I + (κ − 1) ê ê ᵀ,  κ = max(ev_a + ev_b F_n, ev_floor)
    s   = t / sqrt(‖t‖² + v_ε²)  (sqrt) or t / max(‖t‖, v_ε)  (linear),  t = (I − n̂n̂ᵀ) v

so, with g = ∂F/∂F_n = n̂ − μ A s − μ F_n κ' (s·ê) ê (κ' = ev_b unless floored),

    ∂F/∂v   = g ⊗ ∂F_n/∂v − μ F_n A (∂s/∂t)(I − n̂n̂ᵀ),    ∂F_n/∂v = −c n̂  (0 when F_n = 0)
    ∂F/∂p_s = g ⊗ ∂F_n/∂p_s,                              ∂F_n/∂p_s = −k n̂ (φ's gradient is n̂)

The force acts at p_c and moves with the screw link: v = X_c V, X_c = [I, −[r_c]×] with r_c from
the screw link's origin (V its twist, world axes), and the wrench about that origin is X_cᵀ F.
The depth is taken to move with p_c too (δp_s ≈ X_c δ, δ the link's small displacement): the
envelope is a surface of revolution, so the spin, whose displacement â × r_c is tangent at p_c,
leaves the depth alone, as it does in the model (samples fixed in the parent body). So each
point adds X_cᵀ (∂F/∂v) X_c to the link's d_twist block and X_cᵀ (∂F/∂p_s) X_c to its d_pose. The v_ε slope of s is what makes a held screw
stiff: μ F_n κ r² / (v_ε I) ≈ 1e4 s⁻¹ on an EELS spin DOF.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..multibody.pose_quaternions import pose_rotation
from .contact_law import law_locals, material_law, skin_law
from .point_kernels import world_axis


@njit(cache=True)
def point_jacobian(depth, n, v, e, stiffness, damping, mu, ev_a, ev_b, v_eps, mode, ev_floor, ahead, Dv, Dp, W, gk):
    """∂F/∂v (3×3) into Dv and ∂F/∂p_s into Dp at one point (see the module docstring); W is (3, 3, 3)
    scratch. Dp = g ⊗ (−k n̂) is rank one: g·(−k) goes into gk (3) for :func:`add_lever_rank1`. Returns
    False when the point pushes no force (F_n = 0: Dv and Dp are zero) and is not ``ahead`` (about to touch:
    then the normal spring-damper's slopes are given as if it pushed, with F_n = 0). No allocation."""
    vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2]
    raw = stiffness * depth - damping * vn
    fn = raw if (depth > 0.0 and raw > 0.0) else 0.0
    on = 1.0 if (fn > 0.0 or ahead) else 0.0
    t0, t1, t2 = v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2]
    speed = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    # s = a t, ∂s/∂t = a I − b t tᵀ
    if mode == 0:
        rho = math.sqrt(speed * speed + v_eps * v_eps)
        a = 1.0 / rho if rho > 0.0 else 0.0
        b = a * a * a
    elif speed > v_eps:
        a = 1.0 / speed
        b = a * a * a
    else:
        a = 1.0 / v_eps if v_eps > 0.0 else 0.0
        b = 0.0
    s0, s1, s2 = t0 * a, t1 * a, t2 * a
    dsdt, A, B = W[0], W[1], W[2]
    dsdt[0, 0], dsdt[0, 1], dsdt[0, 2] = a - b * t0 * t0, -b * t0 * t1, -b * t0 * t2
    dsdt[1, 0], dsdt[1, 1], dsdt[1, 2] = -b * t1 * t0, a - b * t1 * t1, -b * t1 * t2
    dsdt[2, 0], dsdt[2, 1], dsdt[2, 2] = -b * t2 * t0, -b * t2 * t1, a - b * t2 * t2
    en = e[0] * n[0] + e[1] * n[1] + e[2] * n[2]
    e0, e1, e2 = e[0] - en * n[0], e[1] - en * n[1], e[2] - en * n[2]
    enorm = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if enorm > 1e-12:
        e0, e1, e2 = e0 / enorm, e1 / enorm, e2 / enorm
    else:
        e0, e1, e2 = 0.0, 0.0, 0.0
    kap = ev_a + ev_b * fn
    dkap = ev_b
    if kap < ev_floor:
        kap, dkap = ev_floor, 0.0
    k1 = kap - 1.0
    A[0, 0], A[0, 1], A[0, 2] = 1.0 + k1 * e0 * e0, k1 * e0 * e1, k1 * e0 * e2
    A[1, 0], A[1, 1], A[1, 2] = k1 * e1 * e0, 1.0 + k1 * e1 * e1, k1 * e1 * e2
    A[2, 0], A[2, 1], A[2, 2] = k1 * e2 * e0, k1 * e2 * e1, 1.0 + k1 * e2 * e2
    c = mu * fn * dkap * (s0 * e0 + s1 * e1 + s2 * e2)
    g0 = n[0] - mu * (A[0, 0] * s0 + A[0, 1] * s1 + A[0, 2] * s2) - c * e0
    g1 = n[1] - mu * (A[1, 0] * s0 + A[1, 1] * s1 + A[1, 2] * s2) - c * e1
    g2 = n[2] - mu * (A[2, 0] * s0 + A[2, 1] * s1 + A[2, 2] * s2) - c * e2
    for i in range(3):
        for j in range(3):
            B[i, j] = A[i, 0] * dsdt[0, j] + A[i, 1] * dsdt[1, j] + A[i, 2] * dsdt[2, j]
    cd, ck, mf = -damping * on, -stiffness * on, mu * fn
    for i in range(3):
        gi = g0 if i == 0 else (g1 if i == 1 else g2)
        bn = B[i, 0] * n[0] + B[i, 1] * n[1] + B[i, 2] * n[2]
        for j in range(3):
            Dv[i, j] = gi * cd * n[j] - mf * (B[i, j] - bn * n[j])       # A ∂s/∂t (I − n nᵀ)
            Dp[i, j] = gi * ck * n[j]
    gk[0], gk[1], gk[2] = g0 * ck, g1 * ck, g2 * ck
    return on > 0.0


@njit(cache=True)
def add_lever_quadratic(r, D, out):
    """out += Xᵀ D X for X = [I, L], L = −[r]× (3×6): a point force's derivative as a 6×6 block
    about the origin r is measured from. No allocation."""
    L00, L01, L02 = 0.0, r[2], -r[1]
    L10, L11, L12 = -r[2], 0.0, r[0]
    L20, L21, L22 = r[1], -r[0], 0.0
    # (D L) row by row, kept for Lᵀ (D L) below: the same products in the same order as written out per entry
    x00 = D[0, 0] * L00 + D[0, 1] * L10 + D[0, 2] * L20
    x01 = D[0, 0] * L01 + D[0, 1] * L11 + D[0, 2] * L21
    x02 = D[0, 0] * L02 + D[0, 1] * L12 + D[0, 2] * L22
    x10 = D[1, 0] * L00 + D[1, 1] * L10 + D[1, 2] * L20
    x11 = D[1, 0] * L01 + D[1, 1] * L11 + D[1, 2] * L21
    x12 = D[1, 0] * L02 + D[1, 1] * L12 + D[1, 2] * L22
    x20 = D[2, 0] * L00 + D[2, 1] * L10 + D[2, 2] * L20
    x21 = D[2, 0] * L01 + D[2, 1] * L11 + D[2, 2] * L21
    x22 = D[2, 0] * L02 + D[2, 1] * L12 + D[2, 2] * L22
    for i in range(3):
        out[i, 0] += D[i, 0]
        out[i, 1] += D[i, 1]
        out[i, 2] += D[i, 2]
    out[0, 3] += x00
    out[0, 4] += x01
    out[0, 5] += x02
    out[1, 3] += x10
    out[1, 4] += x11
    out[1, 5] += x12
    out[2, 3] += x20
    out[2, 4] += x21
    out[2, 5] += x22
    for j in range(3):
        c0, c1, c2 = D[0, j], D[1, j], D[2, j]
        # (Lᵀ D)[:, j]
        out[3, j] += L00 * c0 + L10 * c1 + L20 * c2
        out[4, j] += L01 * c0 + L11 * c1 + L21 * c2
        out[5, j] += L02 * c0 + L12 * c1 + L22 * c2
    # (Lᵀ D L)[i, j] = Σ_k L[k, i] (D L)[k, j], summed from 0.0 in k order
    out[3, 3] += ((0.0 + L00 * x00) + L10 * x10) + L20 * x20
    out[3, 4] += ((0.0 + L00 * x01) + L10 * x11) + L20 * x21
    out[3, 5] += ((0.0 + L00 * x02) + L10 * x12) + L20 * x22
    out[4, 3] += ((0.0 + L01 * x00) + L11 * x10) + L21 * x20
    out[4, 4] += ((0.0 + L01 * x01) + L11 * x11) + L21 * x21
    out[4, 5] += ((0.0 + L01 * x02) + L11 * x12) + L21 * x22
    out[5, 3] += ((0.0 + L02 * x00) + L12 * x10) + L22 * x20
    out[5, 4] += ((0.0 + L02 * x01) + L12 * x11) + L22 * x21
    out[5, 5] += ((0.0 + L02 * x02) + L12 * x12) + L22 * x22


@njit(cache=True)
def add_lever_rank1(r, g, m, out):
    """out += (Xᵀ g)(Xᵀ m)ᵀ = Xᵀ (g mᵀ) X for X = [I, L], L = −[r]×: :func:`add_lever_quadratic` of a
    rank-one D = g mᵀ (the depth derivative, g ⊗ (−k n̂)) in 36 products instead of ~90. No allocation."""
    g0, g1, g2, m0, m1, m2 = g[0], g[1], g[2], m[0], m[1], m[2]
    # Lᵀ g = [r]× g = r × g
    a = (g0, g1, g2, r[1] * g2 - r[2] * g1, r[2] * g0 - r[0] * g2, r[0] * g1 - r[1] * g0)
    b = (m0, m1, m2, r[1] * m2 - r[2] * m1, r[2] * m0 - r[0] * m2, r[0] * m1 - r[1] * m0)
    for i in range(6):
        ai = a[i]
        for j in range(6):
            out[i, j] += ai * b[j]


@njit(cache=True, inline="always")
def _point_scratch():
    """Per-call scratch of a Jacobian-block kernel: ∂F/∂v, ∂F/∂p (3×3), point_jacobian's W (3×3×3), a
    rotation, and 3-vectors for ê, the lever arm, n̂, v and g·(−k)."""
    return (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3),
            np.empty(3), np.empty(3), np.empty(3))


@njit(cache=True)
def _clear_marked(d_twist, d_pose, on_link):
    """Zero the blocks of the links marked in on_link (the last evaluation's) and unmark them."""
    for i in range(on_link.size):
        if on_link[i]:
            d_twist[i, :, :] = 0.0
            d_pose[i, :, :] = 0.0
            on_link[i] = False


@njit(cache=True)
def contact_jacobian_blocks(samples, work, ports, mats, m, d_twist, d_pose, on_link):
    """Per screw link, Σ over its samples in contact of X_cᵀ ∂F/∂v X_c and X_cᵀ ∂F/∂p_s X_c (about the
    screw link's origin, world axes), from the last evaluation's per-sample results in its first m rows
    (screw_contact_kernels records: work.point = p_c, work.vel = v; ``mats`` the terrain's material table),
    with the law the forces took (the contact law record ports.law, contact_law.py: its μ and ‖e_v‖ scales; the distances already carry its sinkage). A sample not yet touching (gap under ``near``) whose gap closes within ``lookahead_time`` at its approach speed
    (its p_c and v are there: contact_wrenches' ``near`` rows) adds its normal spring-damper slopes too:
    a step that starts with the contact open then meets it implicitly, as a joint stop's look-ahead
    does (joint_stops.py), instead of integrating k and c explicitly over the step that makes contact.
    Blocks of links marked in on_link are overwritten, others untouched; returns the number of links
    marked."""
    # the records' arrays into locals, once (contact_law.py: a field read in the loop costs a reference count)
    distance, normal, material, owner, point, vel = work.distance, work.normal, work.material, work.owner, \
        work.point, work.vel
    poses, law, axis_B, screw_row, parent_row = ports.poses, ports.law, samples.axis_B, samples.screw_row, \
        samples.parent_row
    lead_angle, hand, near, lookahead_time = samples.lead_angle, samples.hand, samples.near, samples.lookahead_time
    _clear_marked(d_twist, d_pose, on_link)
    Dv, Dp, W, R, e, rc, nrm, vv, gk = _point_scratch()
    count = 0
    mu_scale, ev_scale, _, _, _, v_eps, mode, ev_floor = law_locals(law)
    last = -1                  # rows come grouped by screw: its axis and thread once per screw
    o = 0
    a0 = a1 = a2 = cl = sl = 0.0
    for i in range(m):
        d = -distance[i]
        ahead = False
        if not d > 0.0:
            if not -d < near:
                continue                    # beyond the near rows contact_wrenches gave p_c and v
            vn = vel[i, 0] * normal[i, 0] + vel[i, 1] * normal[i, 1] + vel[i, 2] * normal[i, 2]
            if not -d < -vn * lookahead_time:
                continue
            ahead = True
        s = owner[i]
        if s != last:
            last = s
            b = parent_row[s]
            o = screw_row[s]
            pose_rotation(poses, b, R)
            a0, a1, a2 = world_axis(R, axis_B, s)
            cl, sl = math.cos(lead_angle[s]), hand[s] * math.sin(lead_angle[s])
        for j in range(3):
            nrm[j] = normal[i, j]
            vv[j] = vel[i, j]
            rc[j] = point[i, j] - poses[o, j]
        # ê_c from the contact point: p_c − c_ring is r ê_c, normal to the axis; â × ê_c the
        # circumferential direction (as contact_wrenches builds it)
        na = nrm[0] * a0 + nrm[1] * a1 + nrm[2] * a2
        u0, u1, u2 = na * a0 - nrm[0], na * a1 - nrm[1], na * a2 - nrm[2]
        un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if un > 1e-9:
            u0, u1, u2 = u0 / un, u1 / un, u2 / un
        cx, cy, cz = a1 * u2 - a2 * u1, a2 * u0 - a0 * u2, a0 * u1 - a1 * u0
        e[0], e[1], e[2] = cl * a0 - sl * cx, cl * a1 - sl * cy, cl * a2 - sl * cz
        k, c, mu, ev_a, ev_b = material_law(mats, material[i], mu_scale[s], ev_scale[s])
        if point_jacobian(d, nrm, vv, e, k, c, mu, ev_a, ev_b, v_eps, mode, ev_floor, ahead, Dv, Dp, W, gk):
            add_lever_quadratic(rc, Dv, d_twist[o])
            add_lever_rank1(rc, gk, nrm, d_pose[o])           # X_cᵀ (gk ⊗ n̂) X_c
        if not on_link[o]:
            on_link[o] = True
            count += 1
    return count


@njit(cache=True)
def body_jacobian_blocks(table, work, ports, mats, m, d_twist, d_pose, on_link):
    """Body contact (body_kernels.body_contact_wrenches; its records BodyTable, BodyWork, BodyPorts, the first m
    rows of work: points, vel): per link, Σ over its samples in contact of
    X_pᵀ ∂F/∂v X_p and X_pᵀ ∂F/∂p X_p about the link's origin (world axes), X_p = [I, −[p − o_l]×].
    The body law is point_jacobian's with ê the skin axis R_l axis_B (projected on the tangent plane
    inside), μ and κ from contact_law.skin_law as the forces took them (μ_material · mu_scale · the law's μ
    scale, κ = skin_ratio · its ‖e_v‖ scale; ev_b = 0: no load dependence). The sample is
    fixed in the link, so its depth moves with it (δp = X_p δ_l). Blocks of links marked in on_link are
    overwritten, others untouched; returns the number of links marked."""
    distance, normal, material, sample, owner = work.distance, work.normal, work.material, work.sample, work.owner
    point, vel, poses, law = work.points, work.vel, ports.poses, ports.law
    piece_link, axis_B, mu_scale, skin_ratio = table.piece_link, table.axis_B, table.mu_scale, table.skin_ratio
    _clear_marked(d_twist, d_pose, on_link)
    Dv, Dp, W, R, e, rc, nrm, vv, gk = _point_scratch()
    count = 0
    law_mu, law_ev, _, _, _, v_eps, mode, ev_floor = law_locals(law)
    for i in range(m):
        d = -distance[i]
        if not d > 0.0:
            continue
        k = owner[i]
        q = sample[i]
        b = piece_link[k]
        pose_rotation(poses, b, R)
        for j in range(3):
            e[j] = R[j, 0] * axis_B[q, 0] + R[j, 1] * axis_B[q, 1] + R[j, 2] * axis_B[q, 2]
        for j in range(3):
            nrm[j] = normal[i, j]
            vv[j] = vel[i, j]
            rc[j] = point[i, j] - poses[b, j]
        kk, c, mu, ev_a, ev_b = skin_law(mats, material[i], mu_scale[k], skin_ratio[k], law_mu[b], law_ev[b])
        if point_jacobian(d, nrm, vv, e, kk, c, mu, ev_a, ev_b, v_eps, mode, ev_floor, False, Dv, Dp, W, gk):
            add_lever_quadratic(rc, Dv, d_twist[b])
            add_lever_rank1(rc, gk, nrm, d_pose[b])
        if not on_link[b]:
            on_link[b] = True
            count += 1
    return count
