"""Screw–terrain contact, SDF back end: rings of samples on each screw against the terrain's SDF.

Model (paper §2.2.2). Each screw's envelope cylinder (radius r, length L from the robot
metadata) carries ``rings`` × ``per_ring`` samples (screw_samples.ScrewContactSamples),
fixed in the screw's PARENT body, so they do not depend on the spin angle. A sample p
with terrain signed distance φ(p) < 0 is a contact of depth d = −φ, outward normal n̂
and the terrain material there. The envelope is a surface of revolution, so the contact
acts where the envelope faces the terrain in the sample's ring (centre c_ring, axis â):
ê_c = unit(−n̂ + (n̂·â)â), p_c = c_ring + r ê_c. There (screw_contact_kernels.contact_wrenches):

    slip       v = v_B + ω_B × (p_c − o_B) + ω_s r â × ê_c      (world; ω_s the screw spin:
               the screw DOF's rate, −rate for the mimic rear screw of a pair)
    normal     F_n = max(0, k d − c v·n̂)                          (eq. 2, never pulls)
    friction   F_t = −F_n μ (s + (‖e_v‖ − 1)(s·ê_v) ê_v)           (eq. 6)
               s = v_t / sqrt(‖v_t‖² + v_ε²) (or linear, kernels.py), ‖e_v‖ = a + b F_n
               clamped at ev_floor, ê_v = cos λ â − h sin λ (â × ê_c) normal to the thread

and the force acts at p_c on the screw link: wrench [f, (p_c − o_S) × f] about the screw
link's origin o_S (on the spin axis), so friction's axial torque loads the screw DOF and
the normal force passes through the axis. Why p_c and not p: a robot on a plane rests
on a face of each ring's polygon, between two samples; at the samples themselves the
spin velocity ω_s â × (p − c) has a normal component ±ω_s r sin(π/per_ring) that the
eq. 2 damper turns into a pumping normal force (tens of N at 2 rad/s), and the normal
force would exert a spurious spin torque. The samples decide where and how deep the
contact is; the slip, ê_v and lever arm are the envelope's. Body-to-body contact and
contact on non-screw links are ignored (as in the paper).

Exact rings (``ring_contact="extremal"``, the default; issue 14). Samples alone let a ring sink up to
r(1 − cos(π/per_ring)) into curved terrain (6.9 mm at r = 9 cm, 8 per ring) before any force acts. So each
ring also queries the terrain at its centre c for the local normal n̂_c and meets it at its point
extremal along −n̂_c, p* = c + r ê_c (ê_c = unit(−n̂_c + (n̂_c·â)â)): one contact of depth −φ(p*) with
p*'s normal and material; a sphere's or a cylinder's exact SDF gives the ring's true deepest point, a
first-order SDF (DEM) nearly. A sample still acts where it meets another surface than its ring's
(its own ê_i more than min(2π/per_ring, π/2) from ê_c, or n̂_i ∥ â: a screw end), so a ring wedged
between two walls keeps both; where n̂_c ∥ â the ring has no extremal point and its samples act as
before. c and p* are fixed in the parent body for a given n̂_c, so the contact is still independent of
the spin angle, and the depth's gradient is n̂ at p* (φ is stationary around the ring there): the
Jacobians (jacobian_kernels.py) are unchanged. On a plane (numba) the samples are not even queried.
Cost: one more Terrain.query call (the extremal points) for terrains other than a plane.
``ring_contact="samples"`` is the former model, bit for bit.

Look-ahead (``lookahead_gap``, ``lookahead_time``): a ring within lookahead_gap of the terrain whose gap
closes within lookahead_time at its approach speed declares its normal spring-damper's slopes in the
implicit step's Jacobian before it touches (jacobian_kernels.contact_jacobian_blocks). A step that starts
with a contact open and meets it then takes k and c implicitly instead of throwing the robot (the same
remedy as a joint stop's look-ahead; MuJoCo's contact ``margin``). Forces are unchanged.

Watch (``max_depth``): a contact deeper than max_depth ends the run naming the screw link
and the depth (a bounce from a step too large for k, or a material too soft), never
believable garbage.

Broad phase (``broad_phase``): one bounding sphere per screw (centre c, radius
sqrt(r² + (L/2)²) + margin) against ``terrain.distance_lower_bound``; only screws whose
bound is ≤ 0 are sampled and queried, so a robot far from every surface costs one
sphere query per screw.

Material: the terrain's per-sample material (snakesim.components.materials.Material: k, c,
μ, ev_a, ev_b); any field of ``material`` (a MaterialPatch) overrides it for every terrain
material. The table the kernels read is packed once per terrain object (material_table),
which checks ‖e_v‖ ≥ ev_floor over [0, fn_max]. v_ε, the regularisation mode, ev_floor
and fn_max are this component's.

uses robot: RobotModel      (the multibody's; its screws: robot_screws.py)
in   link_poses[nl,7]       multibody link_poses (xyz + quaternion xyzw, world)
     link_velocities[nl,6]  multibody link_velocities ([v origin, ω], world)
     joint_v[nj]            rad/s, multibody joint_v (screw spin rates)
     terrain                structured Terrain (terrain component)
out  wrenches[nl,6]         N, N·m: to multibody.wrenches ([f, τ] world, about each link origin)
     normal_force[1]        N, Σ F_n over all contacts
     contacts[1]            number of contacts (rings' extremal points and samples)
     screw_normal_force[ns] N, Σ F_n per screw (metadata order)
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs.

Robot: the multibody's RobotModel, handed over at build time; the screw layout is
derived from it once per robot (robot_screws.py), so link rows and DOF order agree.
"""

