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

from .hit_kernels import MISS, R_entries, unit_facing
from .labels import NOTHING, hit_label

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
def pixel_hits(d_l, R, pixel, rng, face_of, src_of, near, far, terrain_vertices, terrain_faces,
               robot_vertices, robot_faces, albedo_t, color_t, refine_t, material_t, face_label, albedo_r, color_r,
               link_r, d_w, distance, normal, albedo, color, link, material, refine, label):
    """The pixel buffers into a cast's results in one pass over the rays (ray k is pixel ``pixel[k]``,
    its direction d_l in the camera frame, the camera's axes R in the world; every ray starts at its
    centre): what ``rays_to_world``, Embree's hits, ``finish_hits`` and ``ray_labels`` give in turn,
    without their intermediate arrays (each of those passes walks every ray: memory, not arithmetic,
    is their cost). The world direction d_w; a hit's t from the ray's start at ``near`` rounded to
    float32 and a terrain face's normal to float32, as the Embree path's buffers hold them, so that
    the fields are the same bit for bit."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R_entries(R)
    for k in range(pixel.shape[0]):
        x, y, z = d_l[k, 0], d_l[k, 1], d_l[k, 2]          # as rays_to_world
        dx, dy, dz = r00 * x + r01 * y + r02 * z, r10 * x + r11 * y + r12 * z, r20 * x + r21 * y + r22 * z
        d_w[k, 0], d_w[k, 1], d_w[k, 2] = dx, dy, dz
        refine[k] = False
        material[k] = MISS
        link[k] = MISS
        q = pixel[k]
        r = np.float32(rng[q] - near) + near      # inf: nothing hit
        if not r <= far:
            distance[k] = math.inf
            label[k] = NOTHING
            continue
        distance[k] = r
        f = face_of[q]
        robot = src_of[q] == ROBOT_ID
        V = robot_vertices if robot else terrain_vertices
        F = robot_faces if robot else terrain_faces
        a, b, c = F[f, 0], F[f, 1], F[f, 2]
        u0, u1, u2 = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1], V[b, 2] - V[a, 2]
        v0, v1, v2 = V[c, 0] - V[a, 0], V[c, 1] - V[a, 1], V[c, 2] - V[a, 2]
        nx, ny, nz = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        if robot:
            albedo[k] = albedo_r[f]
            for j in range(3):
                color[k, j] = color_r[f, j]
            link[k] = link_r[f]
            part = NOTHING
        else:
            nx, ny, nz = float(np.float32(nx)), float(np.float32(ny)), float(np.float32(nz))
            albedo[k] = albedo_t[f]
            for j in range(3):
                color[k, j] = color_t[f, j]
            material[k] = material_t[f]
            refine[k] = refine_t[f]
            part = face_label[f]
        normal[k, 0], normal[k, 1], normal[k, 2] = unit_facing(nx, ny, nz, dx, dy, dz)
        label[k] = hit_label(r, link[k], material[k], part)
