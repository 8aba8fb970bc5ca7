"""O(links) factorisation and solve of the Rosenbrock matrix on the link tree (articulated-body style).

The linearly implicit step's matrix for one multibody (framework/linearization.py) is

    W = M − c G_v − c² G_q + diag(d_extra),        c = γh
      = Σ_l J_lᵀ Ĩ_l J_l + diag(d),                 Ĩ_l = I_l − c A_l^twist − c² A_l^pose

with I_l link l's spatial inertia, A_l its contact blocks (∂W_l/∂V_l, ∂W_l/∂δ_l, generally not
symmetric), J_l its (6 × nv) Jacobian and d the joint-diagonal terms (armature, the PID's gains
and its integral's elimination, joint damping). All 6×6 quantities here are about the ROOT
link's origin O in world axes, so nothing is shifted between parent and child.

With σ_l = m_l [a_l × (O − p_l), a_l] the unit twist of link l's joint (m_l the mimic
multiplier; a counter-rotating screw pair is one DOF k moving two links), the quadratic form
xᵀ W y = Σ_l V_l(x)ᵀ Ĩ_l V_l(y) + Σ d_k x_k y_k is eliminated DOF by DOF from the leaves, as
ABA does (Featherstone, RBDA ch. 7) but with non-symmetric link matrices:

    U_k = Σ_{l∈L_k} Ia_l σ_l,   U'_k = Σ_{l∈L_k} Ia_lᵀ σ_l,   D_k = d_k + Σ_{l∈L_k} σ_lᵀ Ia_l σ_l
    Ia_anchor += −U_k U'_kᵀ / D_k   (and every Ia_l is added to its parent's)

L_k the links DOF k moves directly, its "anchor" the rigid body they hang from (the parent's
nearest non-fixed ancestor-or-self; one for every link of L_k, none an ancestor of another:
:func:`tree_plan` checks). The root's 6×6 block Sbᵀ Ia_root Sb (Sb = blockdiag(R_root,
R_root): Pinocchio's free-flyer velocity is in the root's frame) is factorised by a 6×6 LU.
The solve is the same recursion on a right-hand side (bias wrenches p, β_k = b_k − Σ σ_lᵀ p_l)
and a forward pass y_k = (β_k − U'_k·V_anchor) / D_k. Cost O(nl) per factorisation and per
solve, against O(nv³) and O(nv²) for the dense LU. No pivoting across DOFs: W is dominated by
M (positive definite) and the contact terms only add damping-like blocks (−c A^twist has a
non-negative symmetric part); a zero D_k is reported (returns False).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from snakesim.framework.linear_solve_kernels import lu_factor, lu_solve

from ..kernel_args import record
from .kernels import FIXED, REVOLUTE, _ensure_kinematics, accelerations, cut_wrenches, forward_kinematics


def tree_plan(order, parent, jtype, vidx, nv):
    """(anchor_ptr, anchor_dof) — per link, the DOFs whose elimination lands on it (CSR) — or None
    with the reason when a DOF's links do not hang from one rigid body or one is an ancestor of
    another (then the tree recursion does not apply)."""
    nl = order.size
    anchor_of = np.full(nv, -1, dtype=np.int64)
    links_of: dict[int, list[int]] = {}
    for l in order:
        if jtype[l] != REVOLUTE:
            continue
        a = parent[l]
        while jtype[a] == FIXED:
            a = parent[a]
        k = int(vidx[l])
        if anchor_of[k] >= 0 and anchor_of[k] != a:
            return None, f"DOF {k}'s links hang from different bodies"
        anchor_of[k] = a
        links_of.setdefault(k, []).append(int(l))
    for k, ls in links_of.items():
        if len(ls) > 1:
            members = set(ls)
            for l in ls:
                b = parent[l]
                while b >= 0:
                    if b in members:
                        return None, f"DOF {k} moves link {l} and its ancestor {b}"
                    b = parent[b]
    if np.any(anchor_of[6:] < 0):
        return None, "a DOF moves no link"
    counts = np.zeros(nl + 1, dtype=np.int64)
    for k in range(6, nv):
        counts[anchor_of[k] + 1] += 1
    ptr = np.cumsum(counts)
    dof = np.empty(ptr[-1], dtype=np.int64)
    fill = ptr[:-1].copy()
    for k in range(6, nv):
        a = anchor_of[k]
        dof[fill[a]] = k
        fill[a] += 1
    return (ptr, dof), None


@njit(cache=True)
def _shift(rx, ry, rz, A, out):
    """out = Tᵀ A T, T = [[I, L], [0, I]], L = −[r]×: a 6×6 block about a link origin moved to a point
    at −r from it (twists and wrenches in world axes, [linear, angular])."""
    # X = A T
    X = np.empty((6, 6))
    for i in range(6):
        a0, a1, a2 = A[i, 0], A[i, 1], A[i, 2]
        X[i, 0], X[i, 1], X[i, 2] = a0, a1, a2
        X[i, 3] = -a1 * rz + a2 * ry + A[i, 3]
        X[i, 4] = a0 * rz - a2 * rx + A[i, 4]
        X[i, 5] = -a0 * ry + a1 * rx + A[i, 5]
    for j in range(6):
        x0, x1, x2 = X[0, j], X[1, j], X[2, j]
        out[0, j], out[1, j], out[2, j] = x0, x1, x2
        out[3, j] = -rz * x1 + ry * x2 + X[3, j]
        out[4, j] = rz * x0 - rx * x2 + X[4, j]
        out[5, j] = -ry * x0 + rx * x1 + X[5, j]


@njit(cache=True)
def prepare(order, jtype, mult, mass, com, inertia, R, p, aw, has_a, atw, apo, Iin, AtwO, ApO, sig, blocks=True):
    """The q-dependent parts: each link's spatial inertia about O (Iin), its contact blocks moved to
    O (AtwO, ApO: where has_a, zero elsewhere; untouched when not ``blocks``), its joint's scaled
    unit twist σ_l at O (sig). Massless links' Iin is left as it is (zero from allocation)."""
    root = order[0]
    ox, oy, oz = p[root, 0], p[root, 1], p[root, 2]
    Ic = np.empty((3, 3))
    RI = np.empty((3, 3))
    for l in range(order.size):
        if blocks:
            if has_a[l]:
                dx, dy, dz = p[l, 0] - ox, p[l, 1] - oy, p[l, 2] - oz
                _shift(dx, dy, dz, atw[l], AtwO[l])
                _shift(dx, dy, dz, apo[l], ApO[l])
            else:
                AtwO[l, :, :] = 0.0         # dense() reads every link's block
                ApO[l, :, :] = 0.0
        if jtype[l] == REVOLUTE:
            a0, a1, a2 = aw[l, 0], aw[l, 1], aw[l, 2]
            qx, qy, qz = ox - p[l, 0], oy - p[l, 1], oz - p[l, 2]
            mu = mult[l]
            sig[l, 0] = mu * (a1 * qz - a2 * qy)
            sig[l, 1] = mu * (a2 * qx - a0 * qz)
            sig[l, 2] = mu * (a0 * qy - a1 * qx)
            sig[l, 3], sig[l, 4], sig[l, 5] = mu * a0, mu * a1, mu * a2
        else:
            sig[l, :] = 0.0
        m = mass[l]
        if m == 0.0 and inertia[l, 0, 0] == 0.0 and inertia[l, 1, 1] == 0.0 and inertia[l, 2, 2] == 0.0:
            continue
        Rl = R[l]
        # centre of mass relative to O, world axes
        rx = Rl[0, 0] * com[l, 0] + Rl[0, 1] * com[l, 1] + Rl[0, 2] * com[l, 2] + p[l, 0] - ox
        ry = Rl[1, 0] * com[l, 0] + Rl[1, 1] * com[l, 1] + Rl[1, 2] * com[l, 2] + p[l, 1] - oy
        rz = Rl[2, 0] * com[l, 0] + Rl[2, 1] * com[l, 1] + Rl[2, 2] * com[l, 2] + p[l, 2] - oz
        for i in range(3):              # R I Rᵀ
            for b in range(3):
                RI[i, b] = Rl[i, 0] * inertia[l, 0, b] + Rl[i, 1] * inertia[l, 1, b] + Rl[i, 2] * inertia[l, 2, b]
        for i in range(3):
            for j in range(3):
                Ic[i, j] = RI[i, 0] * Rl[j, 0] + RI[i, 1] * Rl[j, 1] + RI[i, 2] * Rl[j, 2]
        I = Iin[l]
        # [[m 1, −m[r]×], [m[r]×, I_c − m[r]×[r]×]]
        for i in range(3):
            for j in range(3):
                I[i, j] = m if i == j else 0.0
        I[0, 3], I[0, 4], I[0, 5] = 0.0, m * rz, -m * ry
        I[1, 3], I[1, 4], I[1, 5] = -m * rz, 0.0, m * rx
        I[2, 3], I[2, 4], I[2, 5] = m * ry, -m * rx, 0.0
        I[3, 0], I[3, 1], I[3, 2] = 0.0, -m * rz, m * ry
        I[4, 0], I[4, 1], I[4, 2] = m * rz, 0.0, -m * rx
        I[5, 0], I[5, 1], I[5, 2] = -m * ry, m * rx, 0.0
        rr = rx * rx + ry * ry + rz * rz
        I[3, 3] = Ic[0, 0] + m * (rr - rx * rx)
        I[4, 4] = Ic[1, 1] + m * (rr - ry * ry)
        I[5, 5] = Ic[2, 2] + m * (rr - rz * rz)
        I[3, 4] = Ic[0, 1] - m * rx * ry
        I[4, 3] = Ic[1, 0] - m * rx * ry
        I[3, 5] = Ic[0, 2] - m * rx * rz
        I[5, 3] = Ic[2, 0] - m * rx * rz
        I[4, 5] = Ic[1, 2] - m * ry * rz
        I[5, 4] = Ic[2, 1] - m * ry * rz


