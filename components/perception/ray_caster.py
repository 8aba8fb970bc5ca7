"""Ray casting against the physical scene at one instant: Embree (``embreex``) for visibility,
the terrain's own distance field for the exact hit.

    hits = world.cast(origins, directions, max_range, min_range=0)

origins (n, 3) m and unit directions (n, 3), world frame (``cast_from`` takes them in a
sensor frame and its pose). Nothing is built per instant: the terrain is one Embree scene
built once per run (``StaticTerrainScene``), and each robot link's mesh is its own Embree
scene in its link frame, built once per robot (``RobotScenes``). A ray is cast against the
terrain first; then against each link whose bounding sphere (posed at this instant) it can
meet (a sensor's ``RayBundle`` bins its rays by direction once and tests only the bins
inside the cone the sphere subtends; other rays: the segment up to the terrain hit against
spheres around groups of consecutive links, then their links'), and whose box it meets
before its nearest hit so far, in the link's frame, o_l = Rᵀ(o − p), d_l = Rᵀd (a rigid
motion keeps the distance t), with far = the nearest hit so far, so a link only returns
what is nearer; its normal is turned back into the world, n = R·n_l. The nearest of all is
the ray's hit: the same as one scene of the terrain and the posed robot
(tests/perception/test_robot_casting.py), without rebuilding a robot BVH each instant
(~20 ms for EELS 1.0's 23k visual faces, most of it embreex copying vertices one by one).

Embree works in float32 (≈1e-7 relative: 1 µm at 10 m; robot hits are cast in link
coordinates, ≈1e-7 of the link's size). Terrain hits on an analytic kind are then refined
onto the true surface in float64 by Newton's method on the signed distance along the ray,
f(t) = d(o + t·r), f'(t) = n·r, so a plane, wall or tube returns its exact range, not its
tessellation's (two iterations; a step larger than ``refine_limit`` keeps the mesh hit;
compiled for the Fourier-cylinder kinds, tube and moulin: .refine_kernels).
Only hits on faces that approximate a curve are refined (``TerrainSurfaces.refine``): a
plane's faces are the plane.

The rays are cast in chunks, one per thread (``THREADS``: numba's thread count, the CPU
count unless NUMBA_NUM_THREADS says otherwise): embreex and the chunk kernels release the
GIL, and every ray is independent. Sensors keep their rays binned (``RayBundle``), in an
order that deals them out to the chunks in turn (``interleaved``), and their arrays
(``CastBuffers``) from one sample to the next.

Results (``RayHits``): ``distance`` (n,) m along the ray, inf where nothing is hit
within [min_range, max_range]; for the hit rays (``hit``), ``normal`` (n, 3) unit, world,
facing the ray; ``albedo`` (n,), ``color`` (n, 3); ``link`` (n,) the link row hit, −1 for
terrain or nothing (the other fields of a missed ray are unset).
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import itertools
import math
import os

import numba
import numpy as np

from .hit_kernels import (bundle_candidates, finish_hits, link_candidates, link_cones, link_rays,
                          rays_to_world, take_link_hits)
from .mount import rotations_from_quaternions
from .refine_kernels import FourierRefiner
from .surfaces import RobotSurfaces, TerrainSurfaces, optical_table
from .textures import texture_factor, texture_table

REFINE_ITERATIONS = 2
GRAZING = 1e-3          # |n·r| below this: a Newton step is ill-conditioned; keep the mesh hit
#: chunks (threads) a cast is split into; fewer rays than CHUNK_MIN per chunk are not split
THREADS = max(1, int(numba.config.NUMBA_NUM_THREADS))
CHUNK_MIN = 8192
#: chunks per thread: the threads take the next chunk as they finish one, so a thread the OS
#: deschedules (a loaded machine) or a costlier part of the view does not hold up the cast
SPLIT = 2


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


class CastBuffers:
    """The arrays of a cast of ``n`` rays (results, world rays, per-ray scratch), kept by a sensor
    and reused from one cast to the next: fresh arrays of tens of MB are page-faulted in on every
    cast (measured: ~25 ms of a 640x480 image's ~60 ms). The RayHits of a cast into them are
    views, valid until the next cast."""

    def __init__(self, n: int):
        self.n = n
        self.o_w, self.d_w = np.empty((n, 3)), np.empty((n, 3))
        self.start32, self.d32 = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
        self.hits = RayHits(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64))
        self.material, self.refine = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_)
        self.best, self.src = np.empty(n, dtype=np.float32), np.empty(n, dtype=np.int8)
        self.face, self.ng_r = np.empty(n, dtype=np.int64), np.empty((n, 3))


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
    # embreex commits (builds the BVH) on the first run: do it here, not in a cast's threads
    scene.run(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32))
    return scene


def _intersect(scene, origins32, dirs32, far32):
    """Embree's nearest hits: (geomID −1 on a miss, primID, Ng); ``far32`` becomes the hit's t."""
    r = scene.run(origins32, dirs32, dists=far32, query="INTERSECT", output=1)
    return r["geomID"], r["primID"], r["Ng"]


_NO_TERRAIN = (np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros((0, 3), np.float32))


class StaticTerrainScene:
    """The terrain's Embree scene and optical tables (built once; shared by every instant)."""

    def __init__(self, surfaces: TerrainSurfaces, refine_limit: float = 0.5):
        self.surfaces = surfaces
        self.scene = embree_scene((surfaces.vertices, surfaces.faces)) if len(surfaces.faces) else None
        self.refine_limit = float(refine_limit)
        self._albedo, self._color = optical_table(surfaces.terrain.materials)
        self._texture = texture_table(surfaces.terrain.materials)
        self.textured = bool((self._texture[:, 0] != 0).any())
        self.tables = (surfaces.albedo, surfaces.color, surfaces.refine, surfaces.material)
        # Fourier-cylinder kinds (tube, moulin): the Newton iteration compiled (.refine_kernels)
        self.refiner = (FourierRefiner.for_terrain(surfaces.terrain, surfaces.vertices, self.refine_limit + 1.0)
                        if surfaces.refine.any() else None)

    def finish(self, o, d, out: RayHits, material: np.ndarray, refine: np.ndarray) -> None:
        """Refine the hits on curved faces onto the exact surface; apply material textures."""
        curved = np.flatnonzero(refine)
        if curved.size and self.refiner is not None:
            in_chunks(lambda c, k: self.refiner.refine(o, d, curved[k], REFINE_ITERATIONS, GRAZING, self.refine_limit,
                                                       self._albedo, self._color, out.distance, out.normal,
                                                       out.albedo, out.color, material), curved.size)
        elif curved.size:
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


class RobotScenes:
    """One static Embree scene per robot link (its faces in its link frame), built once per robot,
    with what a cast needs to cull and merge: ``rows`` (L,) the link rows that have faces,
    ``face_ids`` per link the robot face index of each of its scene's faces, the links' bounding
    spheres in their frames (``centre`` (L, 3), ``radius`` (L,) m) and boxes (``box``: (lo, hi)
    per link, link frame, padded past float32 rounding), and ``groups`` (G + 1,):
    consecutive links (the chain's neighbours) grouped by about √L, culled by one sphere first."""

    def __init__(self, surfaces: RobotSurfaces):
        self.surfaces = surfaces
        self.rows = np.unique(surfaces.face_link)
        self.scenes, self.face_ids = [], []
        centre, radius, box = [], [], []
        for row in self.rows:
            faces = np.flatnonzero(surfaces.face_link == row)
            used, local = np.unique(surfaces.faces[faces], return_inverse=True)
            V = surfaces.vertices[used]
            c = 0.5 * (V.min(axis=0) + V.max(axis=0))
            # padded past float32 rounding of the link's own coordinates
            r = float(np.linalg.norm(V - c, axis=1).max())
            centre.append(c)
            radius.append(r * (1 + 1e-5) + 1e-6)
            pad = 1e-5 * r + 1e-6
            box.append((V.min(axis=0) - pad, V.max(axis=0) + pad))
            self.scenes.append(embree_scene((V, local.reshape(-1, 3))))
            self.face_ids.append(faces.astype(np.int64))
        L = len(self.rows)
        self.centre = np.array(centre, dtype=np.float64).reshape(L, 3)
        self.radius = np.array(radius, dtype=np.float64)
        self.box = [(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)) for a, b in box]
        self.boxes = (np.array([b[0] for b in self.box]).reshape(L, 3),
                      np.array([b[1] for b in self.box]).reshape(L, 3))
        size = max(1, math.ceil(math.sqrt(L)))
        self.groups = np.r_[np.arange(0, L, size), L].astype(np.int64)
        self.tables = (surfaces.albedo, surfaces.color, surfaces.face_link)

    def spheres(self, rotations: np.ndarray, positions: np.ndarray):
        """Bounding spheres at link poses: (link centres (L, 3) world, group centres (G, 3), group
        radii (G,))."""
        c = np.einsum("lij,lj->li", rotations[self.rows], self.centre) + positions[self.rows]
        g = self.groups
        gc = np.array([c[a:b].mean(axis=0) for a, b in zip(g[:-1], g[1:])]).reshape(-1, 3)
        gr = np.array([(np.linalg.norm(c[a:b] - gc[k], axis=1) + self.radius[a:b]).max()
                       for k, (a, b) in enumerate(zip(g[:-1], g[1:]))])
        return c, gc, gr


