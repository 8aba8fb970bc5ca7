"""Settling a placed robot into the terrain (paper 2.2.6, step 2), then holding it with gravity on.

Phase SETTLING (0, gravity off). Each screw's contact samples (the rings the SDF
contact back end uses, fixed in the screw's parent body) are queried against the
terrain; the NEAREST sample of each screw (signed distance φ_s, outward normal
n̂_s) is pulled towards the surface by a spring, and every link with mass gets a
mass-proportional drag so the motion dies out::

    f_s = −k_attract · max(φ_s, 0) · n̂_s                at the sample p_s, on the parent body
    f_l = −ζ m_l v_l,   τ_l = −ζ m_l r_g² ω_l           at each link origin (drag)

Only the nearest sample is pulled: inside a tube the far side of a ring is far
from the wall too, and pulling it would pull towards the opposite wall. The
joints are free (the set-points follow the measured angles, so the PID adds
only its damping and the shape conforms to the terrain); screws are held at
zero speed.

Settled: every screw (a fraction ``min_contact_fraction`` of them) within
``contact_band`` of the surface (φ_s ≤ band; penetration counts as contact)
and every link origin slower than ``max_speed``, continuously for
``quiet_time``. Then a pre-load is latched as feed-forward torque (virtual
work: the joint torques that would press each screw's nearest point into the
terrain with ``preload`` newtons, â_k the world axis of joint k at its child
origin o_k)::

    τ_k = Σ_{s beyond joint k} â_k · ((p_s − o_k) × (−preload · n̂_s))

(p_s: the envelope point facing the terrain in the nearest sample's ring, where
the SDF contact applies its force)

where the per-screw forces are first made self-equilibrated (Σ F_s n̂_s = 0,
Σ F_s p_s × n̂_s = 0, the least-squares nearest to ``preload`` with F_s ≥ 0):
otherwise the joint reactions would spin the free-floating robot (the tail link
has no contact). These squeeze the robot between opposite surfaces and are
what presses the screws on the terrain once the springs are gone.

Phase LOADING (1, ``load_time`` s, gravity still off): the springs and drag are
released, the joints stay free and the pre-load torques act alone, so the robot
conforms under the squeeze until every screw carries its share (a screw that
latched a fraction of a mm off the wall is pushed onto it; with the joints held
instead, the other screws' friction would pin the shape and that screw would
stay unloaded). Phase HOLDING (2): the set-points are latched at the loaded
angles, the pre-load stays as feed-forward and gravity is switched on: the
contact forces are then the pre-load's, and the position gains only resist the
change gravity brings. ``load_time`` = 0 latches the settled angles and switches
gravity on at once (fine on a floor; between walls the screws touch with ~0 N at
the latch and the robot drops ~2 cm before the pre-load builds).

Partial braces (``screws``, default every screw): only the listed screws are pulled, counted
for ``min_contact_fraction`` and pre-loaded (the others get F = 0 in the self-equilibrated
solve and no spring). E.g. EELS 1.5 between 0.35 m walls braces on screws 0, 2, 3 only: no
4-screw C keeps its bodies out of the walls (assemblies/placement-walls-body.yaml).

Not settled by ``time_limit``: the run stops with the worst screw distance and
the fastest link.

Hand-over ("the autonomy system then takes over"): the optional ``drive`` input is
added to the set-points from ``drive_delay`` s after gravity came on, e.g. a
screw_schedule's set-points: rad/s on screws held by speed (``screw_hold: speed``,
velocity-mode PID), rad on position-mode joints (offsets from the latched shape).
Before that (and unconnected: 0) it is ignored, so locomotion starts from the
settled, held state whenever the latch happens.

Viewing (paper fig. 9, the yellow arrows): ``attraction`` is the set of springs
acting now, one per pulled screw (φ_s > 0, settling only): the nearest sample p_s
and f_s, world frame; empty once latched. Computed only when something reads it.

Discrete state at ``rate`` (give rate = 1/dt: the drag is a damper and must
not be held over several steps): [phase (:class:`SettlePhase` as a float: 0 SETTLING, 1 LOADING,
2 HOLDING), settle_time, quiet_since, latched set-points (nj), latched pre-load torques (nj)]
(times −1 until set). Outputs are computed at each tick from the state and the inputs.

uses robot: RobotModel (the multibody's): link and joint order, masses, joint axes; the screws
     (radius, length, lead angle, mounts) through ``robot.derived(screw_layout)``, as the contact uses
in   link_poses[nl, 7], link_velocities[nl, 6], joint_q[nj]    multibody outputs
     terrain                                                   structured Terrain
     drive[nj]          set-point offsets once holding (optional, default 0): rad/s screws, rad others
out  wrenches[nl, 6]    N, N·m attraction + drag, world axes about link origins (to wrench_sum)
     gravity[1]         0 settling and loading, ``gravity_scale`` holding (multibody gravity input, "scale")
     setpoint[nj]       rad (bend/twist, position mode), rad/s (screws: 0) for joint_pid
     tau_ff[nj]         N·m pre-load torques (0 settling) for joint_pid.tau_ff
     phase[1]           SettlePhase: 0 SETTLING, 1 LOADING, 2 HOLDING
     settle_time[1]     s, time of the latch (NaN before)
     hold_time[1]       s, time gravity came on (NaN before)
     gap[ns]            m, each screw's nearest signed distance to the terrain (nearest sample, or its ring's extremal point)
     max_speed[1]       m/s, fastest link origin
     attraction         AttractionSet: points (n, 3) m, forces (n, 3) N, world; the springs now (n = 0 latched)
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params, Uses

from ..contact.robot_screws import screw_layout
from ..contact.screw_samples import ScrewContactSamples
from ..multibody.robot_model import RobotModel
from ..terrain.base import Terrain
from ..terrain.derived import TerrainDerived


#: relative lever arm below which a wall-force moment direction is not imposed on the pre-load (see
#: Settle._preload_torques)
WEAK_ARM = 0.02


class SettlePhase(IntEnum):
    """The settle component's phase: state element 0 (as a float) and its ``phase`` output."""

    SETTLING = 0       # gravity off, attraction springs and drag, joints free
    LOADING = 1        # gravity off, springs released, pre-load torques with free joints
    HOLDING = 2        # gravity on, set-points latched, pre-load as feed-forward


