"""Convex-hull contact back end (paper §2.2.2, fig. 4): coal collision of the robot's
convex collision pieces with the terrain and with each other, forces by eqs. 2 and 6.

hull_contact:
    uses robot: RobotModel      (the multibody's: links, URDF collision shapes, screw metadata)
    in   link_poses[nl,7]       [x, y, z, qx, qy, qz, qw] of each URDF link, world
         link_velocities[nl,6]  [v of link origin, ω], world
         joint_v[nj]            rad/s, accepted so the SDF back end's wiring fits unchanged;
                                not read: the screw links' own velocities carry the spin
         terrain                structured Terrain (the `terrain` component)
    out  wrenches[nl,6]         N, N·m: [f, τ] on each link, world axes, τ about the LINK
                                ORIGIN (the multibody's `wrenches` input)
         normal_force[1]        N, Σ F_n over robot–terrain contacts
         contacts[1]            robot–terrain contacts (penetrating pairs)
         body_normal_force[1]   N, Σ F_n over body-to-body contacts
         body_contacts[1]       body-to-body contacts (penetrating pairs)
         contact_set            ContactSet of the robot–terrain contacts (contact_set.py)
         (all feedthrough from all inputs)
    The ports, the law's parameters (``material``, v_ε…), the terrain switching, the depth watch
    (``max_depth``) and the contact set are every back end's (../link_contact.py), so an assembly
    swaps back ends by changing the type.

Geometry (robot_geometry.py, terrain_geometry.py, decompose.py): the URDF's collision
shapes (screw envelope cylinders cut into ``cylinder_slices``, module cylinders, boxes;
or the screws' helical blade mesh as ``blade_hulls`` convex hulls) against the terrain
as coal half-spaces or triangle meshes; one contact per colliding pair (narrow.py).

Forces — the SDF back end's kernels, so the two back ends differ only in geometry:

    robot–terrain  F_n = max(0, k d + c ḋ) n̂ (eq. 2), friction eq. 6 with ê_v the thread
                   normal at the contact (screw_samples.thread_direction, from the screw
                   axis, the radial direction to the point, lead angle λ, hand) on screw
                   links, isotropic (eq. 1) elsewhere; k, c, μ, ‖e_v‖ = a + b F_n from the
                   terrain material under the point (the table material_table packs once
                   per terrain object, ``material`` applied, ‖e_v‖ checked on [0, fn_max]);
                   slip regularised (v_ε, kernels.py)
    body–body      eq. 2 + isotropic friction with body_stiffness, body_damping, body_mu;
                   the force on b is F at the contact point, on a −F (equal and opposite)

Velocity of the robot's material point at a contact p on link l: v_l + ω_l × (p − o_l);
a screw link's ω includes its spin. k is per contact (per colliding piece), as in the
SDF back end per sample: a body resting on n pieces sinks d = W / (n k) (c ḋ = 0 at rest).

Terrain geometry follows the terrain's state: a deformable kind's coal parts are meshed again when
its state version moves (terrain/derived.py), the material table only for another terrain object.

Broad phase: each piece's bounding sphere (centre, radius) in the world; a piece is
tested against the terrain only when Terrain.distance_lower_bound(centre, radius) ≤ 0
(one vectorised query for all pieces), a body pair only when the spheres overlap.
"""

from __future__ import annotations

import dataclasses

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Input, Output
from snakesim.components.multibody.robot_ports import joint_names, joint_shape
from snakesim.components.materials import EV_A, EV_B, MU, C, K
from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.components.terrain.derived import TerrainDerived

from ..kernels import MODES
from ..kernels_numba import body_wrenches_nb, contact_forces_nb
from ..link_contact import LinkContact, LinkContactParams
from .narrow import Narrowphase
from .robot_geometry import GeometryOptions, robot_geometry
from .terrain_geometry import terrain_parts


class HullContactParams(LinkContactParams):
    # geometry
    screw_geometry: Literal["envelope", "blades"] = Field(
        "envelope", description="screws as their envelope cylinder, or the blade mesh's convex hulls")
    cylinder_slices: int = Field(3, ge=1, description="pieces each collision cylinder is cut into")
    blade_hulls: int = Field(8, ge=1, description="convex hulls per screw with screw_geometry: blades")
    mesh_hulls: int = Field(4, ge=1, description="convex hulls per <mesh> collision element")
    max_contacts: int = Field(8, ge=1, description="triangles coal reports per piece against a terrain mesh")
    terrain_extent: float = Field(10.0, gt=0, description="m, half-length meshed of unbounded curved terrains")
    terrain_segments: int = Field(64, ge=8, description="facets around curved terrains")
    terrain_resolution: float = Field(0.05, gt=0, description="m, mesh spacing along curved terrains")
    # body-to-body
    body_contact: bool = True
    min_module_gap: int = Field(2, ge=1, description="modules apart for two links to collide")
    body_stiffness: float = Field(1e5, gt=0, description="N/m")
    body_damping: float = Field(1e3, ge=0, description="N·s/m")
    body_mu: float = Field(0.3, ge=0)


