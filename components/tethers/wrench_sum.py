"""Sum of up to four per-link wrench arrays (contact + tethers + ... -> multibody.wrenches).

    y = Σ sign_i · u_i,   each [nl, 6] in the multibody's convention (world axes, about link origins)

The ``sum`` block adds vectors [n]; this one keeps the [nl, 6] shape so the
element names and the build-time shape check still hold. Unconnected inputs
read zero.

nl is given, or taken from the robot source keys (as the multibody's).

in   u0..u3[nl, 6]  (default 0)
out  y[nl, 6]       (feedthrough)
"""

from __future__ import annotations

from pydantic import Field

from snakesim.components.control.robot_source import RobotSource, link_names

from snakesim.framework import Component, Input, Output


class WrenchSumParams(RobotSource):
    nl: int | None = Field(None, ge=1, description="number of links; default: the robot's (robot source keys)")
    signs: list[float] = Field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0], min_length=1, max_length=4)


def _shape(p):
    return (p.nl if p.nl is not None else len(link_names(p)), 6)


class WrenchSum(Component[WrenchSumParams]):
    type_name = "wrench_sum"
    Params = WrenchSumParams
    u0 = Input(shape=_shape, unit=None, default=0.0)
    u1 = Input(shape=_shape, unit=None, default=0.0)
    u2 = Input(shape=_shape, unit=None, default=0.0)
    u3 = Input(shape=_shape, unit=None, default=0.0)
    y = Output(shape=_shape, unit=None, feedthrough=True)

    def setup(self):
        self._terms = [(f"u{i}", s) for i, s in enumerate(self.p.signs)]

    def output(self, t, x, u, y):
        acc = y.y
        acc[:] = 0.0
        for name, s in self._terms:          # at most four terms: a loop over ports, not joints
            acc += s * getattr(u, name)
