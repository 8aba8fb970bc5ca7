"""Ray casting against the physical scene at one instant: Embree (``embreex``) for visibility,
the terrain's own distance field for the exact hit. This is the ``embree`` back end (``EMBREE``,
the default of sensor_scene's ``ray_caster``); ``EmbreeWorld`` implements the sensors' port type,
the ``RayCaster`` protocol (.ray_casting).

    hits = world.cast(origins, directions, max_range, min_range=0)

origins (n, 3) m and unit directions (n, 3), world frame (``cast_from`` takes them in a
sensor frame and its pose). Nothing is built per instant: the terrain is one Embree scene
built once per run (``StaticTerrainScene``; again when a deformable terrain's state changes,
sensor_scene), and each robot link's mesh is its own Embree
scene in its link frame, built once per robot (``RobotScenes``). A ray is cast against the
terrain first (one Embree call for all rays); then against each link it can meet, in its
link frame, o_l = Rᵀ(o − p), d_l = Rᵀd (a rigid motion keeps the distance t), with far = the
nearest hit so far, so a link only returns what is nearer; its normal is turned back into
the world, n = R·n_l. Which rays can meet which link: a sensor's ``RayBundle`` bins its rays
by direction once, and a cast tests only the bins inside the cone the link's bounding
sphere (or box) subtends, then each ray's segment against the link's box, moving it straight
from the sensor frame into the link's (``bundle_link_rays``: it needs no cast, so it runs on
a second thread during the terrain's); the links are then cast nearest first, each one's
rays cut again by the nearest hit so far (``tighten``: a near link hides the links behind
it). A bundle fixed to a link (a sensor's mount) never moves against that link, nor against the
links fixed to it (a lidar's head): its hits on them are cast once and taken as they are, first,
so that they cut the terrain's rays (``RayBundle.mount_hits``). Other rays (shadow rays):
the segment up to the terrain hit against spheres around groups of consecutive links, then
their links'. The nearest of all is the ray's hit: the same as one scene of the terrain and
the posed robot (tests/perception/test_robot_casting.py), without rebuilding a robot BVH each
instant (~20 ms for EELS 1.0's 23k visual faces, most of it embreex copying vertices one by
one).

Embree works in float32 (≈1e-7 relative: 1 µm at 10 m; robot hits are cast in link
coordinates, ≈1e-7 of the link's size). Terrain hits on an analytic kind are then refined
onto the true surface in float64 by Newton's method on the signed distance along the ray,
f(t) = d(o + t·r), f'(t) = n·r, so a plane, wall or tube returns its exact range, not its
tessellation's (until the error left is below a nanometre, REFINE_TOLERANCE; a step larger than
``refine_limit`` keeps the mesh hit; compiled for the Fourier-cylinder kinds, tube and
moulin: .refine_kernels). A DEM's hits are solved onto its bilinear surface, cell by cell
from the ray's origin (the kind's ``refiner``: .refine_kernels.DemRefiner).
Only hits on faces that approximate a curve are refined (``TerrainSurfaces.refine``; a DEM:
every face): a plane's faces are the plane. A cast can skip it (``exact=False``: a sensor's
``terrain_hits: mesh``; its hits are then off along the ray by up to sag/sin θ, θ the grazing
angle, not the sag: docs/perception.md), and leaves unrefined the mesh hits nearer than
``refine_beyond`` whose ray is inside the terrain there (a lidar's minimum range: such a hit only blocks).

The cast runs on ``THREADS`` threads (numba's thread count, the CPU count unless
NUMBA_NUM_THREADS says otherwise; embreex and the compiled kernels release the GIL): the
rays into the world and the terrain's Embree calls in chunks (``CAST_CHUNK_MIN``), which the
threads take in turn, a second thread first finding the links' candidate rays; then the
links, each one Embree call on this thread (few rays each); then the hits' fields in the
same chunks. A thread that is busy or descheduled (a loaded machine) leaves its chunks to the
others. Lighter per-ray kernels split only large casts (``CHUNK_MIN``: an image), the
refinement from a few thousand hits (``REFINE_CHUNK_MIN``). Sensors keep their rays binned
(``RayBundle``), in an order for the chunks (a lidar: its pattern's, whose neighbouring beams
Embree traces faster; a camera's: dealt out to the chunks in blocks, in turn, ``interleaved``), and their
arrays (``CastBuffers``) from one sample to the next.

Results (``RayHits``): ``distance`` (n,) m along the ray, inf where nothing is hit
within [min_range, max_range]; for the hit rays (``hit``), ``normal`` (n, 3) unit, world,
facing the ray; ``albedo`` (n,), ``color`` (n, 3); ``link`` (n,) the link row hit, −1 for
terrain or nothing (the other fields of a missed ray are unset); ``label`` (n,) uint16 what the
ray hit (.labels: nothing, terrain material, robot link, obstacle), every ray.

A sensor that moves during its sample (a spinning lidar's motion distortion, .motion) passes
its rays as they were fired, each from the sensor's pose at its own instant expressed in the
current sensor frame, with the bundle of its nominal rays (``RayBundle.for_moved``): the terrain
is cast along the moved rays, the robot (which moves with its sensor) along the nominal ones.
"""

