"""Screw–terrain contact, SDF back end: rings of samples on each screw against the terrain's SDF.

Model (paper §2.2.2). Each screw's envelope cylinder (radius r, length L from the robot
metadata) carries ``rings`` × ``per_ring`` samples (screw_samples.ScrewContactSamples),
fixed in the screw's PARENT body, so they do not depend on the spin angle. A sample p
with terrain signed distance φ(p) < 0 is a contact of depth d = −φ, outward normal n̂
and the terrain material there. The envelope is a surface of revolution, so the contact
acts where the envelope faces the terrain in the sample's ring (centre c_ring, axis â):
ê_c = unit(−n̂ + (n̂·â)â), p_c = c_ring + r ê_c. There (sdf_kernels.contact_wrenches):

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
     normal_force[1]        N, Σ F_n over all samples
     contacts[1]            number of samples in contact
     screw_normal_force[ns] N, Σ F_n per screw (metadata order)
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs.

Robot: the multibody's RobotModel, handed over at build time; the screw layout is
derived from it once per robot (robot_screws.py), so link rows and DOF order agree.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.materials import MaterialPatch, material_table
from snakesim.components.multibody.robot_model import RobotModel

from ..terrain.analytic import PlaneTerrain
from ..terrain.base import Terrain
from .contact_set import ContactSet
from .kernels import EV_FLOOR, MODES
from .robot_screws import screw_layout
from .screw_samples import ScrewContactSamples
from .sdf_kernels import contact_wrenches, plane_contact_step, sample_points, screw_centres


class ScrewSdfContactParams(Params):
    rings: int = Field(3, ge=1, description="rings of samples per screw, spread over its length")
    per_ring: int = Field(8, ge=1, description="samples per ring, evenly around the envelope")
    phase: float = Field(0.0, description="rad, rotates every ring about its axis (φ = 3π/2 is the joint frame's −z)")
    material: MaterialPatch | None = Field(None, description="overrides the terrain materials' k, c, mu, ev_a, ev_b")
    fn_max: float = Field(500.0, gt=0, description="N, top of the normal load per sample: ‖e_v‖ ≥ ev_floor up to it")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible ‖e_v‖")
    broad_phase: bool = True
    margin: float = Field(0.0, ge=0, description="m added to each screw's bounding sphere")


class ScrewSdfContact(Component[ScrewSdfContactParams]):
    type_name = "screw_sdf_contact"
    Params = ScrewSdfContactParams
    #: query PlaneTerrain in numba (tests and the bench switch it off to compare)
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
        self._points_B = np.ascontiguousarray(np.concatenate([s.points for s in samples]))
        self._radial_B = np.ascontiguousarray(np.concatenate([s.radial for s in samples]))
        self._ringc_B = np.ascontiguousarray(np.concatenate([s.points - s.radius * s.radial for s in samples]))
        self._axis_B = np.ascontiguousarray(lay.mount_R[:, :, 0])
        counts = np.array([len(s) for s in samples], dtype=np.int64)
        self._start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._sphere_r = np.sqrt(lay.radius ** 2 + (0.5 * lay.length) ** 2) + p.margin
        n = self.n_samples = int(self._start[-1])
        self._all = np.arange(lay.ns, dtype=np.int64)
        self._active = np.zeros(lay.ns, dtype=np.int64)
        self._plane = None
        self._R = np.zeros((3, 3))
        self._centres = np.zeros((lay.ns, 3))
        self._pts, self._cpt, self._vel = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        self._owner, self._sample = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        self._force, self._fn = np.zeros((n, 3)), np.zeros(n)
        self._dist, self._normal = np.zeros(n), np.zeros((n, 3))
        self._mat = np.zeros(n, dtype=np.int64)
        self._m = 0
        self._mode = MODES[p.regularisation]
        self._terrain, self._mats = None, None
        self._plane_call = None
        self._seen_poses, self._seen_vel = np.full((lay.nl, 7), np.nan), np.full((lay.nl, 6), np.nan)
        self._seen_jv, self._seen_terrain = np.full(lay.nj, np.nan), None
        # counters (tests and benches read them): evaluations, screws and samples sent to the narrow phase
        self.stats = {"evaluations": 0, "screws_tested": 0, "samples_queried": 0}
        self.bind_outputs(self.used_outputs)

    def _material_table(self, terrain: Terrain) -> np.ndarray:
        if terrain is not self._terrain:
            p = self.p
            self._terrain, self._mats = terrain, material_table(terrain.materials, p.material, fn_max=p.fn_max,
                                                                ev_floor=p.ev_floor, owner=self.name)
            self._plane_call = None
            # planes are queried in numba (no allocation); every other kind through Terrain.query
            self._plane = None
            if type(terrain) is PlaneTerrain and self.fast_plane:
                self._plane = (np.array(terrain.origin, dtype=float), np.array(terrain.n, dtype=float),
                               int(terrain.region_material[0]))
        return self._mats

    # -- hot path --------------------------------------------------------------------------------
    def output(self, t, x, u, y):
        terrain = u.terrain
        if terrain is None:
            raise ValueError(f"{self.name}: input 'terrain' carries no Terrain; connect a terrain component's "
                             "'terrain' output to it")
        mats = self._material_table(terrain)
        lay = self.screws
        poses = u.link_poses
        plane = self._plane
        p = self.p
        st = self.stats
        if plane is not None:
            # the whole evaluation in one numba call (the same kernels as below, without the dispatches)
            n_active, m, n_contact = plane_contact_step(*self._plane_args(u, y))
            st["evaluations"] += 1
            st["screws_tested"] += n_active
            st["samples_queried"] += m
            self._finish(m, n_contact, terrain, u, y)
            return
        if p.broad_phase:
            screw_centres(poses, lay.parent_row, lay.mount_p, self._R, self._centres)
            active = np.flatnonzero(terrain.distance_lower_bound(self._centres, self._sphere_r) <= 0.0)
        else:
            active = self._all
        m = 0
        if active.size:
            m = sample_points(poses, active, active.size, self._start, self._points_B, lay.parent_row, self._R,
                              self._pts, self._sample, self._owner)
        st["evaluations"] += 1
        st["screws_tested"] += int(active.size)
        st["samples_queried"] += m
        if m:
            q = terrain.query(self._pts[:m])
            self._dist[:m] = q.distance
            self._normal[:m] = q.normal
            self._mat[:m] = q.material
        n_contact = contact_wrenches(m, self._dist, self._normal, self._mat, self._sample, self._owner, poses,
                                     u.link_velocities, u.joint_v, self._ringc_B, self._radial_B, self._axis_B,
                                     lay.parent_row, lay.screw_row, lay.radius, lay.lead_angle, lay.hand, lay.spin_dof,
                                     lay.spin_mult, mats, p.v_eps, self._mode, p.ev_floor, self._R,
                                     self._cpt, self._vel, self._force, self._fn, y.wrenches, y.screw_normal_force)
        self._finish(m, n_contact, terrain, u, y)

    def _plane_args(self, u, y):
        """plane_contact_step's arguments, built once per (inputs, outputs) pair and terrain: the plan
        hands the same namespaces every call and their arrays cannot be rebound (held, so ids stay unique)."""
        c = self._plane_call
        if c is None or c[0] is not u or c[1] is not y:
            p, lay, plane = self.p, self.screws, self._plane
            args = (p.broad_phase, plane[0], plane[1], plane[2], self._sphere_r, self._start, self._points_B,
                    lay.mount_p, self._active, self._centres, self._pts, self._dist, self._normal, self._mat,
                    self._sample, self._owner, u.link_poses, u.link_velocities, u.joint_v, self._ringc_B,
                    self._radial_B, self._axis_B, lay.parent_row, lay.screw_row, lay.radius, lay.lead_angle, lay.hand,
                    lay.spin_dof, lay.spin_mult, self._mats, p.v_eps, self._mode, p.ev_floor, self._R, self._cpt,
                    self._vel, self._force, self._fn, y.wrenches, y.screw_normal_force)
            c = self._plane_call = (u, y, args)
        return c[2]

    def _finish(self, m, n_contact, terrain, u, y):
        self._m = m
        y.contacts[0] = n_contact
        y.normal_force[0] = y.screw_normal_force.sum()
        if self._track_inputs:
            # what this evaluation saw, so contact_set can tell whether it describes its inputs
            np.copyto(self._seen_poses, u.link_poses)
            np.copyto(self._seen_vel, u.link_velocities)
            np.copyto(self._seen_jv, u.joint_v)
            self._seen_terrain = terrain

    def bind_outputs(self, used):
        super().bind_outputs(used)
        self._track_inputs = "contact_set" in used

    def calc_contact_set(self, t, x, u, y):
        if not (u.terrain is self._seen_terrain and np.array_equal(u.link_poses, self._seen_poses)
                and np.array_equal(u.link_velocities, self._seen_vel) and np.array_equal(u.joint_v, self._seen_jv)):
            self.output(t, x, u, _Scratch(self.screws))     # the last evaluation was at other inputs
        m = self._m
        on = np.flatnonzero(self._dist[:m] < 0.0)
        y.contact_set = ContactSet(
            t=float(t), points=self._cpt[on].copy(), normals=self._normal[on].copy(), forces=self._force[on].copy(),
            normal_force=self._fn[on].copy(), depth=-self._dist[on], slip=self._vel[on].copy(),
            link=self.screws.screw_row[self._owner[on]], material=self._mat[on].copy(),
            link_names=self.robot.links)


class _Scratch:
    """Output buffers for an evaluation whose numeric results nobody reads."""

    def __init__(self, lay):
        self.wrenches = np.zeros((lay.nl, 6))
        self.normal_force, self.contacts = np.zeros(1), np.zeros(1)
        self.screw_normal_force = np.zeros(lay.ns)
