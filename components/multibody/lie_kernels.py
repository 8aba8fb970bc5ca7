"""numba versions of the two configuration-manifold maps the integrators call every stage.

``integrate_q``: q ⊕ dv, Pinocchio's ``integrate`` joint by joint (what Multibody.integrate was):

    free-flyer    [p, quat] ← [p + R exp6(v, ω).p, quat(R exp6(v, ω).R)]   (M0 · exp6, Pinocchio's
                  special-euclidean integrate: quaternion from the rotation matrix, sign kept on the
                  side of the old quaternion, then first-order normalised, q ← q (3 − |q|²)/2)
    revolute,     q ← q + dv
    prismatic
    continuous    (cos, sin) rotated by dv, then first-order normalised (SO(2))

``dexp_inv6``: the free-flyer's stage correction k ← Jlog6(exp6(u)) k (= Jexp6(u)⁻¹ k, Munthe-Kaas),
with Pinocchio's closed forms (Jlog3, and Jlog6's B block) at θ = |ω| of u.

Same formulas and series switch-overs (θ below ε^¼) as Pinocchio; the arithmetic order differs, so
results agree to round-off (tests/multibody/test_lie_kernels.py: ≤ 1e-14 against pinocchio). Why:
pin.integrate and pin.Jlog6(pin.exp6(u)) cost ~3 µs each per call from Python (argument conversion),
three calls per Rosenbrock step, where these take well under a microsecond.
"""

from __future__ import annotations

import numpy as np
from numba import njit

FREE_FLYER, ADD, SO2 = 0, 1, 2
#: Pinocchio's TaylorSeriesExpansion<double>::precision<3>(): ε^(1/4)
SMALL = float(np.finfo(float).eps ** 0.25)


def joint_layout(model):
    """(kind, idx_q, idx_v) arrays over the model's joints for :func:`integrate_q`, or None if a joint is of
    another kind (spherical, planar, ...: then Pinocchio's integrate is kept)."""
    kind, iq, iv = [], [], []
    for j in list(model.joints)[1:]:
        name = j.shortname()
        if j.nq == 0:
            continue
        if "FreeFlyer" in name:
            kind.append(FREE_FLYER)
        elif j.nq == 1 and j.nv == 1:
            kind.append(ADD)
        elif j.nq == 2 and j.nv == 1 and ("RUB" in name or "Unbounded" in name):
            kind.append(SO2)
        else:
            return None
        iq.append(j.idx_q)
        iv.append(j.idx_v)
    return np.array(kind, np.int64), np.array(iq, np.int64), np.array(iv, np.int64)


@njit(cache=True, inline="always")
def _exp6_coefficients(w0, w1, w2):
    t2 = w0 * w0 + w1 * w1 + w2 * w2
    t = np.sqrt(t2)
    if t < SMALL:
        return 0.5 - t2 / 24.0, 1.0 - t2 / 6.0, 1.0 / 6.0 - t2 / 120.0, 1.0 - t2 / 2.0
    ct, st = np.cos(t), np.sin(t)
    inv_t2 = 1.0 / t2
    a_v = st / t
    return (1.0 - ct) * inv_t2, a_v, (1.0 - a_v) * inv_t2, ct


@njit(cache=True)
def _exp6(u, R, p):
    """exp6 of the motion u = [v, ω] (Pinocchio's order): rotation R (3×3) and translation p."""
    v0, v1, v2, w0, w1, w2 = u[0], u[1], u[2], u[3], u[4], u[5]
    a_wxv, a_v, a_w, diag = _exp6_coefficients(w0, w1, w2)
    wv = w0 * v0 + w1 * v1 + w2 * v2
    p[0] = a_v * v0 + a_w * wv * w0 + a_wxv * (w1 * v2 - w2 * v1)
    p[1] = a_v * v1 + a_w * wv * w1 + a_wxv * (w2 * v0 - w0 * v2)
    p[2] = a_v * v2 + a_w * wv * w2 + a_wxv * (w0 * v1 - w1 * v0)
    R[0, 0] = a_wxv * w0 * w0 + diag
    R[1, 1] = a_wxv * w1 * w1 + diag
    R[2, 2] = a_wxv * w2 * w2 + diag
    R[0, 1] = a_wxv * w0 * w1 - a_v * w2
    R[1, 0] = a_wxv * w1 * w0 + a_v * w2
    R[0, 2] = a_wxv * w0 * w2 + a_v * w1
    R[2, 0] = a_wxv * w2 * w0 - a_v * w1
    R[1, 2] = a_wxv * w1 * w2 - a_v * w0
    R[2, 1] = a_wxv * w2 * w1 + a_v * w0