class RayBundle:
    """A sensor's rays (origins, unit directions (n, 3), its frame), binned once by direction on a
    cube map (``BINS`` × ``BINS`` cells per face; each bin keeps the axis and half-angle β of its
    rays), so that a cast finds the rays that can meet a robot link from the cone its bounding
    sphere (centre c, radius r) subtends seen from the bundle's origin ball (centre o₀, radius ρ):
    half-angle asin((r + ρ)/|c − o₀|) (a ray from within ρ of o₀ that meets the sphere is parallel
    to one from o₀ that meets the sphere grown by ρ). Only the bins whose cone overlaps are tested
    ray by ray (``bundle_candidates``)."""

    BINS = 16

    def __init__(self, origins, directions):
        o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
        self.source = directions          # the array a cast must pass with this bundle
        self.directions = d
        self.centre = o.mean(axis=0) if len(o) else np.zeros(3)
        self.radius = float(np.linalg.norm(o - self.centre, axis=1).max()) * (1 + 1e-9) if len(o) else 0.0
        n, N = len(d), self.BINS
        major = np.abs(d).argmax(axis=1) if n else np.zeros(0, dtype=np.int64)
        rows = np.arange(n)
        m = np.abs(d[rows, major])
        cells = [np.clip(((d[rows, (major + j) % 3] / m + 1.0) * 0.5 * N).astype(np.int64), 0, N - 1)
                 for j in (1, 2)]
        key = ((2 * major + (d[rows, major] > 0)) * N + cells[0]) * N + cells[1]
        order = np.argsort(key, kind="stable")
        used, first = np.unique(key[order], return_index=True)
        self.bin_first = np.r_[first, n].astype(np.int64)
        self.bin_rays = order.astype(np.int64)
        inverse = np.searchsorted(used, key)
        axis = np.zeros((len(used), 3))
        np.add.at(axis, inverse, d)
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        angle = np.zeros(len(used))
        np.maximum.at(angle, inverse, np.arccos(np.clip(np.einsum("ij,ij->i", d, axis[inverse]), -1.0, 1.0)))
        angle = np.minimum(angle * (1 + 1e-9) + 1e-9, np.pi)        # past the arccos's rounding
        self.bin_axis, self.bin_cos, self.bin_sin = axis, np.cos(angle), np.sin(angle)

    def link_cones(self, R, p, centres, radii, reach_max: float, link_R=None, link_p=None, box=None):
        """Each link's cone in the sensor frame, the sensor at (R, p): (axis (L, 3), cos, sin of the
        half-angle); cos −2 where the origin ball meets the sphere (every direction), 2 where the
        sphere is farther than ``reach_max`` (no ray reaches it). With the links' poses (link_R
        (L, 3, 3), link_p (L, 3)) and boxes (lo, hi (L, 3), link frame), the cone of the box where
        it is narrower: the box grown by ρ seen from o₀ outside it lies within the cone around the
        direction to its centre through its farthest corner, when that is under 90° (a convex
        set whose corners lie in a convex cone lies in it)."""
        L = len(centres)
        u, cos_a, sin_a = np.empty((L, 3)), np.empty(L), np.empty(L)
        use_box = box is not None
        if not use_box:
            link_R, link_p, box = np.zeros((L, 3, 3)), np.zeros((L, 3)), (np.zeros((L, 3)), np.zeros((L, 3)))
        link_cones(R, p, self.centre, self.radius, centres, radii, float(reach_max), use_box, link_R, link_p,
                   box[0], box[1], u, cos_a, sin_a)
        return u, cos_a, sin_a

    def candidates(self, R, p, centres, radii, reach_max: float, edges, link_R=None, link_p=None, box=None):
        """CSR lists of the rays that can meet each link, per chunk (``bundle_candidates``)."""
        u, cos_a, sin_a = self.link_cones(R, p, centres, radii, reach_max, link_R, link_p, box)
        return bundle_candidates(self.directions, self.bin_first, self.bin_rays, self.bin_axis, self.bin_cos,
                                 self.bin_sin, u, cos_a, sin_a, np.asarray(edges, dtype=np.int64))