class HullContact(LinkContact[HullContactParams]):
    type_name = "hull_contact"

    joint_v = Input(shape=joint_shape, unit="rad/s", default=0.0, names=joint_names)
    body_normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    body_contacts = Output(shape=(1,), unit="1", feedthrough=True)

    def setup(self):
        p, robot = self.p, self.robot
        if p.screw_geometry == "blades" and not robot.metadata.get("screws"):
            raise ValueError(f"{self.name}: screw_geometry 'blades' needs a design with screws (got {robot.label}, "
                             "which has none); use screw_geometry: envelope")
        # shared by every hull_contact of this robot with these options (read-only here)
        self.geo = robot.derived(robot_geometry, GeometryOptions(
            cylinder_slices=p.cylinder_slices, screw_geometry=p.screw_geometry, blade_hulls=p.blade_hulls,
            mesh_hulls=p.mesh_hulls, min_module_gap=p.min_module_gap))
        self._mode = MODES[p.regularisation]

    def make_cache(self, x, u, y) -> "HullRun":
        import coal

        p = self.p
        return HullRun(self, [coal.Transform3s() for _ in range(self.geo.n_pieces)], Narrowphase(p.max_contacts),
                       _Scratch(self.robot.nl), TerrainDerived(lambda terrain: terrain_parts(
                           terrain, p.terrain_extent, p.terrain_segments, p.terrain_resolution)))

    # -- geometry in the world ---------------------------------------------------------
    def _pieces_world(self, poses):
        g = self.geo
        R = rotation_matrices(poses[:, 3:])
        Rl = R[g.piece_link]
        Rw = Rl @ g.piece_R
        pw = np.einsum("nij,nj->ni", Rl, g.piece_p) + poses[g.piece_link, :3]
        cw = np.einsum("nij,nj->ni", Rl, g.sphere_c) + poses[g.piece_link, :3]
        return R, Rw, pw, cw

    def _terrain_contacts(self, run, terrain, Rw, pw, cw):
        if terrain is not run.terrain:
            run.mats = self.material_table(terrain)
            run.terrain = terrain
        parts = run.parts.get(terrain)          # meshed again only when the terrain's state moved
        g = self.geo
        near = np.flatnonzero(terrain.distance_lower_bound(cw, g.sphere_r) <= 0.0)
        rows = []
        for i in near:
            T = run.transforms[i]
            T.setRotation(Rw[i])
            T.setTranslation(pw[i])
            for part in parts:
                hit = run.narrow.collide(g.geoms[i], T, part.geom, part.transform, part.triangles)
                if hit is not None:
                    # coal's normal points from the robot into the terrain
                    rows.append((g.piece_link[i], hit[0], -hit[1], hit[2], part.triangles))
        return rows

    def _body_contacts(self, run, Rw, pw, cw):
        g = self.geo
        a, b = g.pair_a, g.pair_b
        gap = np.linalg.norm(cw[a] - cw[b], axis=1) - g.sphere_r[a] - g.sphere_r[b]
        rows = []
        for k in np.flatnonzero(gap <= 0.0):
            i, j = a[k], b[k]
            for n in (i, j):
                run.transforms[n].setRotation(Rw[n])
                run.transforms[n].setTranslation(pw[n])
            hit = run.narrow.collide(g.geoms[i], run.transforms[i], g.geoms[j], run.transforms[j], False)
            if hit is not None:
                rows.append((g.piece_link[i], g.piece_link[j], hit[0], hit[1], hit[2]))
        return rows

    # -- forces ----------------------------------------------------------------------------
    def _velocity(self, link, points, poses, vel):
        return vel[link, :3] + np.cross(vel[link, 3:], points - poses[link, :3])

    def _thread_dirs(self, link, points, R, poses):
        """ê_v at each contact: thread normal on screw links, 0 (isotropic) elsewhere."""
        g = self.geo
        hand, lead = g.screw_hand[link], g.screw_lead[link]
        axis = R[link][:, :, 0]
        r = points - poses[link, :3]
        radial = r - np.einsum("ij,ij->i", r, axis)[:, None] * axis
        radial /= np.maximum(np.linalg.norm(radial, axis=1), 1e-12)[:, None]
        e = np.cos(lead)[:, None] * axis - (hand * np.sin(lead))[:, None] * np.cross(axis, radial)
        return np.where((hand != 0)[:, None], e, 0.0)

    def output(self, t, x, u, y):
        p, run = self.p, u.cache
        poses, vel, terrain = u.link_poses, u.link_velocities, self.checked_terrain(u.terrain)
        R, Rw, pw, cw = self._pieces_world(poses)
        trows = self._terrain_contacts(run, terrain, Rw, pw, cw)
        brows = self._body_contacts(run, Rw, pw, cw) if p.body_contact and len(self.geo.pair_a) else []

        nt = len(trows)
        t_link = np.array([r[0] for r in trows], dtype=np.int64)
        t_depth = np.array([r[1] for r in trows], dtype=float)
        t_normal = np.array([r[2] for r in trows], dtype=float).reshape(-1, 3)
        t_point = np.array([r[3] for r in trows], dtype=float).reshape(-1, 3)
        t_force, t_fn = np.zeros((nt, 3)), np.zeros(nt)
        if nt:
            q = terrain.query(t_point)
            # triangles have no inside: orient their normals out of the solid
            tri = np.array([r[4] for r in trows])
            flip = tri & (np.einsum("ij,ij->i", t_normal, q.normal) < 0.0)
            t_normal[flip] *= -1.0
            v = self._velocity(t_link, t_point, poses, vel)
            e = self._thread_dirs(t_link, t_point, R, poses)
            for m in np.unique(q.material):
                sel = q.material == m
                f, fn = np.empty((sel.sum(), 3)), np.empty(sel.sum())
                row = run.mats[m]        # packed with this terrain by _terrain_contacts
                contact_forces_nb(t_depth[sel], t_normal[sel], np.ascontiguousarray(v[sel]),
                                  np.ascontiguousarray(e[sel]), row[K], row[C], row[MU], row[EV_A], row[EV_B],
                                  p.v_eps, self._mode, p.ev_floor, f, fn)
                t_force[sel], t_fn[sel] = f, fn

        nb = len(brows)
        b_a = np.array([r[0] for r in brows], dtype=np.int64)
        b_b = np.array([r[1] for r in brows], dtype=np.int64)
        b_depth = np.array([r[2] for r in brows], dtype=float)
        b_normal = np.array([r[3] for r in brows], dtype=float).reshape(-1, 3)
        b_point = np.array([r[4] for r in brows], dtype=float).reshape(-1, 3)
        b_force, b_fn = np.zeros((nb, 3)), np.zeros(nb)
        if nb:
            v_rel = self._velocity(b_b, b_point, poses, vel) - self._velocity(b_a, b_point, poses, vel)
            contact_forces_nb(b_depth, b_normal, v_rel, np.zeros((nb, 3)), p.body_stiffness, p.body_damping,
                              p.body_mu, 1.0, 0.0, p.v_eps, self._mode, p.ev_floor, b_force, b_fn)

        points = np.concatenate([t_point, b_point, b_point])
        forces = np.concatenate([t_force, b_force, -b_force])
        index = np.concatenate([t_link, b_b, b_a])
        body_wrenches_nb(points, forces, np.ascontiguousarray(poses[:, :3]), index, y.wrenches)
        y.normal_force[0] = t_fn.sum()
        y.contacts[0] = nt
        y.body_normal_force[0] = b_fn.sum()
        y.body_contacts[0] = nb
        run.last = {"t": t, "link": t_link, "point": t_point, "normal": t_normal, "depth": t_depth,
                     "force": t_force, "fn": t_fn, "slip": v if nt else np.zeros((0, 3)),
                     "material": q.material if nt else np.zeros(0, dtype=np.int64),
                     "body_a": b_a, "body_b": b_b, "body_point": b_point, "body_normal": b_normal,
                     "body_depth": b_depth, "body_force": b_force, "body_fn": b_fn}
        run.seen = (terrain, poses.copy(), vel.copy())
        if y is not run.scratch:
            self.watch_depth(t, -t_depth, t_link)


