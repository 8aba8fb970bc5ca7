"""The ``raster`` ray-casting back end: a pinhole camera's image by rasterisation, every other cast
by Embree (.ray_caster).

    sensors: {type: sensor_scene, params: {ray_caster: raster}}

A cast whose bundle is a pinhole image (``RayBundle.image``: a camera's, whose rays from one origin
have the directions (x0 + i·dx, y0 + j·dy, 1)/‖·‖ of its pixels (i, j), checked once per bundle,
``pinhole_grid``) finds each pixel's nearest face by rasterising the terrain's sensor mesh and the
robot's link meshes, posed once per instant (.raster_kernels), instead of Embree's per-ray
traversal: on the default scene's 640x480 view of flat ice, ~20 ms of Embree calls become ~2 ms.
After visibility one compiled pass per pixel (``pixel_hits``) gives what the Embree back end's passes
give (world rays, hit fields, labels: the same per-ray code, fused, since each pass over 300 k rays
costs its memory traffic), then the same refinement of hits on curved terrain onto its surface with
``exact`` and textures (``EmbreeWorld._finish_terrain``), so ``terrain_hits`` means the same in both
back ends. Every ray starts at the camera's centre: the cast's world origins are one row, broadcast
(read-only). What differs, against Embree's image of the same
rays: a range is computed in float64 from the pixel's ray and the face's plane (Embree: float32
from the ray's start at ``near``; equal within float32 rounding, ≲ 1e-6 of the range), and a pixel
whose ray grazes a face's edge may go to the face on the other side of the edge (a silhouette
pixel: the two tests round differently); labels are then equal except at such pixels
(tests/perception/test_raster.py). Lidars, shadow rays and non-pinhole cameras cast with Embree.
"""

from __future__ import annotations

import numpy as np

from .ray_caster import (_EMPTY_ROBOT, _EMPTY_TERRAIN, _NO_FACES, CAST_CHUNK_MIN, CastBuffers, EmbreeWorld,
                         RayBundle, RobotScenes, StaticTerrainScene, in_chunks)
from .ray_casting import RayCasterBackend
from .raster_kernels import ROBOT_ID, TERRAIN_ID, pixel_hits, raster

#: a bundle is a pinhole grid when each ray's x/z, y/z is affine in its pixel's column, row to this
#: (relative to the image's extent in x/z, y/z)
GRID_TOLERANCE = 1e-9


def pinhole_grid(bundle: RayBundle):
    """(width, height, pixel per ray, x0, dx, y0, dy) when ``bundle`` is a pinhole image (its
    ``image`` (width, height, pixel per ray) set, every origin 0, every direction's x/z, y/z
    affine in the pixel's column, row within GRID_TOLERANCE); else None. Found once per bundle."""
    got = getattr(bundle, "_pinhole", False)
    if got is not False:
        return got
    grid = None
    if bundle.image is not None and len(bundle.directions):
        width, height, pixel = bundle.image
        d, o = bundle.directions, bundle.origins
        if not np.any(o) and np.all(d[:, 2] > 0):
            i, j = pixel % width, pixel // width
            x, y = d[:, 0] / d[:, 2], d[:, 1] / d[:, 2]
            fit = []
            for value, index in ((x, i), (y, j)):
                A = np.stack([np.ones(len(index)), index.astype(np.float64)], axis=1)
                coef = np.linalg.lstsq(A, value, rcond=None)[0]
                scale = max(np.ptp(value), 1e-300)
                fit.append(coef if np.abs(A @ coef - value).max() <= GRID_TOLERANCE * scale and coef[1] != 0 else None)
            if fit[0] is not None and fit[1] is not None:
                grid = (int(width), int(height), np.ascontiguousarray(pixel, dtype=np.int64),
                        float(fit[0][0]), float(fit[0][1]), float(fit[1][0]), float(fit[1][1]))
    bundle._pinhole = grid
    return grid


