"""The groove wall's force and its velocity slope per screw, compiled (groove_drag.py has the model).

Loops over a handful of screws per evaluation: NumPy's per-call overhead on (4, 3) arrays was ~0.3 ms an
evaluation, ten evaluations a step under error control (bench/melt_dwell.py's cost line); this is ~µs.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernel_args import record

#: one run's arguments (groove_drag.make_cache): input views, output buffers, the screw table and scratch
GrooveArgs = record("GrooveArgs", ("poses", "vels", "parent", "row", "axis_B", "length", "pen", "strength", "depth",
                                   "v_eps", "normal", "wrenches", "travel", "F", "vp", "ax", "d_twist", "on"))


@njit(cache=True)
def groove_step(g):
    """groove_forces on a GrooveArgs record (the bound call of the hot path)."""
    groove_forces(g.poses, g.vels, g.parent, g.row, g.axis_B, g.length, g.pen, g.strength, g.depth, g.v_eps,
                  g.normal, g.wrenches, g.travel, g.F, g.vp, g.ax)


@njit(cache=True)
def groove_slope_step(g):
    """groove_slopes on a GrooveArgs record."""
    groove_slopes(g.row, g.F, g.vp, g.ax, g.normal, g.v_eps, g.d_twist, g.on)


@njit(cache=True)
def groove_forces(poses, vels, parent, row, axis_B, length, pen, strength, depth, v_eps, normal, wrenches, travel, F,
                  vp, ax):
    """wrenches[row[s], :3] = −F_s w/sqrt(|w|² + v_ε²), F_s = σ_w L_s (δ_s − h_t)⁺, w = (I − n̂n̂ᵀ)(I − ââᵀ) v
    (n̂ the wall's normal at the screw, ``normal[s]``: zero when unknown); travel[s] = |w|. Keeps F, w and the
    world axis per screw for the slope. Rows other than the screws' are left as they are."""
    for s in range(parent.shape[0]):
        q = poses[parent[s]]
        x, y, z, w = q[3], q[4], q[5], q[6]
        a0, a1, a2 = axis_B[s, 0], axis_B[s, 1], axis_B[s, 2]
        # v + w t + u × t, t = 2 u × v: the quaternion rotation of the mount axis
        t0, t1, t2 = 2.0 * (y * a2 - z * a1), 2.0 * (z * a0 - x * a2), 2.0 * (x * a1 - y * a0)
        b0 = a0 + w * t0 + (y * t2 - z * t1)
        b1 = a1 + w * t1 + (z * t0 - x * t2)
        b2 = a2 + w * t2 + (x * t1 - y * t0)
        v = vels[row[s]]
        vn = v[0] * b0 + v[1] * b1 + v[2] * b2
        p0, p1, p2 = v[0] - vn * b0, v[1] - vn * b1, v[2] - vn * b2
        n0, n1, n2 = normal[s, 0], normal[s, 1], normal[s, 2]
        pn = p0 * n0 + p1 * n1 + p2 * n2           # into or out of the wall: the contact's business, not the groove's
        p0, p1, p2 = p0 - pn * n0, p1 - pn * n1, p2 - pn * n2
        sp = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        f = strength * length[s] * max(pen[s] - depth, 0.0)
        k = f / math.sqrt(sp * sp + v_eps * v_eps)
        r = row[s]
        wrenches[r, 0], wrenches[r, 1], wrenches[r, 2] = -k * p0, -k * p1, -k * p2
        wrenches[r, 3], wrenches[r, 4], wrenches[r, 5] = 0.0, 0.0, 0.0
        travel[s] = sp
        F[s] = f
        vp[s, 0], vp[s, 1], vp[s, 2] = p0, p1, p2
        ax[s, 0], ax[s, 1], ax[s, 2] = b0, b1, b2


@njit(cache=True)
def groove_slopes(row, F, vp, ax, normal, v_eps, d_twist, on):
    """d_twist[row[s], :3, :3] = −F (P/s − w wᵀP/s³), P = (I − n̂n̂ᵀ)(I − ââᵀ), s = sqrt(|w|² + v_ε²), where
    F > 0 (on[s] set); other screws' blocks zeroed."""
    for s in range(row.shape[0]):
        r = row[s]
        for i in range(3):
            for j in range(3):
                d_twist[r, i, j] = 0.0
        on[s] = F[s] > 0.0
        if not on[s]:
            continue
        w2 = vp[s, 0] ** 2 + vp[s, 1] ** 2 + vp[s, 2] ** 2 + v_eps * v_eps
        sq = math.sqrt(w2)
        P = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += ((1.0 if i == k else 0.0) - normal[s, i] * normal[s, k]) * (
                        (1.0 if k == j else 0.0) - ax[s, k] * ax[s, j])
                P[i, j] = acc
        for j in range(3):
            wP = vp[s, 0] * P[0, j] + vp[s, 1] * P[1, j] + vp[s, 2] * P[2, j]
            for i in range(3):
                d_twist[r, i, j] = -F[s] * (P[i, j] / sq - vp[s, i] * wP / (w2 * sq))
