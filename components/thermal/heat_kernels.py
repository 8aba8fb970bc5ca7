"""screw_heat's sample and outputs, compiled: the per-sample Python of screw_heat.py in two bound kernels.

The model is screw_heat.py's (and heat_step.py's, bond.py's); these are its hot path, ~100 µs a base step of
NumPy calls on arrays of four screws before (bench/melt_dwell.py --cost), a few µs now. The state is copied
into the record's ``x`` and back around each call (screw_heat.update / output): one copy of ~25 numbers.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..kernel_args import record
from .heat_step import thermal_step

#: one run's arguments (screw_heat.make_cache): the state copy, input views, output buffers, constants, scratch
HeatArgs = record("HeatArgs", (
    "x", "n", "h", "nl",                                                          # state copy, screws, step, ledger
    "heater", "slip_power", "normal_force", "slip_speed", "travel", "mu_base",     # inputs
    "temperature", "penetration", "ev_scale", "mu_scale", "bond_time", "ledger",  # outputs
    "k", "area_s", "area_c", "g0", "max_pen", "slip_pos",                         # constants, scratch
    "thread_depth", "gain", "mu_ref", "stress_1s", "exponent"))


@njit(cache=True)
def heat_update(a):
    """One sample (screw_heat.update): −1 − s if screw s's heater power is negative or not finite (nothing
    changed), else the first screw past its max penetration, or n if none."""
    n = a.n
    for s in range(n):
        p = a.heater[s]
        if not (p >= 0.0 and np.isfinite(p)):
            return -1 - s
    x = a.x
    for s in range(n):
        x[3 * n + s] = a.mu_base[s]                      # mu_base held from the sample
        a.slip_pos[s] = max(a.slip_power[s], 0.0)         # ≥ 0 by eq. 6; round-off below 0 dropped
    thermal_step(a.h, x[0:n], x[n:2 * n], x[2 * n:3 * n], x[4 * n:4 * n + a.nl], a.heater, a.slip_pos,
                 a.normal_force, a.travel, a.slip_speed, a.k, a.area_s, a.area_c, a.g0)
    for s in range(n):
        if x[n + s] > a.max_pen[s]:
            return s
    return n


@njit(cache=True)
def heat_outputs(a):
    """screw_heat's outputs from the state copy: temperature, penetration, ev_scale = 1 + k_e min(δ/h_t, 1),
    mu_scale = mu_base (1 + σ_1 t_b^n A_c / (μ_ref F_n)) (the bond's term only where t_b > 0 and F_n > 0;
    bond.py), bond_time, ledger."""
    n, x = a.n, a.x
    for s in range(n):
        d, tb, mb = x[n + s], x[2 * n + s], x[3 * n + s]
        a.temperature[s] = x[s]
        a.penetration[s] = d
        a.ev_scale[s] = 1.0 + a.gain * min(d / a.thread_depth, 1.0)
        fn = a.normal_force[s]
        if tb > 0.0 and fn > 0.0:
            extra = a.stress_1s * max(tb, 0.0) ** a.exponent * a.area_c[s]
            a.mu_scale[s] = mb * (1.0 + extra / (a.mu_ref * max(fn, 1e-300)))
        else:
            a.mu_scale[s] = mb
        a.bond_time[s] = tb
    for i in range(a.nl):
        a.ledger[i] = x[4 * n + i]
