"""Ray casting against the physical scene at one instant: Embree (``embreex``) for visibility,
the terrain's own distance field for the exact hit.

    hits = world.cast(origins, directions, max_range, min_range=0)

origins (n, 3) m and unit directions (n, 3), world frame (``cast_from`` takes them in a
sensor frame and its pose). The robot's posed link meshes go into an Embree scene at most
once per instant, on the first cast (every sensor sampled at that instant shares it). A
terrain of up to MERGE_FACES faces goes into that same scene (one cast per ray); a larger
one is its own Embree scene, built once per run, and a ray's hit is the nearer of the two.

Embree works in float32 (≈1e-7 relative: 1 µm at 10 m). Terrain hits on an analytic
kind are then refined onto the true surface in float64 by Newton's method on the signed
distance along the ray, f(t) = d(o + t·r), f'(t) = n·r, so a plane, wall or tube
returns its exact range, not its tessellation's (two iterations; a step larger than
``refine_limit`` keeps the mesh hit). Only hits on faces that approximate a curve are
refined (``TerrainSurfaces.refine``): a plane's faces are the plane.

Results (``RayHits``): ``distance`` (n,) m along the ray, inf where nothing is hit
within [min_range, max_range]; for the hit rays (``hit``), ``normal`` (n, 3) unit, world,
facing the ray; ``albedo`` (n,), ``color`` (n, 3); ``link`` (n,) the link row hit, −1 for
terrain or nothing (the other fields of a missed ray are unset).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .mount import rotations_from_quaternions
from .surfaces import RobotSurfaces, TerrainSurfaces, optical_table
from .hit_kernels import nearest_hits, rays_to_world
from .textures import texture_factor, texture_table

_NO_HIT = -1
REFINE_ITERATIONS = 2
GRAZING = 1e-3          # |n·r| below this: a Newton step is ill-conditioned; keep the mesh hit
#: terrains up to this many faces are rebuilt with the robot each instant into one Embree scene
#: (one cast per ray instead of two); larger ones stay in their own scene, built once
MERGE_FACES = 200_000


@dataclasses.dataclass
class RayHits:
    distance: np.ndarray
    normal: np.ndarray
    albedo: np.ndarray
    color: np.ndarray
    link: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return np.isfinite(self.distance)


def embree_scene(*meshes):
    """An Embree scene of triangle meshes given as (vertices, faces) pairs; geometry k is the k-th
    (None when every mesh is empty)."""
    if not any(len(f) for _, f in meshes):
        return None
    from embreex import mesh_construction, rtcore_scene

    scene = rtcore_scene.EmbreeScene()
    for vertices, faces in meshes:
        mesh_construction.TriangleMesh(scene, np.ascontiguousarray(vertices, dtype=np.float32),
                                       np.ascontiguousarray(faces, dtype=np.int32))
    return scene


def _intersect(scene, origins32, dirs32, far32):
    """Embree's raw nearest hits: (geomID, tfar, primID, Ng) arrays; geomID −1 on a miss."""
    r = scene.run(origins32, dirs32, dists=far32.copy(), query="INTERSECT", output=1)
    return r["geomID"], r["tfar"], r["primID"], r["Ng"]


_NONE = (np.zeros(0, np.int32), np.zeros(0, np.float32), np.zeros(0, np.int32), np.zeros((0, 3), np.float32))


class StaticTerrainScene:
    """The terrain's Embree scene and optical tables (built once; shared by every instant)."""

    def __init__(self, surfaces: TerrainSurfaces, refine_limit: float = 0.5):
        self.surfaces = surfaces
        self.scene = embree_scene((surfaces.vertices, surfaces.faces)) if len(surfaces.faces) else None
        # a small terrain is rebuilt with the robot into one scene per instant: one cast, not two
        self.merge = 0 < len(surfaces.faces) <= MERGE_FACES
        self.refine_limit = float(refine_limit)
        self._albedo, self._color = optical_table(surfaces.terrain.materials)
        self._texture = texture_table(surfaces.terrain.materials)
        self.textured = bool((self._texture[:, 0] != 0).any())

    def finish(self, o, d, out: RayHits, material: np.ndarray, refine: np.ndarray) -> None:
        """Refine the hits on curved faces onto the exact surface; apply material textures."""
        curved = np.flatnonzero(refine)
        if curved.size:
            t, n, mat, ok = self._refine(o[curved], d[curved], out.distance[curved])
            good = curved[ok]
            out.distance[good], out.normal[good] = t[ok], n[ok]
            out.albedo[good], out.color[good] = self._albedo[mat[ok]], self._color[mat[ok]]
            material[good] = mat[ok]
        if self.textured:
            on = np.flatnonzero(material >= 0)
            f = texture_factor(self._texture, material[on], o[on] + out.distance[on, None] * d[on])
            out.albedo[on] *= f
            out.color[on] *= f[:, None]

    def _refine(self, o, d, t):
        """Newton on f(t) = distance(o + t·d): -> t, analytic normal, material, and whether it
        converged (not grazing, within refine_limit of the mesh hit)."""
        terrain = self.surfaces.terrain
        t0 = t.copy()
        ok = np.ones(len(t), dtype=bool)
        for _ in range(REFINE_ITERATIONS):
            q = terrain.query(o + t[:, None] * d)
            slope = np.einsum("ij,ij->i", q.normal, d)
            ok &= np.abs(slope) > GRAZING
            t = np.where(ok, t - q.distance / np.where(ok, slope, 1.0), t)
        ok &= np.abs(t - t0) < self.refine_limit
        t = np.where(ok, t, t0)
        # normal and material from the last query, one Newton step before t (≈ κ·sag² away: µrad)
        normal = q.normal * np.where(slope > 0, -1.0, 1.0)[:, None]
        return t, normal, q.material, ok