@dataclass(frozen=True)
class AttractionSet:
    """The attraction springs acting now: spring s pulls the world point ``points[s]`` (m) with
    ``forces[s]`` (N, world axes), f = −k_attract φ n̂. Only screws with φ > 0 are listed; none once latched."""

    points: np.ndarray
    forces: np.ndarray

    def __len__(self) -> int:
        return int(self.points.shape[0])

    @classmethod
    def empty(cls) -> "AttractionSet":
        return cls(np.zeros((0, 3)), np.zeros((0, 3)))


class SettleParams(Params):
    k_attract: float = Field(2000.0, gt=0, description="N/m, attraction spring per screw")
    drag: float = Field(8.0, ge=0, description="1/s, ζ: mass-proportional drag while settling")
    gyration: float = Field(0.1, gt=0, description="m, r_g of the angular drag")
    contact_band: float = Field(1e-3, gt=0, description="m, a screw within this of the surface is in contact")
    min_contact_fraction: float = Field(1.0, gt=0, le=1, description="share of screws that must be in contact")
    max_speed: float = Field(5e-3, gt=0, description="m/s, every link origin slower than this to latch")
    quiet_time: float = Field(0.2, ge=0, description="s, how long both conditions must hold")
    time_limit: float = Field(10.0, gt=0, description="s, settling must finish by then or the run stops")
    preload: float = Field(0.0, ge=0, description="N per screw: pressing force the latched feed-forward torques make")
    screw_hold: Literal["speed", "angle"] = Field(
        "speed", description="screw set-points: 0 rad/s (velocity-mode PID) or the latched angle (position "
                             "mode, a brake: a velocity PI lets a screw roll down a vertical wall like a wheel)")
    gravity_scale: float = Field(1.0, description="gravity input while holding (1: the multibody's gravity)")
    load_time: float = Field(0.0, ge=0, description="s from the latch to gravity on (pre-load builds up meanwhile)")
    drive_delay: float = Field(0.0, ge=0, description="s from gravity on to adding the drive input to the set-points")
    rings: int = Field(3, ge=1, description="sample rings per screw (as screw_sdf_contact)")
    screws: list[int] | None = Field(None, description="screw indices (design order) pulled, counted and pre-loaded; "
                                                      "null: every screw")
    per_ring: int = Field(12, ge=1, description="samples per ring")


