"""Body–terrain contact, SDF back end: samples on every body link's collision shape against the terrain's SDF.

Model (paper §2.2.2, eq. 2; friction as eq. 6 with the skin axis in place of the thread
normal). Each selected link's URDF collision shapes (cylinders, capsules, spheres, boxes;
end caps, the tail and the head included) carry samples ≤ ``spacing`` apart, fixed in the
link (body_samples.py). The design's screw links are left out by default
(``exclude_screws``): ``screw_sdf_contact`` models them with eq. 6, and a scene sums the
two with ``wrench_sum``. A sample p with terrain signed distance φ(p) < 0 is a contact of
depth d = −φ, outward normal n̂ and the terrain material there (k, c, μ):

    slip       v = v_l + ω_l × (p − o_l)                        (world; the link's material point)
    normal     F_n = max(0, k d − c v·n̂)                        (eq. 2, per sample, never pulls)
    friction   F_t = −F_n (μ_along (s·â)â + μ_across (s − (s·â)â))   s = v_t / sqrt(‖v_t‖² + v_ε²)

with â the link's skin axis projected on the tangent plane (a cylinder's axis: snake skin
or scales, wheels or skids), μ_along = μ·along, μ_across = μ·across, the factors of
``friction`` (or of the first ``link_friction`` pattern matching the link). That is eq. 6
(kernels_numba.point_contact_force) with μ → μ·across, ‖e_v‖ → along/across, ê_v → â;
along = across = 1 is isotropic Coulomb friction (eq. 1), regularised in slip like the
screws'. The force acts at p on the link: wrench [f, (p − o_l) × f] about the link origin.

Accuracy: k is per sample, as in both other back ends (a face resting on n samples sinks
F/(n k)); a curved surface rests on its samples' polygon, which lies inside the true
surface by at most the sag r(1 − cos(π/n_around)) (body_samples.py).

Watch (``max_depth``): a sample deeper than max_depth in the terrain ends the run with a
named reason (a bounce from a step too large for k, or a material too soft), never
believable garbage.

Broad phase (``broad_phase``): one bounding sphere per piece (collision element) against
``terrain.distance_lower_bound``; only pieces whose bound is ≤ 0 are sampled and queried.
A plane is queried inside numba in one call.

Jacobian (``port_jacobian``, for rosenbrock_w): per link, Σ over its samples in contact of
X_pᵀ (∂F/∂v) X_p and X_pᵀ (∂F/∂p) X_p about the link origin (X_p = [I, −[p − o_l]×]; ∂F from eq. 2
and the regularised eq. 6 with the skin axis, jacobian_kernels.body_jacobian_blocks), read by the
multibody as the screw contact's are. Left out, as there: the turning of lever arms, normals and
skin axes with the link (tests/contact/test_body_contact_jacobian.py).

Material: the terrain's per-sample material (materials.Material: k, c, μ; its ev_a, ev_b
describe screw threads and are not read here); any field of ``material`` (MaterialPatch)
overrides it for every terrain material.

uses robot: RobotModel      (the multibody's: links, URDF collision shapes, screw links)
in   link_poses[nl,7]       multibody link_poses (xyz + quaternion xyzw, world)
     link_velocities[nl,6]  multibody link_velocities ([v origin, ω], world)
     terrain                structured Terrain (terrain component)
out  wrenches[nl,6]         N, N·m: [f, τ] world, τ about each link origin (multibody.wrenches,
                            directly or through wrench_sum with the screw contact's)
     normal_force[1]        N, Σ F_n over all body samples
     contacts[1]            body samples in contact
     link_normal_force[nl]  N, Σ F_n per link
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs.
"""

from __future__ import annotations

import fnmatch
import functools
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.materials import MaterialPatch, material_table
from snakesim.components.multibody.robot_model import RobotModel

from ..kernel_args import bind
from ..terrain.base import Terrain
from .body_kernels import (BodyPorts, BodyTable, BodyWork, body_centres_step, body_plane_step, body_sample_step,
                           body_seen_step, body_wrench_step)
from .body_samples import BodySampleOptions, body_samples
from .contact_set import ContactSet
from .kernels import EV_FLOOR, MODES
from .screw_contact_kernels import Surface


