"""numba twins of kernels.py for the per-step path (same formulas, same conventions).

``contact_forces_nb`` writes into preallocated ``out_force[n,3]`` and ``out_fn[n]``: no
allocation per step. ``mode`` is an int: kernels.MODES ("sqrt" 0, "linear" 1).
Agreement with the numpy kernels to 1e-12 is a test (tests/contact/test_kernels.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernels import EV_FLOOR, MODES


@njit(cache=True, inline="always")
def point_contact_force(depth, nx, ny, nz, vx, vy, vz, ex, ey, ez, stiffness, damping, mu, ev_a, ev_b, v_eps,
                        mode, ev_floor):
    """Eq. 2 and regularised eq. 6 at one point -> (F_n, F_x, F_y, F_z), world frame.

    n̂ unit outward normal, v the robot point's velocity relative to the terrain, e the
    anisotropy axis (any length: projected on the tangent plane and normalised here; none
    left means isotropic). The one copy of the contact law every numba back end calls.
    """
    vn = vx * nx + vy * ny + vz * nz
    fn = 0.0
    if depth > 0.0:
        fn = stiffness * depth - damping * vn
        if fn < 0.0:
            fn = 0.0                                   # never pulls
    # tangential slip and its regularised direction
    tx, ty, tz = vx - vn * nx, vy - vn * ny, vz - vn * nz
    speed = math.sqrt(tx * tx + ty * ty + tz * tz)
    if mode == 0:
        den = math.sqrt(speed * speed + v_eps * v_eps)
    else:
        den = speed if speed > v_eps else v_eps
    g = 1.0 / den if den > 0.0 else 0.0
    sx, sy, sz = tx * g, ty * g, tz * g
    # anisotropy axis in the tangent plane
    en = ex * nx + ey * ny + ez * nz
    ex, ey, ez = ex - en * nx, ey - en * ny, ez - en * nz
    enorm = math.sqrt(ex * ex + ey * ey + ez * ez)
    if enorm > 1e-12:
        ex, ey, ez = ex / enorm, ey / enorm, ez / enorm
    else:
        ex, ey, ez = 0.0, 0.0, 0.0
    k = ev_a + ev_b * fn
    if k < ev_floor:
        k = ev_floor
    c = (k - 1.0) * (sx * ex + sy * ey + sz * ez)
    m = -mu * fn
    return fn, fn * nx + m * (sx + c * ex), fn * ny + m * (sy + c * ey), fn * nz + m * (sz + c * ez)


@njit(cache=True)
def contact_forces_nb(depth, normal, velocity, e_dir, stiffness, damping, mu, ev_a, ev_b, v_eps, mode,
                      ev_floor, out_force, out_fn):
    for i in range(depth.shape[0]):
        fn, fx, fy, fz = point_contact_force(
            depth[i], normal[i, 0], normal[i, 1], normal[i, 2], velocity[i, 0], velocity[i, 1], velocity[i, 2],
            e_dir[i, 0], e_dir[i, 1], e_dir[i, 2], stiffness, damping, mu, ev_a, ev_b, v_eps, mode, ev_floor)
        out_fn[i] = fn
        out_force[i, 0], out_force[i, 1], out_force[i, 2] = fx, fy, fz


@njit(cache=True, inline="always")
def add_wrench(out_wrench, b, rx, ry, rz, fx, fy, fz):
    """out_wrench[b] += [f, r × f]: force f applied at r from body b's origin (world frame)."""
    out_wrench[b, 0] += fx
    out_wrench[b, 1] += fy
    out_wrench[b, 2] += fz
    out_wrench[b, 3] += ry * fz - rz * fy
    out_wrench[b, 4] += rz * fx - rx * fz
    out_wrench[b, 5] += rx * fy - ry * fx


@njit(cache=True)
def body_wrenches_nb(points, forces, origins, body_index, out_wrench):
    """out_wrench[b] = Σ_{i: body_index[i] = b} [f_i, (p_i − o_b) × f_i] (world frame)."""
    out_wrench[:, :] = 0.0
    for i in range(points.shape[0]):
        b = body_index[i]
        add_wrench(out_wrench, b, points[i, 0] - origins[b, 0], points[i, 1] - origins[b, 1],
                   points[i, 2] - origins[b, 2], forces[i, 0], forces[i, 1], forces[i, 2])


def contact_forces_numba(depth, normal, velocity, e_dir, stiffness, damping, mu, ev_a=1.0, ev_b=0.0,
                         v_eps=0.0, mode="sqrt", ev_floor=EV_FLOOR, out_force=None, out_fn=None):
    """Convenience wrapper with the numpy kernel's signature (allocates if no out given)."""
    depth = np.ascontiguousarray(depth, dtype=np.float64)
    n = depth.shape[0]
    if out_force is None:
        out_force = np.empty((n, 3))
    if out_fn is None:
        out_fn = np.empty(n)
    contact_forces_nb(depth, np.ascontiguousarray(normal, dtype=np.float64),
                      np.ascontiguousarray(velocity, dtype=np.float64),
                      np.ascontiguousarray(e_dir, dtype=np.float64), float(stiffness), float(damping),
                      float(mu), float(ev_a), float(ev_b), float(v_eps), MODES[mode], float(ev_floor),
                      out_force, out_fn)
    return out_force, out_fn
