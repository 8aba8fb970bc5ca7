"""One thermal step of the heated screws: temperature, melt-in depth, refreeze bond and the energy ledger.

Per screw s (one compiled loop over the screws; h the step, s)::

    C dT/dt = P_heat + P_slip − q_ice − q_conv − q_rad
    q_ice  = G (T − T_m)      melting: in contact (F_n > contact_force) and T > T_m; a melt film at T_m
                              separates screw and ice (the probe balance's interface condition)
           = G (T − T_ice)    in contact at or below T_m: the screw touches the cold ice, nothing melts
           = 0                out of contact
    q_conv = h_c A_s (T − T_env)                  (convection: an Earth analogue; h_c = 0 in vacuum)
    q_rad  = ε σ A_s (T⁴ − T_env⁴)                (radiation: vacuum, Enceladus)

The step is linearly implicit Euler (Rosenbrock–Euler): every term is evaluated at the new temperature T⁺,
radiation linearised about T, q_rad ≈ εσA_s (T⁴ − T_env⁴ + 4T³ (T⁺ − T)). The update is then one division
per screw, unconditionally stable for the linear terms (all slopes ≥ 0 add to the diagonal C/h), and the
fluxes booked in the ledger are exactly the ones the step used, so

    C (T⁺ − T) = h (P_heat + P_slip − q_ice − q_conv − q_rad)

holds to round-off and the ledger closes to round-off over a whole run (tests/thermal/test_energy.py).

The regime is decided on T⁺: the melting step is taken first; where its T⁺ is not above T_m the step is
taken again with the cold-contact flux (which only removes more heat, so its T⁺ is not above T_m either).
The issue's brief wrote q_ice = G (T − T_ice) for both regimes; with that, a screw on −180 °C ice would melt
in faster than on −5 °C ice through a film that is at T_m (the flux driven by 200 K across a film that
is at 0 °C), so the melting regime takes the film's temperature instead.

Melt-in (ice_properties.py): where the screw melts, all of q_ice melts ice (ρ_i (L_f + c_i (T_m − T_ice))
Δδ = h q_ice / A_c, no lateral loss into the ice around, as the probe balance assumes); below T_m q_ice
warms the cold ice and nothing melts.
The groove relaxes only as the screw leaves it: δ⁺ = δ exp(−Δs / ℓ_g), Δs = h (v_travel − v_still)⁺ the
distance the screw's centre moved along the ice across its axis during the step (groove_drag's travel_speed:
rolling or sliding out), less a dead band v_still: a braced screw trembles at ~1 mm/s while the brace
regulates its load (melt-dwell-climb.yaml), and a tremble does not carry it out of its groove. The
contact's slip speed does not count: a screw spinning in place slips inside its own groove and stays. Refreeze bond (sintering): while embedded (δ > 0), in contact, below T_m and still
(v_travel + v_slip < v_still) the hold time t_b grows; it resets to 0 as soon as the screw moves (rolls,
slides or spins) faster than v_break. The bond's strength is Gubler's power law in hold time (see bond.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .ice_properties import SIGMA

#: ledger columns, J (summed over the screws): what came in, what is stored, where it went
LEDGER = ("heater_in", "friction_in", "stored", "to_ice_melting", "to_cold_ice", "radiated", "convected",
          "latent", "residual")
HEATER, FRICTION, STORED, MELTING, COLD, RADIATED, CONVECTED, LATENT, RESIDUAL = range(len(LEDGER))

#: the scalar constants' slots in ``k`` (screw_heat.setup packs them)
(K_C, K_EPS, K_HC, K_TICE, K_TENV, K_TMELT, K_STEFAN, K_RHO, K_LATENT, K_GROOVE, K_STILL, K_BREAK, K_FCONTACT,
 K_LOADEXP, K_FREF, NK) = range(16)


@njit(cache=True)
def thermal_step(h, T, delta, t_bond, ledger, P_heat, P_slip, fn, travel, slip, k, area_s, area_c, g0):
    """Advance one step in place: ``T`` K, ``delta`` m, ``t_bond`` s (per screw) and ``ledger`` (J, LEDGER),
    from the heater and slip powers (W), the normal forces (N: contact above k[K_FCONTACT]), the speeds of the
    screws' centres along the ice (``travel``, m/s) and the contacts' slip speeds (m/s). ``k`` the scalar constants (K_*), ``area_s`` the screws' surfaces, ``area_c``
    their contact strips (m²), ``g0`` their contact conductances at the reference load (W/K)."""
    C, eps, h_c, t_ice, t_env, t_melt = k[K_C], k[K_EPS], k[K_HC], k[K_TICE], k[K_TENV], k[K_TMELT]
    for s in range(T.shape[0]):
        T0 = T[s]
        contact = fn[s] > k[K_FCONTACT]
        G = 0.0
        if contact:
            G = g0[s] if k[K_LOADEXP] == 0.0 else g0[s] * (max(fn[s], 0.0) / k[K_FREF]) ** k[K_LOADEXP]
        hA = h_c * area_s[s]
        r = eps * SIGMA * area_s[s]
        T3 = T0 * T0 * T0
        slope = 4.0 * r * T3                                # dq_rad/dT at T
        rad0 = r * (T3 * T0 - t_env ** 4) - slope * T0      # q_rad = rad0 + slope T⁺
        rhs = C / h * T0 + P_heat[s] + P_slip[s] + hA * t_env - rad0
        diag = C / h + hA + slope + G
        Tn = (rhs + G * t_melt) / diag                      # melting: the film at T_m
        melting = contact and Tn > t_melt
        t_far = t_melt
        if not melting:                                     # the cold ice (or out of contact: G = 0)
            t_far = t_ice
            Tn = (rhs + G * t_ice) / diag
        e_ice = h * G * (Tn - t_far)
        ledger[HEATER] += h * P_heat[s]
        ledger[FRICTION] += h * P_slip[s]
        ledger[STORED] += C * (Tn - T0)
        ledger[RADIATED] += h * (rad0 + slope * Tn)
        ledger[CONVECTED] += h * hA * (Tn - t_env)
        if melting:
            d = e_ice / (area_c[s] * k[K_STEFAN])
            ledger[MELTING] += e_ice
            ledger[LATENT] += k[K_RHO] * k[K_LATENT] * area_c[s] * d
            delta[s] += d
        else:
            ledger[COLD] += e_ice
        T[s] = Tn
        # the groove relaxes as the screw's centre leaves it (a screw spinning in place slips inside its groove
        # and stays there); the bond grows while frozen in and still, and any motion breaks it
        delta[s] *= math.exp(-h * max(abs(travel[s]) - k[K_STILL], 0.0) / k[K_GROOVE])
        v = abs(travel[s]) + abs(slip[s])
        if v > k[K_BREAK]:
            t_bond[s] = 0.0
        elif contact and Tn < t_melt and delta[s] > 0.0 and v < k[K_STILL]:
            t_bond[s] += h
    ledger[RESIDUAL] = (ledger[HEATER] + ledger[FRICTION] - ledger[STORED] - ledger[MELTING] - ledger[COLD]
                        - ledger[RADIATED] - ledger[CONVECTED])


def constants(**values) -> np.ndarray:
    """The ``k`` array from keywords named as the K_* slots without the prefix (lower case)."""
    k = np.zeros(NK)
    for name, v in values.items():
        k[globals()["K_" + name.rstrip("_").upper()]] = v        # break_: a keyword, spelt with "_"
    return k
