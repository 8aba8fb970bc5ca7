"""Per-point contact forces as a component (numba kernel, no allocation per step).

point_contact:
    in   depth[n] m, normal[n,3] 1 (outward terrain normal), velocity[n,3] m/s (robot
         material point relative to terrain, spin included), thread_dir[n,3] 1 (ê_v;
         optional, unused when ev_a = 1 and ev_b = 0)
    out  force[n,3] N (on the robot, at each point, world), normal_force[n] N
         (feedthrough from all inputs)

Generic over where the points come from (screw samples + an SDF terrain query upstream);
the body-wrench reduction is screw_samples.body_wrenches / kernels_numba.body_wrenches_nb.

params  material   one Material (k, c, mu, ev_a, ev_b: snakesim.components.materials)
        fn_max     N, top of the normal load per point: ‖e_v‖ = ev_a + ev_b·F_n must stay
                   ≥ ev_floor on [0, fn_max] (checked when the parameters are read)
        ev_floor, v_eps, regularisation   the kernels' knobs (kernels.py)
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from snakesim.components.materials import EV_A, EV_B, MU, C, K, Material, ev_range_problem, material_table
from snakesim.framework import Component, Input, Output, Params

from .kernels import EV_FLOOR, MODES
from .kernels_numba import contact_forces_nb


class PointContactParams(Params):
    n: int = Field(1, ge=1, description="number of contact points")
    material: Material = Field(Material(name="point", mu=0.25), description="the contact material")
    fn_max: float = Field(500.0, gt=0, description="N, top of the working range of F_n per contact")
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible ‖e_v‖")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"

    @model_validator(mode="after")
    def _ev_positive_on_range(self):
        problem = ev_range_problem(self.material, self.fn_max, self.ev_floor)
        if problem:
            raise ValueError(problem)
        return self


class PointContact(Component[PointContactParams]):
    type_name = "point_contact"
    depth = Input(shape="n", unit="m")
    normal = Input(shape=("n", 3), unit="1")
    velocity = Input(shape=("n", 3), unit="m/s")
    thread_dir = Input(shape=("n", 3), unit="1", default=0.0)
    force = Output(shape=("n", 3), unit="N", feedthrough=True)
    normal_force = Output(shape="n", unit="N", feedthrough=True)

    def setup(self):
        p = self.p
        m = material_table([p.material], fn_max=p.fn_max, ev_floor=p.ev_floor, owner=self.name)[0]
        self._args = (float(m[K]), float(m[C]), float(m[MU]), float(m[EV_A]), float(m[EV_B]),
                      float(p.v_eps), MODES[p.regularisation], float(p.ev_floor))

    def output(self, t, x, u, y):
        contact_forces_nb(u.depth, u.normal, u.velocity, u.thread_dir, *self._args, y.force, y.normal_force)
