"""Signal sources: constant, step and sine, of any length n.

out  y[n]  (unit set by the ``unit`` parameter; no inputs, no state)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Component, Output, Params


def _as_vector(value, n):
    v = np.broadcast_to(np.asarray(value, dtype=float), (n,))
    return np.array(v)


class ConstantParams(Params):
    value: float | list[float] = 0.0
    n: int = Field(1, ge=1, description="length of the output vector")
    unit: str = "1"

    @model_validator(mode="after")
    def _length(self):
        if isinstance(self.value, list) and len(self.value) not in (1, self.n):
            raise ValueError(f"value has {len(self.value)} elements but n = {self.n}")
        return self


class Constant(Component[ConstantParams]):
    """y = value (held constant)."""

    type_name = "constant"
    time_invariant = True
    y = Output(shape="n", unit=None, feedthrough=())

    def setup(self):
        self._v = _as_vector(self.p.value, self.p.n)

    def output(self, t, x, u, y):
        y.y[:] = self._v


class StepParams(ConstantParams):
    initial: float | list[float] = 0.0
    t_step: float = Field(1.0, description="s")


class Step(Component[StepParams]):
    """y = initial for t < t_step, value after."""

    type_name = "step"
    y = Output(shape="n", unit=None, feedthrough=())

    def setup(self):
        self._a = _as_vector(self.p.initial, self.p.n)
        self._b = _as_vector(self.p.value, self.p.n)

    def output(self, t, x, u, y):
        y.y[:] = self._b if t >= self.p.t_step else self._a


class SineParams(Params):
    amplitude: float | list[float] = 1.0
    frequency: float = Field(1.0, ge=0, description="Hz")
    phase: float = Field(0.0, description="rad")
    offset: float = 0.0
    n: int = Field(1, ge=1)


class Sine(Component[SineParams]):
    """y = offset + amplitude · sin(2π f t + phase)."""

    type_name = "sine"
    y = Output(shape="n", unit=None, feedthrough=())

    def setup(self):
        self._amp = _as_vector(self.p.amplitude, self.p.n)
        self._w = 2.0 * np.pi * self.p.frequency

    def output(self, t, x, u, y):
        np.multiply(self._amp, np.sin(self._w * t + self.p.phase), out=y.y)
        y.y += self.p.offset
