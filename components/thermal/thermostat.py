"""Screw heater thermostat: the field practice of heating the screws to a set-point (paper 4.3.2: 10–40 °C,
checked by onboard thermocouples), as a bounded PI on the measured temperature, one loop per screw::

    e = T* − T_meas                       K
    P = clip(k_p e + k_i I, 0, P_max)     W per screw (a heater only heats)
    I ← I + T_s e   unless P is clipped and e drives it further (clamping anti-windup)

sampled at the component's ``rate`` (T_s its period), holding P between samples. ``set_point`` and
``melting_point`` in K: a set-point at or below the melting point warns (the screws would never melt in:
not an error, a cold-screw scene is legitimate), naming both keys.

in   temperature[n]  K (thermocouple.measured, or screw_heat.temperature)
out  heater_power[n] W (to screw_heat.heater_power)
"""

from __future__ import annotations

import warnings

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params

from .ice_properties import T_MELT


class ThermostatParams(Params):
    set_point: float = Field(293.15, gt=0, description="K, T* (20 °C)")
    max_power: float = Field(60.0, ge=0, description="W per screw, P_max (an assumption; no source gives EELS's)")
    kp: float = Field(20.0, ge=0, description="W/K")
    ki: float = Field(2.0, ge=0, description="W/(K s)")
    melting_point: float = Field(T_MELT, gt=0, description="K: a set-point at or below it warns")
    n: int = Field(1, ge=1, description="number of heaters (screws)")


class Thermostat(Component[ThermostatParams]):
    type_name = "thermostat"

    temperature = Input(shape="n", unit="K")
    heater_power = Output(shape="n", unit="W", feedthrough=())

    def setup(self):
        p = self.p
        if self.rate is None:
            raise ValueError(f"{self.name}: thermostat is a sampled controller: give it `rate: HZ`")
        if p.set_point <= p.melting_point:
            warnings.warn(f"{self.name}: set_point = {p.set_point:g} K is not above melting_point = "
                          f"{p.melting_point:g} K: the heated screws will not melt into the ice", stacklevel=2)

    def discrete_state(self):
        return np.zeros(2 * self.p.n)          # [integral (K s), power (W)] per heater

    def output(self, t, x, u, y):
        y.heater_power[:] = x[self.p.n:]

    def update(self, t, xd, u):
        p, n, T_s = self.p, self.p.n, 1.0 / self.rate
        e = p.set_point - np.asarray(u.temperature, float)
        I = xd[:n]
        raw = p.kp * e + p.ki * (I + T_s * e)
        P = np.clip(raw, 0.0, p.max_power)
        wind = ((raw > p.max_power) & (e > 0)) | ((raw < 0.0) & (e < 0))
        xd[:n] = np.where(wind, I, I + T_s * e)
        xd[n:] = P
