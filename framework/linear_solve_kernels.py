"""numba kernels of the structured solve in :mod:`.linearization` (no allocation per call).

Sparse operands are triplets (rows, cols, vals); ``owned`` marks the tangent coordinates of
second-order states; an owner is the slice [q0, q0 + nv) (its q tangent) followed by its v.
"""

from __future__ import annotations

import functools

from numba import njit


def bind(kernel, *args):
    """``kernel`` compiled once for these arguments' types; a call without arguments (no per-call typing).
    For arrays and numbers fixed for as long as the call is kept."""
    entry = kernel.compile(tuple(kernel.typeof_pyval(a) for a in args))
    return functools.partial(entry, *args)


@njit(cache=True)
def lu_solve(lu, piv, b):
    """b ← A⁻¹ b for scipy.linalg.lu_factor's (lu, piv) of A (row interchanges, then L, then U)."""
    n = b.size
    for i in range(n):
        p = piv[i]
        if p != i:
            b[i], b[p] = b[p], b[i]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= lu[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= lu[i, j] * b[j]
        b[i] = s / lu[i, i]


@njit(cache=True)
def lu_factor(a, piv):
    """In-place LU with partial pivoting (LAPACK getrf's result: L unit lower, U upper, piv[i] the row
    swapped with i at step i). Returns False if a pivot is zero."""
    n = a.shape[0]
    for k in range(n):
        p = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big, p = abs(a[i, k]), i
        piv[k] = p
        if big == 0.0:
            return False
        if p != k:
            for j in range(n):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            l = a[i, k]
            if l != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= l * a[k, j]
    return True


@njit(cache=True, inline="always")
def _first_order_entry(col, q0, nv, c, c2, g, p):
    """One term of the first-order states' share −c² G_F D (P_v + c P_q) of an owner's reduced matrix
    (c2 = c²): for P's entry p at state column ``col`` and g = (G_F D)'s entry on its row, the reduced
    matrix's column j and the amount w subtracted there (c³ g p on a q column, c² g p on a v column);
    j = −1 for a column outside the owner."""
    if q0 <= col < q0 + nv:
        return col - q0, c2 * c * g * p
    if q0 + nv <= col < q0 + 2 * nv:
        return col - q0 - nv, c2 * g * p
    return -1, 0.0


@njit(cache=True)
def reduced_matrix(W, M, Gq, Gv, c, q0, nv, Dinv, gf_r, gf_c, gf_v, p_ptr, p_c, p_v):
    """W = M − c G_v − c² G_q − c² G_F D (P_v + c P_q): the owner's reduced (nv × nv) matrix
    (P's triplets sorted by row, row f at p_ptr[f]:p_ptr[f + 1])."""
    c2 = c * c
    for i in range(nv):
        for j in range(nv):
            W[i, j] = M[i, j] - c * Gv[i, j] - c2 * Gq[i, j]
    for a in range(gf_r.size):
        f = gf_c[a]
        g = gf_v[a] * Dinv[f]
        for b in range(p_ptr[f], p_ptr[f + 1]):
            j, w = _first_order_entry(p_c[b], q0, nv, c, c2, g, p_v[b])
            if j >= 0:
                W[gf_r[a], j] -= w


@njit(cache=True)
def owner_solve(r, out, owned, Dinv, c, q0, nv, M, Gq, gf_r, gf_c, gf_v, p_r, p_c, p_v, lu, piv, z, rhs):
    """The owner's k_q, k_v into out:  [reduced W] k_v = M r_v + c G_q r_q + c G_F D (r_F + c P_q r_q),
    k_q = r_q + c k_v. z (ndx) and rhs (nv) are scratch."""
    v0 = q0 + nv
    for i in range(nv):
        s = 0.0
        for j in range(nv):
            s += M[i, j] * r[v0 + j] + c * Gq[i, j] * r[q0 + j]
        rhs[i] = s
    first_order_share(r, owned, Dinv, c, q0, nv, gf_r, gf_c, gf_v, p_r, p_c, p_v, z, rhs)
    lu_solve(lu, piv, rhs)
    for i in range(nv):
        out[v0 + i] = rhs[i]
        out[q0 + i] = r[q0 + i] + c * rhs[i]


@njit(cache=True)
def first_order_solve(r, out, owned, Dinv, c, p_r, p_c, p_v, z):
    """k_F = D (r_F + c (P_q k_q + P_v k_v)) into out's first-order rows (owners' rows already solved)."""
    for i in range(r.size):
        z[i] = 0.0 if owned[i] else r[i]
    for k in range(p_r.size):
        col = p_c[k]
        if owned[col]:
            z[p_r[k]] += c * p_v[k] * out[col]
    for i in range(r.size):
        if not owned[i]:
            out[i] = Dinv[i] * z[i]


@njit(cache=True)
def reduced_diagonal(out, c, q0, nv, Dinv, gf_r, gf_c, gf_v, p_ptr, p_c, p_v):
    """out = diagonal of −c² G_F D (P_v + c P_q) (the first-order states' share of the reduced matrix,
    :func:`reduced_matrix`) for an owner whose other terms a structured factor holds. Returns False
    if that share has an off-diagonal entry (the structured factor cannot take it)."""
    c2 = c * c
    for i in range(nv):
        out[i] = 0.0
    for a in range(gf_r.size):
        f = gf_c[a]
        g = gf_v[a] * Dinv[f]
        for b in range(p_ptr[f], p_ptr[f + 1]):
            j, w = _first_order_entry(p_c[b], q0, nv, c, c2, g, p_v[b])
            if j < 0 or w == 0.0:
                continue
            if j != gf_r[a]:
                return False
            out[j] -= w
    return True


@njit(cache=True)
def first_order_share(r, owned, Dinv, c, q0, nv, gf_r, gf_c, gf_v, p_r, p_c, p_v, z, rhs):
    """rhs += c G_F D (r_F + c P_q r_q): the first-order states' share of an owner's right-hand side
    (:func:`owner_solve`'s), z (ndx) scratch."""
    if gf_r.size == 0:
        return
    for i in range(r.size):
        z[i] = 0.0 if owned[i] else r[i]
    for k in range(p_r.size):
        col = p_c[k]
        if q0 <= col < q0 + nv:
            z[p_r[k]] += c * p_v[k] * r[col]
    for i in range(r.size):
        z[i] *= Dinv[i]
    for k in range(gf_r.size):
        rhs[gf_r[k]] += c * gf_v[k] * z[gf_c[k]]


@njit(cache=True)
def first_order_rhs(r, owned, Dinv, c, q0, nv, gf_r, gf_c, gf_v, p_r, p_c, p_v, z, rhs):
    """rhs = c G_F D (r_F + c P_q r_q) (:func:`first_order_share` into a zeroed rhs)."""
    for i in range(rhs.size):
        rhs[i] = 0.0
    first_order_share(r, owned, Dinv, c, q0, nv, gf_r, gf_c, gf_v, p_r, p_c, p_v, z, rhs)
