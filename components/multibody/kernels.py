"""numba kernels over the URDF link tree: kinematics, external and inter-body wrenches.

Every link of the URDF (massless frames included) is one row; rows are in
the URDF's ``<link>`` document order and ``order`` lists them parents first.
Per link ``l`` (see :class:`.model.TreeArrays` for how they are filled):

    parent[l]   row of the parent link (-1 for the root)
    jtype[l]    0 root (free-flyer), 1 fixed, 2 revolute/continuous (mimics too)
    R0, p0      joint origin in the parent link frame
    axis        unit joint axis in the joint (= child link) frame
    qidx, qkind where the angle is in q: kind 0 an angle, kind 1 (cos, sin)
    vidx        its column of v; mult, offset: angle = mult * q_dof + offset
                (1, 0 for a joint with its own coordinate, the <mimic> values
                otherwise, so a rear screw turns with its front screw)

Frames and units: world axes everywhere; a link's velocity is
[v of its origin, ω] and its acceleration the classical [a of its origin, α]
(no gravity); wrenches are [f, τ] about the point named. Sums of wrenches
are taken about the root link origin, not the world origin, so a robot far
from the origin loses no digits. The kernels allocate only a few 3-vectors
of scratch per call, never per link.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..kernel_args import record
from .pose_quaternions import quaternion_matrix

ROOT, FIXED, REVOLUTE = 0, 1, 2


@njit(cache=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def forward_kinematics(order, parent, jtype, R0, p0, axis, qidx, qkind, vidx, mult, offset, q, v,
                       R, p, w, vo, aw, thd):
    """Poses (R, p), angular velocity w, origin velocity vo, world joint axis aw and joint rate thd."""
    rj = np.empty((3, 3))
    rot = np.empty((3, 3))
    for k in range(order.size):
        l = order[k]
        if jtype[l] == ROOT:
            quaternion_matrix(q[3], q[4], q[5], q[6], R[l])
            for i in range(3):
                p[l, i] = q[i]
                vo[l, i] = R[l, i, 0] * v[0] + R[l, i, 1] * v[1] + R[l, i, 2] * v[2]
                w[l, i] = R[l, i, 0] * v[3] + R[l, i, 1] * v[4] + R[l, i, 2] * v[5]
                aw[l, i] = 0.0
            thd[l] = 0.0
            continue
        P = parent[l]
        # joint frame in the world (a joint origin without rotation, the usual case, is the parent's axes)
        r0 = R0[l]
        same = (r0[0, 0] == 1.0 and r0[1, 1] == 1.0 and r0[2, 2] == 1.0 and r0[0, 1] == 0.0 and r0[0, 2] == 0.0
                and r0[1, 0] == 0.0 and r0[1, 2] == 0.0 and r0[2, 0] == 0.0 and r0[2, 1] == 0.0)
        for i in range(3):
            if same:
                rj[i, 0], rj[i, 1], rj[i, 2] = R[P, i, 0], R[P, i, 1], R[P, i, 2]
            else:
                for j in range(3):
                    rj[i, j] = R[P, i, 0] * r0[0, j] + R[P, i, 1] * r0[1, j] + R[P, i, 2] * r0[2, j]
            p[l, i] = p[P, i] + R[P, i, 0] * p0[l, 0] + R[P, i, 1] * p0[l, 1] + R[P, i, 2] * p0[l, 2]
        r0, r1, r2 = p[l, 0] - p[P, 0], p[l, 1] - p[P, 1], p[l, 2] - p[P, 2]
        c0, c1, c2 = _cross(w[P, 0], w[P, 1], w[P, 2], r0, r1, r2)
        vo[l, 0], vo[l, 1], vo[l, 2] = vo[P, 0] + c0, vo[P, 1] + c1, vo[P, 2] + c2
        if jtype[l] == FIXED:
            for i in range(3):
                for j in range(3):
                    R[l, i, j] = rj[i, j]
                w[l, i] = w[P, i]
                aw[l, i] = 0.0
            thd[l] = 0.0
            continue
        if qkind[l] != 0 and offset[l] == 0.0 and (mult[l] == 1.0 or mult[l] == -1.0):
            # a continuous joint's (cos, sin), or its mirror for a −1 mimic: read, not atan2'd and rebuilt
            c0, s0 = q[qidx[l]], q[qidx[l] + 1]
            n = np.sqrt(c0 * c0 + s0 * s0)
            c, s = c0 / n, mult[l] * s0 / n
        else:
            th = q[qidx[l]] if qkind[l] == 0 else np.arctan2(q[qidx[l] + 1], q[qidx[l]])
            th = mult[l] * th + offset[l]
            c, s = np.cos(th), np.sin(th)
        ax, ay, az = axis[l, 0], axis[l, 1], axis[l, 2]
        rate = mult[l] * v[vidx[l]]
        thd[l] = rate
        # R = rj rot(axis, θ); about a coordinate axis only two columns turn
        if ay == 0.0 and az == 0.0 and ax == 1.0:
            for i in range(3):
                R[l, i, 0] = rj[i, 0]
                R[l, i, 1] = rj[i, 1] * c + rj[i, 2] * s
                R[l, i, 2] = rj[i, 2] * c - rj[i, 1] * s
                aw[l, i] = rj[i, 0]
                w[l, i] = w[P, i] + aw[l, i] * rate
            continue
        if ax == 0.0 and az == 0.0 and ay == 1.0:
            for i in range(3):
                R[l, i, 0] = rj[i, 0] * c - rj[i, 2] * s
                R[l, i, 1] = rj[i, 1]
                R[l, i, 2] = rj[i, 0] * s + rj[i, 2] * c
                aw[l, i] = rj[i, 1]
                w[l, i] = w[P, i] + aw[l, i] * rate
            continue
        if ax == 0.0 and ay == 0.0 and az == 1.0:
            for i in range(3):
                R[l, i, 0] = rj[i, 0] * c + rj[i, 1] * s
                R[l, i, 1] = rj[i, 1] * c - rj[i, 0] * s
                R[l, i, 2] = rj[i, 2]
                aw[l, i] = rj[i, 2]
                w[l, i] = w[P, i] + aw[l, i] * rate
            continue
        t = 1.0 - c
        rot[0, 0], rot[0, 1], rot[0, 2] = c + t * ax * ax, t * ax * ay - s * az, t * ax * az + s * ay
        rot[1, 0], rot[1, 1], rot[1, 2] = t * ax * ay + s * az, c + t * ay * ay, t * ay * az - s * ax
        rot[2, 0], rot[2, 1], rot[2, 2] = t * ax * az - s * ay, t * ay * az + s * ax, c + t * az * az
        for i in range(3):
            for j in range(3):
                R[l, i, j] = rj[i, 0] * rot[0, j] + rj[i, 1] * rot[1, j] + rj[i, 2] * rot[2, j]
            aw[l, i] = rj[i, 0] * ax + rj[i, 1] * ay + rj[i, 2] * az
            w[l, i] = w[P, i] + aw[l, i] * rate


@njit(cache=True)
def accelerations(order, parent, jtype, vidx, mult, R, p, w, aw, thd, v, a, alpha, ao):
    """Classical accelerations: alpha (angular), ao (of each link origin), world axes, from a = dv/dt."""
    for k in range(order.size):
        l = order[k]
        if jtype[l] == ROOT:
            c0, c1, c2 = _cross(v[3], v[4], v[5], v[0], v[1], v[2])
            b0, b1, b2 = a[0] + c0, a[1] + c1, a[2] + c2
            for i in range(3):
                alpha[l, i] = R[l, i, 0] * a[3] + R[l, i, 1] * a[4] + R[l, i, 2] * a[5]
                ao[l, i] = R[l, i, 0] * b0 + R[l, i, 1] * b1 + R[l, i, 2] * b2
            continue
        P = parent[l]
        r0, r1, r2 = p[l, 0] - p[P, 0], p[l, 1] - p[P, 1], p[l, 2] - p[P, 2]
        e0, e1, e2 = _cross(alpha[P, 0], alpha[P, 1], alpha[P, 2], r0, r1, r2)
        u0, u1, u2 = _cross(w[P, 0], w[P, 1], w[P, 2], r0, r1, r2)
        f0, f1, f2 = _cross(w[P, 0], w[P, 1], w[P, 2], u0, u1, u2)
        ao[l, 0], ao[l, 1], ao[l, 2] = ao[P, 0] + e0 + f0, ao[P, 1] + e1 + f1, ao[P, 2] + e2 + f2
        if jtype[l] == FIXED:
            alpha[l, 0], alpha[l, 1], alpha[l, 2] = alpha[P, 0], alpha[P, 1], alpha[P, 2]
            continue
        acc = mult[l] * a[vidx[l]]
        rate = thd[l]
        g0, g1, g2 = _cross(w[P, 0], w[P, 1], w[P, 2], aw[l, 0] * rate, aw[l, 1] * rate, aw[l, 2] * rate)
        alpha[l, 0] = alpha[P, 0] + aw[l, 0] * acc + g0
        alpha[l, 1] = alpha[P, 1] + aw[l, 1] * acc + g1
        alpha[l, 2] = alpha[P, 2] + aw[l, 2] * acc + g2


@njit(cache=True)
def generalized_forces(order, parent, jtype, vidx, mult, R, p, aw, W, S, tau):
    """tau += Σ_l J_lᵀ W_l: the generalised force of world-axes wrenches W[l] = [f, τ about link l's origin].

    Free-flyer rows follow Pinocchio's convention (the root's local frame);
    a mimic joint's share goes to its primary coordinate times the multiplier.
    S is scratch (nlinks, 6).
    """
    root = order[0]
    for l in range(W.shape[0]):
        r0, r1, r2 = p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2]
        c0, c1, c2 = _cross(r0, r1, r2, W[l, 0], W[l, 1], W[l, 2])
        S[l, 0], S[l, 1], S[l, 2] = W[l, 0], W[l, 1], W[l, 2]
        S[l, 3], S[l, 4], S[l, 5] = W[l, 3] + c0, W[l, 4] + c1, W[l, 5] + c2
    for k in range(order.size - 1, -1, -1):
        l = order[k]
        if jtype[l] == ROOT:
            for i in range(3):
                tau[i] += R[l, 0, i] * S[l, 0] + R[l, 1, i] * S[l, 1] + R[l, 2, i] * S[l, 2]
                tau[3 + i] += R[l, 0, i] * S[l, 3] + R[l, 1, i] * S[l, 4] + R[l, 2, i] * S[l, 5]
            continue
        if jtype[l] == REVOLUTE:
            r0, r1, r2 = p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2]
            c0, c1, c2 = _cross(r0, r1, r2, S[l, 0], S[l, 1], S[l, 2])
            tau[vidx[l]] += mult[l] * (aw[l, 0] * (S[l, 3] - c0) + aw[l, 1] * (S[l, 4] - c1) + aw[l, 2] * (S[l, 5] - c2))
        P = parent[l]
        for i in range(6):
            S[P, i] += S[l, i]


@njit(cache=True)
def cut_wrenches(order, parent, R, p, w, alpha, ao, mass, com, inertia, W, g, S, cut_links, out):
    """Wrench the parent side exerts on the subtree below each cut link, in that link's frame, into
    ``out[link row]`` (other rows untouched).

    Per link, the momentum rate minus gravity minus the external wrench;
    summed over the subtree (Newton-Euler on the URDF links, so it holds
    across fixed joints that the optimised model merged away). out[l] =
    [f, τ about the cut link's origin], cut link axes.
    """
    root = order[0]
    ib = np.empty(3)
    iw = np.empty(3)
    jb = np.empty(3)
    jw = np.empty(3)
    for l in range(mass.shape[0]):
        m = mass[l]
        cx = R[l, 0, 0] * com[l, 0] + R[l, 0, 1] * com[l, 1] + R[l, 0, 2] * com[l, 2]
        cy = R[l, 1, 0] * com[l, 0] + R[l, 1, 1] * com[l, 1] + R[l, 1, 2] * com[l, 2]
        cz = R[l, 2, 0] * com[l, 0] + R[l, 2, 1] * com[l, 1] + R[l, 2, 2] * com[l, 2]
        e0, e1, e2 = _cross(alpha[l, 0], alpha[l, 1], alpha[l, 2], cx, cy, cz)
        u0, u1, u2 = _cross(w[l, 0], w[l, 1], w[l, 2], cx, cy, cz)
        f0, f1, f2 = _cross(w[l, 0], w[l, 1], w[l, 2], u0, u1, u2)
        F0 = m * (ao[l, 0] + e0 + f0 - g[0])
        F1 = m * (ao[l, 1] + e1 + f1 - g[1])
        F2 = m * (ao[l, 2] + e2 + f2 - g[2])
        # world inertia Iw = R I Rᵀ applied to alpha and w
        for i in range(3):
            # Rᵀ alpha, Rᵀ w
            ib[i] = R[l, 0, i] * alpha[l, 0] + R[l, 1, i] * alpha[l, 1] + R[l, 2, i] * alpha[l, 2]
            iw[i] = R[l, 0, i] * w[l, 0] + R[l, 1, i] * w[l, 1] + R[l, 2, i] * w[l, 2]
        for i in range(3):
            jb[i] = inertia[l, i, 0] * ib[0] + inertia[l, i, 1] * ib[1] + inertia[l, i, 2] * ib[2]
            jw[i] = inertia[l, i, 0] * iw[0] + inertia[l, i, 1] * iw[1] + inertia[l, i, 2] * iw[2]
        h0 = R[l, 0, 0] * jb[0] + R[l, 0, 1] * jb[1] + R[l, 0, 2] * jb[2]
        h1 = R[l, 1, 0] * jb[0] + R[l, 1, 1] * jb[1] + R[l, 1, 2] * jb[2]
        h2 = R[l, 2, 0] * jb[0] + R[l, 2, 1] * jb[1] + R[l, 2, 2] * jb[2]
        k0 = R[l, 0, 0] * jw[0] + R[l, 0, 1] * jw[1] + R[l, 0, 2] * jw[2]
        k1 = R[l, 1, 0] * jw[0] + R[l, 1, 1] * jw[1] + R[l, 1, 2] * jw[2]
        k2 = R[l, 2, 0] * jw[0] + R[l, 2, 1] * jw[1] + R[l, 2, 2] * jw[2]
        n0, n1, n2 = _cross(w[l, 0], w[l, 1], w[l, 2], k0, k1, k2)
        # about the root origin: COM at (p + c - p_root), link origin at (p - p_root)
        rx, ry, rz = p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2]
        m0, m1, m2 = _cross(rx + cx, ry + cy, rz + cz, F0, F1, F2)
        x0, x1, x2 = _cross(rx, ry, rz, W[l, 0], W[l, 1], W[l, 2])
        S[l, 0], S[l, 1], S[l, 2] = F0 - W[l, 0], F1 - W[l, 1], F2 - W[l, 2]
        S[l, 3] = h0 + n0 + m0 - W[l, 3] - x0
        S[l, 4] = h1 + n1 + m1 - W[l, 4] - x1
        S[l, 5] = h2 + n2 + m2 - W[l, 5] - x2
    for k in range(order.size - 1, 0, -1):
        l = order[k]
        P = parent[l]
        for i in range(6):
            S[P, i] += S[l, i]
    for k in range(cut_links.size):
        l = cut_links[k]
        rx, ry, rz = p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2]
        c0, c1, c2 = _cross(rx, ry, rz, S[l, 0], S[l, 1], S[l, 2])
        t0, t1, t2 = S[l, 3] - c0, S[l, 4] - c1, S[l, 5] - c2
        for i in range(3):
            out[l, i] = R[l, 0, i] * S[l, 0] + R[l, 1, i] * S[l, 1] + R[l, 2, i] * S[l, 2]
            out[l, 3 + i] = R[l, 0, i] * t0 + R[l, 1, i] * t1 + R[l, 2, i] * t2


@njit(cache=True)
def momentum_energy(R, p, w, vo, mass, com, inertia, g, h, c_of_m, energy):
    """Total link momentum h = [P, L about the world origin], centre of mass, [kinetic, potential] energy.

    Kinetic energy here is that of the links; the component adds the
    armature (rotor) term. Potential energy is -Σ m g·c.
    """
    for i in range(6):
        h[i] = 0.0
    mt, ke, pe = 0.0, 0.0, 0.0
    s0, s1, s2 = 0.0, 0.0, 0.0
    iw = np.empty(3)
    jw = np.empty(3)
    for l in range(mass.shape[0]):
        m = mass[l]
        if m == 0.0 and inertia[l, 0, 0] == 0.0 and inertia[l, 1, 1] == 0.0 and inertia[l, 2, 2] == 0.0:
            continue
        cx = R[l, 0, 0] * com[l, 0] + R[l, 0, 1] * com[l, 1] + R[l, 0, 2] * com[l, 2]
        cy = R[l, 1, 0] * com[l, 0] + R[l, 1, 1] * com[l, 1] + R[l, 1, 2] * com[l, 2]
        cz = R[l, 2, 0] * com[l, 0] + R[l, 2, 1] * com[l, 1] + R[l, 2, 2] * com[l, 2]
        u0, u1, u2 = _cross(w[l, 0], w[l, 1], w[l, 2], cx, cy, cz)
        v0, v1, v2 = vo[l, 0] + u0, vo[l, 1] + u1, vo[l, 2] + u2
        X, Y, Z = p[l, 0] + cx, p[l, 1] + cy, p[l, 2] + cz
        for i in range(3):
            iw[i] = R[l, 0, i] * w[l, 0] + R[l, 1, i] * w[l, 1] + R[l, 2, i] * w[l, 2]
        for i in range(3):
            jw[i] = inertia[l, i, 0] * iw[0] + inertia[l, i, 1] * iw[1] + inertia[l, i, 2] * iw[2]
        k0 = R[l, 0, 0] * jw[0] + R[l, 0, 1] * jw[1] + R[l, 0, 2] * jw[2]
        k1 = R[l, 1, 0] * jw[0] + R[l, 1, 1] * jw[1] + R[l, 1, 2] * jw[2]
        k2 = R[l, 2, 0] * jw[0] + R[l, 2, 1] * jw[1] + R[l, 2, 2] * jw[2]
        a0, a1, a2 = _cross(X, Y, Z, m * v0, m * v1, m * v2)
        h[0] += m * v0
        h[1] += m * v1
        h[2] += m * v2
        h[3] += a0 + k0
        h[4] += a1 + k1
        h[5] += a2 + k2
        ke += 0.5 * m * (v0 * v0 + v1 * v1 + v2 * v2) + 0.5 * (iw[0] * jw[0] + iw[1] * jw[1] + iw[2] * jw[2])
        pe -= m * (g[0] * X + g[1] * Y + g[2] * Z)
        mt += m
        s0 += m * X
        s1 += m * Y
        s2 += m * Z
    if mt > 0:
        c_of_m[0], c_of_m[1], c_of_m[2] = s0 / mt, s1 / mt, s2 / mt
    energy[0] = ke
    energy[1] = pe


@njit(cache=True)
def poses(R, p, out):
    """out[l] = [x, y, z, qx, qy, qz, qw] (unit quaternion, w >= 0) from R[l], p[l]."""
    for l in range(R.shape[0]):
        m00, m11, m22 = R[l, 0, 0], R[l, 1, 1], R[l, 2, 2]
        tr = m00 + m11 + m22
        if tr > 0.0:
            s = np.sqrt(tr + 1.0) * 2.0
            qw = 0.25 * s
            qx = (R[l, 2, 1] - R[l, 1, 2]) / s
            qy = (R[l, 0, 2] - R[l, 2, 0]) / s
            qz = (R[l, 1, 0] - R[l, 0, 1]) / s
        elif m00 > m11 and m00 > m22:
            s = np.sqrt(1.0 + m00 - m11 - m22) * 2.0
            qw = (R[l, 2, 1] - R[l, 1, 2]) / s
            qx = 0.25 * s
            qy = (R[l, 0, 1] + R[l, 1, 0]) / s
            qz = (R[l, 0, 2] + R[l, 2, 0]) / s
        elif m11 > m22:
            s = np.sqrt(1.0 + m11 - m00 - m22) * 2.0
            qw = (R[l, 0, 2] - R[l, 2, 0]) / s
            qx = (R[l, 0, 1] + R[l, 1, 0]) / s
            qy = 0.25 * s
            qz = (R[l, 1, 2] + R[l, 2, 1]) / s
        else:
            s = np.sqrt(1.0 + m22 - m00 - m11) * 2.0
            qw = (R[l, 1, 0] - R[l, 0, 1]) / s
            qx = (R[l, 0, 2] + R[l, 2, 0]) / s
            qy = (R[l, 1, 2] + R[l, 2, 1]) / s
            qz = 0.25 * s
        if qw < 0.0:
            qx, qy, qz, qw = -qx, -qy, -qz, -qw
        n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        out[l, 0], out[l, 1], out[l, 2] = p[l, 0], p[l, 1], p[l, 2]
        out[l, 3], out[l, 4], out[l, 5], out[l, 6] = qx / n, qy / n, qz / n, qw / n


@njit(cache=True)
def state_outputs(order, parent, jtype, R0, p0, axis, qidx, qkind, vidx, mult, offset, q, v,
                  R, p, w, vo, aw, thd, jq_idx, jq_cs, dof_v, joint_q, joint_v, link_poses, link_velocities):
    """forward_kinematics, then the state outputs in one call (one dispatch per evaluation):
    joint_q (continuous joints' (cos, sin) as an angle in (-π, π]), joint_v, link_poses,
    link_velocities [v origin, ω]."""
    forward_kinematics(order, parent, jtype, R0, p0, axis, qidx, qkind, vidx, mult, offset, q, v,
                       R, p, w, vo, aw, thd)
    for j in range(jq_idx.size):
        i = jq_idx[j]
        joint_q[j] = np.arctan2(q[i + 1], q[i]) if jq_cs[j] else q[i]
        joint_v[j] = v[dof_v[j]]
    poses(R, p, link_poses)
    for l in range(R.shape[0]):
        for i in range(3):
            link_velocities[l, i] = vo[l, i]
            link_velocities[l, 3 + i] = w[l, i]


@njit(cache=True)
def joint_forces(with_wrenches, dof_v, tau, damping, v, order, parent, jtype, vidx, mult, R, p, aw, W, S, T):
    """Generalised force T[nv]: τ − damping·v on the DOF joints, plus Σ J_lᵀ W_l when
    ``with_wrenches`` (generalized_forces; needs the kinematics of this state in R, p, aw)."""
    for i in range(T.size):
        T[i] = 0.0
    for j in range(dof_v.size):
        T[dof_v[j]] = tau[j] - damping[j] * v[dof_v[j]]
    if with_wrenches:
        generalized_forces(order, parent, jtype, vidx, mult, R, p, aw, W, S, T)


# -- the component's kernels, on argument records (kernel_args.py) --------------------------------
#
#   tree   Tree    constants of the robot and the dynamics model (built once per component)
#   kin    Kin     this run's state views q, v and kinematics scratch (built in make_cache)
#   ports  Ports   this run's input views and output buffers, and which outputs are read
#
# The kinematics in kin (R, p, w, vo, aw, thd) belong to the state recorded in kin.at_q,
# kin.at_v when kin.fresh[0]: a kernel that needs them at the current state recomputes them
# only if the state differs bit for bit (the state outputs computed them there already in
# the usual evaluation order; a Harness, a sampled output group or an unread state output
# may leave them at another state).

Tree = record("Tree", ("order", "parent", "jtype", "R0", "p0", "axis", "qidx", "qkind", "vidx", "mult", "offset",
                       "mass", "com", "inertia", "jq_idx", "jq_cs", "dof_v", "damping", "cut_links", "g_param",
                       "gravity_scale"))
Kin = record("Kin", ("q", "v", "at_q", "at_v", "fresh", "R", "p", "w", "vo", "aw", "thd", "alpha", "ao", "S", "T",
                     "qdd", "g", "h_scratch", "c_scratch", "e_scratch"))
Ports = record("Ports", ("tau", "wrenches", "gravity", "q", "v", "joint_q", "joint_v", "link_poses",
                         "link_velocities", "link_rotations", "momentum", "com", "energy", "a", "link_accelerations",
                         "joint_wrenches", "want_qv", "want_rot", "want_cut"))


@njit(cache=True)
def _same_bits(a, b):
    x, y = a.view(np.uint64), b.view(np.uint64)
    for i in range(x.size):
        if x[i] != y[i]:
            return False
    return True


@njit(cache=True)
def _kinematics(tree, kin):
    """forward_kinematics into kin at kin.q, kin.v, and remember that state."""
    t = tree
    forward_kinematics(t.order, t.parent, t.jtype, t.R0, t.p0, t.axis, t.qidx, t.qkind, t.vidx, t.mult, t.offset,
                       kin.q, kin.v, kin.R, kin.p, kin.w, kin.vo, kin.aw, kin.thd)
    kin.at_q[:] = kin.q
    kin.at_v[:] = kin.v
    kin.fresh[0] = True


@njit(cache=True)
def _ensure_kinematics(tree, kin):
    if not (kin.fresh[0] and _same_bits(kin.q, kin.at_q) and _same_bits(kin.v, kin.at_v)):
        _kinematics(tree, kin)


@njit(cache=True)
def _gravity(tree, kin, gin):
    """The gravity the input asks for (NaN: the parameter) into kin.g; True if it changed."""
    g, gp = kin.g, tree.g_param
    if tree.gravity_scale:
        s = gin[0]
        want0, want1, want2 = (gp[0], gp[1], gp[2]) if s != s else (s * gp[0], s * gp[1], s * gp[2])
    elif np.isnan(gin).any():
        want0, want1, want2 = gp[0], gp[1], gp[2]
    else:
        want0, want1, want2 = gin[0], gin[1], gin[2]
    if want0 == g[0] and want1 == g[1] and want2 == g[2]:
        return False
    g[0], g[1], g[2] = want0, want1, want2
    return True


@njit(cache=True)
def state_step(tree, kin, ports):
    """The state outputs (kinematics, joint values, link poses and velocities, and q, v and the
    link rotations when read) at kin.q, kin.v."""
    t = tree
    state_outputs(t.order, t.parent, t.jtype, t.R0, t.p0, t.axis, t.qidx, t.qkind, t.vidx, t.mult, t.offset,
                  kin.q, kin.v, kin.R, kin.p, kin.w, kin.vo, kin.aw, kin.thd, t.jq_idx, t.jq_cs, t.dof_v,
                  ports.joint_q, ports.joint_v, ports.link_poses, ports.link_velocities)
    kin.at_q[:] = kin.q
    kin.at_v[:] = kin.v
    kin.fresh[0] = True
    if ports.want_qv:
        ports.q[:] = kin.q
        ports.v[:] = kin.v
    if ports.want_rot:
        ports.link_rotations[:] = kin.R


@njit(cache=True)
def force_step(tree, kin, ports):
    """Gravity from its input into kin.g, and the generalised force kin.T (joint torques, damping,
    the link wrenches through the kinematics of this state). Returns True if gravity changed."""
    changed = _gravity(tree, kin, ports.gravity)
    W = ports.wrenches
    loaded = False
    for i in range(W.shape[0]):
        for j in range(6):
            if W[i, j] != 0.0:
                loaded = True
    if loaded:
        _ensure_kinematics(tree, kin)
    t = tree
    joint_forces(loaded, t.dof_v, ports.tau, t.damping, kin.v, t.order, t.parent, t.jtype, t.vidx, t.mult,
                 kin.R, kin.p, kin.aw, W, kin.S, kin.T)
    return changed


@njit(cache=True)
def acceleration_step(tree, kin, ports):
    """From kin.qdd (the solved accelerations): a, the link accelerations and, when read, the
    joint wrenches (kinematics of this state: force_step ran first)."""
    t = tree
    _ensure_kinematics(tree, kin)
    ports.a[:] = kin.qdd
    accelerations(t.order, t.parent, t.jtype, t.vidx, t.mult, kin.R, kin.p, kin.w, kin.aw, kin.thd, kin.v, kin.qdd,
                  kin.alpha, kin.ao)
    la = ports.link_accelerations
    for l in range(la.shape[0]):
        for i in range(3):
            la[l, i] = kin.ao[l, i]
            la[l, 3 + i] = kin.alpha[l, i]
    if ports.want_cut:
        cut_wrenches(t.order, t.parent, kin.R, kin.p, kin.w, kin.alpha, kin.ao, t.mass, t.com, t.inertia,
                     ports.wrenches, kin.g, kin.S, t.cut_links, ports.joint_wrenches)


@njit(cache=True)
def momentum_step(tree, kin, ports):
    """Momentum and centre of mass (the energy it also computes, with the parameter gravity, is dropped)."""
    _ensure_kinematics(tree, kin)
    t = tree
    momentum_energy(kin.R, kin.p, kin.w, kin.vo, t.mass, t.com, t.inertia, t.g_param, ports.momentum, ports.com,
                    kin.e_scratch)


@njit(cache=True)
def energy_step(tree, kin, ports):
    """Link kinetic and potential energy (gravity from its input into kin.g) into ports.energy; the
    component adds the rotors' kinetic energy. Returns True if gravity changed."""
    changed = _gravity(tree, kin, ports.gravity)
    _ensure_kinematics(tree, kin)
    t = tree
    momentum_energy(kin.R, kin.p, kin.w, kin.vo, t.mass, t.com, t.inertia, kin.g, kin.h_scratch, kin.c_scratch,
                    ports.energy)
    return changed