from __future__ import annotations

import concurrent.futures
import copy
import dataclasses
import functools
import itertools
import math
import os

import numba
import numpy as np

from snakesim.components.multibody.pose_quaternions import rotation_matrices

from .hit_kernels import (bundle_link_rays, finish_hits, link_candidates, link_cones, link_rays, rays_to_world,
                          gather_reaching, scatter_hits, take_link_hits, take_mount_hits, tighten)
from .labels import LABEL_DTYPE, ray_labels, relabel_refined, terrain_face_labels
from .ray_casting import RayCaster, RayCasterBackend
from .refine_kernels import FourierRefiner
from .surfaces import RobotSurfaces, TerrainSurfaces, optical_table
from .textures import apply_textures, texture_table

#: Newton steps at most, and the error (m) a hit is done at: Newton's error after a step of size
#: a_k is ≈ C·a_k² with C ≈ a_k / a_{k−1}² (quadratic convergence, C measured by the steps), so a
#: hit is done once a_k³ < tol·a_{k−1}² (or a_k < tol). Two steps finish most hits from the mesh's
#: (a tube's: all); on a rough wall seen at a grazing angle, from a mesh hit centimetres off, it
#: takes up to six (two fixed steps left 12-15 % of them more than a nanometre off).
REFINE_ITERATIONS = 8
REFINE_TOLERANCE = 1e-9
GRAZING = 1e-3          # |n·r| below this: a Newton step is ill-conditioned; keep the mesh hit
#: threads a cast's compiled kernels run on
THREADS = max(1, int(numba.config.NUMBA_NUM_THREADS))
#: rays per chunk at least of the light kernels run on their own (textures, a camera's pixels:
#: ~6 ns a ray; fewer: on this thread alone): on a lidar frame's rays a handoff to a busy core
#: costs more than they take; the refinement (~0.2 µs per evaluation, several per hit) splits
#: from REFINE_CHUNK_MIN hits
CHUNK_MIN = 65536
REFINE_CHUNK_MIN = 2048
#: rays per chunk at least of the cast itself (world rays, the terrain's Embree call, the hits):
#: two threads' Embree calls overlap when the other core is free (a 64x1024 frame's terrain:
#: 3.6 ms against 4.6 ms in one call) and cost ~0.3 ms more when it is busy
CAST_CHUNK_MIN = 8192
#: share of a chunk's rays at most that reach the terrain's bounds for ``intersect_near`` to cast them
#: apart (the others: gathering and scattering cost more than Embree's culling of the few left out)
REACHING_SHARE = 0.8
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
    #: .labels (a back end may leave it None: sensors then label from ``link`` alone, .labels.labels_of)
    label: np.ndarray | None = None

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
        self.hits = RayHits(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64),
                            np.empty(n, dtype=LABEL_DTYPE))
        self.material, self.refine = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_)
        self.best, self.src = np.empty(n, dtype=np.float32), np.empty(n, dtype=np.int8)
        self.face, self.ng_r = np.empty(n, dtype=np.int64), np.empty((n, 3))
        self._near = None

    def near(self) -> tuple:
        """intersect_near's scratch (made on first use: a lidar's casts): kept rays, their float32
        rays and far limits, the terrain's hits."""
        if self._near is None:
            n = self.n
            self._near = (np.empty(n, dtype=np.int64), np.empty((n, 3), np.float32), np.empty((n, 3), np.float32),
                          np.empty(n, np.float32), np.empty(n, np.int32), np.empty(n, np.int32),
                          np.empty((n, 3), np.float32))
        return self._near


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
_NO_FACES = np.zeros(0, np.int64)


