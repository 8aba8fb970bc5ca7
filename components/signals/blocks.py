"""Algebraic and sampled blocks: gain, sum, zero-order hold.

gain:  y = k · u           (feedthrough)
sum:   y = Σ sign_i · u_i  (feedthrough, up to four inputs)
zoh:   y = u sampled at ``rate`` and held (discrete state: the held value)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params


class GainParams(Params):
    k: float = 1.0
    n: int = Field(1, ge=1)


class Gain(Component[GainParams]):
    type_name = "gain"
    u = Input(shape="n", unit=None)
    y = Output(shape="n", unit=None, feedthrough=("u",))

    def output(self, t, x, u, y):
        np.multiply(u.u, self.p.k, out=y.y)


class SumParams(Params):
    signs: list[float] = Field(default_factory=lambda: [1.0, 1.0], min_length=1, max_length=4)
    n: int = Field(1, ge=1)


class Sum(Component[SumParams]):
    """Unconnected inputs read zero, so one block serves two to four terms."""

    type_name = "sum"
    u0 = Input(shape="n", unit=None, default=0.0)
    u1 = Input(shape="n", unit=None, default=0.0)
    u2 = Input(shape="n", unit=None, default=0.0)
    u3 = Input(shape="n", unit=None, default=0.0)
    y = Output(shape="n", unit=None, feedthrough=True)

    def setup(self):
        self._terms = [(f"u{i}", s) for i, s in enumerate(self.p.signs)]

    def output(self, t, x, u, y):
        acc = y.y
        acc[:] = 0.0
        for name, s in self._terms:
            acc += s * getattr(u, name)


class ZohParams(Params):
    n: int = Field(1, ge=1)


class ZeroOrderHold(Component[ZohParams]):
    """Samples its input at its rate; the output is the previous sample (a unit delay)."""

    type_name = "zero_order_hold"
    u = Input(shape="n", unit=None)
    y = Output(shape="n", unit=None, feedthrough=())

    def discrete_state(self):
        return np.zeros(self.p.n)

    def output(self, t, x, u, y):
        y.y[:] = x

    def update(self, t, xd, u):
        xd[:] = u.u