@njit(cache=True)
def prepare_from(order, p, has_a, atw, apo, Iin_src, sig_src, Iin, AtwO, ApO, sig):
    """:func:`prepare` with the link inertias and joint twists copied from ``Iin_src``, ``sig_src`` (the
    forward dynamics' at the same configuration) instead of recomputed; the contact blocks shifted as there."""
    root = order[0]
    ox, oy, oz = p[root, 0], p[root, 1], p[root, 2]
    for l in range(order.size):
        if has_a[l]:
            dx, dy, dz = p[l, 0] - ox, p[l, 1] - oy, p[l, 2] - oz
            _shift(dx, dy, dz, atw[l], AtwO[l])
            _shift(dx, dy, dz, apo[l], ApO[l])
        else:
            AtwO[l, :, :] = 0.0
            ApO[l, :, :] = 0.0
        for i in range(6):
            sig[l, i] = sig_src[l, i]
            for j in range(6):
                Iin[l, i, j] = Iin_src[l, i, j]


@njit(cache=True)
def _factor_root(Rr, A, root_lu, root_piv):
    """LU of the free-flyer's block Sbᵀ A Sb, Sb = blockdiag(Rr, Rr) (A: the root's articulated 6×6)."""
    for bi in range(2):
        for bj in range(2):
            for i in range(3):
                for j in range(3):
                    s = 0.0
                    for a in range(3):
                        for b in range(3):
                            s += Rr[a, i] * A[3 * bi + a, 3 * bj + b] * Rr[b, j]
                    root_lu[3 * bi + i, 3 * bj + j] = s
    return lu_factor(root_lu, root_piv)


