"""The per-ray loops of the perception sensors, compiled (numba; every ray is independent, so
the loops split over the cores): what Embree returns turned into hits, and hits into pixels,
without a Python or NumPy pass per quantity.

    rays_to_world   sensor-frame rays to the world (float64), and Embree's float32 copies
                    starting at min_range
    nearest_hits    per ray, the nearest of the terrain's and the robot's Embree hits: range,
                    unit normal facing the ray, albedo, colour, link row, material, and
                    whether the hit is on a face that only approximates a curved terrain
    develop         per hit pixel, Lambertian shading (.reflectance) with a headlamp or a sun,
                    and the pixel's range and optical-frame depth
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

MISS = -1


@njit(cache=True, nogil=True, parallel=True)
def rays_to_world(o_l, d_l, R, p, min_range, o_w, d_w, start32, d32):
    """o_w = p + R·o_l, d_w = R·d_l per ray; start32 = o_w + min_range·d_w and d32 in float32."""
    for i in prange(o_l.shape[0]):
        for a in range(3):
            o = p[a] + R[a, 0] * o_l[i, 0] + R[a, 1] * o_l[i, 1] + R[a, 2] * o_l[i, 2]
            d = R[a, 0] * d_l[i, 0] + R[a, 1] * d_l[i, 1] + R[a, 2] * d_l[i, 2]
            o_w[i, a], d_w[i, a] = o, d
            start32[i, a] = o + min_range * d
            d32[i, a] = d


@njit(cache=True, nogil=True, parallel=True)
def nearest_hits(d, min_range, max_range,
                 geom_a, t_a, prim_a, ng_a, robot_in_a,
                 geom_b, t_b, prim_b, ng_b,
                 albedo_t, color_t, refine_t, material_t, albedo_r, color_r, link_r,
                 distance, normal, albedo, color, link, material, refine):
    """Fill the output arrays (n rays) from Embree's raw hits in one or two scenes: scene A holds
    the terrain as geometry 0 and, when ``robot_in_a``, the robot as geometry 1; scene B (raw
    arrays of length n, else length 0: absent) holds the robot alone. Distances are from the
    rays' start plus min_range; hits beyond max_range are misses (inf)."""
    n = d.shape[0]
    has_a, has_b = geom_a.shape[0] == n, geom_b.shape[0] == n
    for i in prange(n):
        best = math.inf
        src = 0             # 0 none, 1 terrain (A), 2 robot in A, 3 robot in B
        if has_a and geom_a[i] != MISS:
            best = t_a[i]
            src = 2 if (robot_in_a and geom_a[i] == 1) else 1
        if has_b and geom_b[i] != MISS and t_b[i] < best:
            best, src = t_b[i], 3
        refine[i] = False
        material[i] = MISS
        link[i] = MISS
        if src == 0 or best + min_range > max_range:
            distance[i] = math.inf
            continue
        distance[i] = best + min_range
        if src == 1:
            f = prim_a[i]
            nx, ny, nz = ng_a[i, 0], ng_a[i, 1], ng_a[i, 2]
            albedo[i] = albedo_t[f]
            for c in range(3):
                color[i, c] = color_t[f, c]
            material[i] = material_t[f]
            refine[i] = refine_t[f]
        else:
            if src == 2:
                f = prim_a[i]
                nx, ny, nz = ng_a[i, 0], ng_a[i, 1], ng_a[i, 2]
            else:
                f = prim_b[i]
                nx, ny, nz = ng_b[i, 0], ng_b[i, 1], ng_b[i, 2]
            albedo[i] = albedo_r[f]
            for c in range(3):
                color[i, c] = color_r[f, c]
            link[i] = link_r[f]
        s = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz)
        # facing the ray: a surface seen from behind (an open mesh, a wall's back) shades as its front
        if nx * d[i, 0] + ny * d[i, 1] + nz * d[i, 2] > 0.0:
            s = -s
        normal[i, 0], normal[i, 1], normal[i, 2] = nx * s, ny * s, nz * s


@njit(cache=True, nogil=True, parallel=True)
def develop(pixel, o_z, d_z, d_w, distance, normal, reflect, headlamp, to_sun, intensity, ambient,
            reference_range, shadowed, image, depth, rng):
    """Write each hit ray's pixel: image[p, :] = reflect·(ambient + E·cos θ) (E·(r_ref/r)² for a
    headlamp, l = −ray; a sun's l = to_sun, 0 where shadowed), range r, depth o_z + r·d_z."""
    for k in prange(pixel.shape[0]):
        r = distance[k]
        if not math.isfinite(r):
            continue
        p = pixel[k]
        if headlamp:
            cos = -(normal[k, 0] * d_w[k, 0] + normal[k, 1] * d_w[k, 1] + normal[k, 2] * d_w[k, 2])
            e = intensity * max(cos, 0.0) * (reference_range / r) ** 2
        elif shadowed[k]:
            e = 0.0
        else:
            cos = normal[k, 0] * to_sun[0] + normal[k, 1] * to_sun[1] + normal[k, 2] * to_sun[2]
            e = intensity * max(cos, 0.0)
        for c in range(image.shape[1]):
            image[p, c] = reflect[k, c] * (ambient + e)
        rng[p] = r
        depth[p] = o_z[k] + r * d_z[k]