class RasterWorld(EmbreeWorld):
    """The physical scene at one instant (a ``RayCaster``): a pinhole image's primary visibility by
    rasterisation, the rest as ``EmbreeWorld``."""

    _posed = None

    def posed_robot(self) -> np.ndarray:
        """The robot's vertices (n, 3) in the world at this instant (once per instant: both eyes of
        a stereo pair use them)."""
        if self._posed is None:
            self._posed = self.robot.surfaces.posed(self.rotations, self.link_poses[:, :3])
        return self._posed

    def cast_from(self, R, p, origins, directions, max_range: float, min_range: float = 0.0,
                  bundle: RayBundle | None = None, buffers: CastBuffers | None = None, exact: bool = True,
                  refine_beyond: float = 0.0, texture_contrast: float = 1.0):
        grid = pinhole_grid(bundle) if bundle is not None and bundle.source is directions else None
        if grid is None:
            return super().cast_from(R, p, origins, directions, max_range, min_range, bundle, buffers, exact,
                                     refine_beyond, texture_contrast)
        width, height, pixel, x0, dx, y0, dy = grid
        n = len(origins)
        b = buffers if buffers is not None and buffers.n == n else CastBuffers(n)
        R, p = np.ascontiguousarray(R, dtype=np.float64), np.asarray(p, dtype=np.float64)
        lo, hi = float(min_range), float(max_range)
        rng, face_of, src_of = _raster_buffers(b, width * height)
        rng.fill(np.inf)
        # a counted hit is at t ≥ near along a unit ray q/‖q‖: at depth z ≥ near / max ‖q‖
        corners = np.array([[x0 + i * dx, y0 + j * dy, 1.0] for i in (0, width - 1) for j in (0, height - 1)])
        z_min = max(lo / np.linalg.norm(corners, axis=1).max(), 1e-9)
        meshes = []
        ter, rob = self.terrain, self.robot
        if ter is not None and len(ter.surfaces.faces):
            meshes.append(((ter.surfaces.vertices - p) @ R, ter.surfaces.faces, TERRAIN_ID))
        if rob is not None:
            meshes.append(((self.posed_robot() - p) @ R, rob.surfaces.faces, ROBOT_ID))

        def band(c, sl):                     # rows whose first pixel is in the slice: each row once
            row0, row1 = -(-sl.start // width), -(-sl.stop // width)
            for vertices, faces, source in meshes:
                raster(vertices, faces, source, x0, dx, y0, dy, width, row0, row1, lo, hi, z_min, rng, face_of,
                       src_of)

        in_chunks(band, width * height)
        empty_v, empty_f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)      # as the surfaces' faces
        tv, tf = (ter.surfaces.vertices, ter.surfaces.faces) if ter is not None else (empty_v, empty_f)
        rv, rf = (self.posed_robot(), rob.surfaces.faces) if rob is not None else (empty_v, empty_f)
        tables_t = ter.tables if ter is not None else _EMPTY_TERRAIN
        tables_r = rob.tables if rob is not None else _EMPTY_ROBOT
        face_label = ter.face_label if ter is not None else _NO_FACES
        out = b.hits

        def hits(c, sl):                     # world rays, hits' fields and labels: one pass (pixel_hits)
            pixel_hits(directions[sl], R, pixel[sl], rng, face_of, src_of, lo, hi, tv, tf, rv, rf, *tables_t,
                       face_label, *tables_r, b.d_w[sl], out.distance[sl], out.normal[sl], out.albedo[sl],
                       out.color[sl], out.link[sl], b.material[sl], b.refine[sl], out.label[sl])

        in_chunks(hits, n, CAST_CHUNK_MIN)
        # every ray from the camera's centre (pinhole_grid: the origins are 0): one row, read-only, for all
        o_w = np.broadcast_to(p + 0.0, (n, 3))
        return self._finish_terrain(b, o_w, b.d_w, hi, exact, refine_beyond, texture_contrast)


def _raster_buffers(b: CastBuffers, pixels: int):
    """The pixel buffers (range, face, source) of a sensor's raster casts, kept with its CastBuffers."""
    got = getattr(b, "raster", None)
    if got is None or len(got[0]) != pixels:
        got = (np.empty(pixels), np.empty(pixels, dtype=np.int64), np.empty(pixels, dtype=np.int8))
        b.raster = got
    return got


#: the ``raster`` back end (registered in components/plugin.py): Embree's scenes, kept for what it casts
RASTER = RayCasterBackend("raster", terrain=StaticTerrainScene, robot=RobotScenes, world=RasterWorld)
