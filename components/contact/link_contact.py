"""What every robot–terrain contact back end shares: its ports, its parameters of the law, the terrain
it follows, the depth watch and the contact set.

The back ends (screw_sdf_contact, body_contact, hull_contact) differ in geometry (where the contacts
are) and agree on everything else, so an assembly swaps one for another by changing the type:

uses robot: RobotModel      (the multibody's: links, collision shapes, screws)
in   link_poses[nl,7]       multibody link_poses (xyz + quaternion xyzw, world)
     link_velocities[nl,6]  multibody link_velocities ([v origin, ω], world)
     terrain                structured Terrain (terrain component)
out  wrenches[nl,6]         N, N·m: [f, τ] world, τ about each link origin (multibody.wrenches, directly
                            or through wrench_sum)
     normal_force[1]        N, Σ F_n over the robot–terrain contacts
     contacts[1]            robot–terrain contacts
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs.

A back end's run cache (``u.cache``) answers three questions (:class:`ContactRun`): does the last
evaluation describe these inputs (``describes``), evaluate again into scratch outputs
(``evaluate_scratch``), and which contacts are active (``active_contacts``): the contact set is then
built here once for all. The material table is packed once per terrain object (``material_table``);
the depth watch (``max_depth``) stops the run naming the link and the depth.
"""

from __future__ import annotations

from typing import Literal, Protocol, TypeVar

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.materials import MaterialPatch, material_table
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_element_names, link_shape

from ..terrain.base import Terrain
from .contact_set import ContactSet
from .kernels import EV_FLOOR


class LinkContactParams(Params):
    material: MaterialPatch | None = Field(None, description="overrides the terrain materials' k, c, mu, ev_a, ev_b")
    fn_max: float = Field(500.0, gt=0, description="N, top of the normal load per contact: ‖e_v‖ ≥ ev_floor up to it")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible ‖e_v‖ (or along/across ratio)")
    max_depth: float | None = Field(0.03, gt=0, description="m; a contact deeper in the terrain stops the run (a "
                                                            "step too large for k, or a material too soft: the "
                                                            "weight sinks a link by F/k, about a millimetre); "
                                                            "None: no watch")


P = TypeVar("P", bound=LinkContactParams)


class ContactRun(Protocol):
    """A back end's run cache, as :class:`LinkContact` reads it."""

    terrain: object

    def describes(self, u) -> bool:
        """The last evaluation was at exactly these inputs (terrain object, poses, velocities…)."""

    def evaluate_scratch(self, t, x, u) -> None:
        """Evaluate at these inputs into scratch outputs (the numeric outputs are not touched)."""

    def active_contacts(self) -> dict:
        """The last evaluation's contacts in contact: ContactSet's array fields (points … material)."""


class LinkContact(Component[P]):
    """The shared base of the robot–terrain contact back ends (module docstring); not a component
    on its own."""

    #: query a plane (Terrain.fast_plane) in numba (tests and the bench switch it off to compare)
    fast_plane = True

    robot = Uses(RobotModel)
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    terrain = Input(type=Terrain)
    wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True,
                      names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")))
    normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    contacts = Output(shape=(1,), unit="1", feedthrough=True)
    contact_set = Output(type=ContactSet, feedthrough=True, calc="calc_contact_set")

    def material_table(self, terrain: Terrain) -> np.ndarray:
        """The kernels' material table ([K, C, MU, EV_A, EV_B] per terrain material, ``material``
        applied; checked: ‖e_v‖ ≥ ev_floor up to fn_max), packed once per terrain object."""
        p = self.p
        return material_table(terrain.materials, p.material, fn_max=p.fn_max, ev_floor=p.ev_floor, owner=self.name)

    def checked_terrain(self, terrain) -> Terrain:
        """The terrain input, or a clear error when nothing carries one."""
        if terrain is None:
            raise ValueError(f"{self.name}: input 'terrain' carries no Terrain; connect a terrain component's "
                             "'terrain' output to it")
        return terrain

    def watch_depth(self, t: float, distance: np.ndarray, link_of_row: np.ndarray, deepest: float | None = None,
                    what: str = "link"):
        """Stop the run when a contact is deeper than ``max_depth``: ``distance`` the rows' signed
        distances (m, < 0 inside), ``link_of_row`` each row's link row, ``deepest`` −min(distance)
        when the caller has it already, ``what`` the link's role in the message."""
        limit = self.p.max_depth
        if limit is None or distance.size == 0:
            return
        if deepest is None:
            deepest = -float(distance.min())
        if not deepest > limit:
            return
        k = int(distance.argmin())
        link = self.robot.links[link_of_row[k]]
        self.stop(f"contact on {what} '{link}' is {-distance[k] * 1e3:.3g} mm deep at t = {t:.6g} s, beyond "
                  f"max_depth = {limit * 1e3:g} mm: the step is too large for the contact stiffness (see the "
                  f"run's step_check) or the material too soft")

    def calc_contact_set(self, t, x, u, y):
        run = u.cache
        if not run.describes(u):        # the last evaluation was at other inputs
            run.evaluate_scratch(t, x, u)
        y.contact_set = ContactSet(t=float(t), link_names=self.robot.links, **run.active_contacts())
