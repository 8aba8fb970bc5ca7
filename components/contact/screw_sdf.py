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

Contact law inputs and outputs (contact_law.py), per screw: ``screw_mu_scale`` (μ × it),
``screw_ev_scale`` (‖e_v‖ × it), ``screw_sinkage`` (m, the surface lowered under the screw: a groove)
in, ``screw_slip_power`` (W, friction's dissipation) and ``screw_slip_speed`` (m/s, load-weighted) out,
so a thermal or terramechanics model wires to the screws without another back end.

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
     screw_mu_scale[ns]     1, default 1; screw_ev_scale[ns] 1, default 1; screw_sinkage[ns] m, default 0
out  wrenches[nl,6]         N, N·m: to multibody.wrenches ([f, τ] world, about each link origin)
     normal_force[1]        N, Σ F_n over all contacts
     contacts[1]            number of contacts (rings' extremal points and samples)
     screw_normal_force[ns] N, Σ F_n per screw (metadata order)
     screw_slip_power[ns]   W, Σ −F_t·v per screw;  screw_slip_speed[ns] m/s, Σ F_n‖v_t‖ / Σ F_n
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs. The ports, the terrain switching, the contact set and the depth watch
are every back end's (link_contact.py); the run, its records and the law check the sampled back ends'
(sampled_contact.py).

Robot: the multibody's RobotModel, handed over at build time; the screw layout is
derived from it once per robot (robot_screws.py), so link rows and DOF order agree.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Input, Output
from snakesim.components.multibody.robot_ports import joint_names, joint_shape

from ..kernel_args import bind
from .robot_screws import screw_layout
from .sampled_contact import (SampledContact, SampledContactParams, SampledContactRun, SampledKernels, law_ports,
                              query_into)
from .screw_contact_kernels import Samples, SdfPorts, SdfWork
from .plane_kernels import plane_extremal_step, plane_step
from .screw_samples import ScrewContactSamples
from .sdf_kernels import (centres_step, jacobian_step, ring_extremal_step, ring_finish_step, ring_sample_step,
                          sample_step, seen_step, wrench_step)


class ScrewSdfContactParams(SampledContactParams):
    rings: int = Field(3, ge=1, description="rings of samples per screw, spread over its length")
    per_ring: int = Field(8, ge=1, description="samples per ring, evenly around the envelope")
    phase: float = Field(0.0, description="rad, rotates every ring about its axis (φ = 3π/2 is the joint frame's −z)")
    ring_contact: Literal["extremal", "samples"] = Field(
        "extremal", description="'extremal': each ring meets the terrain at its deepest point along the local "
        "normal (exact on curved terrain); 'samples': only where its samples do (sinks up to r(1 − cos(π/per_ring)))")
    lookahead_gap: float = Field(0.01, ge=0, description="m: rings this close to the terrain, not yet touching, "
                                                         "are looked at for the implicit step's look-ahead")
    lookahead_time: float = Field(0.02, ge=0, description="s: a ring whose gap closes within this time at its "
                                                          "approach speed puts its spring-damper in the implicit "
                                                          "step's Jacobian before it touches (0: only contacts)")


def _per_screw(c):
    return (c.screws.ns,)


def _screw_names(c):
    return c.screws.names


class ScrewSdfContact(SampledContact[ScrewSdfContactParams]):
    type_name = "screw_sdf_contact"

    joint_v = Input(shape=joint_shape, unit="rad/s", names=joint_names)
    screw_normal_force = Output(shape=_per_screw, unit="N", feedthrough=True, names=_screw_names)
    screw_mu_scale, screw_ev_scale, screw_sinkage, screw_slip_power, screw_slip_speed = law_ports(_per_screw,
                                                                                                  _screw_names)

    law_ports = ("screw_mu_scale", "screw_ev_scale", "screw_sinkage", "screw_slip_power", "screw_slip_speed")
    depth_what = "screw link"
    jacobian_inputs = ("link_poses", "link_velocities", "joint_v")

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
        self.table = Samples(
            broad_phase=p.broad_phase, sphere_r=self._sphere_r,
            start=start, points_B=points_B,
            mount_p=lay.mount_p, ringc_B=np.ascontiguousarray(np.concatenate([s.points - s.radius * s.radial
                                                                              for s in samples])),
            radial_B=radial_B, axis_B=np.ascontiguousarray(lay.mount_R[:, :, 0]), parent_row=lay.parent_row,
            screw_row=lay.screw_row, radius=lay.radius, lead_angle=lay.lead_angle, hand=lay.hand,
            spin_dof=lay.spin_dof, spin_mult=lay.spin_mult, ring_start=ring_start,
            ring_first=ring_first.astype(np.int64),
            cos_sep=float(np.cos(min(2.0 * np.pi / p.per_ring, 0.5 * np.pi))), near=p.lookahead_gap,
            lookahead_time=p.lookahead_time)
        self.kernels = SampledKernels(plane=plane_extremal_step if self.exact else plane_step, centres=centres_step,
                                      sample=ring_sample_step if self.exact else sample_step, wrench=wrench_step,
                                      seen=seen_step, jacobian=jacobian_step)
        self.owner_link = lay.screw_row
        self.law_row_of_owner = np.arange(lay.ns, dtype=np.int64)
        self.law_row_names = lay.names

    def stiffness_hint(self, u, readers):
        """Penalty contact on the lightest screw, one point per ring at once (:mod:`.stiffness_hint`)."""
        from .stiffness_hint import penalty_modes

        lay = self.screws
        return penalty_modes(self, u, [(int(lay.screw_row[s]), self.samples[s].rings) for s in range(lay.ns)],
                             "ring contact(s)")

    @property
    def run_class(self):
        return ScrewContactRun


class ScrewContactRun(SampledContactRun):
    """One run of the screw contact: the sampled run's rows, plus the contact points p_c and (exact
    rings) the rings' extremal points, queried after the samples (``after_query``)."""

    owners_tested = "screws_tested"

    def __init__(self, comp: ScrewSdfContact, u, y):
        nr = comp.n_rings
        self.point = np.zeros((comp.n_rows, 3))
        self.ext_points, self.ext_normal = np.zeros((nr, 3)), np.zeros((nr, 3))
        self.ext_distance, self.ext_material = np.zeros(nr), np.zeros(nr, dtype=np.int64)
        super().__init__(comp, u, y, comp.n_rows, comp.screws.ns, comp._sphere_r, comp.law_ports)
        self.extremal_call = bind(ring_extremal_step, comp.table, self.work, self.ports)
        self.finish_call = bind(ring_finish_step, comp.table, self.work, self.ports)

    @property
    def force_point(self):
        return self.point

    def work_record(self, comp):
        lay, n, nr = comp.screws, comp.n_rows, comp.n_rings
        return SdfWork(active=self.active, centres=self.centres, points=self.points, distance=self.distance,
                       normal=self.normal, material=self.material, sample=self.sample, owner=self.owner,
                       R=np.zeros((3, 3)), point=self.point, vel=self.vel, force=self.force, fn=self.fn,
                       counts=self.counts, track="contact_set" in comp.used_outputs,
                       seen_poses=np.full((lay.nl, 7), np.nan), seen_vels=np.full((lay.nl, 6), np.nan),
                       seen_joint_v=np.full(lay.nj, np.nan), ring_row=np.zeros(n, dtype=np.int64),
                       ring_dir=np.zeros((n, 3)), ext_points=self.ext_points, ext_row=np.zeros(nr, dtype=np.int64),
                       ext_distance=self.ext_distance, ext_normal=self.ext_normal, ext_material=self.ext_material)

    def ports_record(self, comp, u, y, law):
        return SdfPorts(poses=u.link_poses, vels=u.link_velocities, joint_v=u.joint_v, wrenches=y.wrenches,
                        screw_fn=y.screw_normal_force, normal_force=y.normal_force, contacts=y.contacts, law=law)

    def after_query(self, terrain) -> None:
        """Exact rings: the rings' extremal points, queried in turn, then the rings' rows."""
        if not self.comp.exact:
            return
        ne = self.extremal_call()
        if ne:
            query_into(terrain, self.ext_points[:ne], self.ext_distance, self.ext_normal, self.ext_material)
        self.finish_call()