from __future__ import annotations

import functools
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.materials import MaterialPatch, material_table
from snakesim.components.multibody.linearization import LinkWrenchJacobian
from snakesim.components.multibody.robot_model import RobotModel

from ..kernel_args import bind
from ..kernel_reductions import least_distance
from ..terrain.base import Terrain
from .contact_set import ContactSet
from .kernels import EV_FLOOR, MODES
from .robot_screws import screw_layout
from .screw_samples import ScrewContactSamples
from .plane_kernels import plane_extremal_step, plane_step
from .screw_contact_kernels import Samples, SdfPorts, SdfWork, Surface
from .sdf_kernels import (centres_step, jacobian_step, ring_extremal_step, ring_finish_step, ring_sample_step,
                          sample_step, seen_step, wrench_step)


class ScrewSdfContactParams(Params):
    max_depth: float | None = Field(0.03, gt=0, description="m; a contact deeper in the terrain stops the run (a "
                                                            "step too large for k, or a material too soft: the "
                                                            "weight sinks a screw by F/k, about a millimetre); "
                                                            "None: no watch")
    rings: int = Field(3, ge=1, description="rings of samples per screw, spread over its length")
    per_ring: int = Field(8, ge=1, description="samples per ring, evenly around the envelope")
    phase: float = Field(0.0, description="rad, rotates every ring about its axis (φ = 3π/2 is the joint frame's −z)")
    material: MaterialPatch | None = Field(None, description="overrides the terrain materials' k, c, mu, ev_a, ev_b")
    fn_max: float = Field(500.0, gt=0, description="N, top of the normal load per sample: ‖e_v‖ ≥ ev_floor up to it")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible ‖e_v‖")
    ring_contact: Literal["extremal", "samples"] = Field(
        "extremal", description="'extremal': each ring meets the terrain at its deepest point along the local "
        "normal (exact on curved terrain); 'samples': only where its samples do (sinks up to r(1 − cos(π/per_ring)))")
    broad_phase: bool = True
    margin: float = Field(0.0, ge=0, description="m added to each screw's bounding sphere")
    lookahead_gap: float = Field(0.01, ge=0, description="m: rings this close to the terrain, not yet touching, "
                                                         "are looked at for the implicit step's look-ahead")
    lookahead_time: float = Field(0.02, ge=0, description="s: a ring whose gap closes within this time at its "
                                                          "approach speed puts its spring-damper in the implicit "
                                                          "step's Jacobian before it touches (0: only contacts)")


