"""Ice friction as a function of ice temperature and sliding speed, as a μ scale on the screw contact.

    μ(T, v) = bilinear interpolation of ice_friction_data.MU_K in (T, log10 v)
              (T and v clipped to the table's range: 98–263 K, 5e-8–1e-3 m/s: no extrapolation; faster
              sliding keeps the 1e-3 m/s value, i.e. this law leaves out frictional melting)
    mu_scale = μ(T, v) / μ_material          → screw_sdf_contact.screw_mu_scale (or screw_heat.mu_base)

The table, its source (Schulson & Fortt 2012) and what of it is assumed: ice_friction_data.py. v is the
contact's load-weighted slip speed per screw (``slip_speed``); T the ice temperature, a parameter (the
terrain's) or the optional ``ice_temperature`` input (K; NaN or unconnected: the parameter).

``apply: false`` leaves the contact's μ as it is (mu_scale = 1, mu = μ_material, nothing computed): a scene
can wire the law in and switch it with a parameter (melt-dwell-climb's ``ice_friction``).

in   slip_speed[n] m/s (contact.screw_slip_speed), ice_temperature[1] K (optional)
out  mu[n] (the law's μ), mu_scale[n] = μ / μ_material     (feedthrough)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params

from .ice_friction_data import MU_K, SPEEDS, TEMPERATURES

_LOGV = np.log10(SPEEDS)


def ice_mu(T, v):
    """μk at ice temperature ``T`` K and slip speed ``v`` m/s (arrays broadcast), bilinear in (T, log10 v)."""
    T = np.clip(np.asarray(T, float), TEMPERATURES[0], TEMPERATURES[-1])
    lv = np.clip(np.log10(np.maximum(np.abs(np.asarray(v, float)), SPEEDS[0])), _LOGV[0], _LOGV[-1])
    T, lv = np.broadcast_arrays(T, lv)
    i = np.clip(np.searchsorted(TEMPERATURES, T, side="right") - 1, 0, len(TEMPERATURES) - 2)
    j = np.clip(np.searchsorted(_LOGV, lv, side="right") - 1, 0, len(_LOGV) - 2)
    a = (T - TEMPERATURES[i]) / (TEMPERATURES[i + 1] - TEMPERATURES[i])
    b = (lv - _LOGV[j]) / (_LOGV[j + 1] - _LOGV[j])
    return ((1 - a) * (1 - b) * MU_K[i, j] + a * (1 - b) * MU_K[i + 1, j]
            + (1 - a) * b * MU_K[i, j + 1] + a * b * MU_K[i + 1, j + 1])


class IceFrictionParams(Params):
    ice_temperature: float = Field(263.0, gt=0, description="K, T of the ice (input overrides when finite)")
    mu_material: float = Field(0.3, gt=0, description="μ of the contact's material, which mu_scale divides out")
    n: int = Field(1, ge=1, description="number of screws")
    apply: bool = Field(True, description="false: mu_scale = 1 and mu = mu_material (the law switched off)")


class IceFriction(Component[IceFrictionParams]):
    type_name = "ice_friction"

    slip_speed = Input(shape="n", unit="m/s")
    ice_temperature = Input(shape=(1,), unit="K", default=np.nan)
    mu = Output(shape="n", unit="1", feedthrough=True)
    mu_scale = Output(shape="n", unit="1", feedthrough=True)

    def output(self, t, x, u, y):
        if not self.p.apply:
            y.mu[:], y.mu_scale[:] = self.p.mu_material, 1.0
            return
        T = float(u.ice_temperature[0])
        if not T == T:
            T = self.p.ice_temperature
        elif T < 0:
            raise ValueError(f"{self.name}: ice_temperature input = {T:g} K; valid: a temperature >= 0 K")
        y.mu[:] = ice_mu(T, u.slip_speed)
        np.divide(y.mu, self.p.mu_material, out=y.mu_scale)
