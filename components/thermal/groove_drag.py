"""The groove's walls: lateral resistance on a screw melted in deeper than its thread.

Within the thread depth h_t the screw's threads sit in their own impressions (thread engagement, the
contact law's ‖e_v‖ scale from screw_heat). Deeper, the screw's core lies in a trough of ice: to move
across its axis (roll or slide out along the wall) it has to crush the groove wall ahead of it. The
contact law's ports (μ, ‖e_v‖, sinkage) cannot say this: a sinkage lowers the surface under the screw
wherever it goes, it leaves no lip behind. So the wall is an external force on the screw link, summed
with the contact's wrenches (tethers/wrench_sum.py) into the multibody::

    F_g = σ_w L (δ − h_t)⁺                      N, the wall's crushing resistance (a rigid-plastic wall:
                                                 strength σ_w over the submerged strip L × (δ − h_t))
    w   = (I − n̂ n̂ᵀ)(I − â âᵀ) v_S             m/s, the screw link origin's velocity across its axis â and
                                                 along the wall (n̂ the terrain's normal at the screw's centre:
                                                 into or out of the wall is the contact's business)
    f   = −F_g w / sqrt(|w|² + v_ε²)            N, at the screw link's origin (on its axis: no moment)

a regularised Coulomb law, like the contact's eq. 6, in v⊥. σ_w (``wall_strength``): the default 1 MPa is
of the order of ice's compressive strength at slow loading — this model's assumption, not a value read from
a source. Its velocity slope is declared to the implicit step (a LinkWrenchJacobian: ∂f/∂v_S =
−F_g (P/s − w wᵀP/s³), P = (I − n̂n̂ᵀ)(I − ââᵀ), s = sqrt(|w|² + v_ε²); the rotation of â and n̂ is left
out, as the contact leaves out the rotation of its normals), so a stiff wall costs no stability at a 10 ms
step. n̂ is a terrain query at each screw's centre, made at the component's ``rate`` once any screw has
moved ``normal_distance`` (5 mm) from where its normal was last sampled, held between (the wall turns
slowly under a screw: on a plane nothing changes; on a wall of curvature radius R the held normal is off by
at most ~normal_distance / R rad); before the first sample, or with no terrain wired, n̂ = 0.

Also out: ``travel_speed`` = |w| per screw, the speed at which the screw leaves its groove along the wall
(screw_heat's groove relaxation reads it; a screw moving into the wall as it melts in does not leave its
groove), and ``wall_force`` = F_g per screw, the force it takes to push the screw out across the groove's
wall (melt_climb_watch compares it with the screw's traction to name an embedded screw).


in   link_poses[nl, 7], link_velocities[nl, 6]   from the multibody
     terrain                                     the terrain (optional: the wall's normal)
     penetration[ns] m                           screw_heat.penetration
out  wrenches[nl, 6]   N, N·m (world, about link origins; to a wrench_sum with the contact's)
     travel_speed[ns]  m/s
     wall_force[ns]    N, F_g
uses robot: RobotModel (the multibody's): the screw layout (components/contact/robot_screws.py)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody.linearization import LinkWrenchJacobian
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.terrain.base import Terrain
from snakesim.framework import Component, Input, Output, Params, Uses

from ..kernel_args import bind
from .groove_kernels import GrooveArgs, groove_slope_step, groove_step


class GrooveDragParams(Params):
    wall_strength: float = Field(1e6, ge=0, description="Pa, σ_w: the groove wall's crushing resistance")
    thread_depth: float = Field(0.0175, gt=0, description="m, h_t (screw_heat's)")
    v_eps: float = Field(1e-3, gt=0, description="m/s, the regularisation of the wall's Coulomb law")
    normal_distance: float = Field(0.005, ge=0, description="m: the wall's normal at a screw is sampled again once "
                                   "the screw has moved this far (per axis) since its last sample (0: every sample)")


def _per_screw(c):
    return (c.ns,)


def _names(c):
    return c.screw_names


class GrooveDrag(Component[GrooveDragParams]):
    type_name = "groove_drag"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    penetration = Input(shape=_per_screw, unit="m")
    terrain = Input(type=Terrain, default=None)
    wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True)
    travel_speed = Output(shape=_per_screw, unit="m/s", feedthrough=True, names=_names)
    wall_force = Output(shape=_per_screw, unit="N", feedthrough=True, names=_names)

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: groove_drag samples the wall's normal at a rate: give it `rate: HZ`")
        lay = self.robot.derived(screw_layout)
        self.ns, self.screw_names = lay.ns, tuple(lay.names)
        self._row = np.ascontiguousarray(lay.screw_row, dtype=np.int64)
        self._parent = np.ascontiguousarray(lay.parent_row, dtype=np.int64)
        self._axis_B = np.ascontiguousarray(np.asarray(lay.mount_R)[:, :, 0])
        self._length = np.ascontiguousarray(lay.length, dtype=float)

    def discrete_state(self):
        return np.zeros(3 * self.ns)           # the wall's normal at each screw (0: not known yet)

    def update(self, t, xd, u):
        if u.terrain is None:
            return
        centres = np.asarray(u.link_poses)[self._row, :3]
        c = u.cache
        last = c["queried_at"] if c is not None and c["terrain"] is u.terrain else None
        # the wall turns slowly under a screw: ask the terrain again once a screw has moved normal_distance
        # from where its normal was sampled (a plane's normal is the same anywhere: no change at all there)
        if last is None or np.abs(centres - last).max() > self.p.normal_distance:
            xd[:] = u.terrain.query(centres).normal.ravel()
            if c is not None:
                c["queried_at"], c["terrain"] = centres.copy(), u.terrain

    def make_cache(self, x, u, y):
        nl, ns, p = self.robot.nl, self.ns, self.p
        y.wrenches[:] = 0.0                       # only the screws' rows are ever written
        c = {"d_twist": np.zeros((nl, 6, 6)), "d_pose": np.zeros((nl, 6, 6)),
             "vp": np.zeros((ns, 3)), "axis": np.zeros((ns, 3)), "on": np.zeros(ns, dtype=np.bool_),
             "normal": np.zeros((ns, 3)), "queried_at": None, "terrain": None}
        g = GrooveArgs(poses=u.link_poses, vels=u.link_velocities, parent=self._parent, row=self._row,
                       axis_B=self._axis_B, length=self._length, pen=u.penetration, strength=float(p.wall_strength),
                       depth=float(p.thread_depth), v_eps=float(p.v_eps), normal=c["normal"], wrenches=y.wrenches,
                       travel=y.travel_speed,
                       F=y.wall_force, vp=c["vp"], ax=c["axis"], d_twist=c["d_twist"], on=c["on"])
        c["forces"], c["slopes"] = bind(groove_step, g), bind(groove_slope_step, g)
        c["none"] = LinkWrenchJacobian(rows=self._row[:0], d_twist=c["d_twist"], d_pose=c["d_pose"],
                                       inputs=("link_poses", "link_velocities"))
        return c

    def output(self, t, x, u, y):
        c = u.cache
        c["normal"].ravel()[:] = x              # the sampled normals (discrete state) into the kernel's record
        c["forces"]()

    def port_jacobian(self, port, t, x, u, y):
        """∂f/∂v_S of each screw pressing a groove wall (see the module docstring)."""
        if port != "wrenches" or u.cache is None:
            return None
        c = u.cache
        if not y.wall_force.any():             # no screw past its thread: no slope (one empty declaration, kept)
            return c["none"]
        c["slopes"]()
        return LinkWrenchJacobian(rows=self._row[c["on"]], d_twist=c["d_twist"], d_pose=c["d_pose"],
                                  inputs=("link_poses", "link_velocities"))