@njit(cache=True)
def _free_flyer(q, dv, out, a, b):
    # M0 from [p, quat (x, y, z, w)] (Eigen's toRotationMatrix)
    x, y, z, w = q[a + 3], q[a + 4], q[a + 5], q[a + 6]
    tx, ty, tz = 2.0 * x, 2.0 * y, 2.0 * z
    twx, twy, twz = tx * w, ty * w, tz * w
    txx, txy, txz = tx * x, ty * x, tz * x
    tyy, tyz, tzz = ty * y, tz * y, tz * z
    R0 = np.empty((3, 3))
    R0[0, 0], R0[0, 1], R0[0, 2] = 1.0 - (tyy + tzz), txy - twz, txz + twy
    R0[1, 0], R0[1, 1], R0[1, 2] = txy + twz, 1.0 - (txx + tzz), tyz - twx
    R0[2, 0], R0[2, 1], R0[2, 2] = txz - twy, tyz + twx, 1.0 - (txx + tyy)
    Re = np.empty((3, 3))
    pe = np.empty(3)
    _exp6(dv[b:b + 6], Re, pe)
    for i in range(3):
        out[a + i] = q[a + i] + (R0[i, 0] * pe[0] + R0[i, 1] * pe[1] + R0[i, 2] * pe[2])
    m = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            m[i, j] = R0[i, 0] * Re[0, j] + R0[i, 1] * Re[1, j] + R0[i, 2] * Re[2, j]
    # quaternion of m (Eigen's / Pinocchio's assignment)
    c = np.empty(4)                 # x, y, z, w
    t = m[0, 0] + m[1, 1] + m[2, 2]
    if t > 0.0:
        t = np.sqrt(t + 1.0)
        c[3] = 0.5 * t
        t = 0.5 / t
        c[0] = (m[2, 1] - m[1, 2]) * t
        c[1] = (m[0, 2] - m[2, 0]) * t
        c[2] = (m[1, 0] - m[0, 1]) * t
    else:
        i = 0
        if m[1, 1] > m[0, 0]:
            i = 1
        if m[2, 2] > m[i, i]:
            i = 2
        j = (i + 1) % 3
        k = (j + 1) % 3
        t = np.sqrt(m[i, i] - m[j, j] - m[k, k] + 1.0)
        c[i] = 0.5 * t
        t = 0.5 / t
        c[3] = (m[k, j] - m[j, k]) * t
        c[j] = (m[j, i] + m[i, j]) * t
        c[k] = (m[k, i] + m[i, k]) * t
    if c[0] * x + c[1] * y + c[2] * z + c[3] * w < 0.0:
        for i in range(4):
            c[i] = -c[i]
    n2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]
    alpha = (3.0 - n2) / 2.0
    for i in range(4):
        out[a + 3 + i] = c[i] * alpha


@njit(cache=True)
def integrate_q(q, dv, out, kind, iq, iv):
    """out = q ⊕ dv joint by joint (module docstring); out may be q."""
    for n in range(kind.size):
        a, b = iq[n], iv[n]
        if kind[n] == ADD:
            out[a] = q[a] + dv[b]
        elif kind[n] == SO2:
            ca, sa, om = q[a], q[a + 1], dv[b]
            co, so = np.cos(om), np.sin(om)
            c0, c1 = ca * co - sa * so, sa * co + ca * so
            f = (3.0 - (c0 * c0 + c1 * c1)) / 2.0
            out[a], out[a + 1] = c0 * f, c1 * f
        else:
            _free_flyer(q, dv, out, a, b)


