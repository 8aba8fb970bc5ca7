"""Compiled kernels of the ``raster`` back end (.raster): primary visibility of a pinhole image by
rasterising triangles into a buffer of ranges, each pixel tested against each triangle by the same
test a ray caster makes, in float64.

A pinhole camera's ray through pixel (i, j) (column, row) has, in its frame, the direction
q = (x0 + i·dx, y0 + j·dy, 1) (unit: q/|q|), from the frame's origin. For a triangle a, b, c in
that frame the ray's line meets it iff the three edge functions E_ab(q) = (a × b)·q, E_bc, E_ca
have one sign (homogeneous rasterisation: no clipping, each E affine in i and j), and then at
t = |q|·(n·a)/(n·q) m along the unit ray (n = (b − a) × (c − a)); the hit counts when
near ≤ t ≤ far and t is the nearest so far. That is a ray cast's result for the pixel's ray,
enumerated per triangle instead of per ray: only the pixels in the bounding box of the
triangle's image (its part at z ≥ z_min, the nearest a counted hit can be) are tested. Edge tests
are inclusive: a pixel on an edge shared by two faces is covered by both (a ray caster's
watertight test gives it to one): the two then differ only at silhouettes, where the two tests'
rounding decides a pixel whose ray grazes an edge.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .hit_kernels import MISS, ROBOT

TERRAIN_ID, ROBOT_ID = 0, 1


@njit(cache=True, nogil=True)
def _bbox(a, b, c, x0, dx, y0, dy, z_min, width, row0, row1):
    """Pixel box (i0, i1, j0, j1), half-open, of the triangle's part at z ≥ z_min; i0 ≥ i1 if none."""
    lo_u, hi_u, lo_v, hi_v = math.inf, -math.inf, math.inf, -math.inf
    inside = 0
    for k in range(3):
        p = a if k == 0 else (b if k == 1 else c)
        s = b if k == 0 else (c if k == 1 else a)
        if p[2] >= z_min:
            inside += 1
            u, v = (p[0] / p[2] - x0) / dx, (p[1] / p[2] - y0) / dy
            lo_u, hi_u, lo_v, hi_v = min(lo_u, u), max(hi_u, u), min(lo_v, v), max(hi_v, v)
        if (p[2] >= z_min) != (s[2] >= z_min):      # the edge crosses z = z_min: its point there
            f = (z_min - p[2]) / (s[2] - p[2])
            x, y = p[0] + f * (s[0] - p[0]), p[1] + f * (s[1] - p[1])
            u, v = (x / z_min - x0) / dx, (y / z_min - y0) / dy
            lo_u, hi_u, lo_v, hi_v = min(lo_u, u), max(hi_u, u), min(lo_v, v), max(hi_v, v)
    if inside == 0:
        return 0, 0, 0, 0
    # one pixel of margin: the box's rounding never drops a pixel the exact test would cover
    i0 = max(0, int(math.floor(lo_u)) - 1)
    i1 = min(width, int(math.ceil(hi_u)) + 2)
    j0 = max(row0, int(math.floor(lo_v)) - 1)
    j1 = min(row1, int(math.ceil(hi_v)) + 2)
    return i0, i1, j0, j1