@njit(cache=True)
def factor(order, parent, jtype, vidx, anc_ptr, anc_dof, R, Iin, AtwO, ApO, has_a, sig, c, d, Ia, Ucol, Urow, D,
           root_lu, root_piv):
    """Eliminate every DOF of W = Σ J_lᵀ (Iin − c AtwO − c² ApO)_l J_l + diag(d) from the leaves
    (module docstring); the root's 6×6 block LU into root_lu, root_piv. False if a pivot is zero."""
    c2 = c * c
    nl = order.size
    for l in range(nl):
        if has_a[l]:
            for i in range(6):
                for j in range(6):
                    Ia[l, i, j] = Iin[l, i, j] - c * AtwO[l, i, j] - c2 * ApO[l, i, j]
        else:
            Ia[l] = Iin[l]
    nv = D.size
    for k in range(6, nv):
        D[k] = d[k]
        for i in range(6):
            Ucol[k, i] = 0.0
            Urow[k, i] = 0.0
    for n in range(nl - 1, -1, -1):
        l = order[n]
        A = Ia[l]
        for a in range(anc_ptr[l], anc_ptr[l + 1]):
            k = anc_dof[a]
            if D[k] == 0.0 or not np.isfinite(D[k]):
                return False
            inv = 1.0 / D[k]
            for i in range(6):
                ui = Ucol[k, i] * inv
                for j in range(6):
                    A[i, j] -= ui * Urow[k, j]
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            s0, s1, s2, s3, s4, s5 = sig[l, 0], sig[l, 1], sig[l, 2], sig[l, 3], sig[l, 4], sig[l, 5]
            dk = 0.0
            for i in range(6):
                col = A[i, 0] * s0 + A[i, 1] * s1 + A[i, 2] * s2 + A[i, 3] * s3 + A[i, 4] * s4 + A[i, 5] * s5
                row = A[0, i] * s0 + A[1, i] * s1 + A[2, i] * s2 + A[3, i] * s3 + A[4, i] * s4 + A[5, i] * s5
                Ucol[k, i] += col
                Urow[k, i] += row
                dk += sig[l, i] * col
            D[k] += dk
        if n > 0:
            P = Ia[parent[l]]
            for i in range(6):
                for j in range(6):
                    P[i, j] += A[i, j]
    # the free-flyer: Sbᵀ Ia_root Sb, Sb = blockdiag(R_root, R_root)
    return _factor_root(R[order[0]], Ia[order[0]], root_lu, root_piv)


