"""Contact force kernels (paper §2.2.2, eqs. 1, 2, 6): pure, vectorised over contact points.

Conventions (all vectors world frame, one row per contact point, n points):

    depth[n]       m     penetration, > 0 inside the terrain (minus the signed distance)
    normal[n,3]    1     outward terrain normal (unit)
    velocity[n,3]  m/s   velocity of the robot's material point relative to the terrain
                         (for a screw sample: includes the spin, see screw_samples.py)
    e_dir[n,3]     1     anisotropy axis ê_v (any length, any tilt: it is projected onto
                         the tangent plane and normalised here)
    -> force[n,3]  N     force applied AT the contact point ON the robot; fn[n] N normal load

Normal force (eq. 2, made one-sided). The paper writes F_n = (k d + c‖v_n‖) v̂_n; a
damping term on the *magnitude* of v_n pushes harder while separating too, and a
signed damping term may pull. We use the signed penetration rate ḋ = −v·n̂ and clamp the
total, so contact never attracts:

    F_n = max(0, k d + c ḋ)  for d > 0,   0 otherwise;   force_n = F_n n̂

Friction. v_t = v − (v·n̂) n̂. The unit slip direction v̂_t of eqs. 1 and 6 is singular at
v_t = 0 (a resting robot chatters between ±μF_n and an adaptive integrator thrashes).
We replace it by a regularised direction s = g(‖v_t‖) v_t:

    mode "sqrt"   (default, C∞)  s = v_t / sqrt(‖v_t‖² + v_ε²)
    mode "linear" (C⁰, saturating) s = v_t / max(‖v_t‖, v_ε)

Trade: below v_ε static friction is approximated by viscous friction of slope μF_n/v_ε, so
a loaded contact creeps instead of sticking. Creep bound on a slope θ (isotropic, weight
W, F_n = W cosθ, driving force W sinθ; equilibrium μ F_n ‖s‖ = W sinθ, i.e. ‖s‖ = r with
r = tanθ/μ < 1, else it slides anyway):

    linear:  v/v_ε = r                  ->  v_creep = v_ε tanθ / μ   (exactly)
    sqrt:    v/sqrt(v² + v_ε²) = r      ->  v_creep = v_ε r / sqrt(1 − r²)
                                           = v_ε tanθ/μ · (1 + r²/2 + …)
                                           ≤ 1.155 v_ε tanθ/μ for r ≤ 1/2

For the anisotropic law the weakest direction governs: use μ·min(1, ‖e_v‖) for μ. With
v_ε = 0 both modes are the paper's exact laws (s = 0 at v_t = 0).

Isotropic (eq. 1):    F_t = −F_n μ s
Anisotropic (eq. 6):  F_t = −F_n μ (s + (‖e_v‖ − 1)(s·ê_v) ê_v),   ‖e_v‖ = a + b F_n

‖e_v‖ ≤ 0 would reverse the friction along ê_v (an energy source). Every contact component
rejects materials (snakesim.components.materials) whose a + b F_n < ev_floor anywhere on
its [0, fn_max]; the kernels additionally clamp ‖e_v‖ at ev_floor so an out-of-range load
(an impact) cannot produce an energy source. If ê_v has no tangential component (< 1e-12)
the point is treated as isotropic.

Each function has a numba twin in kernels_numba.py that agrees to 1e-12.
"""

from __future__ import annotations

import numpy as np

MODES = {"sqrt": 0, "linear": 1}
EV_FLOOR = 1e-3


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def normal_force(depth, normal, velocity, stiffness, damping):
    """Eq. 2, one-sided: F_n[n] = max(0, k d + c ḋ) where d > 0, with ḋ = −v·n̂."""
    depth = np.asarray(depth, dtype=float)
    rate = -_dot(np.asarray(velocity, float), np.asarray(normal, float))
    fn = stiffness * depth + damping * rate
    return np.where(depth > 0.0, np.maximum(fn, 0.0), 0.0)


def tangential_velocity(velocity, normal):
    """v_t = v − (v·n̂) n̂, shape (n,3)."""
    velocity = np.asarray(velocity, float)
    normal = np.asarray(normal, float)
    return velocity - _dot(velocity, normal)[:, None] * normal


def slip_direction(v_t, v_eps=0.0, mode="sqrt"):
    """Regularised unit slip direction s (n,3); ‖s‖ < 1 below v_ε, s = 0 at rest."""
    v_t = np.asarray(v_t, float)
    speed = np.sqrt(_dot(v_t, v_t))
    if mode == "sqrt":
        den = np.sqrt(speed * speed + v_eps * v_eps)
    elif mode == "linear":
        den = np.maximum(speed, v_eps)
    else:
        raise ValueError(f"regularisation mode must be one of {sorted(MODES)}, got {mode!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.where(den > 0.0, 1.0 / np.where(den > 0.0, den, 1.0), 0.0)
    return v_t * g[:, None]


def tangent_axis(e_dir, normal):
    """ê_v projected onto the tangent plane and normalised; zero rows where degenerate."""
    e_dir = np.asarray(e_dir, float)
    normal = np.asarray(normal, float)
    e = e_dir - _dot(e_dir, normal)[:, None] * normal
    norm = np.sqrt(_dot(e, e))
    ok = norm > 1e-12
    return np.where(ok[:, None], e / np.where(ok, norm, 1.0)[:, None], 0.0)


def isotropic_friction(fn, v_t, mu, v_eps=0.0, mode="sqrt"):
    """Eq. 1: F_t = −F_n μ s, shape (n,3)."""
    s = slip_direction(v_t, v_eps, mode)
    return -(mu * np.asarray(fn, float))[:, None] * s


def ev_magnitude(fn, ev_a, ev_b, ev_floor=EV_FLOOR):
    """‖e_v‖ = a + b F_n (fig. 6 fit), clamped at ev_floor."""
    return np.maximum(ev_a + ev_b * np.asarray(fn, float), ev_floor)


def anisotropic_friction(fn, v_t, e_dir, normal, mu, ev_a, ev_b=0.0, v_eps=0.0, mode="sqrt",
                         ev_floor=EV_FLOOR):
    """Eq. 6: F_t = −F_n μ (s + (‖e_v‖ − 1)(s·ê_v) ê_v), shape (n,3)."""
    fn = np.asarray(fn, float)
    s = slip_direction(v_t, v_eps, mode)
    e = tangent_axis(e_dir, normal)
    k = ev_magnitude(fn, ev_a, ev_b, ev_floor)
    skew = s + ((k - 1.0) * _dot(s, e))[:, None] * e
    return -(mu * fn)[:, None] * skew


def contact_forces(depth, normal, velocity, e_dir, stiffness, damping, mu, ev_a=1.0, ev_b=0.0,
                   v_eps=0.0, mode="sqrt", ev_floor=EV_FLOOR):
    """Normal (eq. 2) + anisotropic friction (eq. 6) per point -> (force[n,3], fn[n]).

    ev_a = 1, ev_b = 0 gives isotropic friction (eq. 1); e_dir is then ignored.
    """
    normal = np.asarray(normal, float)
    velocity = np.asarray(velocity, float)
    fn = normal_force(depth, normal, velocity, stiffness, damping)
    v_t = tangential_velocity(velocity, normal)
    ft = anisotropic_friction(fn, v_t, e_dir, normal, mu, ev_a, ev_b, v_eps, mode, ev_floor)
    return fn[:, None] * normal + ft, fn