class Skin(Params):
    """Body friction factors on the terrain material's μ: along and across the link's skin axis."""

    along: float = Field(1.0, gt=0, description="μ_along / μ (along the link's axis: a snake's belly scales)")
    across: float = Field(1.0, gt=0, description="μ_across / μ (across it)")


class BodyContactParams(Params):
    links: list[str] = Field(default_factory=lambda: ["*"], min_length=1,
                             description="link name patterns (fnmatch) that get samples")
    exclude: list[str] = Field(default_factory=list, description="link name patterns left out")
    exclude_screws: bool = Field(True, description="leave out the design's screw links (screw_sdf_contact's)")
    spacing: float = Field(0.03, gt=0, le=1.0, description="m, largest distance between neighbouring samples")
    min_around: int = Field(8, ge=3, description="least samples around a cylinder")
    friction: Skin = Field(default_factory=Skin, description="skin friction factors of every link")
    link_friction: dict[str, Skin] = Field(default_factory=dict,
                                           description="skin friction by link pattern (first match wins)")
    material: MaterialPatch | None = Field(None, description="overrides the terrain materials' k, c, mu")
    fn_max: float = Field(500.0, gt=0, description="N, top of the normal load per sample (material check)")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible along/across ratio")
    broad_phase: bool = True
    margin: float = Field(0.0, ge=0, description="m added to each piece's bounding sphere")
    max_depth: float | None = Field(0.03, gt=0, description="m; a sample deeper in the terrain stops the run "
                                                            "(a step too large or a material too soft: the "
                                                            "weight sinks a body by F/k, about a millimetre); "
                                                            "None: no watch")

    @model_validator(mode="after")
    def _ratios_above_floor(self):
        for where, skin in [("friction", self.friction), *((f"link_friction['{k}']", v)
                                                          for k, v in self.link_friction.items())]:
            if skin.along / skin.across < self.ev_floor:
                raise ValueError(f"{where}: along / across = {skin.along:g} / {skin.across:g} is below "
                                 f"ev_floor = {self.ev_floor:g}; give along a larger share")
        return self


