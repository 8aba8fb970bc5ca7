"""Water ice near its melting point, and the melting-probe (Stefan) balance the melt-in model uses.

Constants (SI), the values the sources' summary gives (/work/shared/reference/physics-sources.md:
"ρ_i ≈ 917 kg/m³, L_f ≈ 334 kJ/kg, c_i ≈ 2.1 kJ/(kg K) near 0 °C (lower at Enceladus temperatures)");
they are Params of the screw-heat component, these are its defaults:

    RHO_ICE      917       kg/m³
    LATENT_FUSION 334e3    J/kg
    C_ICE        2100      J/(kg K)   (near 0 °C; a constant here: at −180 °C it is lower, so the
                                       sensible term below is an upper bound there)
    T_MELT       273.15    K
    SIGMA        5.670374419e-8 W/(m² K⁴), Stefan–Boltzmann (CODATA, exact in the 2019 SI)

The melting-probe energy balance (the cryobot literature's penetration speed, e.g. the Stefan-problem
analyses of melting probes, Weinberg & Ortiz, arXiv 2002.02178, "Ice penetration by a bluff-body
melting probe"; the balance itself as physics-sources.md states it): a net power q into a contact of
area A melts ice that first has to be warmed from T_ice to T_m::

    ρ_i (L_f + c_i (T_m − T_ice)) dδ/dt = q / A        (m/s)

so every joule into the ice while melting goes either into latent heat (the L_f share) or into
warming the melted ice (the c_i share): ``stefan_energy_density`` is the bracket times ρ_i (J/m³).
"""

from __future__ import annotations

RHO_ICE = 917.0
LATENT_FUSION = 334e3
C_ICE = 2100.0
T_MELT = 273.15
SIGMA = 5.670374419e-8


def stefan_energy_density(t_ice: float, rho: float = RHO_ICE, latent: float = LATENT_FUSION, c_ice: float = C_ICE,
                          t_melt: float = T_MELT) -> float:
    """J/m³ to warm ice from ``t_ice`` (K) to its melting point and melt it: ρ_i (L_f + c_i (T_m − T_ice))."""
    return rho * (latent + c_ice * max(t_melt - t_ice, 0.0))


def melt_speed(power: float, area: float, t_ice: float, **kw) -> float:
    """m/s, the Stefan / melting-probe penetration speed of ``power`` W through ``area`` m² into ice at
    ``t_ice`` K (the closed form the tests compare the component with)."""
    return power / (area * stefan_energy_density(t_ice, **kw))
