"""The contact law record: one description of the law at a point, read alike by the force kernels and
their Jacobians, with the per-owner inputs other models drive and the slip outputs they read.

The law (kernels_numba.point_contact_force; its derivatives jacobian_kernels.point_jacobian) is eq. 2 and
the regularised eq. 6 with the material row (k, c, μ, ev_a, ev_b) of the terrain under the point. A
contact component's samples belong to owners (a screw; a body piece), and each owner maps to a law row
(the screw; the piece's link). Per law row the record carries (inputs, read every evaluation):

    mu_scale[r]   1     μ → μ · mu_scale (an ice-friction law of temperature and speed, a wet film)
    ev_scale[r]   1     ‖e_v‖ → ‖e_v‖ · ev_scale (thread engagement of a screw sunk in its groove)
    sinkage[r]    m     the surface is lowered by this much under the row's samples: φ → φ + sinkage
                        (a screw melted into its groove sits that much deeper before the ice pushes)

and writes (outputs, every evaluation):

    slip_power[r] W     Σ −F_t · v over the row's contacts: the power friction dissipates (≥ 0: eq. 6
                        with ‖e_v‖ > 0 never feeds energy), the frictional heat a thermal model takes
    slip_speed[r] m/s   Σ F_n ‖v_t‖ / Σ F_n: the load-weighted slip speed (0 without contact)

The force kernels read the record's arrays once per evaluation into locals (a record field read in a
loop costs a reference count each time) and hand the helpers plain values. Defaults (1, 1, 0) leave the law as it was to the bit (× 1.0 and + 0.0 are exact). A contact component
exposes them as ports (``screw_mu_scale``…, ``link_slip_power``…), so a thermal or terramechanics model
is an ordinary component wired to them, not a new back end. Inputs are checked each evaluation
(``begin_law``, into ``bad_row``): a negative or non-finite μ scale would make friction a source of energy, a
non-positive ‖e_v‖ scale reverse it, a negative sinkage lift the surface; the component stops naming the row.

Sinkage is applied to the queried distances (``begin_law``) before any kernel reads them, so the
forces, the Jacobian, the contact set and the depth watch all see the lowered surface. Lowering only
raises φ, so the broad phase and the look-ahead rows chosen before it stay a superset.
"""

from __future__ import annotations

import math

from numba import njit

from ..kernel_args import record
from ..materials import EV_A, EV_B, MU, C, K

#: fields: the regularisation (v_eps m/s, mode kernels.MODES, ev_floor), the owner → law row map,
#: the inputs (views of the component's input ports) and the outputs (its output buffers, or scratch)
ContactLaw = record("ContactLaw", ("v_eps", "mode", "ev_floor", "row_of_owner", "mu_scale", "ev_scale", "sinkage",
                                   "slip_power", "slip_speed", "row_fn", "bad_row"))


@njit(cache=True, inline="always")
def material_law(mats, mat, mu_scale, ev_scale):
    """(k, c, μ, ev_a, ev_b) at a point of material ``mat``: the material's row with its law row's μ and
    ‖e_v‖ scales (``law.mu_scale[row]``, ``law.ev_scale[row]``) applied."""
    return mats[mat, K], mats[mat, C], mats[mat, MU] * mu_scale, mats[mat, EV_A] * ev_scale, mats[mat, EV_B] * ev_scale


@njit(cache=True, inline="always")
def skin_law(mats, mat, mu_factor, ratio, mu_scale, ev_scale):
    """(k, c, μ, ev_a, ev_b) of a body skin: μ = μ_material · mu_factor · mu_scale, ‖e_v‖ = ratio · ev_scale
    (no load dependence): along / across the skin axis (body_kernels.py)."""
    return mats[mat, K], mats[mat, C], mats[mat, MU] * mu_factor * mu_scale, ratio * ev_scale, 0.0


@njit(cache=True, inline="always")
def law_locals(law):
    """The record's fields a force or Jacobian kernel reads in its loop, as locals: (mu_scale, ev_scale,
    slip_power, slip_speed, row_fn, v_eps, mode, ev_floor)."""
    return (law.mu_scale, law.ev_scale, law.slip_power, law.slip_speed, law.row_fn, law.v_eps, law.mode,
            law.ev_floor)


@njit(cache=True)
def begin_law(law, m, distance, owner):
    """Before an evaluation's contacts: check the inputs (``law.bad_row[0]``: the first row out of range,
    else −1), add the sinkage of each sample's row to the first m distances (φ → φ + sinkage, after the
    terrain query), and zero the outputs the contacts add to."""
    mu_scale, ev_scale, sinkage = law.mu_scale, law.ev_scale, law.sinkage
    law.bad_row[0] = -1
    for r in range(mu_scale.shape[0]):
        a, g, s = mu_scale[r], ev_scale[r], sinkage[r]
        if not (a >= 0.0 and g > 0.0 and s >= 0.0 and math.isfinite(a) and math.isfinite(g) and math.isfinite(s)):
            law.bad_row[0] = r
            break
    rows = law.row_of_owner
    for i in range(m):
        distance[i] += sinkage[rows[owner[i]]]
    law.slip_power[:] = 0.0
    law.slip_speed[:] = 0.0
    law.row_fn[:] = 0.0


@njit(cache=True, inline="always")
def add_slip(power, speed, row_fn, row, fn, fx, fy, fz, nx, ny, nz, vx, vy, vz):
    """One contact's share of its row's outputs (``law.slip_power``, ``slip_speed``, ``row_fn``): force
    (fx, fy, fz) with normal load fn at a point moving at v, terrain normal n̂."""
    vn = vx * nx + vy * ny + vz * nz
    tx, ty, tz = vx - vn * nx, vy - vn * ny, vz - vn * nz
    ftn = fx * nx + fy * ny + fz * nz
    # −F_t · v_t with F_t = F − (F·n̂) n̂
    power[row] -= (fx - ftn * nx) * tx + (fy - ftn * ny) * ty + (fz - ftn * nz) * tz
    speed[row] += fn * math.sqrt(tx * tx + ty * ty + tz * tz)
    row_fn[row] += fn


@njit(cache=True)
def finish_law(law):
    """slip_speed from its load-weighted sum (after every contact was added)."""
    speed, row_fn = law.slip_speed, law.row_fn
    for r in range(row_fn.shape[0]):
        speed[r] = speed[r] / row_fn[r] if row_fn[r] > 0.0 else 0.0