_EMPTY_TERRAIN = (np.zeros(0), np.zeros((0, 3)), np.zeros(0, np.bool_), np.zeros(0, np.int64))
_EMPTY_ROBOT = (np.zeros(0), np.zeros((0, 3)), np.zeros(0, np.int64))
_POOL: tuple[int, concurrent.futures.ThreadPoolExecutor] | None = None


def _pool() -> concurrent.futures.ThreadPoolExecutor:
    """The cast threads (made again in a forked child: a fork copies the pool, not its threads)."""
    global _POOL
    if _POOL is None or _POOL[0] != os.getpid():
        _POOL = (os.getpid(), concurrent.futures.ThreadPoolExecutor(max(1, THREADS - 1),
                                                                    thread_name_prefix="snakesim-rays"))
    return _POOL[1]


def chunks(n: int) -> list[slice]:
    """The ray ranges a cast of n rays is split into (SPLIT per thread; one when n is small)."""
    k = max(1, min(THREADS * SPLIT if THREADS > 1 else 1, n // CHUNK_MIN))
    edges = np.linspace(0, n, k + 1).astype(int)
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]


def interleaved(n: int) -> np.ndarray:
    """A cast order of n rays (a permutation) that deals them out to the chunks in turn: each of
    the k chunks gets every k-th ray, so each covers the whole field of view, not a band of it
    (an image's upper half is sky, cheap; its lower half ground)."""
    return np.argsort(np.arange(n) % len(chunks(n)), kind="stable")


def in_chunks(fn, n: int) -> None:
    """fn(chunk index, slice) for each of chunks(n), on THREADS threads (this one among them), each
    taking the next chunk when it is done with one."""
    parts = chunks(n)
    if len(parts) == 1:
        fn(0, parts[0])
        return
    ticket = itertools.count()            # next() is atomic under the GIL

    def work():
        for c in iter(ticket.__next__, None):
            if c >= len(parts):
                return
            fn(c, parts[c])

    futures = [_pool().submit(work) for _ in range(min(THREADS, len(parts)) - 1)]
    work()
    for f in futures:
        f.result()


class SensorWorld:
    """The physical scene at simulated time ``t``: the static terrain and the robot at
    ``link_poses`` (nl, 7) [x, y, z, qx, qy, qz, qw] world. Cheap to create (it keeps the
    poses); rotations and the links' bounding spheres are made on first use and kept for the
    instant."""

    def __init__(self, t: float, terrain: StaticTerrainScene | None, robot: RobotScenes | None,
                 link_poses: np.ndarray | None):
        self.t = t
        self.terrain = terrain
        self.robot = robot if robot is not None and len(robot.rows) else None
        self.link_poses = link_poses
        self._rotations = None
        self._spheres = None

    @property
    def rotations(self) -> np.ndarray:
        """(nl, 3, 3) link axes in the world."""
        if self._rotations is None:
            self._rotations = rotations_from_quaternions(self.link_poses[:, 3:7])
        return self._rotations

    def link_pose(self, row: int) -> tuple[np.ndarray, np.ndarray]:
        """(R (3, 3), p (3,)) of link ``row`` in the world."""
        return self.rotations[row], self.link_poses[row, :3]

    def spheres(self):
        """The robot links' bounding spheres at this instant (``RobotScenes.spheres``)."""
        if self._spheres is None:
            self._spheres = self.robot.spheres(self.rotations, self.link_poses[:, :3])
        return self._spheres

    def cast(self, origins, directions, max_range: float, min_range: float = 0.0) -> RayHits:
        """Nearest hit of each world ray (origins, unit directions (n, 3)) within
        [min_range, max_range] m (rays start at min_range)."""
        o = np.ascontiguousarray(origins, dtype=np.float64)
        d = np.ascontiguousarray(directions, dtype=np.float64)
        return self.cast_from(np.eye(3), np.zeros(3), o, d, max_range, min_range)[0]

    def cast_from(self, R, p, origins, directions, max_range: float, min_range: float = 0.0,
                  bundle: RayBundle | None = None, buffers: CastBuffers | None = None):
        """Rays given in a sensor frame at (R, p) in the world: -> (hits, world origins, world
        directions). ``bundle``: the same rays binned (a sensor's, made once), which finds the
        rays that can meet the robot faster than testing each ray against each link;
        ``buffers``: the sensor's CastBuffers of as many rays, written over (else fresh arrays)."""
        n = len(origins)
        b = buffers if buffers is not None and buffers.n == n else CastBuffers(n)
        o_w, d_w, start32, d32 = b.o_w, b.d_w, b.start32, b.d32
        R, p = np.ascontiguousarray(R, dtype=np.float64), np.asarray(p, dtype=np.float64)
        # rows of missed rays are left unset except distance (inf): readers select hits first
        out, material, refine = b.hits, b.material, b.refine
        lo, hi = float(min_range), float(max_range)
        parts = chunks(n)
        cand = [None] * len(parts)
        if self.robot is not None:
            centres = self.spheres()[0]          # once, before the threads share it
            if bundle is not None:
                if bundle.source is not directions:
                    raise ValueError("cast_from: the bundle was made from other rays than the directions given")
                L = len(self.robot.rows)
                rows = self.robot.rows
                offsets, rays = bundle.candidates(R, p, centres, self.robot.radius, hi,
                                                  [sl.start for sl in parts] + [n], self.rotations[rows],
                                                  self.link_poses[rows, :3], self.robot.boxes)
                cand = [(offsets[c * L:(c + 1) * L + 1], rays) for c in range(len(parts))]

        def run(c, sl):
            rays_to_world(origins[sl], directions[sl], R, p, lo, o_w[sl], d_w[sl], start32[sl], d32[sl])
            self._cast_chunk(o_w[sl], d_w[sl], start32[sl], d32[sl], lo, hi, cand[c],
                             (b.best[sl], b.src[sl], b.face[sl], b.ng_r[sl]), out.distance[sl],
                             out.normal[sl], out.albedo[sl], out.color[sl], out.link[sl], material[sl], refine[sl])

        in_chunks(run, n)
        ter = self.terrain
        if ter is not None and (refine.any() or ter.textured):
            ter.finish(o_w, d_w, out, material, refine)      # distances are from the origins
            far = out.distance > max_range        # a refined hit may move past the range by rounding
            out.distance[far] = np.inf
        return out, o_w, d_w

    def _cast_chunk(self, o_w, d_w, start32, d32, lo, hi, candidates, scratch, *outputs):
        """Cast one chunk of rays (terrain, then the robot links each ray can meet: ``candidates``
        (offsets, rays) from the bundle, else each ray's segment against the links' spheres) and
        fill its slices of the outputs (finish_hits)."""
        m = len(o_w)
        best, src, face, ng_r = scratch
        best.fill(hi - lo)                    # Embree's tfar: the nearest hit so far
        src.fill(0)
        ter, rob = self.terrain, self.robot
        terrain_hits = _intersect(ter.scene, start32, d32, best) if ter is not None and ter.scene else _NO_TERRAIN
        if rob is not None and m:
            if candidates is None:
                centre, group_centre, group_radius = self.spheres()
                candidates = link_candidates(o_w, d_w, lo, best, centre, rob.radius, rob.groups,
                                             group_centre, group_radius)
            offsets, rays = candidates
            rotations, positions = self.rotations, self.link_poses[:, :3]
            for k in np.flatnonzero(offsets[1:] > offsets[:-1]):
                ids = rays[offsets[k]:offsets[k + 1]]
                row = rob.rows[k]
                R, p = rotations[row], positions[row]
                ids, o_l, d_l, far = link_rays(ids, o_w, d_w, lo, best, R, p, *rob.box[k])
                if not len(ids):
                    continue
                geom, prim, ng = _intersect(rob.scenes[k], o_l, d_l, far)
                take_link_hits(ids, geom, far, prim, ng, R, rob.face_ids[k], best, src, face, ng_r)
        tables_t = ter.tables if ter is not None else _EMPTY_TERRAIN
        tables_r = rob.tables if rob is not None else _EMPTY_ROBOT
        finish_hits(d_w, lo, hi, best, src, face, ng_r, *terrain_hits, *tables_t, *tables_r, *outputs)