class BodyContact(Component[BodyContactParams]):
    type_name = "body_contact"
    #: query a plane (Terrain.fast_plane) in numba (tests switch it off to compare with Terrain.query)
    fast_plane = True

    robot = Uses(RobotModel)
    link_poses = Input(shape=lambda c: (c.robot.nl, 7), unit=None)
    link_velocities = Input(shape=lambda c: (c.robot.nl, 6), unit=None)
    terrain = Input(type=Terrain)
    wrenches = Output(shape=lambda c: (c.robot.nl, 6), unit=None, feedthrough=True,
                      names=lambda c: tuple(f"{ln}.{k}" for ln in c.robot.links for k in ("fx", "fy", "fz", "tx", "ty", "tz")))
    normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    contacts = Output(shape=(1,), unit="1", feedthrough=True)
    link_normal_force = Output(shape=lambda c: (c.robot.nl,), unit="N", feedthrough=True,
                               names=lambda c: c.robot.links)
    contact_set = Output(type=ContactSet, feedthrough=True, calc="calc_contact_set")

    # -- set-up ------------------------------------------------------------------------------
    def setup(self):
        p = self.p
        for pat in p.link_friction:
            if not fnmatch.filter(self.robot.links, pat):
                raise ValueError(f"{self.name}: link_friction pattern '{pat}' matches no link of {self.robot.label}; "
                                 f"links: {', '.join(self.robot.links)}")
        opts = BodySampleOptions(spacing=p.spacing, min_around=p.min_around, links=tuple(p.links),
                                 exclude=tuple(p.exclude), exclude_screws=p.exclude_screws, margin=p.margin)
        try:
            self.samples = s = self.robot.derived(body_samples, opts)
        except ValueError as e:
            raise ValueError(f"{self.name}: {e}") from None
        skins = [self._skin(self.robot.links[row]) for row in s.piece_link]
        self.n_samples = s.n
        mu_scale = np.array([k.across for k in skins], dtype=np.float64)
        skin_ratio = np.array([k.along / k.across for k in skins], dtype=np.float64)
        self._table = BodyTable(
            broad_phase=p.broad_phase, piece_link=s.piece_link, centre_B=s.piece_centre, piece_r=s.piece_radius,
            start=s.start, points_B=s.points, axis_B=s.axis, mu_scale=mu_scale, skin_ratio=skin_ratio,
            v_eps=p.v_eps, mode=MODES[p.regularisation], ev_floor=p.ev_floor)
        # port_jacobian's constant arguments (the record's fields are numba-side only)
        self._jac_table = (s.piece_link, s.axis, mu_scale, skin_ratio)

    def stiffness_hint(self, u, readers):
        """Penalty contact on the lightest sampled link, one point at once (:mod:`.stiffness_hint`)."""
        from .stiffness_hint import penalty_modes

        return penalty_modes(self, u, [(int(r), 1) for r in set(self.samples.piece_link.tolist())], "contact point")

    def _skin(self, link: str) -> Skin:
        for pat, skin in self.p.link_friction.items():
            if fnmatch.fnmatch(link, pat):
                return skin
        return self.p.friction

    # -- this run's cache ------------------------------------------------------------------------
    def make_cache(self, x, u, y):
        return _Cache(self, u, y)

    # -- hot path --------------------------------------------------------------------------------
    def output(self, t, x, u, y):
        c = u.cache
        if u.terrain is not c.terrain:
            c.use_terrain(self, u.terrain)
        c.step()
        m = int(c.counts[4])
        if m and self.p.max_depth is not None:
            deepest = -float(c.distance[:m].min())
            if deepest > self.p.max_depth:
                k = int(c.distance[:m].argmin())
                link = self.robot.links[self.samples.piece_link[c.owner[k]]]
                self.stop(f"contact on link '{link}' is {deepest * 1e3:.3g} mm deep at t = {t:.6g} s, beyond "
                          f"max_depth = {self.p.max_depth * 1e3:g} mm: the step is too large for the contact "
                          f"stiffness (see the run's step_check) or the material too soft")

    def port_jacobian(self, port, t, x, u, y):
        """∂wrenches/∂(link twist, displacement): per link 6×6 blocks Σ X_pᵀ (∂F/∂v) X_p and
        Σ X_pᵀ (∂F/∂p) X_p over the last evaluation's samples in contact
        (jacobian_kernels.body_jacobian_blocks), for linearly implicit integrators. Left out, as for the
        screws: the rotation of lever arms, normals and skin axes with the link."""
        from snakesim.components.multibody.linearization import LinkWrenchJacobian
        from .jacobian_kernels import body_jacobian_blocks
        c = u.cache
        if port != "wrenches" or c.terrain is _UNSET:
            return None
        nl, p = self.robot.nl, self.p
        piece_link, axis_B, mu_scale, skin_ratio = self._jac_table
        if c.jac is None:
            c.jac = (np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6)), np.zeros(nl, dtype=np.bool_))
        d_twist, d_pose, on = c.jac
        body_jacobian_blocks(int(c.counts[4]), c.distance, c.normal, c.material, c.sample, c.owner, c.points, c.vel,
                             u.link_poses, piece_link, axis_B, mu_scale, skin_ratio, c.mats,
                             p.v_eps, MODES[p.regularisation], p.ev_floor, d_twist, d_pose, on)
        return LinkWrenchJacobian(rows=np.flatnonzero(on), d_twist=d_twist, d_pose=d_pose,
                                  inputs=("link_poses", "link_velocities"))

    def calc_contact_set(self, t, x, u, y):
        c = u.cache
        if u.terrain is not c.terrain:
            c.use_terrain(self, u.terrain)
            c.step_scratch()
        elif not c.seen():          # the last evaluation was at other inputs
            c.step_scratch()
        m = int(c.counts[4])
        on = np.flatnonzero(c.distance[:m] < 0.0)
        y.contact_set = ContactSet(
            t=float(t), points=c.points[on].copy(), normals=c.normal[on].copy(), forces=c.force[on].copy(),
            normal_force=c.fn[on].copy(), depth=-c.distance[on], slip=c.vel[on].copy(),
            link=self.samples.piece_link[c.owner[on]], material=c.material[on].copy(), link_names=self.robot.links)


_UNSET = object()