@njit(cache=True)
def integrate_state(x, dx, out, nq, nv, kind, iq, iv):
    """The multibody's [q, v] ⊕ [dq, dv]: integrate_q on q, a vector add on v."""
    integrate_q(x[:nq], dx[:nv], out[:nq], kind, iq, iv)
    for i in range(nv):
        out[nq + i] = x[nq + i] + dx[nv + i]


@njit(cache=True)
def dexp_inv6(u, k):
    """k[:6] ← Jlog6(exp6(u[:6])) k[:6] (Pinocchio's Jlog6 at θ = |ω|, translation p of exp6(u))."""
    Re = np.empty((3, 3))
    p = np.empty(3)
    _exp6(u, Re, p)
    w0, w1, w2 = u[3], u[4], u[5]
    t2 = w0 * w0 + w1 * w1 + w2 * w2
    t = np.sqrt(t2)
    if t < SMALL:
        alpha = 1.0 / 12.0 + t2 / 720.0
        diag = 0.5 * (2.0 - t2 / 6.0)
        beta = 1.0 / 12.0 + t2 / 720.0
        beta_dot = 1.0 / 360.0
    else:
        ct, st = np.cos(t), np.sin(t)
        st_1mct = st / (1.0 - ct)
        alpha = 1.0 / t2 - st_1mct / (2.0 * t)
        diag = 0.5 * (t * st_1mct)
        tinv = 1.0 / t
        t2inv = tinv * tinv
        inv_2_2ct = 1.0 / (2.0 * (1.0 - ct))
        beta = t2inv - st * tinv * inv_2_2ct
        beta_dot = -2.0 * t2inv * t2inv + (1.0 + st * tinv) * t2inv * inv_2_2ct
    w = (w0, w1, w2)
    A = np.empty((3, 3))            # Jlog3: alpha w wᵀ + diag I + ½[w]×
    for i in range(3):
        for j in range(3):
            A[i, j] = alpha * w[i] * w[j]
        A[i, i] += diag
    A[0, 1] -= 0.5 * w2
    A[0, 2] += 0.5 * w1
    A[1, 0] += 0.5 * w2
    A[1, 2] -= 0.5 * w0
    A[2, 0] -= 0.5 * w1
    A[2, 1] += 0.5 * w0
    wTp = w0 * p[0] + w1 * p[1] + w2 * p[2]
    s1 = beta_dot * wTp
    s2 = t2 * beta_dot + 2.0 * beta
    C = np.empty((3, 3))            # B = C A, C = (s1 w − s2 p) wᵀ + β w pᵀ + wᵀp β I + ½[p]×
    for i in range(3):
        vi = s1 * w[i] - s2 * p[i]
        for j in range(3):
            C[i, j] = vi * w[j] + beta * w[i] * p[j]
        C[i, i] += wTp * beta
    C[0, 1] -= 0.5 * p[2]
    C[0, 2] += 0.5 * p[1]
    C[1, 0] += 0.5 * p[2]
    C[1, 2] -= 0.5 * p[0]
    C[2, 0] -= 0.5 * p[1]
    C[2, 1] += 0.5 * p[0]
    kv0, kv1, kv2, kw0, kw1, kw2 = k[0], k[1], k[2], k[3], k[4], k[5]
    # B kw = C (A kw)
    a0 = A[0, 0] * kw0 + A[0, 1] * kw1 + A[0, 2] * kw2
    a1 = A[1, 0] * kw0 + A[1, 1] * kw1 + A[1, 2] * kw2
    a2 = A[2, 0] * kw0 + A[2, 1] * kw1 + A[2, 2] * kw2
    for i in range(3):
        k[i] = (A[i, 0] * kv0 + A[i, 1] * kv1 + A[i, 2] * kv2) + (C[i, 0] * a0 + C[i, 1] * a1 + C[i, 2] * a2)
    k[3], k[4], k[5] = a0, a1, a2
