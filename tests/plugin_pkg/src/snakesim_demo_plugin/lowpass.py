"""First-order low-pass filter, one per element of a vector signal.

    τ ẏ = u − y

in   u[n]  any unit
out  y[n]  the unit of u   (state only: no feedthrough, so it can close loops)
continuous state: y [n]

Its response to a step of u from y0 to u1 at t0 is
y(t) = u1 + (y0 − u1)·e^(−(t − t0)/τ); the corner frequency is 1/(2πτ) Hz.
The plugin's tests check both the derivative alone (Harness) and the step
response of the scene ``lowpass-step`` run by the installed ``snakesim``.
"""


from __future__ import annotations

from importlib.resources import files

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Component, ContinuousState, Input, Output, Params, hookimpl


class LowPassParams(Params):
    tau: float = Field(0.1, gt=0, description="time constant τ, s")
    n: int = Field(1, ge=1, description="number of signals filtered")
    y0: float | list[float] = Field(0.0, description="initial output, the unit of u")

    @model_validator(mode="after")
    def _length(self):
        if isinstance(self.y0, list) and len(self.y0) not in (1, self.n):
            raise ValueError(f"y0 has {len(self.y0)} elements but n = {self.n}")
        return self


class LowPass(Component[LowPassParams]):
    """First-order low-pass filter τ ẏ = u − y (demo plugin)."""

    type_name = "demo_lowpass"      # third-party names carry a prefix: no clash with built-ins
    u = Input(shape="n", unit=None, doc="signal to filter")
    y = Output(shape="n", unit=None, feedthrough=(), doc="filtered signal")


    def setup(self):
        self._inv_tau = 1.0 / self.p.tau

    def continuous_state(self):
        y0 = np.broadcast_to(np.asarray(self.p.y0, dtype=float), (self.p.n,))
        return ContinuousState(np.array(y0))

    def output(self, t, x, u, y):
        y.y[:] = x

    def derivative(self, t, x, u, dx):
        np.subtract(u.u, x, out=dx)
        dx *= self._inv_tau


@hookimpl
def snakesim_register_components(registry):
    registry.add_component(LowPass)


@hookimpl
def snakesim_assembly_paths():
    # scenes shipped inside the package: `snakesim run lowpass-step` finds them by name
    return [files("snakesim_demo_plugin") / "assemblies"]
