"""Analytic steady axial speed of a straight screw robot on a flat plane (from eq. 6).

Setting. A straight rigid robot lies on the plane z = 0, joints locked; every screw pair
is two counter-rotating, opposite-hand screws (radius r, lead angle λ) turning at ±ω;
each screw touches the ground along its bottom line with load F_n. Only axial translation
u (along the screw axes, x) is considered.

Derivation. Take a right-hand screw (h = +1) spinning at +ω about +x. At the bottom line
ê_r = −ẑ, so ê_φ = ê_x × ê_r = +ŷ, and the screw's material point moves relative to the
body at ω ê_x × (−r ẑ) = ωr ŷ. The slip velocity on the ground is therefore

    v_t = (u, ωr)                         (x, y components; z = 0)

and the thread normal (screw_samples.py) is ê_v = cos λ ê_x − h sin λ ê_φ = (c, −h s)
with c = cos λ, s = sin λ. With k = ‖e_v‖, eq. 6 (regularised or not: s_reg = g(‖v_t‖) v_t
with a scalar g > 0) gives the axial force

    F_x = −F_n μ g [u + (k − 1)(u c − h ωr s) c]

Steady state is F_x = 0; g, μ and F_n are positive scalars and drop out:

    u (1 + (k − 1) c²) = h (k − 1) ωr s c

    u* = h ωr (k − 1) sin λ cos λ / (1 + (k − 1) cos² λ)

The opposite-hand screw at −ω has h → −h and ω → −ω: the same u*, so the pair has no net
axial force at u* either; its lateral forces are mirror images and cancel. Hence:

  * k → 1 (isotropic):     u* → 0          (isotropic friction cannot propel)
  * k → ∞ (no slip across the threads): u* → h ωr tan λ (the screw-in-a-nut speed,
    lead × revolutions per second)
  * μ and v_ε do not enter: the axial balance is homogeneous in the regularised slip
    direction. (They set how fast the steady state is reached, not its value.)
  * 0 < k < 1 reverses the direction of travel.

The sign convention: positive ω spins the screw right-handedly about its +x axis; h = +1
right-hand thread; the result is along +x.
"""

from __future__ import annotations

import numpy as np


def steady_axial_speed(omega, radius, lead, k, mu=None, v_eps=0.0, hand=1):
    """Steady axial speed u* (m/s) of a screw pair driven at ω (rad/s) on a flat plane.

    lead: lead angle λ (rad); k: ‖e_v‖ (> 0); hand: +1 right, −1 left for the screw
    spinning at +ω. ``mu`` and ``v_eps`` are accepted for symmetry with the kernels and
    do not change the result (see the module docstring). Broadcasts over arrays.
    """
    k = np.asarray(k, float)
    if np.any(k <= 0):
        raise ValueError(f"k = ‖e_v‖ must be > 0, got {k}")
    if mu is not None and mu <= 0:
        raise ValueError(f"mu must be > 0, got {mu}")
    if v_eps < 0:
        raise ValueError(f"v_eps must be ≥ 0, got {v_eps}")
    c, s = np.cos(lead), np.sin(lead)
    u = hand * omega * radius * (k - 1.0) * s * c / (1.0 + (k - 1.0) * c * c)
    return u if np.ndim(u) else float(u)
