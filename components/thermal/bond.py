"""Refreeze bond of a stopped, embedded screw (sintering), and what it adds to the breakaway friction.

When a screw that melted into its groove cools below T_m while it stands still, the melt water refreezes
around it and the contact sinters: the bond's strength grows with the hold time t_b. Gubler (J. Glaciol.
28 (100), 457–473, 1982, "Strength of bonds between ice grains after short contact times") measured the
tensile load capacity of ice–ice bonds after 1–500 s of contact, rising sharply near the melting point
(fastest at −5 °C); healing of snow surface-to-surface contacts follows a power law in time (The Cryosphere
8, 1651–1659, 2014). The form used here is that power law::

    σ_b(t_b) = σ_1 (t_b / 1 s)^n          Pa, t_b ≥ 0  (0 before any hold)

σ_1 (``bond_stress_1s``) and n (``bond_exponent``) are parameters; their defaults (1 kPa, 0.5) are this
model's assumptions, not values read from the sources (only the abstracts were found).

The bond resists breakaway as extra friction capacity σ_b A_c on top of μ F_n, so through the contact law's
per-screw μ scale::

    mu_scale = mu_base (1 + σ_b A_c / (μ_ref F_n))      (F_n > 0; 1 without contact)

with μ_ref the material's μ the contact scales (``mu_reference``) and mu_base any other law's scale
(ice_friction's). The bond breaks (t_b → 0) as soon as the screw slides or rolls (heat_step.thermal_step).
"""

from __future__ import annotations

import numpy as np


def bond_stress(t_bond, stress_1s: float, exponent: float):
    """Pa, σ_1 (t_b / 1 s)^n (0 at t_b = 0)."""
    return stress_1s * np.power(np.maximum(t_bond, 0.0), exponent)


def bond_mu_scale(t_bond, fn, area, mu_ref: float, stress_1s: float, exponent: float):
    """1 + σ_b A_c / (μ_ref F_n) where F_n > 0, else 1."""
    extra = bond_stress(t_bond, stress_1s, exponent) * area
    return 1.0 + np.where(fn > 0.0, extra / (mu_ref * np.maximum(fn, 1e-300)), 0.0)