class SensorWorld:
    """The physical scene at simulated time ``t``: the static terrain and the robot at
    ``link_poses`` (nl, 7) [x, y, z, qx, qy, qz, qw] world. Cheap to create (it keeps the
    poses); rotations and the robot's Embree scene are made on first use and kept for the
    instant."""

    def __init__(self, t: float, terrain: StaticTerrainScene | None, robot: RobotSurfaces | None,
                 link_poses: np.ndarray | None):
        self.t = t
        self.terrain = terrain
        self.robot = robot
        self.link_poses = link_poses
        self._rotations = None
        self._scenes = None

    @property
    def rotations(self) -> np.ndarray:
        """(nl, 3, 3) link axes in the world."""
        if self._rotations is None:
            self._rotations = rotations_from_quaternions(self.link_poses[:, 3:7])
        return self._rotations

    def link_pose(self, row: int) -> tuple[np.ndarray, np.ndarray]:
        """(R (3, 3), p (3,)) of link ``row`` in the world."""
        return self.rotations[row], self.link_poses[row, :3]

    def scenes(self):
        """(scene A, robot in A, scene B) for this instant: A the terrain (with the robot when the
        terrain is small enough to rebuild), B the robot alone otherwise; built on first use."""
        if self._scenes is None:
            ter, rob = self.terrain, self.robot
            robot = None
            if rob is not None and len(rob.faces):
                robot = (rob.posed(self.rotations, self.link_poses[:, :3]), rob.faces)
            if ter is not None and ter.merge and robot is not None:
                s = ter.surfaces
                self._scenes = (embree_scene((s.vertices, s.faces), robot), True, None)
            else:
                self._scenes = (ter.scene if ter is not None else None, False,
                                embree_scene(robot) if robot is not None else None)
        return self._scenes

    def cast(self, origins, directions, max_range: float, min_range: float = 0.0) -> RayHits:
        """Nearest hit of each world ray (origins, unit directions (n, 3)) within
        [min_range, max_range] m (rays start at min_range)."""
        o = np.ascontiguousarray(origins, dtype=np.float64)
        d = np.ascontiguousarray(directions, dtype=np.float64)
        return self.cast_from(np.eye(3), np.zeros(3), o, d, max_range, min_range)[0]

    def cast_from(self, R, p, origins, directions, max_range: float, min_range: float = 0.0):
        """Rays given in a sensor frame at (R, p) in the world: -> (hits, world origins, world
        directions)."""
        n = len(origins)
        o_w, d_w = np.empty((n, 3)), np.empty((n, 3))
        start32, d32 = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
        rays_to_world(origins, directions, np.ascontiguousarray(R, dtype=np.float64),
                      np.asarray(p, dtype=np.float64), float(min_range), o_w, d_w, start32, d32)
        # rows of missed rays are left unset except distance (inf): readers select hits first
        out = RayHits(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64))
        material = np.empty(n, dtype=np.int64)
        refine = np.empty(n, dtype=np.bool_)
        far32 = np.full(n, max_range - min_range, dtype=np.float32)
        ter = self.terrain
        a, robot_in_a, b = self.scenes() if n else (None, False, None)
        raw_a = _intersect(a, start32, d32, far32) if a is not None else _NONE
        raw_b = _intersect(b, start32, d32, far32) if b is not None else _NONE
        s = ter.surfaces if ter is not None else None
        tables_t = (s.albedo, s.color, s.refine, s.material) if s is not None else _EMPTY_TERRAIN
        rob = self.robot
        tables_r = (rob.albedo, rob.color, rob.face_link) if rob is not None else _EMPTY_ROBOT
        nearest_hits(d_w, float(min_range), float(max_range), *raw_a, robot_in_a, *raw_b, *tables_t, *tables_r,
                     out.distance, out.normal, out.albedo, out.color, out.link, material, refine)
        if ter is not None and (refine.any() or ter.textured):
            ter.finish(o_w, d_w, out, material, refine)      # distances are from the origins
            far = out.distance > max_range        # a refined hit may move past the range by rounding
            out.distance[far] = np.inf
        return out, o_w, d_w


_EMPTY_TERRAIN = (np.zeros(0), np.zeros((0, 3)), np.zeros(0, np.bool_), np.zeros(0, np.int64))
_EMPTY_ROBOT = (np.zeros(0), np.zeros((0, 3)), np.zeros(0, np.int64))