class ScrewSdfContact(Component[ScrewSdfContactParams]):
    type_name = "screw_sdf_contact"
    #: query a plane (Terrain.fast_plane) in numba (tests and the bench switch it off to compare)
    fast_plane = True

    robot = Uses(RobotModel)
    link_poses = Input(shape=lambda c: (c.robot.nl, 7), unit=None)
    link_velocities = Input(shape=lambda c: (c.robot.nl, 6), unit=None)
    joint_v = Input(shape=lambda c: (c.robot.nj,), unit="rad/s", names=lambda c: c.robot.joints)
    terrain = Input(type=Terrain)
    wrenches = Output(shape=lambda c: (c.robot.nl, 6), unit=None, feedthrough=True,
                      names=lambda c: tuple(f"{ln}.{k}" for ln in c.robot.links for k in ("fx", "fy", "fz", "tx", "ty", "tz")))
    normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    contacts = Output(shape=(1,), unit="1", feedthrough=True)
    screw_normal_force = Output(shape=lambda c: (c.screws.ns,), unit="N", feedthrough=True,
                                names=lambda c: c.screws.names)
    contact_set = Output(type=ContactSet, feedthrough=True, calc="calc_contact_set")

    @property
    def layout(self):
        """The screw layout (``self.screws``); kept for readers outside contact/."""
        return self.screws

    # -- set-up ------------------------------------------------------------------------------
    def setup(self):
        p = self.p
        lay = self.screws = self.robot.derived(screw_layout)
        samples = [ScrewContactSamples(lay.radius[s], lay.length[s], p.rings, p.per_ring, lay.lead_angle[s],
                                       int(lay.hand[s]), lay.mount_R[s], lay.mount_p[s], p.phase)
                   for s in range(lay.ns)]
        self.samples = samples
        points_B = np.ascontiguousarray(np.concatenate([s.points for s in samples]))
        radial_B = np.ascontiguousarray(np.concatenate([s.radial for s in samples]))
        counts = np.array([len(s) for s in samples], dtype=np.int64)
        self.n_samples = int(counts.sum())
        self.exact = p.ring_contact == "extremal"
        start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        n_rings = np.array([s.rings for s in samples], dtype=np.int64)
        ring_start = np.concatenate([[0], np.cumsum(n_rings)]).astype(np.int64)
        ring_first = np.concatenate([start[k] + s.per_ring * np.arange(s.rings) for k, s in enumerate(samples)])
        self.n_rings = int(n_rings.sum())
        #: rows of the per-contact arrays: the samples, then (exact rings) one per ring
        self.n_rows = self.n_samples + (self.n_rings if self.exact else 0)
        self._sphere_r = np.sqrt(lay.radius ** 2 + (0.5 * lay.length) ** 2) + p.margin + p.lookahead_gap
        self._samples = Samples(
            broad_phase=p.broad_phase, sphere_r=self._sphere_r,
            start=start, points_B=points_B,
            mount_p=lay.mount_p, ringc_B=np.ascontiguousarray(np.concatenate([s.points - s.radius * s.radial
                                                                              for s in samples])),
            radial_B=radial_B, axis_B=np.ascontiguousarray(lay.mount_R[:, :, 0]), parent_row=lay.parent_row,
            screw_row=lay.screw_row, radius=lay.radius, lead_angle=lay.lead_angle, hand=lay.hand,
            spin_dof=lay.spin_dof, spin_mult=lay.spin_mult, v_eps=p.v_eps, mode=MODES[p.regularisation],
            ev_floor=p.ev_floor, ring_start=ring_start, ring_first=ring_first.astype(np.int64),
            cos_sep=float(np.cos(min(2.0 * np.pi / p.per_ring, 0.5 * np.pi))), near=p.lookahead_gap,
            lookahead_time=p.lookahead_time)

    def stiffness_hint(self, u, readers):
        """Penalty contact on the lightest screw, one point per ring at once (:mod:`.stiffness_hint`)."""
        from .stiffness_hint import penalty_modes

        lay = self.screws
        return penalty_modes(self, u, [(int(lay.screw_row[s]), self.samples[s].rings) for s in range(lay.ns)],
                             "ring contact(s)")

    def _material_table(self, terrain: Terrain) -> np.ndarray:
        """The kernels' material table ([K, C, MU, EV_A, EV_B] per terrain material, ``material`` applied;
        checked: ‖e_v‖ ≥ ev_floor up to fn_max), packed once per terrain object (the cache keeps it)."""
        p = self.p
        return material_table(terrain.materials, p.material, fn_max=p.fn_max, ev_floor=p.ev_floor, owner=self.name)

    # -- this run's cache ------------------------------------------------------------------------
    def make_cache(self, x, u, y):
        """Per-sample scratch, the counters, and the kernels bound to this plan's port buffers (and, for
        the contact set when the last evaluation saw other inputs, to scratch outputs)."""
        return _Cache(self, u, y)

    # -- hot path --------------------------------------------------------------------------------
    def output(self, t, x, u, y):
        c = u.cache
        if u.terrain is not c.terrain:
            c.use_terrain(self, u.terrain)
        c.step()
        if self.p.max_depth is not None and -c.deepest() > self.p.max_depth:
            k = int(c.distance[:int(c.counts[4])].argmin())
            link = self.robot.links[self.screws.screw_row[c.owner[k]]]
            self.stop(f"contact on screw link '{link}' is {-c.distance[k] * 1e3:.3g} mm deep at t = {t:.6g} s, "
                      f"beyond max_depth = {self.p.max_depth * 1e3:g} mm: the step is too large for the contact "
                      f"stiffness (see the run's step_check) or the material too soft")

    def port_jacobian(self, port, t, x, u, y):
        """∂wrenches/∂(screw link twist, displacement): per screw link 6×6 blocks from the last
        evaluation's contacts (jacobian_kernels.py), for linearly implicit integrators."""
        c = u.cache
        if port != "wrenches" or c.terrain is _UNSET:
            return None
        if c.jac is None:           # per terrain (use_terrain resets it): the blocks and the bound kernel
            c.jac = _jacobian_call(self, c)
        d_twist, d_pose, on, call = c.jac
        call()
        return LinkWrenchJacobian(rows=np.flatnonzero(on), d_twist=d_twist, d_pose=d_pose, inputs=_JAC_INPUTS)

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
            t=float(t), points=c.point[on].copy(), normals=c.normal[on].copy(), forces=c.force[on].copy(),
            normal_force=c.fn[on].copy(), depth=-c.distance[on], slip=c.vel[on].copy(),
            link=self.screws.screw_row[c.owner[on]], material=c.material[on].copy(),
            link_names=self.robot.links)


