"""Per-point contact forces as a component (numba kernel, no allocation per step).

point_contact:
    in   depth[n] m, normal[n,3] 1 (outward terrain normal), velocity[n,3] m/s (robot
         material point relative to terrain, spin included), thread_dir[n,3] 1 (ê_v;
         optional, unused when ev_a = 1 and ev_b = 0)
    out  force[n,3] N (on the robot, at each point, world), normal_force[n] N
         (feedthrough from all inputs)

Generic over where the points come from (screw samples + an SDF terrain query upstream);
the body-wrench reduction is screw_samples.body_wrenches / kernels_numba.body_wrenches_nb.
"""

from __future__ import annotations

from pydantic import Field

from snakesim.framework import Component, Input, Output

from .kernels import MODES
from .kernels_numba import contact_forces_nb
from .materials import FrictionMaterial


class PointContactParams(FrictionMaterial):
    n: int = Field(1, ge=1, description="number of contact points")


class PointContact(Component[PointContactParams]):
    type_name = "point_contact"
    Params = PointContactParams
    depth = Input(shape="n", unit="m")
    normal = Input(shape=("n", 3), unit="1")
    velocity = Input(shape=("n", 3), unit="m/s")
    thread_dir = Input(shape=("n", 3), unit="1", default=0.0)
    force = Output(shape=("n", 3), unit="N", feedthrough=True)
    normal_force = Output(shape="n", unit="N", feedthrough=True)

    def setup(self):
        p = self.p
        self._args = (float(p.stiffness), float(p.damping), float(p.mu), float(p.ev_a), float(p.ev_b),
                      float(p.v_eps), MODES[p.regularisation], float(p.ev_floor))

    def output(self, t, x, u, y):
        contact_forces_nb(u.depth, u.normal, u.velocity, u.thread_dir, *self._args, y.force, y.normal_force)
