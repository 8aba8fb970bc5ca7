"""Test-only components of the framework tests (registered by conftest.py's ``registry``; the builder tests
use the classes): a linear oscillator with a closed-form solution (integrator orders, energy), a
structured-value source and sink, an integer-valued source, a port with element names, a component that
asks the run to stop, and a rotor on a manifold."""

from __future__ import annotations

import dataclasses

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ContinuousState, Input, Output, Params


class OscillatorParams(Params):
    omega: float = Field(1.0, gt=0, description="rad/s")
    x0: float = 1.0
    v0: float = 0.0


class Oscillator(Component[OscillatorParams]):
    """ẍ = −ω² x; energy = ½(v² + ω² x²) per unit mass."""

    type_name = "test_oscillator"
    Params = OscillatorParams
    x = Output(unit="m", feedthrough=())
    v = Output(unit="m/s", feedthrough=())
    energy = Output(unit="J", feedthrough=())

    def continuous_state(self):
        return ContinuousState(np.array([self.p.x0, self.p.v0]), second_order=1, names=("x", "v"))

    def output(self, t, x, u, y):
        y.x[...] = x[0]
        y.v[...] = x[1]
        y.energy[...] = 0.5 * (x[1] ** 2 + self.p.omega ** 2 * x[0] ** 2)

    def derivative(self, t, x, u, dx):
        dx[0] = x[1]
        dx[1] = -self.p.omega ** 2 * x[0]


@dataclasses.dataclass(frozen=True)
class Wrench:
    force: float
    torque: float


class WrenchSource(Component[Params]):
    type_name = "test_wrench_source"
    w = Output(type=Wrench, feedthrough=())

    def output(self, t, x, u, y):
        y.w = Wrench(force=2.0 * t, torque=-t)


class WrenchToForce(Component[Params]):
    type_name = "test_wrench_to_force"
    w = Input(type=Wrench)
    force = Output(unit="N", feedthrough=("w",))

    def output(self, t, x, u, y):
        y.force[...] = u.w.force


class CounterParams(Params):
    start: int = 0


class IntSource(Component[CounterParams]):
    """An int64 output: the base-step count since t = 0 at 1 kHz."""

    type_name = "test_int_source"
    Params = CounterParams
    count = Output(dtype=np.int64, unit="1", feedthrough=())

    def output(self, t, x, u, y):
        y.count[...] = self.p.start + int(round(t * 1000))


class Planar(Component[Params]):
    """A 2-vector output with element names (columns ``.x`` and ``.y``)."""

    type_name = "test_planar"
    p_xy = Output(shape=(2,), unit="m", names=("x", "y"), feedthrough=())

    def output(self, t, x, u, y):
        y.p_xy[0] = t
        y.p_xy[1] = -t


class StopperParams(Params):
    t_stop: float = 0.25


class Stopper(Component[StopperParams]):
    """Reads a signal (so it is kept), asks the run to stop at t >= t_stop."""

    type_name = "test_stopper"
    is_sink = True
    Params = StopperParams
    u = Input(shape=None, unit=None)

    def update(self, t, xd, u):
        if t >= self.p.t_stop:
            self.stop("mission complete")


class RotorParams(Params):
    rate: float = 1.0   # rad/s
    angle0: float = 0.0


class Rotor(Component[RotorParams]):
    """A heading on the unit circle: state (cos θ, sin θ), tangent θ̇ = rate (a manifold)."""

    type_name = "test_rotor"
    Params = RotorParams
    angle = Output(unit="rad", feedthrough=())
    norm = Output(unit="1", feedthrough=())

    def continuous_state(self):
        a = self.p.angle0
        return ContinuousState(np.array([np.cos(a), np.sin(a)]), ndx=1, names=("c", "s"))

    def output(self, t, x, u, y):
        y.angle[...] = np.arctan2(x[1], x[0])
        y.norm[...] = np.hypot(x[0], x[1])

    def derivative(self, t, x, u, dx):
        dx[0] = self.p.rate

    def integrate(self, x, dx, out):
        c, s = np.cos(dx[0]), np.sin(dx[0])
        x0, x1 = x[0], x[1]
        out[0] = c * x0 - s * x1
        out[1] = s * x0 + c * x1


TEST_COMPONENTS = (Oscillator, WrenchSource, WrenchToForce, IntSource, Planar, Stopper, Rotor)