@dataclasses.dataclass
class HullRun:
    """One run's hull state (``u.cache``): coal transforms moved every call, the narrow phase, the
    terrain last packed (its material table; its coal parts, per state version), the last evaluation
    and its inputs. Answers the contact set's questions (link_contact.ContactRun)."""

    comp: HullContact
    transforms: list
    narrow: Narrowphase
    scratch: "_Scratch"
    parts: TerrainDerived
    terrain: object = None
    mats: np.ndarray | None = None
    last: dict = dataclasses.field(default_factory=dict)
    seen: tuple | None = None

    def describes(self, u) -> bool:
        s = self.seen
        return s is not None and u.terrain is s[0] and np.array_equal(u.link_poses, s[1]) \
            and np.array_equal(u.link_velocities, s[2])

    def evaluate_scratch(self, t, x, u) -> None:
        self.comp.output(t, x, u, self.scratch)

    def active_contacts(self) -> dict:
        c = self.last
        return dict(points=c["point"].copy(), normals=c["normal"].copy(), forces=c["force"].copy(),
                    normal_force=c["fn"].copy(), depth=c["depth"].copy(), slip=c["slip"].copy(),
                    link=c["link"].copy(), material=c["material"].copy())


class _Scratch:
    """Output buffers for an evaluation whose numeric outputs nobody reads."""

    def __init__(self, nl):
        self.wrenches = np.zeros((nl, 6))
        self.normal_force, self.contacts = np.zeros(1), np.zeros(1)
        self.body_normal_force, self.body_contacts = np.zeros(1), np.zeros(1)