@njit(cache=True)
def factor_symmetric(order, parent, jtype, vidx, anc_ptr, anc_dof, R, Iin, sig, d, Ia, U, D, root_lu, root_piv):
    """:func:`factor` for a symmetric W = Σ J_lᵀ Iin_l J_l + diag(d) (c = 0: the mass matrix of the forward
    dynamics): the same elimination on the upper triangles only (U = Ucol = Urow), ~45 % fewer operations.
    Ia's lower triangles are left stale except the root's, mirrored for its 6×6 block."""
    nl = order.size
    for l in range(nl):
        for i in range(6):
            for j in range(i, 6):
                Ia[l, i, j] = Iin[l, i, j]
    nv = D.size
    for k in range(6, nv):
        D[k] = d[k]
        for i in range(6):
            U[k, i] = 0.0
    col = np.empty(6)
    for n in range(nl - 1, -1, -1):
        l = order[n]
        A = Ia[l]
        for a in range(anc_ptr[l], anc_ptr[l + 1]):
            k = anc_dof[a]
            if D[k] == 0.0 or not np.isfinite(D[k]):
                return False
            inv = 1.0 / D[k]
            for i in range(6):
                ui = U[k, i] * inv
                for j in range(i, 6):
                    A[i, j] -= ui * U[k, j]
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            dk = 0.0
            for i in range(6):
                s = 0.0
                for j in range(i):
                    s += A[j, i] * sig[l, j]
                for j in range(i, 6):
                    s += A[i, j] * sig[l, j]
                col[i] = s
                U[k, i] += s
                dk += sig[l, i] * s
            D[k] += dk
        if n > 0:
            P = Ia[parent[l]]
            for i in range(6):
                for j in range(i, 6):
                    P[i, j] += A[i, j]
    root = order[0]
    A = Ia[root]
    for i in range(6):
        for j in range(i):
            A[i, j] = A[j, i]
    return _factor_root(R[root], A, root_lu, root_piv)


