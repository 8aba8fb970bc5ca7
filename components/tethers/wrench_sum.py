"""Sum of up to four per-link wrench arrays (contact + tethers + ... -> multibody.wrenches).

    y = Σ sign_i · u_i,   each [nl, 6] in the multibody's convention (world axes, about link origins)

The ``sum`` block adds vectors [n]; this one keeps the [nl, 6] shape so the
element names and the build-time shape check still hold. Unconnected inputs
read zero.

nl is the ``nl`` param when given, else the robot's (the multibody's link
count): in a scene with a multibody it needs no params; without a robot, give
``nl``.

in   u0..u3[nl, 6]  (default 0)
out  y[nl, 6]       (feedthrough)
uses robot: RobotModel (the multibody's), optional: nl when the param is not given
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.framework.linearization import Elementwise

class WrenchSumParams(Params):
    nl: int | None = Field(None, ge=1, description="number of links; default: the robot's")
    signs: list[float] = Field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0], min_length=1, max_length=4)


def _shape(c):
    return (c.nl, 6)


class WrenchSum(Component[WrenchSumParams]):
    type_name = "wrench_sum"
    robot = Uses(RobotModel, required=False)
    u0 = Input(shape=_shape, unit=None, default=0.0)
    u1 = Input(shape=_shape, unit=None, default=0.0)
    u2 = Input(shape=_shape, unit=None, default=0.0)
    u3 = Input(shape=_shape, unit=None, default=0.0)
    y = Output(shape=_shape, unit=None, feedthrough=True)

    def setup(self):
        if self.p.nl is not None:
            self.nl = self.p.nl
        elif self.robot is not None:
            self.nl = self.robot.nl
        else:
            raise ValueError(f"{self.name}: no link count: give 'nl', or put it in a scene with a multibody "
                             f"(it takes the robot's)")
        self._terms = [(f"u{i}", s) for i, s in enumerate(self.p.signs)]
        self._jacobian = None

    def port_jacobian(self, port, t, x, u, y):
        """∂y/∂u_i = sign_i·I: passes the inputs' Jacobians on (the contacts' LinkWrenchJacobian reaches the
        multibody through a sum only so, components/multibody/linearization._link_wrench_terms; without it
        rosenbrock_w integrates the summed contact forces explicitly, and stiff friction chatters). Constant:
        built once, and the same object each call, so the linearization's check of the sum's structure
        (keyed on the declaration's identity) runs once, not at every Jacobian."""
        if self._jacobian is None:
            n = 6 * self.nl
            i = np.arange(n)
            self._jacobian = Elementwise(n, tuple((name, i, i, np.full(n, float(s))) for name, s in self._terms))
        return self._jacobian

    def output(self, t, x, u, y):
        acc = y.y
        acc[:] = 0.0
        for name, s in self._terms:          # at most four terms: a loop over ports, not joints
            acc += getattr(u, name) if s == 1.0 else s * getattr(u, name)    # 1·u is u: no temporary