class Settle(Component[SettleParams]):
    type_name = "placement_settle"

    robot = Uses(RobotModel, doc="the multibody's robot: link/joint order, masses, joint axes, screws")

    link_poses = Input(shape=lambda c: (c.robot.nl, 7), unit=None)
    link_velocities = Input(shape=lambda c: (c.robot.nl, 6), unit=None)
    joint_q = Input(shape=lambda c: (c.robot.nj,), unit="rad")
    terrain = Input(type=Terrain)
    drive = Input(shape=lambda c: (c.robot.nj,), unit=None, default=0.0, names=lambda c: c.robot.joints)
    wrenches = Output(shape=lambda c: (c.robot.nl, 6), unit=None, feedthrough=("link_poses", "link_velocities", "terrain"))
    gravity = Output(shape=(1,), unit="1", feedthrough=())
    setpoint = Output(shape=lambda c: (c.robot.nj,), unit=None, feedthrough=("joint_q", "drive"),
                      names=lambda c: c.robot.joints)
    tau_ff = Output(shape=lambda c: (c.robot.nj,), unit="N*m", feedthrough=(), names=lambda c: c.robot.joints)
    phase = Output(shape=(1,), unit="1", feedthrough=())
    settle_time = Output(shape=(1,), unit="s", feedthrough=(), may_be_nan=True)
    hold_time = Output(shape=(1,), unit="s", feedthrough=(), may_be_nan=True)
    gap = Output(shape=lambda c: (c.screws.ns,), unit="m", feedthrough=("link_poses", "terrain"),
                 names=lambda c: c.screws.names)
    max_speed = Output(shape=(1,), unit="m/s", feedthrough=("link_velocities",))
    attraction = Output(type=AttractionSet, feedthrough=("link_poses", "terrain"), calc="calc_attraction")

    def setup(self):
        p = self.p
        if self.rate is None:
            raise ValueError(f"{self.name}: placement_settle has discrete state: give it a rate (Hz), "
                             "best 1/dt (its drag is a damper)")
        robot = self.robot
        lay = self.screws = robot.derived(screw_layout)
        tree, links, joints = robot.tree, robot.links, robot.joints
        samples = [ScrewContactSamples(lay.radius[s], lay.length[s], p.rings, p.per_ring, lay.lead_angle[s],
                                       int(lay.hand[s]), lay.mount_R[s], lay.mount_p[s]) for s in range(lay.ns)]
        self._pts_B = np.concatenate([s.points for s in samples])          # (n, 3) in the parent body
        # each sample's ring centre and the screw axis (parent body): where the envelope faces the terrain
        self._centre_B = self._pts_B - np.concatenate([s.radius * s.radial for s in samples])
        self._axis_B = np.concatenate([np.repeat(s.axis[None], len(s), axis=0) for s in samples])
        self._radius = np.repeat(lay.radius, [len(s) for s in samples])
        self._row = np.repeat(lay.parent_row, [len(s) for s in samples])   # parent link row per sample
        self._start = np.concatenate([[0], np.cumsum([len(s) for s in samples])[:-1]])
        self._screw_of = np.repeat(np.arange(lay.ns), [len(s) for s in samples])
        self._mass = np.array([tree.links[tree.link_index[n]].mass for n in links])
        kinds = np.array(robot.joint_kinds)
        self._bend = kinds == "bend"
        self._screw = kinds == "screw"
        self._speed_screw = self._screw & (p.screw_hold == "speed")        # set-point 0 rad/s
        self._nj, self._ns = robot.nj, lay.ns
        # pre-load map: joint k's child row and axis (child frame), and which screws lie beyond it
        jts = [tree.joint_by_name[j] for j in joints]
        self._jrow = np.array([robot.link_index(j.child) for j in jts])
        self._jaxis = np.array([j.axis for j in jts], dtype=float)
        beyond = [set(tree.subtree(j.child)) for j in jts]
        self._distal = np.array([[links[r] in b for r in lay.parent_row] for b in beyond], dtype=float)
        self._T = 1.0 / self.rate
        if p.screws is None:
            self._use = np.ones(lay.ns, dtype=bool)
        else:
            bad = [s for s in p.screws if not 0 <= s < lay.ns]
            if bad or not p.screws:
                raise ValueError(f"{self.name}: params.screws = {p.screws}: give screw indices 0..{lay.ns - 1} "
                                 f"({', '.join(lay.names)}), at least one")
            self._use = np.zeros(lay.ns, dtype=bool)
            self._use[p.screws] = True
        self._need = int(np.ceil(p.min_contact_fraction * self._use.sum() - 1e-9))

    def make_cache(self, x, u, y):
        """What output() saw (for calc_attraction at the same inputs) and the latched pre-load."""
        return _Cache(self.robot.nl)

    def discrete_state(self):
        # times < 0: not yet
        return np.concatenate([[float(SettlePhase.SETTLING), -1.0, -1.0], np.zeros(2 * self._nj)])

    # -- geometry --------------------------------------------------------------------------------
    def _nearest(self, poses, terrain):
        """Per screw: nearest sample's distance, normal, world point and parent row."""
        from scipy.spatial.transform import Rotation

        R = Rotation.from_quat(poses[self._row, 3:]).as_matrix()            # (n, 3, 3)
        pts = np.einsum("nij,nj->ni", R, self._pts_B) + poses[self._row, :3]
        q = terrain.query(pts)
        # argmin of φ within each screw's block of samples
        order = np.lexsort((q.distance, self._screw_of))
        first = order[self._start]
        phi, n, p = q.distance[first], q.normal[first], pts[first]
        # the nearest sample's ring meets the terrain at its point extremal along −n̂ (as screw_sdf_contact's
        # exact rings do): on curved terrain the sample lies up to r (1 − cos(π/per_ring)) farther out, a
        # gap the contact never closes. Where that point is nearer, it is the screw's nearest point.
        Rf = R[first]
        c = np.einsum("nij,nj->ni", Rf, self._centre_B[first]) + poses[self._row[first], :3]
        a = np.einsum("nij,nj->ni", Rf, self._axis_B[first])
        e = -n + np.einsum("ni,ni->n", n, a)[:, None] * a
        en = np.linalg.norm(e, axis=1)
        ok = en > 1e-9
        if ok.any():
            ext = c[ok] + self._radius[first][ok, None] * e[ok] / en[ok, None]
            qe = terrain.query(ext)
            nearer = np.flatnonzero(ok)[qe.distance < phi[ok]]
            keep = qe.distance < phi[ok]
            phi, n, p = phi.copy(), n.copy(), p.copy()
            phi[nearer], n[nearer], p[nearer] = qe.distance[keep], qe.normal[keep], ext[keep]
        return phi, n, p, self._row[first]

    def _speed(self, vel):
        return float(np.sqrt((vel[:, :3] ** 2).sum(axis=1)).max())

    def _envelope_points(self, poses, terrain):
        """Per screw: normal n̂ at its nearest sample and the envelope point facing the terrain in that
        sample's ring, p = c_ring + r ê_c, ê_c = unit(−n̂ + (n̂·â)â), as the SDF contact applies its force
        (screw_sdf.py). The sample itself lies up to r sin(π/per_ring) aside: as a lever arm it would
        skew the self-equilibrated forces (a spurious moment about the normal)."""
        from scipy.spatial.transform import Rotation

        R = Rotation.from_quat(poses[self._row, 3:]).as_matrix()
        pts = np.einsum("nij,nj->ni", R, self._pts_B) + poses[self._row, :3]
        q = terrain.query(pts)
        first = np.lexsort((q.distance, self._screw_of))[self._start]
        Rf = R[first]
        c = np.einsum("nij,nj->ni", Rf, self._centre_B[first]) + poses[self._row[first], :3]
        a = np.einsum("nij,nj->ni", Rf, self._axis_B[first])
        n = q.normal[first]
        e = -n + np.einsum("ni,ni->n", n, a)[:, None] * a
        e /= np.maximum(np.linalg.norm(e, axis=1), 1e-12)[:, None]
        return n, c + self._radius[first, None] * e

    def _preload_torques(self, poses, terrain):
        """τ_k = Σ_s [s beyond k] â_k · ((p_s − o_k) × (−F n̂_s)): the joint torques pressing each screw into the
        terrain, and the screw forces F."""
        from scipy.spatial.transform import Rotation

        n, pts = self._envelope_points(poses, terrain)
        # self-equilibrated magnitudes F ≥ 0 nearest to `preload`: Σ F n = 0, Σ F p × n = 0, else the
        # free-floating robot would be spun by the joint reactions (e.g. the contact-less tail link)
        # (the moment rows scaled by the spread L of the points). Only the wrench directions the screws
        # exert with a lever arm above WEAK_ARM·L are imposed: e.g. between walls every force is along
        # ±y and the contact points lie within ~1 mm of one plane x = const, so the moment about the
        # normal is ~1e-3 L per newton; imposing it exactly would trade most of the pre-load for a
        # few mN·m that friction carries anyway.
        c = pts[self._use].mean(axis=0)
        L = max(float(np.sqrt(((pts[self._use] - c) ** 2).sum(axis=1).mean())), 1e-9)
        A = np.vstack([n.T, np.cross(pts - c, n).T / L]) * self._use        # (6, ns), both rows in N per N
        _, S, Vt = np.linalg.svd(A, full_matrices=False)
        C = Vt[S > WEAK_ARM * S[0]]                                         # the imposed directions
        from scipy.optimize import lsq_linear

        w = 1e3                                             # equality by a heavy penalty, F ≥ 0 by bounds
        M = np.vstack([np.eye(self._ns), w * C])
        rhs = np.concatenate([np.full(self._ns, self.p.preload), np.zeros(len(C))])
        F = lsq_linear(M, rhs, bounds=(0.0, np.where(self._use, np.inf, 1e-12))).x
        F[~self._use] = 0.0                                 # screws left out of the brace carry no pre-load
        f = -F[:, None] * n                                                 # (ns, 3) into the terrain
        Rj = Rotation.from_quat(poses[self._jrow, 3:]).as_matrix()
        axis = np.einsum("kij,kj->ki", Rj, self._jaxis)                    # (nj, 3) world
        arm = pts[None, :, :] - poses[self._jrow, None, :3]               # (nj, ns, 3)
        return np.einsum("ks,ksi,ki->k", self._distal, np.cross(arm, f[None]), axis), F

    # -- outputs and update ----------------------------------------------------------------------
    def output(self, t, xd, u, y):
        terrain = u.terrain
        if terrain is None:
            raise ValueError(f"{self.name}: input 'terrain' carries no Terrain; connect a terrain component's "
                             "'terrain' output to it")
        phase = int(xd[0])
        latched, holding = phase >= SettlePhase.LOADING, phase == SettlePhase.HOLDING
        phi, n, pts, rows = nearest = self._nearest(u.link_poses, terrain)
        if "attraction" in self.used_outputs:        # for calc_attraction at the same inputs
            c = u.cache
            c.nearest.keep(terrain, nearest)
            np.copyto(c.poses, u.link_poses)
        y.gap[:] = phi
        y.max_speed[0] = self._speed(u.link_velocities)
        y.phase[0] = xd[0]
        y.settle_time[0] = xd[1] if xd[1] >= 0.0 else np.nan
        y.hold_time[0] = xd[1] + self.p.load_time if holding else np.nan
        W = y.wrenches
        W[:] = 0.0
        if holding:
            y.gravity[0] = self.p.gravity_scale
            y.setpoint[:] = xd[3:3 + self._nj]
            if t >= xd[1] + self.p.load_time + self.p.drive_delay - 1e-12:
                y.setpoint[:] += u.drive
            y.tau_ff[:] = xd[3 + self._nj:]
            return
        y.gravity[0] = 0.0
        if latched:                                                     # loading: free joints, pre-load only
            y.setpoint[:] = np.where(self._speed_screw, 0.0, u.joint_q)
            y.tau_ff[:] = xd[3 + self._nj:]
            return
        y.tau_ff[:] = 0.0
        p = self.p
        f = -p.k_attract * (np.maximum(phi, 0.0) * self._use)[:, None] * n
        arm = pts - u.link_poses[rows, :3]
        np.add.at(W, (rows, slice(0, 3)), f)
        np.add.at(W, (rows, slice(3, 6)), np.cross(arm, f))
        m = self._mass[:, None]
        W[:, :3] -= p.drag * m * u.link_velocities[:, :3]
        W[:, 3:] -= p.drag * m * p.gyration ** 2 * u.link_velocities[:, 3:]
        y.setpoint[:] = np.where(self._speed_screw, 0.0, u.joint_q)     # free joints: the PID only damps

    def calc_attraction(self, t, xd, u, y):
        if int(xd[0]) != SettlePhase.SETTLING:
            y.attraction = AttractionSet.empty()
            return
        c = u.cache
        nearest = c.nearest.value
        # output() saw other inputs: another terrain, its state changed since, or other poses
        if c.nearest.stale(u.terrain) or not np.array_equal(c.poses, u.link_poses):
            nearest = self._nearest(u.link_poses, u.terrain)
        phi, n, pts, _ = nearest
        pulled = (phi > 0.0) & self._use
        y.attraction = AttractionSet(pts[pulled].copy(), -self.p.k_attract * phi[pulled, None] * n[pulled])

    def update(self, t, xd, u):
        p = self.p
        phase = int(xd[0])
        if phase == SettlePhase.HOLDING:
            return
        if phase == SettlePhase.LOADING:
            if t - xd[1] >= p.load_time - 1e-12:
                xd[3:3 + self._nj] = np.where(self._speed_screw, 0.0, u.joint_q)
                xd[0] = SettlePhase.HOLDING
            return
        phi, _, _, _ = self._nearest(u.link_poses, u.terrain)
        speed = self._speed(u.link_velocities)
        touching = int(((phi <= p.contact_band) & self._use).sum())
        quiet = touching >= self._need and speed <= p.max_speed
        if not quiet:
            xd[2] = -1.0
        elif xd[2] < 0.0:
            xd[2] = t
        if quiet and t - xd[2] >= p.quiet_time - 1e-12:
            xd[3:3 + self._nj] = np.where(self._speed_screw, 0.0, u.joint_q)
            tau, u.cache.preload_forces = self._preload_torques(u.link_poses, u.terrain)
            xd[3 + self._nj:] = np.where(self._screw, 0.0, tau)
            xd[0], xd[1] = (SettlePhase.HOLDING if p.load_time <= 0.0 else SettlePhase.LOADING), t
            return
        if t >= p.time_limit:
            worst = int(np.argmax(np.where(self._use, phi, -np.inf)))
            self.stop(f"placement did not settle within time_limit {p.time_limit:g} s: "
                      f"{touching}/{int(self._use.sum())} screws within contact_band {p.contact_band:g} m (need {self._need}; farthest "
                      f"{self.screws.names[worst]} at {phi[worst]:.4f} m), fastest link {speed:.4f} m/s "
                      f"(max_speed {p.max_speed:g}); raise time_limit or k_attract, or improve the shape guess")


class _Cache:
    """One run's settle state outside the discrete state: what output() saw, for calc_attraction
    (link poses, and the nearest samples with the terrain and state version they came from:
    terrain/derived.py), and ``preload_forces`` (N per screw, set at the latch)."""

    __slots__ = ("poses", "nearest", "preload_forces")

    def __init__(self, nl: int):
        self.nearest, self.preload_forces = TerrainDerived(), None
        self.poses = np.full((nl, 7), np.nan)