@njit(cache=True)
def solve(order, parent, jtype, vidx, anc_ptr, anc_dof, R, sig, Ucol, Urow, D, root_lu, root_piv, b, pb, V, done):
    """b ← W⁻¹ b with :func:`factor`'s result (pb, V: (nl, 6) scratch; done: (nv,) bool scratch)."""
    nl = order.size
    for l in range(nl):
        for i in range(6):
            pb[l, i] = 0.0
    # backward: bias wrenches, β_k = b_k − Σ σ_lᵀ p_l (kept in b[k])
    for n in range(nl - 1, -1, -1):
        l = order[n]
        for a in range(anc_ptr[l], anc_ptr[l + 1]):
            k = anc_dof[a]
            f = b[k] / D[k]
            for i in range(6):
                pb[l, i] += Ucol[k, i] * f
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            b[k] -= (sig[l, 0] * pb[l, 0] + sig[l, 1] * pb[l, 1] + sig[l, 2] * pb[l, 2] + sig[l, 3] * pb[l, 3]
                     + sig[l, 4] * pb[l, 4] + sig[l, 5] * pb[l, 5])
        if n > 0:
            P = parent[l]
            for i in range(6):
                pb[P, i] += pb[l, i]
    root = order[0]
    Rr = R[root]
    y = np.empty(6)
    for bi in range(2):
        for i in range(3):
            s = 0.0
            for a in range(3):
                s += Rr[a, i] * pb[root, 3 * bi + a]
            y[3 * bi + i] = b[3 * bi + i] - s
    lu_solve(root_lu, root_piv, y)
    for i in range(6):
        b[i] = y[i]
    for bi in range(2):
        for a in range(3):
            V[root, 3 * bi + a] = Rr[a, 0] * y[3 * bi] + Rr[a, 1] * y[3 * bi + 1] + Rr[a, 2] * y[3 * bi + 2]
    for k in range(done.size):
        done[k] = False
    for n in range(1, nl):
        l = order[n]
        P = parent[l]
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            if not done[k]:
                s = 0.0
                for i in range(6):
                    s += Urow[k, i] * V[P, i]
                b[k] = (b[k] - s) / D[k]
                done[k] = True
            yk = b[k]
            for i in range(6):
                V[l, i] = V[P, i] + sig[l, i] * yk
        else:
            for i in range(6):
                V[l, i] = V[P, i]


@njit(cache=True)
def apply(order, parent, jtype, vidx, R, sig, Iin, ApO, has_a, c, rq, rv, dv, dq, out, Vv, Vq, F):
    """out = M r_v + c G_q r_q on the tree: Σ_l J_lᵀ (Iin_l J_l r_v + c ApO_l J_l r_q) + dv ∘ r_v + c dq ∘ r_q
    (dv, dq: the joint-diagonal parts; their first six entries are ignored)."""
    nl = order.size
    root = order[0]
    Rr = R[root]
    for bi in range(2):
        for a in range(3):
            Vv[root, 3 * bi + a] = Rr[a, 0] * rv[3 * bi] + Rr[a, 1] * rv[3 * bi + 1] + Rr[a, 2] * rv[3 * bi + 2]
            Vq[root, 3 * bi + a] = Rr[a, 0] * rq[3 * bi] + Rr[a, 1] * rq[3 * bi + 1] + Rr[a, 2] * rq[3 * bi + 2]
    for n in range(1, nl):
        l = order[n]
        P = parent[l]
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            for i in range(6):
                Vv[l, i] = Vv[P, i] + sig[l, i] * rv[k]
                Vq[l, i] = Vq[P, i] + sig[l, i] * rq[k]
        else:
            for i in range(6):
                Vv[l, i] = Vv[P, i]
                Vq[l, i] = Vq[P, i]
    for l in range(nl):
        I = Iin[l]
        for i in range(6):
            F[l, i] = (I[i, 0] * Vv[l, 0] + I[i, 1] * Vv[l, 1] + I[i, 2] * Vv[l, 2] + I[i, 3] * Vv[l, 3]
                       + I[i, 4] * Vv[l, 4] + I[i, 5] * Vv[l, 5])
        if has_a[l] and c != 0.0:
            A = ApO[l]
            for i in range(6):
                F[l, i] += c * (A[i, 0] * Vq[l, 0] + A[i, 1] * Vq[l, 1] + A[i, 2] * Vq[l, 2] + A[i, 3] * Vq[l, 3]
                                + A[i, 4] * Vq[l, 4] + A[i, 5] * Vq[l, 5])
    nv = out.size
    for k in range(6, nv):
        out[k] = dv[k] * rv[k] + c * dq[k] * rq[k]
    for n in range(nl - 1, 0, -1):
        l = order[n]
        if jtype[l] == REVOLUTE:
            k = vidx[l]
            out[k] += (sig[l, 0] * F[l, 0] + sig[l, 1] * F[l, 1] + sig[l, 2] * F[l, 2] + sig[l, 3] * F[l, 3]
                       + sig[l, 4] * F[l, 4] + sig[l, 5] * F[l, 5])
        P = parent[l]
        for i in range(6):
            F[P, i] += F[l, i]
    for bi in range(2):
        for i in range(3):
            out[3 * bi + i] = Rr[0, i] * F[root, 3 * bi] + Rr[1, i] * F[root, 3 * bi + 1] + Rr[2, i] * F[root, 3 * bi + 2]


