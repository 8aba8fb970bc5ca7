"""Planar pendulum (point mass on a massless rod) and a viscous joint damper.

pendulum: m L² θ̈ = −m g L sin θ + τ
    in   tau      N*m   (applied at the pivot; default 0)
    out  theta    rad   (state only)
         omega    rad/s (state only)
    continuous state [θ, ω], second order

viscous_damper: τ = −c ω
    in   omega    rad/s
    out  tau      N*m   (feedthrough)

With the damper, small angles follow θ̈ + 2ζω₀θ̇ + ω₀²θ = 0 with
ω₀² = g/L and 2ζω₀ = c/(mL²): the assembly test compares against that.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ContinuousState, Input, Output, Params


class PendulumParams(Params):
    length: float = Field(1.0, gt=0, description="m")
    mass: float = Field(1.0, gt=0, description="kg")
    gravity: float = Field(9.81, ge=0, description="m/s²")
    theta0: float = Field(0.1, description="rad")
    omega0: float = Field(0.0, description="rad/s")


class Pendulum(Component[PendulumParams]):
    type_name = "pendulum"
    tau = Input(unit="N*m", default=0.0)
    theta = Output(unit="rad", feedthrough=())
    omega = Output(unit="rad/s", feedthrough=())

    def setup(self):
        p = self.p
        self._g_over_l = p.gravity / p.length
        self._inv_inertia = 1.0 / (p.mass * p.length ** 2)

    def continuous_state(self):
        return ContinuousState(np.array([self.p.theta0, self.p.omega0]), second_order=1, names=("theta", "omega"))

    def output(self, t, x, u, y):
        y.theta[...] = x[0]
        y.omega[...] = x[1]

    def derivative(self, t, x, u, dx):
        dx[0] = x[1]
        dx[1] = -self._g_over_l * np.sin(x[0]) + self._inv_inertia * u.tau


class DamperParams(Params):
    c: float = Field(0.1, ge=0, description="N·m·s/rad")


class ViscousDamper(Component[DamperParams]):
    type_name = "viscous_damper"
    omega = Input(unit="rad/s")
    tau = Output(unit="N*m", feedthrough=("omega",))

    def output(self, t, x, u, y):
        np.multiply(u.omega, -self.p.c, out=y.tau)
