"""Compiled query of the slot moulin (analytic.SlotMoulin): its first-order distance, normal and region per
point, the formulas of SlotMoulin's docstring written out over points and modes instead of NumPy passes over
(points × modes) arrays (three of them per query, one per ν, were most of a moulin-brace-down step).

In the shaft frame (u, v, s) = Rᵀ(x − origin), with the meander c(s) = Σ_j M_j cos(k_j s + φ_j) and
v' = v − c(s), t = clamp(u, −L, L), δ = (u − t, v'), ρ = |δ|, ν = δ_v/ρ::

    h(t, s, ν) = b + slope·s + ½(1 + ν) R(t, s, +1) + ½(1 − ν) R(t, s, −1)
    R(t, s, σ) = Σ_i A_i cos(β_i + σ m_i π/2),   β_i = m_i π t / a + k_i s + φ_i

    flat walls (|u| <= L): the nearer (by g/‖∇g‖) of g± = h(t, s, ±1) ∓ v', ∇g± = (∂h±/∂t, ∓1, ∂h±/∂s)
    ends (|u| > L):        g = h − ρ, ∇g = (∂h/∂ν ∇ν − δ̂) + ∂h/∂s ŝ, ∇ν = (−ν δ_u, δ_u²/ρ)/ρ²
    meander:               ∂g/∂s += −c'(s) ∂g/∂v'
    d = g/‖∇g‖, n = R ∇g/‖∇g‖;  with the surface, d = max(d, z − top) (normal +z, region 1)

Both walls' terms come from one e^{iβ} per mode: cos(β ± mπ/2) = cos β cos(mπ/2) ∓ sin β sin(mπ/2) (``half_turn``
holds cos(mπ/2), sin(mπ/2)), and e^{iβ} = e^{i m π t/a} e^{i(k s + φ)} with no trigonometric call for the s part
(a sine and a cosine cost several times the rest of a mode): e^{i(k s + φ)} of each roughness and meander mode is
tabulated over s (:func:`s_table`, spacing h = TAYLOR_REACH / max|k|, ``TABLE_DEPTH`` down the shaft from its
mouth) and turned by e^{i k (s − s_g)} from the nearest node s_g, a Taylor series in |k (s − s_g)| <= 0.05 to
seventh order (error < 1e-15), as perception/refine_kernels.py does; off the table sine and cosine are called.
The t part is 1 for the m = 0 modes (uniform across the slot, the scenes' walls) and called otherwise.
tests/terrain/test_moulin_slot.py checks the kernel against the same formulas in NumPy and against the analytic
walls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: largest |k (s − s_g)| turned by the Taylor series (sets the table's spacing)
TAYLOR_REACH = 0.05
#: m: how far down the shaft (from its mouth, s = 0, to s = −TABLE_DEPTH) e^{i(k s + φ)} is tabulated
TABLE_DEPTH = 40.0


@njit(cache=True, inline="always")
def _turn(tab, g, j, e):
    """e^{i(k s_g + φ)} (tab[0, g, j], tab[1, g, j]) turned by e^{i e}, |e| <= TAYLOR_REACH: (cos, sin)."""
    e2 = e * e
    ce = 1.0 - e2 * (0.5 - e2 * (1.0 / 24.0 - e2 * (1.0 / 720.0)))
    se = e * (1.0 - e2 * (1.0 / 6.0 - e2 * (1.0 / 120.0 - e2 * (1.0 / 5040.0))))
    tc, ts = tab[0, g, j], tab[1, g, j]
    return tc * ce - ts * se, ts * ce + tc * se


@njit(cache=True)
def slot_query(p, origin, R, a, b, L, slope, modes, half_turn, meander, s0, h, rough_tab, meander_tab, surface, top,
               out_d, out_n, out_region):
    """Distance (m), unit outward normal (world) and region (0 wall, 1 surface) of each point p (n, 3).

    R (3, 3): columns û, v̂, ŝ; modes (nm, 4) rows (A, m, k, φ); half_turn (nm, 2) rows (cos mπ/2, sin mπ/2);
    meander (nc, 4) rows (M, ·, k, φ); rough_tab (2, G, nm), meander_tab (2, G, nc): cos, sin (k s_g + φ) at
    s_g = s0 + g h (:func:`s_table`). Writes out_d (n,), out_n (n, 3), out_region (n,)."""
    pi_a = math.pi / a
    for i in range(p.shape[0]):
        x, y, z = p[i, 0] - origin[0], p[i, 1] - origin[1], p[i, 2] - origin[2]
        u = x * R[0, 0] + y * R[1, 0] + z * R[2, 0]
        v = x * R[0, 1] + y * R[1, 1] + z * R[2, 1]
        s = x * R[0, 2] + y * R[1, 2] + z * R[2, 2]
        g = int(math.floor((s - s0) / h + 0.5))
        on_table = 0 <= g < rough_tab.shape[1]
        ds = s - (s0 + g * h)
        c = 0.0
        c_s = 0.0
        for j in range(meander.shape[0]):
            if on_table:
                cw, sw = _turn(meander_tab, g, j, meander[j, 2] * ds)
            else:
                arg = meander[j, 2] * s + meander[j, 3]
                cw, sw = math.cos(arg), math.sin(arg)
            c += meander[j, 0] * cw
            c_s -= meander[j, 0] * meander[j, 2] * sw
        v -= c                                                       # v'
        t = min(max(u, -L), L)
        du = u - t
        rho = math.hypot(du, v)
        if rho > 0.0:
            safe, eu, ev = rho, du / rho, v / rho
        else:
            safe, eu, ev = 1.0, 0.0, 1.0                             # on the core: δ̂ = +v̂, as ν = 1
        # both walls' R, ∂R/∂t, ∂R/∂s
        rp = rpt = rps = rm = rmt = rms = 0.0
        for j in range(modes.shape[0]):
            A, kt, k = modes[j, 0], pi_a * modes[j, 1], modes[j, 2]
            if on_table:
                cb, sb = _turn(rough_tab, g, j, k * ds)              # e^{i(k s + φ)}
            else:
                cb, sb = math.cos(k * s + modes[j, 3]), math.sin(k * s + modes[j, 3])
            if kt != 0.0:                                            # × e^{i kt t}
                ct, st = math.cos(kt * t), math.sin(kt * t)
                cb, sb = cb * ct - sb * st, sb * ct + cb * st
            ch, sh = half_turn[j, 0], half_turn[j, 1]
            cp, sp = cb * ch - sb * sh, sb * ch + cb * sh              # cos, sin (β + mπ/2)
            cm, sm = cb * ch + sb * sh, sb * ch - cb * sh              # cos, sin (β − mπ/2)
            rp += A * cp
            rpt -= A * kt * sp
            rps -= A * k * sp
            rm += A * cm
            rmt -= A * kt * sm
            rms -= A * k * sm
        h0 = b + slope * s
        if abs(u) <= L:
            # flat walls: the nearer of g± = h± ∓ v'
            hp, hm = h0 + rp, h0 + rm
            np_ = math.sqrt(rpt * rpt + 1.0 + (slope + rps) ** 2)
            nm_ = math.sqrt(rmt * rmt + 1.0 + (slope + rms) ** 2)
            if (hp - v) / np_ <= (hm + v) / nm_:
                g, n0, n1, n2 = hp - v, rpt, -1.0, slope + rps
            else:
                g, n0, n1, n2 = hm + v, rmt, 1.0, slope + rms
        else:
            # the ends: round the core point, h blended by ν (∂t/∂u = 0 there)
            wp, wm = 0.5 * (1.0 + ev), 0.5 * (1.0 - ev)
            h_nu = 0.5 * (rp - rm)
            g = h0 + wp * rp + wm * rm - rho
            n0 = h_nu * (-ev * eu / safe) - eu
            n1 = h_nu * (eu * eu / safe) - ev
            n2 = slope + wp * rps + wm * rms
        n2 -= c_s * n1                                               # ∂g/∂s += −c'(s) ∂g/∂v'
        norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        d = g / norm
        n0 /= norm
        n1 /= norm
        n2 /= norm
        if surface and p[i, 2] - top > d:
            out_d[i] = p[i, 2] - top
            out_n[i, 0] = 0.0
            out_n[i, 1] = 0.0
            out_n[i, 2] = 1.0
            out_region[i] = 1
        else:
            out_d[i] = d
            for r in range(3):
                out_n[i, r] = R[r, 0] * n0 + R[r, 1] * n1 + R[r, 2] * n2
            out_region[i] = 0


def half_turns(modes: np.ndarray) -> np.ndarray:
    """(nm, 2): cos(m π/2), sin(m π/2) of each roughness mode (A, m, k, φ) — the far wall's quarter shift."""
    q = 0.5 * np.pi * np.asarray(modes, dtype=float).reshape(-1, 4)[:, 1]
    return np.ascontiguousarray(np.column_stack([np.cos(q), np.sin(q)]))


def s_table(modes: np.ndarray, meander: np.ndarray):
    """(s0, h, rough_tab (2, G, nm), meander_tab (2, G, nc)): cos, sin (k s_g + φ) of each mode at the nodes
    s_g = s0 + g h from s0 = −TABLE_DEPTH to the mouth (a node past it), h = TAYLOR_REACH / max|k|."""
    k_all = np.concatenate([modes[:, 2], meander[:, 2]])
    h = TAYLOR_REACH / max(float(np.abs(k_all).max(initial=0.0)), 1.0)      # (k = 0 only: any spacing)
    s0, G = -TABLE_DEPTH, int(np.ceil(TABLE_DEPTH / h)) + 2
    sg = s0 + h * np.arange(G)

    def tab(md):
        arg = np.multiply.outer(sg, md[:, 2]) + md[:, 3]
        return np.ascontiguousarray(np.stack([np.cos(arg), np.sin(arg)]))
    return s0, h, tab(modes), tab(meander)