# -- forward dynamics on the link tree (no Pinocchio Data) ------------------------------------------
#
# a = M⁻¹ (T − b(q, v)): T the generalised force (kernels.force_step: τ − damping·v + Σ J_lᵀ W_l),
# b = C(q, v) v − (gravity's generalised force) by Newton–Euler on the links with zero joint
# accelerations (kernels.accelerations with a = 0, then kernels.cut_wrenches' per-link momentum
# rates summed over the subtrees and projected on the joints), and M factorised by the same
# elimination as the implicit step's matrix with c = 0 (d = the armature; on upper triangles only,
# factor_symmetric, since M is symmetric). O(links), and it needs
# no Pinocchio Data, whose nv³ second-order tensors are 0.92 GB at 100 EELS 1.0 modules.

TreeDynamics = record("TreeDynamics", ("arm", "anc_ptr", "anc_dof", "azero", "alpha", "ao", "S", "W0", "cut0",
                                       "out0", "has_a", "Iin", "scratch6", "sig", "Ia", "Ucol", "Urow", "D",
                                       "root_lu", "root_piv", "pb", "V", "done", "a", "at_q"))


def tree_dynamics(ta, nv, arm, plan, Iin=None, sig=None, at_q=None) -> object:
    """The scratch record of :func:`forward_step` for link-tree arrays ``ta`` (model.TreeArrays). ``Iin``
    (nl, 6, 6), ``sig`` (nl, 6) and ``at_q`` (nq, NaN: none yet) may be given, to read the last solve's link
    inertias and joint twists, and the configuration they belong to (ArticulatedW.prepare reuses them)."""
    nl = ta.order.size
    z6 = lambda: np.zeros((nl, 6, 6))  # noqa: E731
    return TreeDynamics(arm=arm, anc_ptr=plan[0], anc_dof=plan[1], azero=np.zeros(nv), alpha=np.zeros((nl, 3)),
                        ao=np.zeros((nl, 3)), S=np.zeros((nl, 6)), W0=np.zeros((nl, 6)),
                        cut0=np.zeros(0, np.int64), out0=np.zeros((nl, 6)), has_a=np.zeros(nl, np.bool_),
                        Iin=z6() if Iin is None else Iin, scratch6=z6(), sig=np.zeros((nl, 6)) if sig is None else sig,
                        Ia=z6(), Ucol=np.zeros((nv, 6)), Urow=np.zeros((nv, 6)), D=np.zeros(nv),
                        root_lu=np.zeros((6, 6)), root_piv=np.zeros(6, np.int64), pb=np.zeros((nl, 6)),
                        V=np.zeros((nl, 6)), done=np.zeros(nv, np.bool_), a=np.zeros(nv),
                        at_q=np.full(0, np.nan) if at_q is None else at_q)


