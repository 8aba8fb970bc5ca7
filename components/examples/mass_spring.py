"""1-D point masses joined by linear spring-dampers (a chain, built by repetition).

point_mass: m ẍ = f_left + f_right
    in   f_left, f_right  N   (default 0)
    out  x m, v m/s           (state only)
    continuous state [x, v], second order

spring_damper: between a (left) and b (right), rest length L0
    f = k (x_b − x_a − L0) + c (v_b − v_a)
    in   x_a, v_a, x_b, v_b
    out  f_a = +f  (on a),  f_b = −f  (on b)   N, feedthrough

Internal forces are equal and opposite, so a free chain conserves momentum
exactly: a test checks it.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ContinuousState, Input, Output, Params


class PointMassParams(Params):
    mass: float = Field(1.0, gt=0, description="kg")
    x0: float = Field(0.0, description="m")
    v0: float = Field(0.0, description="m/s")


class PointMass(Component[PointMassParams]):
    type_name = "point_mass"
    f_left = Input(unit="N", default=0.0)
    f_right = Input(unit="N", default=0.0)
    x = Output(unit="m", feedthrough=())
    v = Output(unit="m/s", feedthrough=())

    def continuous_state(self):
        return ContinuousState(np.array([self.p.x0, self.p.v0]), second_order=1, names=("x", "v"))

    def output(self, t, x, u, y):
        y.x[...] = x[0]
        y.v[...] = x[1]

    def derivative(self, t, x, u, dx):
        dx[0] = x[1]
        dx[1] = (u.f_left + u.f_right) / self.p.mass


class SpringParams(Params):
    k: float = Field(100.0, ge=0, description="N/m")
    c: float = Field(0.0, ge=0, description="N·s/m")
    rest_length: float = Field(1.0, description="m")


class SpringDamper(Component[SpringParams]):
    type_name = "spring_damper"
    x_a = Input(unit="m")
    v_a = Input(unit="m/s", default=0.0)
    x_b = Input(unit="m")
    v_b = Input(unit="m/s", default=0.0)
    f_a = Output(unit="N")
    f_b = Output(unit="N")

    def output(self, t, x, u, y):
        p = self.p
        f = p.k * (u.x_b - u.x_a - p.rest_length) + p.c * (u.v_b - u.v_a)
        y.f_a[...] = f
        y.f_b[...] = -f