class StaticTerrainScene:
    """The terrain's Embree scene and optical tables (built once; shared by every instant)."""

    def __init__(self, surfaces: TerrainSurfaces, refine_limit: float = 0.5):
        self.surfaces = surfaces
        self.scene = embree_scene((surfaces.vertices, surfaces.faces)) if len(surfaces.faces) else None
        # the mesh's bounds, padded past float32 rounding (``intersect_near``)
        if len(surfaces.faces):
            V = surfaces.vertices[np.unique(surfaces.faces)]
            lo, hi = V.min(axis=0), V.max(axis=0)
            pad = 1e-5 * float(np.abs(V).max()) + 1e-6
            self.bounds = (lo - pad, hi + pad)
        self.refine_limit = float(refine_limit)
        self._albedo, self._color = optical_table(surfaces.terrain.materials)
        self._texture = texture_table(surfaces.terrain.materials)
        self.textured = bool((self._texture[:, 0] != 0).any())
        self.tables = (surfaces.albedo, surfaces.color, surfaces.refine, surfaces.material)
        #: per face its ground-truth label (.labels: an obstacle field's faces their obstacle's)
        self.face_label = terrain_face_labels(surfaces.terrain, surfaces.vertices, surfaces.faces, surfaces.material)
        self._contrast_tables = {1.0: self._texture}
        # the kind's compiled refinement (``Terrain.refiner``, .refine_kernels): tube, moulin: Newton;
        # DEM: the bilinear surface's first crossing
        self.refiner = (FourierRefiner.for_terrain(surfaces.terrain, surfaces.vertices, self.refine_limit + 1.0)
                        if surfaces.refine.any() else None)

    def intersect_near(self, start32, d32, far32, scratch):
        """``_intersect`` of rays many of which cannot reach the terrain (a lidar's beams that its head
        hides centimetres out: ``far32``; those into the sky above flat ground): only the rays whose
        segment reaches the terrain's bounds go to Embree (``gather_reaching``, into ``scratch``:
        CastBuffers.near()'s rows of these rays), the others miss. The same hits as ``_intersect``; on
        a 64x1024 lidar frame of the default scene 2.7 ms of Embree calls become 1.6 ms (Embree's
        per-ray cost is ~25 ns even for a ray it culls at once). A camera's rays gain nothing: Embree
        culls its sky rays as fast as they are gathered."""
        keep, s, d, far, geom, prim, ng = scratch
        m = gather_reaching(start32, d32, far32, self.bounds[0], self.bounds[1], keep, s, d, far)
        if m > REACHING_SHARE * len(far32):
            return _intersect(self.scene, start32, d32, far32)
        geom_k, prim_k, ng_k = _intersect(self.scene, s[:m], d[:m], far[:m])
        scatter_hits(keep[:m], geom_k, prim_k, ng_k, far[:m], geom, prim, ng, far32)
        return geom, prim, ng

    def texture(self, contrast: float = 1.0) -> np.ndarray:
        """The texture table with every material's contrast times ``contrast`` (a sensor's
        ``texture_contrast``: 0 featureless, 1 as the materials say), made once per value."""
        table = self._contrast_tables.get(contrast)
        if table is None:
            table = self._texture.copy()
            table[:, 2] = np.clip(table[:, 2] * contrast, 0.0, 1.0)
            if len(self._contrast_tables) > 8:          # a few sensors' values at most
                self._contrast_tables = {1.0: self._texture}
            self._contrast_tables[contrast] = table
        return table

    def finish(self, o, d, out: RayHits, material: np.ndarray, refine: np.ndarray, exact: bool = True,
               refine_beyond: float = 0.0, texture_contrast: float = 1.0) -> None:
        """Refine the hits on curved faces onto the exact surface (``exact``; compiled kinds: not
        the mesh hits nearer than ``refine_beyond`` whose ray is inside the terrain there, which
        only block); apply material textures (their contrasts times ``texture_contrast``)."""
        curved = np.flatnonzero(refine) if exact else np.zeros(0, dtype=np.int64)
        if curved.size and self.refiner is not None:
            in_chunks(lambda c, k: self.refiner.refine(o, d, curved[k], REFINE_ITERATIONS, REFINE_TOLERANCE, GRAZING,
                                                       self.refine_limit, self._albedo, self._color, out.distance,
                                                       out.normal, out.albedo, out.color, material, refine_beyond),
                      curved.size, REFINE_CHUNK_MIN)
        elif curved.size:
            t, n, mat, ok = self._refine(o[curved], d[curved], out.distance[curved])
            good = curved[ok]
            out.distance[good], out.normal[good] = t[ok], n[ok]
            out.albedo[good], out.color[good] = self._albedo[mat[ok]], self._color[mat[ok]]
            material[good] = mat[ok]
        if self.textured:
            table = self.texture(float(texture_contrast))
            in_chunks(lambda c, k: apply_textures(table, material[k], o[k], d[k], out.distance[k],
                                                  out.albedo[k], out.color[k]), len(material))

    def _refine(self, o, d, t):
        """Newton on f(t) = distance(o + t·d), each ray until the error left is below
        REFINE_TOLERANCE (at most REFINE_ITERATIONS steps): -> t, analytic normal, material, and
        whether it converged (not grazing, within refine_limit of the mesh hit)."""
        terrain = self.surfaces.terrain
        t0, t = t.copy(), t.copy()
        ok = np.ones(len(t), dtype=bool)
        normal, material = np.zeros((len(t), 3)), np.zeros(len(t), dtype=np.int64)
        going, last = np.arange(len(t)), np.zeros(len(t))
        for _ in range(REFINE_ITERATIONS):
            if not going.size:
                break
            q = terrain.query(o[going] + t[going, None] * d[going])
            slope = np.einsum("ij,ij->i", q.normal, d[going])
            graze = np.abs(slope) <= GRAZING
            ok[going[graze]] = False
            step = q.distance / np.where(graze, 1.0, slope)
            t[going] = np.where(graze, t[going], t[going] - step)
            # normal and material from the last query, one step before t (≈ C·step² away: µrad)
            normal[going] = q.normal * np.where(slope > 0, -1.0, 1.0)[:, None]
            material[going] = q.material
            a, tol = np.abs(step), REFINE_TOLERANCE
            done = graze | (a < tol) | (a * a * a < tol * last[going] ** 2)
            last[going] = a
            going = going[~done]
        ok &= np.abs(t - t0) < self.refine_limit
        return np.where(ok, t, t0), normal, material, ok


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
    ray by ray (``bundle_link_rays``).

    ``mount`` (row, R_ls, p_ls): the bundle's frame is fixed to robot link ``row`` (R_ls, p_ls its
    pose in the link frame, as a sensor's .mount). The rays then never move against that link:
    their hits on it are cast once (``mount_hits``) and every cast takes them instead of
    culling and casting that link (a lidar's housing, which its rays start in or next to, is
    the link most of its rays can meet). A cast must then pose the bundle on that link.
    ``rigid`` [(row, R, p), ...]: links fixed to the mount link (R, p their frames in its frame:
    .mount.rigid_links; a lidar's head, whose shell hides some of its beams): their hits are cast
    once as well, and a cast takes them while each is where ``rigid`` says (within
    ``RIGID_TOLERANCE``; else it is cast as any other link). The hits are those of the link cast
    at each instant, but for the float32 rounding of the rays in its frame (≲ 1e-7 of the link's
    size: its pose relative to the mount is the URDF's, not the instant's, rounded otherwise)."""

    BINS = 16
    #: rad, and m relative to the link's offset from the mount link (plus 1 m): how far a rigid
    #: link's instant pose may be from the one its hits were cast at (rounding of the poses: ~1e-15)
    RIGID_TOLERANCE = 1e-9

    def __init__(self, origins, directions, mount=None, rigid=()):
        o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
        self.source = directions          # the array a cast must pass with this bundle
        self.directions = d
        self.origins = o
        self.mount = None
        if mount is not None:
            row, R_ls, p_ls = mount
            self.mount = (int(row), np.array(R_ls, dtype=np.float64).reshape(3, 3),
                          np.array(p_ls, dtype=np.float64).reshape(3))
        self.rigid = [(int(r), np.array(R, dtype=np.float64).reshape(3, 3), np.array(q, dtype=np.float64).reshape(3))
                      for r, R, q in rigid] if mount is not None else []
        self._mount_hits = {}
        #: (width, height, pixel index per ray) when the rays are an image's pixels (a camera's: a
        #: back end may rasterise it, .raster); None otherwise
        self.image = None
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
        # the rays in bin order, contiguous: a cast reads them bin by bin
        self.binned_origins = np.ascontiguousarray(o[order])
        self.binned_directions = np.ascontiguousarray(d[order])

    def for_moved(self, directions: np.ndarray) -> "RayBundle":
        """This bundle standing for ``directions`` (with their origins): the same rays, each moved by the
        sensor's own motion up to its firing instant (a lidar's motion distortion, .motion), in an array the
        sensor reuses from one sample to the next. A cast with it casts the terrain along the moved rays and
        the robot, which moves with its sensor, along this bundle's nominal rays (the mount link's hits
        cast once, as ever). Shares everything with this bundle."""
        moved = copy.copy(self)
        moved.source = directions
        return moved

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

    def link_rays(self, R, p, centres, radii, reach_max: float, link_R, link_p, box, links, min_range: float):
        """Per link of ``links`` (in that order), the rays in its cone that meet its box within
        reach_max − min_range of their start, moved into its frame (``bundle_link_rays``)."""
        u, cos_a, sin_a = self.link_cones(R, p, centres, radii, reach_max, link_R, link_p, box)
        M = np.einsum("kji,jl->kil", link_R, R)                  # R_lᵀ R: sensor -> link frame
        c = np.einsum("kji,kj->ki", link_R, p - link_p)          # R_lᵀ (p − p_l)
        return bundle_link_rays(self.binned_origins, self.binned_directions, self.bin_first, self.bin_rays,
                                self.bin_axis, self.bin_cos, self.bin_sin, u, cos_a, sin_a, links, M, c, min_range,
                                reach_max - min_range, box[0], box[1])

    def mount_hits(self, robot: "RobotScenes", min_range: float, max_range: float):
        """The rays' hits on their mount link and the links fixed to it (``rigid``), each cast once in
        its frame (kept per robot and range): a list of (link row, t (n,) float32 from the rays' starts
        at min_range, inf on a miss, robot face (n,), Embree's normal Ng (n, 3) link frame), the mount
        link first; empty without a mount, and without the links that have no faces."""
        key = (id(robot), float(min_range), float(max_range))
        got = self._mount_hits.get(key)
        if got is not None and got[0] is robot:
            return got[1]
        hits = []
        if self.mount is not None:
            row, R_ls, p_ls = self.mount
            d_m = self.directions @ R_ls.T
            start_m = self.origins @ R_ls.T + p_ls + min_range * d_m
            for r, R_mr, p_mr in [(row, None, None), *self.rigid]:
                k = np.flatnonzero(robot.rows == r)
                if not len(k):
                    continue
                k = int(k[0])
                # the mount link's rays as before; a rigid link's moved into its frame, x_r = R_mrᵀ(x_m − p_mr)
                d_l, start = (d_m, start_m) if R_mr is None else (d_m @ R_mr, (start_m - p_mr) @ R_mr)
                far = np.full(len(d_l), max_range - min_range, np.float32)
                geom, prim, ng = _intersect(robot.scenes[k], start.astype(np.float32), d_l.astype(np.float32), far)
                miss = geom == -1
                far[miss] = np.inf
                face = robot.face_ids[k][np.where(miss, 0, prim)]
                hits.append((r, far, face, np.ascontiguousarray(ng, dtype=np.float32)))
        if len(self._mount_hits) > 3:          # a few robots or ranges at most: the oldest go
            self._mount_hits.clear()
        self._mount_hits[key] = (robot, hits)      # the robot kept: its id cannot be reused meanwhile
        return hits

    def rigid_in_place(self, rotations: np.ndarray, positions: np.ndarray) -> list[int]:
        """The rows of the ``rigid`` links at the pose ``rigid`` gives them on the mount link at this
        instant (link axes (nl, 3, 3), positions (nl, 3) world), within RIGID_TOLERANCE."""
        if not self.rigid:
            return []
        m = self.mount[0]
        R_wm, p_wm = rotations[m], positions[m]
        tol = self.RIGID_TOLERANCE
        return [r for r, R_mr, p_mr in self.rigid
                if np.abs(rotations[r] - R_wm @ R_mr).max() <= tol
                and np.abs(positions[r] - p_wm - R_wm @ p_mr).max() <= tol * (1.0 + np.abs(p_mr).max())]


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


@functools.lru_cache(maxsize=256)
def chunks(n: int, minimum: int = CHUNK_MIN) -> tuple[slice, ...]:
    """The ranges n rays are split into (SPLIT per thread; one when n < 2·minimum); kept per (n,
    minimum): a frame asks for its sensors' few sizes many times (~1.5 ms a frame made afresh)."""
    k = max(1, min(THREADS * SPLIT if THREADS > 1 else 1, n // minimum))
    edges = np.linspace(0, n, k + 1).astype(int)
    return tuple(slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]))


def interleaved(n: int, block: int = 64) -> np.ndarray:
    """A cast order of n rays (a permutation) that deals them out to the chunks in blocks of
    ``block`` consecutive rays, in turn: each of the k chunks gets every k-th block, so each covers
    the whole field of view, not a band of it (an image's upper half is sky, cheap; its lower half
    ground), while a block's rays stay neighbours: a kernel that reads or writes per pixel (a
    raster's buffers, the image) walks whole cache lines, which one ray in k would share with the
    other threads' chunks (measured: a rasterised 640x480 stereo pair on two threads, median 10.0
    against 12.1 ms). A lidar keeps its pattern order instead: its beams are fewer and their
    neighbours' paths alike (.lidar)."""
    return np.argsort((np.arange(n) // block) % len(chunks(n)), kind="stable")


def in_chunks(fn, n: int, minimum: int = CHUNK_MIN) -> None:
    """fn(chunk index, slice) for each of chunks(n, minimum), on THREADS threads (this one among
    them), each taking the next chunk when it is done with one."""
    parts = chunks(n, minimum)
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
        if not f.cancel():        # not started (a busy or descheduled thread): this one did its chunks
            f.result()


class EmbreeWorld(RayCaster):
    """The physical scene at simulated time ``t`` (a ``RayCaster``, Embree's): the static terrain and the robot at
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
        """(nl, 3, 3) link axes in the world (the LINK_POSES port's quaternions are unit)."""
        if self._rotations is None:
            self._rotations = rotation_matrices(self.link_poses[:, 3:7])
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
                  bundle: RayBundle | None = None, buffers: CastBuffers | None = None, exact: bool = True,
                  refine_beyond: float = 0.0, texture_contrast: float = 1.0):
        """Rays given in a sensor frame at (R, p) in the world: -> (hits, world origins, world
        directions). ``bundle``: the same rays binned (a sensor's, made once), which finds the
        rays that can meet the robot faster than testing each ray against each link (and, with a
        mount, takes its hits on the mount link cast once); ``buffers``: the sensor's CastBuffers
        of as many rays, written over (else fresh arrays). ``exact``: terrain hits on curved
        faces refined onto the analytic surface (False: the mesh's hits, as Embree returns them);
        ``refine_beyond`` m: a mesh hit nearer than this whose ray is inside the terrain there is
        not refined (it only blocks: a lidar's minimum range; its distance stays below this);
        ``texture_contrast``: the terrain materials' texture contrasts times this (0: featureless)."""
        n = len(origins)
        b = buffers if buffers is not None and buffers.n == n else CastBuffers(n)
        o_w, d_w, start32, d32 = b.o_w, b.d_w, b.start32, b.d32
        R, p = np.ascontiguousarray(R, dtype=np.float64), np.asarray(p, dtype=np.float64)
        if bundle is not None and bundle.source is not directions:
            raise ValueError("cast_from: the bundle was made from other rays than the directions given")
        # rows of missed rays are left unset except distance (inf): readers select hits first
        lo, hi = float(min_range), float(max_range)
        ter, rob = self.terrain, self.robot
        # the links' candidate rays need no cast: found on the other thread while this one starts
        # on the terrain (that thread then takes terrain chunks too)
        robot = self._robot_rays(R, p, bundle, lo, hi) if rob is not None and n and bundle is not None else None
        terrain_hits = [_NO_TERRAIN] * len(chunks(n, CAST_CHUNK_MIN))
        # the hits on the mount link and the links fixed to it where they are (cast once): taken first,
        # so that they cut the terrain's rays (a lidar's head hides ~40 % of its beams, centimetres out)
        fixed = robot[-1] if robot is not None else []
        mounted = [(t, f, ng, self.rotations[row]) for row, t, f, ng in bundle.mount_hits(rob, lo, hi)
                   if row in fixed] if fixed else []
        near = b.near() if mounted else None

        def first(c, sl):                    # world rays, then the terrain: best = its hit's t
            rays_to_world(origins[sl], directions[sl], R, p, lo, o_w[sl], d_w[sl], start32[sl], d32[sl])
            b.best[sl].fill(hi - lo)         # Embree's tfar: the nearest hit so far
            b.src[sl].fill(0)
            for t_m, face_m, ng_m, R_m in mounted:
                take_mount_hits(t_m[sl], face_m[sl], ng_m[sl], R_m, b.best[sl], b.src[sl], b.face[sl], b.ng_r[sl])
            if ter is not None and ter.scene is not None:
                if mounted:                  # many rays end within centimetres, on the mount's links
                    terrain_hits[c] = ter.intersect_near(start32[sl], d32[sl], b.best[sl], [a[sl] for a in near])
                    b.src[sl][terrain_hits[c][0] != -1] = 0      # nearer than the link's hit (or as near: kept)
                else:
                    terrain_hits[c] = _intersect(ter.scene, start32[sl], d32[sl], b.best[sl])

        in_chunks(first, n, CAST_CHUNK_MIN)
        if robot is not None:
            self._cast_bundle_robot(R, p, bundle, lo, hi, b, *robot)
        elif rob is not None and n:
            self._cast_robot(o_w, d_w, lo, b)
        return self._finish_cast(b, o_w, d_w, lo, hi, terrain_hits, exact, refine_beyond, texture_contrast)

    def _finish_cast(self, b: CastBuffers, o_w, d_w, lo: float, hi: float, terrain_hits: list, exact: bool,
                     refine_beyond: float, texture_contrast: float):
        """After visibility (per ray: ``b.best``, ``b.src``, a robot hit's ``b.face``, ``b.ng_r``; per
        chunk of chunks(n, CAST_CHUNK_MIN) the terrain's (geomID, primID, Ng)): the hits' fields and
        labels, the refinement onto curved terrain and textures. -> (hits, o_w, d_w)."""
        n = len(d_w)
        out, material, refine = b.hits, b.material, b.refine
        ter, rob = self.terrain, self.robot
        tables_t = ter.tables if ter is not None else _EMPTY_TERRAIN
        tables_r = rob.tables if rob is not None else _EMPTY_ROBOT
        face_label = ter.face_label if ter is not None else _NO_FACES

        def finish(c, sl):                   # the hits, and their labels while the chunk is in cache
            finish_hits(d_w[sl], lo, hi, b.best[sl], b.src[sl], b.face[sl], b.ng_r[sl], *terrain_hits[c], *tables_t,
                        *tables_r, out.distance[sl], out.normal[sl], out.albedo[sl], out.color[sl], out.link[sl],
                        material[sl], refine[sl])
            ray_labels(out.distance[sl], out.link[sl], material[sl], terrain_hits[c][0], terrain_hits[c][1],
                       face_label, out.label[sl])

        in_chunks(finish, n, CAST_CHUNK_MIN)
        return self._finish_terrain(b, o_w, d_w, hi, exact, refine_beyond, texture_contrast)

    def _finish_terrain(self, b: CastBuffers, o_w, d_w, max_range: float, exact: bool, refine_beyond: float,
                        texture_contrast: float):
        """After the hits' fields and labels (``_finish_cast``): the refinement of hits on curved terrain
        (``exact``) and textures, and the labels refinement changes. -> (hits, o_w, d_w)."""
        out, material, refine = b.hits, b.material, b.refine
        ter = self.terrain
        if ter is not None and ((exact and refine.any()) or ter.textured):
            ter.finish(o_w, d_w, out, material, refine, exact, refine_beyond,        # distances are from the origins
                       texture_contrast)
            far = out.distance > max_range        # a refined hit may move past the range by rounding
            out.distance[far] = np.inf
            if exact:                             # refinement may move a hit onto another material, or out of range
                relabel_refined(np.flatnonzero(refine), out.distance, material, out.label)
        return out, o_w, d_w

    def _robot_rays(self, R, p, bundle: RayBundle, lo: float, hi: float):
        """The links a bundle's rays can meet, nearest first (the mount link and the links fixed to it
        left out where they are: their hits are cast once), and their candidate rays in their frames
        (``RayBundle.link_rays``), computed on a cast thread during the terrain's when there are two
        (measured on a 64x1024 lidar frame, load ~4: min 7.9 ms against 8.5 ms found after it):
        -> (links, the future or None, the arguments, the rows whose hits are cast once)."""
        rob = self.robot
        rotations, positions = self.rotations, self.link_poses[:, :3]
        centres = self.spheres()[0]
        links = np.arange(len(rob.rows))
        if bundle.mount is not None:
            row, R_ls, p_ls = bundle.mount
            R_wl, p_wl = rotations[row], positions[row]
            if (np.abs(R - R_wl @ R_ls).max() > 1e-9
                    or np.abs(p - p_wl - R_wl @ p_ls).max() > 1e-9 * (1.0 + np.abs(p_wl).max())):
                raise ValueError(f"cast_from: the bundle is fixed to link row {row} at its mount pose, "
                                 "but the rays were posed elsewhere: give R, p = R_wl·R_ls, p_wl + R_wl·p_ls")
            # the mount link, and the links fixed to it where they are: cast once (``mount_hits``)
            fixed = [row, *bundle.rigid_in_place(rotations, positions)]
            links = links[~np.isin(rob.rows, fixed)]
        else:
            fixed = []
        # nearest first: its hits shorten the rays of the links it hides (``tighten``)
        links = links[np.argsort(np.linalg.norm(centres[links] - p, axis=1) - rob.radius[links], kind="stable")]
        rows = rob.rows
        args = (R, p, centres, rob.radius, hi, rotations[rows], positions[rows], rob.boxes, links, lo)
        return links, (_pool().submit(bundle.link_rays, *args) if THREADS > 1 else None), args, fixed

    def _cast_bundle_robot(self, R, p, bundle, lo, hi, b, links, future, args, fixed):
        """After the terrain (and the hits of the mount link and the links ``fixed`` to it, taken with
        it: ``cast_from``), each other link's candidate rays
        (``_robot_rays``), nearest link first, each cut by the nearest hit so far (``tighten``) and
        cast with it as Embree's far limit."""
        rob = self.robot
        best, src, face, ng_r = b.best, b.src, b.face, b.ng_r
        rotations = self.rotations
        # not started yet (the thread busy or descheduled on a loaded machine): found here instead
        found = future.result() if future is not None and not future.cancel() else bundle.link_rays(*args)
        offsets, count, ids, o_l, d_l, entry = found
        far = np.empty(len(ids), dtype=np.float32)
        for j in np.flatnonzero(count):
            k, a = links[j], offsets[j]
            sl = slice(a, a + count[j])
            m = tighten(ids[sl], entry[sl], o_l[sl], d_l[sl], best, far[sl])
            if m:
                sl = slice(a, a + m)
                row = rob.rows[k]
                geom, prim, ng = _intersect(rob.scenes[k], o_l[sl], d_l[sl], far[sl])
                take_link_hits(ids[sl], geom, far[sl], prim, ng, rotations[row], rob.face_ids[k], best, src, face,
                               ng_r)

    def _cast_robot(self, o_w, d_w, lo, b):
        """After the terrain, rays without a bundle (shadow rays): each ray's segment up to its
        terrain hit against the links' spheres (``link_candidates``), then link by link."""
        rob = self.robot
        best, src, face, ng_r = b.best, b.src, b.face, b.ng_r
        rotations, positions = self.rotations, self.link_poses[:, :3]
        centres, group_centre, group_radius = self.spheres()
        offsets, rays = link_candidates(o_w, d_w, lo, best, centres, rob.radius, rob.groups, group_centre,
                                        group_radius)
        for k in np.flatnonzero(offsets[1:] > offsets[:-1]):
            row = rob.rows[k]
            R_l, p_l = rotations[row], positions[row]
            ids, o_l, d_l, far = link_rays(rays[offsets[k]:offsets[k + 1]], o_w, d_w, lo, best, R_l, p_l,
                                           *rob.box[k])
            if len(ids):
                geom, prim, ng = _intersect(rob.scenes[k], o_l, d_l, far)
                take_link_hits(ids, geom, far, prim, ng, R_l, rob.face_ids[k], best, src, face, ng_r)


#: the name SensorWorld had when it was both the port type and this implementation
SensorWorld = EmbreeWorld

#: the ``embree`` back end: what sensor_scene builds with it (registered in components/plugin.py)
EMBREE = RayCasterBackend("embree", terrain=StaticTerrainScene, robot=RobotScenes, world=EmbreeWorld)