@njit(cache=True)
def forward_step(tree, kin, fd):
    """dv/dt into fd.a (returned) at kin.q, kin.v from the generalised force kin.T and gravity kin.g
    (kernels.force_step ran first). NaN if M's elimination meets a zero pivot."""
    t = tree
    _ensure_kinematics(tree, kin)
    R, p, w, aw = kin.R, kin.p, kin.w, kin.aw
    accelerations(t.order, t.parent, t.jtype, t.vidx, t.mult, R, p, w, aw, kin.thd, kin.v, fd.azero, fd.alpha, fd.ao)
    S = fd.S
    cut_wrenches(t.order, t.parent, R, p, w, fd.alpha, fd.ao, t.mass, t.com, t.inertia, fd.W0, kin.g, S, fd.cut0,
                 fd.out0)
    a = fd.a
    T = kin.T
    for i in range(a.size):
        a[i] = T[i]
    root = t.order[0]
    for n in range(t.order.size - 1, 0, -1):
        l = t.order[n]
        if t.jtype[l] == REVOLUTE:
            rx, ry, rz = p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2]
            tx = S[l, 3] - (ry * S[l, 2] - rz * S[l, 1])
            ty = S[l, 4] - (rz * S[l, 0] - rx * S[l, 2])
            tz = S[l, 5] - (rx * S[l, 1] - ry * S[l, 0])
            a[t.vidx[l]] -= t.mult[l] * (aw[l, 0] * tx + aw[l, 1] * ty + aw[l, 2] * tz)
    for i in range(3):
        a[i] -= R[root, 0, i] * S[root, 0] + R[root, 1, i] * S[root, 1] + R[root, 2, i] * S[root, 2]
        a[3 + i] -= R[root, 0, i] * S[root, 3] + R[root, 1, i] * S[root, 4] + R[root, 2, i] * S[root, 5]
    prepare(t.order, t.jtype, t.mult, t.mass, t.com, t.inertia, R, p, aw, fd.has_a, fd.scratch6, fd.scratch6,
            fd.Iin, fd.scratch6, fd.scratch6, fd.sig, False)
    if fd.at_q.size:
        fd.at_q[:] = kin.q          # Iin and sig belong to this configuration
    if not factor_symmetric(t.order, t.parent, t.jtype, t.vidx, fd.anc_ptr, fd.anc_dof, R, fd.Iin, fd.sig, fd.arm,
                            fd.Ia, fd.Ucol, fd.D, fd.root_lu, fd.root_piv):
        a[:] = np.nan
        return a
    solve(t.order, t.parent, t.jtype, t.vidx, fd.anc_ptr, fd.anc_dof, R, fd.sig, fd.Ucol, fd.Ucol, fd.D,
          fd.root_lu, fd.root_piv, a, fd.pb, fd.V, fd.done)
    return a


def mass_matrix(ta, nv, arm, q) -> np.ndarray:
    """M(q) (nv × nv, armature ``arm`` on the diagonal) column by column on the link tree: O(nv · links),
    for set-up checks and dense fallbacks, without a Pinocchio Data."""
    nl = ta.order.size
    R, p, w, vo, aw, thd = (np.zeros((nl, 3, 3)), np.zeros((nl, 3)), np.zeros((nl, 3)), np.zeros((nl, 3)),
                            np.zeros((nl, 3)), np.zeros(nl))
    forward_kinematics(ta.order, ta.parent, ta.jtype, ta.R0, ta.p0, ta.axis, ta.qidx, ta.qkind, ta.vidx, ta.mult,
                       ta.offset, np.asarray(q, dtype=float), np.zeros(nv), R, p, w, vo, aw, thd)
    z6 = np.zeros((nl, 6, 6))
    Iin, sig = np.zeros((nl, 6, 6)), np.zeros((nl, 6))
    no = np.zeros(nl, np.bool_)
    prepare(ta.order, ta.jtype, ta.mult, ta.mass, ta.com, ta.inertia, R, p, aw, no, z6, z6, Iin, z6.copy(),
            z6.copy(), sig)
    M = np.zeros((nv, nv))
    e, zero, col, s1, s2, s3 = np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros((nl, 6)), np.zeros((nl, 6)), \
        np.zeros((nl, 6))
    for j in range(nv):
        e[j] = 1.0
        apply(ta.order, ta.parent, ta.jtype, ta.vidx, R, sig, Iin, Iin, no, 0.0, zero, e, arm, zero, col, s1, s2, s3)
        M[:, j] = col
        e[j] = 0.0
    return 0.5 * (M + M.T)