@njit(cache=True, nogil=True)
def raster(vertices, faces, source, x0, dx, y0, dy, width, row0, row1, near, far, z_min, rng, face_of, src_of):
    """Rasterise triangles (``vertices`` (nv, 3) in the camera frame, ``faces`` (nf, 3)) into rows
    [row0, row1) of the pixel buffers: ``rng`` (h·w) m along the unit ray (the nearest so far),
    ``face_of`` the face index, ``src_of`` ``source`` (TERRAIN_ID, ROBOT_ID) where a face is nearer."""
    a, b, c = np.empty(3), np.empty(3), np.empty(3)
    for f in range(faces.shape[0]):
        for k in range(3):
            a[k] = vertices[faces[f, 0], k]
            b[k] = vertices[faces[f, 1], k]
            c[k] = vertices[faces[f, 2], k]
        if a[2] < z_min and b[2] < z_min and c[2] < z_min:
            continue
        i0, i1, j0, j1 = _bbox(a, b, c, x0, dx, y0, dy, z_min, width, row0, row1)
        if i0 >= i1 or j0 >= j1:
            continue
        # edge normals a×b, b×c, c×a and the face normal n; E(q) = e·q with q = (x0 + i·dx, y0 + j·dy, 1)
        e = np.empty((3, 3))
        for k in range(3):
            p = a if k == 0 else (b if k == 1 else c)
            s = b if k == 0 else (c if k == 1 else a)
            e[k, 0] = p[1] * s[2] - p[2] * s[1]
            e[k, 1] = p[2] * s[0] - p[0] * s[2]
            e[k, 2] = p[0] * s[1] - p[1] * s[0]
        u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        v0, v1, v2 = c[0] - a[0], c[1] - a[1], c[2] - a[2]
        nx, ny, nz = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        na = nx * a[0] + ny * a[1] + nz * a[2]
        if nx == 0.0 and ny == 0.0 and nz == 0.0:
            continue                                     # degenerate: no ray meets it
        for j in range(j0, j1):
            y = y0 + j * dy
            r0 = e[0, 1] * y + e[0, 2]
            r1 = e[1, 1] * y + e[1, 2]
            r2 = e[2, 1] * y + e[2, 2]
            ny_ = ny * y + nz
            base = j * width
            for i in range(i0, i1):
                x = x0 + i * dx
                E0 = e[0, 0] * x + r0
                E1 = e[1, 0] * x + r1
                E2 = e[2, 0] * x + r2
                if not ((E0 >= 0.0 and E1 >= 0.0 and E2 >= 0.0) or (E0 <= 0.0 and E1 <= 0.0 and E2 <= 0.0)):
                    continue
                nq = nx * x + ny_
                if nq == 0.0:
                    continue                             # the ray lies in the face's plane
                t = na / nq * math.sqrt(x * x + y * y + 1.0)
                if t < near or t > far or t >= rng[base + i]:
                    continue
                rng[base + i] = t
                face_of[base + i] = f
                src_of[base + i] = source


@njit(cache=True, nogil=True)
def gather(pixel, rng, face_of, src_of, near, terrain_vertices, terrain_faces, robot_vertices, robot_faces,
           best, src, face, ng_r, geom_t, prim_t, ng_t):
    """The pixel buffers into a cast's per-ray arrays (ray k is pixel ``pixel[k]``), as a ray
    caster leaves them for ``finish_hits``: ``best`` the hit's t from the ray's start at ``near``,
    a robot hit's global face and world normal (``robot_vertices`` posed, world), a terrain
    hit's face and normal in geom_t/prim_t/ng_t (geom_t MISS where nothing is hit)."""
    for k in range(pixel.shape[0]):
        p = pixel[k]
        t = rng[p]
        src[k] = 0
        geom_t[k] = MISS
        if not math.isfinite(t):
            continue
        best[k] = t - near
        f = face_of[p]
        robot = src_of[p] == ROBOT_ID
        V = robot_vertices if robot else terrain_vertices
        F = robot_faces if robot else terrain_faces
        a, b, c = F[f, 0], F[f, 1], F[f, 2]
        u0, u1, u2 = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1], V[b, 2] - V[a, 2]
        v0, v1, v2 = V[c, 0] - V[a, 0], V[c, 1] - V[a, 1], V[c, 2] - V[a, 2]
        nx, ny, nz = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        if robot:
            src[k] = ROBOT
            face[k] = f
            ng_r[k, 0], ng_r[k, 1], ng_r[k, 2] = nx, ny, nz
        else:
            geom_t[k] = 0
            prim_t[k] = f
            ng_t[k, 0], ng_t[k, 1], ng_t[k, 2] = nx, ny, nz