_UNSET = object()
_JAC_INPUTS = ("link_poses", "link_velocities", "joint_v")


def _jacobian_call(comp: ScrewSdfContact, c) -> tuple:
    """(d_twist, d_pose, on_link, call): the per-link blocks (zeroed) and sdf_kernels.jacobian_step bound to
    them, the sample tables, this run's work and ports and the terrain's surface record."""
    nl = comp.screws.nl
    d_twist, d_pose, on = np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6)), np.zeros(nl, dtype=np.bool_)
    return d_twist, d_pose, on, bind(jacobian_step, comp._samples, c.work, c.ports, c.surface, d_twist, d_pose, on)


class _Cache:
    """One run's contact scratch and bound kernels (see ScrewSdfContact.make_cache).

    ``terrain`` and ``mats``: the terrain object in use and its material table; ``stats``: evaluations,
    and screws and samples sent to the narrow phase (tests and benches)."""

    __slots__ = ("comp", "terrain", "mats", "surface", "step", "step_scratch", "work", "ports", "scratch_ports", "seen",
                 "centres_call", "sample_call", "extremal_call", "finish_call", "ext_points", "ext_distance",
                 "ext_normal", "ext_material", "counts", "active", "centres", "points", "distance", "normal",
                 "material", "sample", "owner", "point", "vel", "force", "fn", "jac", "deepest")

    def __init__(self, comp: ScrewSdfContact, u, y):
        lay, n, nr = comp.screws, comp.n_rows, comp.n_rings
        self.comp = comp
        self.jac = None                                            # port_jacobian's blocks, made on first use
        self.terrain = _UNSET                                      # not even None: output() checks it first
        self.mats = self.surface = self.step = self.step_scratch = None
        self.active = np.arange(lay.ns, dtype=np.int64)           # every screw, unless the broad phase says
        self.centres = np.zeros((lay.ns, 3))
        self.points, self.point, self.vel, self.force = (np.zeros((n, 3)) for _ in range(4))
        self.distance, self.normal, self.fn = np.zeros(n), np.zeros((n, 3)), np.zeros(n)
        self.material, self.sample, self.owner = (np.zeros(n, dtype=np.int64) for _ in range(3))
        self.counts = np.zeros(7, dtype=np.int64)      # [5] sample rows m (ring rows follow), [6] extremal points
        self.ext_points, self.ext_normal = np.zeros((nr, 3)), np.zeros((nr, 3))
        self.ext_distance, self.ext_material = np.zeros(nr), np.zeros(nr, dtype=np.int64)
        self.counts[3] = lay.ns
        self.work = SdfWork(active=self.active, centres=self.centres, points=self.points, distance=self.distance,
                            normal=self.normal, material=self.material, sample=self.sample, owner=self.owner,
                            R=np.zeros((3, 3)), point=self.point, vel=self.vel, force=self.force, fn=self.fn,
                            counts=self.counts, track="contact_set" in comp.used_outputs,
                            seen_poses=np.full((lay.nl, 7), np.nan), seen_vels=np.full((lay.nl, 6), np.nan),
                            seen_joint_v=np.full(lay.nj, np.nan), ring_row=np.zeros(n, dtype=np.int64),
                            ring_dir=np.zeros((n, 3)), ext_points=self.ext_points, ext_row=np.zeros(nr, dtype=np.int64),
                            ext_distance=self.ext_distance, ext_normal=self.ext_normal, ext_material=self.ext_material)
        ins = dict(poses=u.link_poses, vels=u.link_velocities, joint_v=u.joint_v)
        self.ports = SdfPorts(wrenches=y.wrenches, screw_fn=y.screw_normal_force, normal_force=y.normal_force,
                              contacts=y.contacts, **ins)
        self.scratch_ports = SdfPorts(wrenches=np.zeros((lay.nl, 6)), screw_fn=np.zeros(lay.ns),
                                      normal_force=np.zeros(1), contacts=np.zeros(1), **ins)
        self.seen = bind(seen_step, self.work, self.ports)
        self.deepest = bind(least_distance, self.distance, self.counts)
        self.centres_call = bind(centres_step, comp._samples, self.work, self.ports)
        self.sample_call = bind(ring_sample_step if comp.exact else sample_step, comp._samples, self.work, self.ports)
        self.extremal_call = bind(ring_extremal_step, comp._samples, self.work, self.ports)
        self.finish_call = bind(ring_finish_step, comp._samples, self.work, self.ports)

    @property
    def stats(self) -> dict:
        return {"evaluations": int(self.counts[0]), "screws_tested": int(self.counts[1]),
                "samples_queried": int(self.counts[2])}

    def use_terrain(self, comp: ScrewSdfContact, terrain) -> None:
        """The terrain-dependent records (material table; a plane's origin and normal, queried in numba;
        every other kind through Terrain.query), for each new terrain object."""
        if terrain is None:
            raise ValueError(f"{comp.name}: input 'terrain' carries no Terrain; connect a terrain component's "
                             "'terrain' output to it")
        self.jac = None                                            # its Jacobian call binds the new surface
        self.mats = mats = comp._material_table(terrain)
        fast = terrain.fast_plane() if comp.fast_plane else None     # the kind says: one plane
        plane = fast is not None
        self.surface = Surface(origin=np.array(fast[0] if plane else (0.0, 0.0, 0.0), dtype=float),
                               n=np.array(fast[1] if plane else (0.0, 0.0, 1.0), dtype=float),
                               region_material=int(terrain.region_material[0]) if plane else 0, mats=mats)
        s = comp._samples
        if plane:       # the whole evaluation in one numba call
            kernel = plane_extremal_step if comp.exact else plane_step
            self.step = bind(kernel, s, self.work, self.ports, self.surface)
            self.step_scratch = bind(kernel, s, self.work, self.scratch_ports, self.surface)
        else:
            self.step = functools.partial(self._evaluate, bind(wrench_step, s, self.work, self.ports, self.surface))
            self.step_scratch = functools.partial(self._evaluate, bind(wrench_step, s, self.work, self.scratch_ports,
                                                                       self.surface))
        self.terrain = terrain

    def _evaluate(self, wrench) -> None:
        """One evaluation on a terrain other than a plane: the broad phase, the samples' points,
        Terrain.query, then the wrenches (``wrench``, bound to the outputs or to scratch)."""
        terrain, comp = self.terrain, self.comp
        if comp.p.broad_phase:
            self.centres_call()
            active = np.flatnonzero(terrain.distance_lower_bound(self.centres, comp._sphere_r) <= 0.0)
            self.active[:active.size] = active
            self.counts[3] = active.size
        m = self.sample_call()
        if m:
            q = terrain.query(self.points[:m])
            self.distance[:m] = q.distance
            self.normal[:m] = q.normal
            self.material[:m] = q.material
            if comp.exact:          # the rings' extremal points, queried in turn
                ne = self.extremal_call()
                if ne:
                    q = terrain.query(self.ext_points[:ne])
                    self.ext_distance[:ne] = q.distance
                    self.ext_normal[:ne] = q.normal
                    self.ext_material[:ne] = q.material
                self.finish_call()
        wrench()
