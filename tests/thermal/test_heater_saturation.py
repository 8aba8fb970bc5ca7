"""In melting contact the screw heater saturates for every field set-point: the set-point then only sets the
heat the screw starts with, not how fast it melts in (docs/thermal.md, the Enceladus row of the critical
dwell). A screw on the ice loses G (T − T_m) through its melt film, G = g_c A_c = 23 W/K by default; holding
10 °C asks 230 W of a 60 W heater. So the heater runs at P_max, and the screw settles at T* where

    P_max = G (T* − T_m) + ε σ A_s (T*⁴ − T_env⁴)        (vacuum: no convection)

melting in at v* = G (T* − T_m) / (ρ_i (L_f + c_i (T_m − T_ice)) A_c), the same for 10 and 40 °C. A set-point
below T* is held (the heater has power to spare), and melts in slower: the saturation is the parameters',
not a clamp in the code.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from snakesim.components.thermal import ScrewHeat, Thermostat
from snakesim.components.thermal.ice_properties import SIGMA, T_MELT, stefan_energy_density
from snakesim.framework import Harness

RATE = 10.0                      # Hz, both components (the scene: heat 100 Hz, thermostat 10 Hz)
T_ICE = 93.15                    # K, Enceladus, vacuum
P_MAX, EPS, G_C, W, L, R, C = 60.0, 0.1, 20000.0, 0.01, 0.115, 0.07, 1.5 * 900.0
G, A_C, A_S = G_C * W * L, W * L, 2 * np.pi * R * L


def hold(set_point: float, seconds: float):
    """A screw pressed on the ice (100 N) under its thermostat, started at the set-point (pre-heated, as in
    the scene). Returns the heater powers (W) per sample, the final temperature (K) and penetration (m),
    and the penetration one sample before the end."""
    heat = Harness(ScrewHeat, {"screws": 1, "initial_temperature": set_point, "ice_temperature": T_ICE,
                               "environment_temperature": T_ICE, "convection": 0.0, "emissivity": EPS}, rate=RATE)
    stat = Harness(Thermostat, {"set_point": set_point, "max_power": P_MAX}, rate=RATE)
    heat.inputs.normal_force = [100.0]
    powers, before = [], 0.0
    for k in range(int(seconds * RATE)):
        stat.inputs.temperature = heat.outputs()["temperature"]
        stat.update(k / RATE)
        P = stat.outputs()["heater_power"]
        powers.append(P[0])
        heat.inputs.heater_power = P
        before = heat.xd[1]
        heat.update(k / RATE)
    return np.array(powers), heat.xd[0], heat.xd[1], before


def test_heater_saturates_in_melting_contact_so_the_set_point_does_not_set_the_melt_rate():
    rad = lambda T: EPS * SIGMA * A_S * (T ** 4 - T_ICE ** 4)              # noqa: E731
    T_star = brentq(lambda T: P_MAX - G * (T - T_MELT) - rad(T), T_MELT, T_MELT + P_MAX / G)
    e = stefan_energy_density(T_ICE)
    v_star = G * (T_star - T_MELT) / (e * A_C)
    seconds = 600.0
    for sp_c in (10.0, 40.0):
        sp = T_MELT + sp_c
        assert G * (sp - T_MELT) > P_MAX                    # the set-point asks more than the heater has
        P, T, d, d_before = hold(sp, seconds)
        sat = np.flatnonzero(P < P_MAX)                     # last unsaturated sample
        t_sat = (sat[-1] + 1) / RATE if sat.size else 0.0
        assert t_sat < 60.0, f"{sp_c} °C: heater still below P_max at {t_sat} s"
        # after saturation T − T* decays at least as the implicit step's factor 1/(1 + h G/C) per step
        # (radiation's slope only speeds it up)
        n = (seconds - t_sat) * RATE
        bound = (sp - T_star) * (1.0 + G / (C * RATE)) ** (-n)
        assert abs(T - T_star) <= bound + 1e-9, (sp_c, T - T_star, bound)
        v = (d - d_before) * RATE                           # the last step's melt speed
        assert v == pytest.approx(v_star, abs=G * bound / (e * A_C) + 1e-12)
    assert 2.0 < T_star - T_MELT < P_MAX / G                # ~2.5 °C: radiation takes ~1.6 W of the 60 W


def test_a_set_point_the_heater_can_hold_melts_in_slower():
    sp = T_MELT + 1.0                                       # G × 1 K + radiation < P_max: held
    # the PI loop's slowest mode decays as exp(−(G + k_p) t / (2 C)) (C s² + (G + k_p) s + k_i = 0, complex
    # roots): after 600 s, < 1e-4 of the ~0.6 K the contact's 25 W first pull the screw below its set-point
    P, T, d, d_before = hold(sp, 600.0)
    assert P[-1] < P_MAX
    assert P[-1] == pytest.approx(G * 1.0 + EPS * SIGMA * A_S * (sp ** 4 - T_ICE ** 4), rel=1e-3)
    assert T == pytest.approx(sp, abs=1e-3)
    v = (d - d_before) * RATE
    assert v == pytest.approx(G * 1.0 / (stefan_energy_density(T_ICE) * A_C), rel=1e-3)