@njit(cache=True)
def rhs_solve(order, parent, jtype, vidx, anc_ptr, anc_dof, R, sig, Iin, ApO, has_a, arm, gq, Ucol, Urow, D, root_lu,
              root_piv, c, r, q0, extra, b, pb, V, V2, F, done, out):
    """The owner's share of (I − cJ)⁻¹ r in one call: b = M r_v + c G_q r_q + extra (:func:`apply`),
    b ← W⁻¹ b (:func:`solve`), then out[v] = b, out[q] = r_q + c b. r_q = r[q0:q0+nv], r_v after it."""
    nv = b.size
    rq = r[q0:q0 + nv]
    rv = r[q0 + nv:q0 + 2 * nv]
    apply(order, parent, jtype, vidx, R, sig, Iin, ApO, has_a, c, rq, rv, arm, gq, b, V, V2, F)
    for i in range(nv):
        b[i] += extra[i]
    solve(order, parent, jtype, vidx, anc_ptr, anc_dof, R, sig, Ucol, Urow, D, root_lu, root_piv, b, pb, V, done)
    for i in range(nv):
        out[q0 + nv + i] = b[i]
        out[q0 + i] = r[q0 + i] + c * b[i]


WSolve = record("WSolve", ("order", "parent", "jtype", "vidx", "anc_ptr", "anc_dof", "R", "sig", "Iin", "ApO", "has_a",
                           "arm", "gq", "Ucol", "Urow", "D", "root_lu", "root_piv", "c", "r", "q0", "extra", "b", "pb",
                           "V", "V2", "F", "done", "out"))


@njit(cache=True)
def rhs_solve_step(w):
    """:func:`rhs_solve` on one record (linearization.ArticulatedW.bind_solve_into)."""
    rhs_solve(w.order, w.parent, w.jtype, w.vidx, w.anc_ptr, w.anc_dof, w.R, w.sig, w.Iin, w.ApO, w.has_a, w.arm, w.gq,
              w.Ucol, w.Urow, w.D, w.root_lu, w.root_piv, w.c, w.r, w.q0, w.extra, w.b, w.pb, w.V, w.V2, w.F, w.done,
              w.out)


WFactor = record("WFactor", ("order", "parent", "jtype", "vidx", "anc_ptr", "anc_dof", "R", "Iin", "AtwO", "ApO",
                             "has_a", "sig", "c", "arm", "gv", "gq", "extra", "d", "Ia", "Ucol", "Urow", "D", "root_lu",
                             "root_piv"))


@njit(cache=True)
def factor_step(w):
    """d = arm − c gv − c² gq + extra (the joint diagonal), then :func:`factor`, on one record
    (linearization.ArticulatedW.factor)."""
    c2 = w.c * w.c
    for i in range(w.d.size):
        w.d[i] = ((w.arm[i] - w.c * w.gv[i]) - c2 * w.gq[i]) + w.extra[i]
    return factor(w.order, w.parent, w.jtype, w.vidx, w.anc_ptr, w.anc_dof, w.R, w.Iin, w.AtwO, w.ApO, w.has_a, w.sig,
                  w.c, w.d, w.Ia, w.Ucol, w.Urow, w.D, w.root_lu, w.root_piv)
