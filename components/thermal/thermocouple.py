"""Thermocouple: the screws' measured temperature, for controllers and ROS 2 (paper 4.3.2: the screw
temperature was checked by onboard thermocouples).

    measured = T + bias + noise          K, sampled at the component's ``rate`` and held

noise: white, seeded (components/sensors/noise.py: one Philox draw per sample, keyed by ``seed``), so a
run is reproducible bit for bit; noise needs a rate.

in   temperature[n]  K (screw_heat.temperature)
out  measured[n]     K (sampled and held)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.sensors.noise import noise_needs_rate, white_noise
from snakesim.framework import Component, Input, Output, Params


class ThermocoupleParams(Params):
    noise: float = Field(0.0, ge=0, description="K, standard deviation (type K thermocouples: ~1 K class)")
    bias: float = Field(0.0, description="K")
    seed: int = Field(0, ge=0, description="noise seed")
    n: int = Field(1, ge=1, description="number of thermocouples (screws)")
    initial_reading: float = Field(293.15, gt=0, description="K, what it shows before its first sample")


class Thermocouple(Component[ThermocoupleParams]):
    type_name = "thermocouple"

    temperature = Input(shape="n", unit="K")
    measured = Output(shape="n", unit="K", feedthrough=())

    def setup(self):
        noise_needs_rate(self.name, self.rate, self.p.noise)
        if self.rate is None:
            raise ValueError(f"{self.name}: a thermocouple samples at a rate: give it `rate: HZ`")
        self._std = np.full(self.p.n, self.p.noise)

    def discrete_state(self):
        x = np.full(1 + self.p.n, self.p.initial_reading)     # [sample counter, held reading per screw]
        x[0] = 0.0
        return x

    def output(self, t, x, u, y):
        y.measured[:] = x[1:]

    def update(self, t, xd, u):
        reading = np.asarray(u.temperature, float) + self.p.bias
        if self.p.noise > 0:
            reading = reading + white_noise(self.p.seed, xd[0], self._std)
        xd[1:] = reading
        xd[0] += 1.0