class _Cache:
    """One run's body-contact scratch and bound kernels; ``stats`` counts evaluations, pieces and samples."""

    __slots__ = ("comp", "terrain", "step", "step_scratch", "seen", "centres_call", "sample_call", "counts",
                 "active", "centres", "points", "distance", "normal", "material", "sample", "owner", "vel", "force",
                 "fn", "work", "ports", "scratch_ports", "mats", "jac")

    def __init__(self, comp: BodyContact, u, y):
        s, n, nl = comp.samples, comp.n_samples, comp.robot.nl
        self.comp = comp
        self.terrain = _UNSET
        self.step = self.step_scratch = None
        self.mats = self.jac = None
        self.active = np.arange(s.n_pieces, dtype=np.int64)
        self.centres = np.zeros((s.n_pieces, 3))
        self.points, self.vel, self.force, self.normal = (np.zeros((n, 3)) for _ in range(4))
        self.distance, self.fn = np.zeros(n), np.zeros(n)
        self.material, self.sample, self.owner = (np.zeros(n, dtype=np.int64) for _ in range(3))
        self.counts = np.zeros(5, dtype=np.int64)
        self.counts[3] = s.n_pieces
        self.work = BodyWork(active=self.active, centres=self.centres, points=self.points, distance=self.distance,
                             normal=self.normal, material=self.material, sample=self.sample, owner=self.owner,
                             R=np.zeros((3, 3)), vel=self.vel, force=self.force, fn=self.fn, counts=self.counts,
                             track="contact_set" in comp.used_outputs, seen_poses=np.full((nl, 7), np.nan),
                             seen_vels=np.full((nl, 6), np.nan))
        ins = dict(poses=u.link_poses, vels=u.link_velocities)
        self.ports = BodyPorts(wrenches=y.wrenches, link_fn=y.link_normal_force, normal_force=y.normal_force,
                               contacts=y.contacts, **ins)
        self.scratch_ports = BodyPorts(wrenches=np.zeros((nl, 6)), link_fn=np.zeros(nl), normal_force=np.zeros(1),
                                       contacts=np.zeros(1), **ins)
        self.seen = bind(body_seen_step, self.work, self.ports)
        self.centres_call = bind(body_centres_step, comp._table, self.work, self.ports)
        self.sample_call = bind(body_sample_step, comp._table, self.work, self.ports)

    @property
    def stats(self) -> dict:
        return {"evaluations": int(self.counts[0]), "pieces_tested": int(self.counts[1]),
                "samples_queried": int(self.counts[2])}

    def use_terrain(self, comp: BodyContact, terrain) -> None:
        """The terrain-dependent records (material table; a plane's origin and normal), per terrain object."""
        if terrain is None:
            raise ValueError(f"{comp.name}: input 'terrain' carries no Terrain; connect a terrain component's "
                             "'terrain' output to it")
        p = comp.p
        mats = material_table(terrain.materials, p.material, fn_max=p.fn_max, ev_floor=p.ev_floor, owner=comp.name)
        self.mats = mats
        fast = terrain.fast_plane() if comp.fast_plane else None     # the kind says: one plane
        plane = fast is not None
        surface = Surface(origin=np.array(fast[0] if plane else (0.0, 0.0, 0.0), dtype=float),
                          n=np.array(fast[1] if plane else (0.0, 0.0, 1.0), dtype=float),
                          region_material=int(terrain.region_material[0]) if plane else 0, mats=mats)
        t = comp._table
        if plane:
            self.step = bind(body_plane_step, t, self.work, self.ports, surface)
            self.step_scratch = bind(body_plane_step, t, self.work, self.scratch_ports, surface)
        else:
            self.step = functools.partial(self._evaluate, bind(body_wrench_step, t, self.work, self.ports, surface))
            self.step_scratch = functools.partial(self._evaluate, bind(body_wrench_step, t, self.work,
                                                                       self.scratch_ports, surface))
        self.terrain = terrain

    def _evaluate(self, wrench) -> None:
        """Broad phase, sample points, Terrain.query, then the wrenches (bound to outputs or scratch)."""
        terrain, comp = self.terrain, self.comp
        if comp.p.broad_phase:
            self.centres_call()
            active = np.flatnonzero(terrain.distance_lower_bound(self.centres, comp.samples.piece_radius) <= 0.0)
            self.active[:active.size] = active
            self.counts[3] = active.size
        m = self.sample_call()
        if m:
            q = terrain.query(self.points[:m])
            self.distance[:m] = q.distance
            self.normal[:m] = q.normal
            self.material[:m] = q.material
        wrench()
