"""The per-ray loops of the perception sensors, compiled (numba): what Embree returns turned into
hits, and hits into pixels, without a Python or NumPy pass per quantity.

    rays_to_world     sensor-frame rays to the world (float64), and Embree's float32 copies
                      starting at min_range
    link_cones        each robot link's cone seen from a sensor bundle's origin ball: its bounding
                      sphere's, or its box's where narrower (.ray_caster.RayBundle.link_cones)
    bundle_link_rays  which rays of a sensor's bundle (rays from about one point) can meet which
                      robot link: directions within the cone the link's bounding sphere (or box)
                      subtends, tested only in the direction bins that cone overlaps, then the
                      segment against the link's box, moved straight from the sensor frame into
                      the link's; links in the order given (nearest first) -> per link its rays,
                      in its frame, and where they enter its box
    tighten           a link's rays of bundle_link_rays cut by the best hits so far (the terrain,
                      and the links nearer the sensor, cast first)
    link_candidates   which rays can meet which link, for any rays (shadow rays): the ray's segment [start, start +
                      best·d] against the link's bounding sphere (world), culled first by
                      spheres around groups of consecutive links; -> CSR lists per link
    link_rays         a link's candidate rays in its link frame (float32, Embree's input), those
                      that meet its box before their nearest hit so far (far)
    take_link_hits    a link's Embree hits (nearer than the best so far, by construction) into
                      the per-ray best: distance, robot face, normal turned into the world
    take_mount_hits   the same for the hits of a sensor's bundle on the link it is fixed to (and
                      the links fixed to that one), cast once in that link's frame (a link cannot
                      move against itself), where nearer than the best so far
    gather_reaching   the rays whose segment up to their best hit so far meets a box (the
                      terrain's bounds), gathered for Embree; scatter_hits puts its hits back
    finish_hits       per ray, the final hit: range from the origin, unit normal facing the ray,
                      albedo, colour, link row, material, and whether the hit is on a face that
                      only approximates a curved terrain
    develop           per pixel its label and, where hit, Lambertian shading (.reflectance) with a
                      headlamp or a sun, and the pixel's range and optical-frame depth

Every kernel is serial and works on one chunk of rays: the caster runs the chunks in threads
(these kernels release the GIL; ray_caster.in_chunks). No numba parallel region:
on a loaded machine its workers wait on descheduled threads (measured: a 65k-ray prange
kernel of 0.25 ms took 9 ms on average with the 2 cores busy). A kernel that writes arrays reads
a matrix's entries into scalars first (``R_entries``) and its inlined helpers take scalars, not
arrays: numba cannot tell that the arrays do not overlap, so it would read the matrix again after
every write, and an inlined helper's array arguments cost a reference count each per call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MISS = -1
#: ``src`` codes of take_link_hits / finish_hits: the ray's best hit so far is a robot face
ROBOT = 2


@njit(cache=True, nogil=True, inline="always")
def R_entries(R):
    """A 3x3 matrix's entries as scalars, row by row: a loop that writes arrays then keeps them in
    registers (read from R it would read them again after every write: the arrays might overlap)."""
    return R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2]


@njit(cache=True, nogil=True)
def rays_to_world(o_l, d_l, R, p, min_range, o_w, d_w, start32, d32):
    """o_w = p + R·o_l, d_w = R·d_l per ray; start32 = o_w + min_range·d_w and d32 in float32."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R_entries(R)
    p0, p1, p2 = p[0], p[1], p[2]
    for i in range(o_l.shape[0]):
        x, y, z = o_l[i, 0], o_l[i, 1], o_l[i, 2]
        o0 = p0 + r00 * x + r01 * y + r02 * z
        o1 = p1 + r10 * x + r11 * y + r12 * z
        o2 = p2 + r20 * x + r21 * y + r22 * z
        x, y, z = d_l[i, 0], d_l[i, 1], d_l[i, 2]
        d0, d1, d2 = r00 * x + r01 * y + r02 * z, r10 * x + r11 * y + r12 * z, r20 * x + r21 * y + r22 * z
        o_w[i, 0], o_w[i, 1], o_w[i, 2] = o0, o1, o2
        d_w[i, 0], d_w[i, 1], d_w[i, 2] = d0, d1, d2
        start32[i, 0], start32[i, 1], start32[i, 2] = o0 + min_range * d0, o1 + min_range * d1, o2 + min_range * d2
        d32[i, 0], d32[i, 1], d32[i, 2] = d0, d1, d2


@njit(cache=True, nogil=True, inline="always")
def _meets(sx, sy, sz, dx, dy, dz, t1, c, r):
    """Whether the segment s + t·d, 0 <= t <= t1 (d unit), passes within r of the point c."""
    ox, oy, oz = c[0] - sx, c[1] - sy, c[2] - sz
    t = min(max(ox * dx + oy * dy + oz * dz, 0.0), t1)
    qx, qy, qz = ox - t * dx, oy - t * dy, oz - t * dz
    return qx * qx + qy * qy + qz * qz <= r * r


@njit(cache=True, nogil=True)
def link_candidates(o, d, min_range, best, centre, radius, group_first, group_centre, group_radius):
    """Rays (world origins o, unit directions d; segment from o + min_range·d over ``best``) that
    meet each link's bounding sphere (centre (L, 3) world, radius (L,)); links are tested only
    inside a group sphere they belong to (group g: links group_first[g] .. group_first[g+1]-1).
    -> (offsets (L + 1,), rays): link k's rays are rays[offsets[k]:offsets[k + 1]], ascending."""
    n, L, G = o.shape[0], centre.shape[0], group_centre.shape[0]
    counts = np.zeros(L, dtype=np.int64)
    for phase in range(2):
        if phase == 1:
            offsets = np.zeros(L + 1, dtype=np.int64)
            for k in range(L):
                offsets[k + 1] = offsets[k] + counts[k]
            rays = np.empty(offsets[L], dtype=np.int64)
            fill = offsets[:L].copy()
        for i in range(n):
            dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
            sx, sy, sz = o[i, 0] + min_range * dx, o[i, 1] + min_range * dy, o[i, 2] + min_range * dz
            t1 = best[i]
            for g in range(G):
                if not _meets(sx, sy, sz, dx, dy, dz, t1, group_centre[g], group_radius[g]):
                    continue
                for k in range(group_first[g], group_first[g + 1]):
                    if _meets(sx, sy, sz, dx, dy, dz, t1, centre[k], radius[k]):
                        if phase == 0:
                            counts[k] += 1
                        else:
                            rays[fill[k]] = i
                            fill[k] += 1
    return offsets, rays


@njit(cache=True, nogil=True)
def link_cones(R, p, centre_b, rho, centres, radii, reach_max, use_box, link_R, link_p, box_lo, box_hi,
               u, cos_a, sin_a):
    """Each link's cone seen from a bundle's origin ball (centre_b sensor frame, radius rho), the
    sensor at (R, p): axis u (L, 3) sensor frame, cos and sin of the half-angle (RayBundle.link_cones
    says which cone and why)."""
    o0 = np.empty(3)
    for a in range(3):
        o0[a] = p[a] + R[a, 0] * centre_b[0] + R[a, 1] * centre_b[1] + R[a, 2] * centre_b[2]
    lo, hi, o_l, ax, w = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(centres.shape[0]):
        vx, vy, vz = centres[k, 0] - o0[0], centres[k, 1] - o0[1], centres[k, 2] - o0[2]
        for a in range(3):               # Rᵀ(c − o₀)
            u[k, a] = R[0, a] * vx + R[1, a] * vy + R[2, a] * vz
        D = math.sqrt(vx * vx + vy * vy + vz * vz)
        reach = radii[k] + rho
        if D <= reach:
            cos_a[k], sin_a[k] = -2.0, 0.0
        else:
            sin_a[k] = reach / D
            cos_a[k] = math.sqrt(1.0 - sin_a[k] ** 2)
            for a in range(3):
                u[k, a] /= D
        if use_box:
            inside = True
            for a in range(3):
                lo[a], hi[a] = box_lo[k, a] - rho, box_hi[k, a] + rho
                o_l[a] = (link_R[k, 0, a] * (o0[0] - link_p[k, 0]) + link_R[k, 1, a] * (o0[1] - link_p[k, 1])
                          + link_R[k, 2, a] * (o0[2] - link_p[k, 2]))
                inside = inside and lo[a] <= o_l[a] <= hi[a]
                ax[a] = 0.5 * (lo[a] + hi[a]) - o_l[a]
            na = math.sqrt(ax[0] ** 2 + ax[1] ** 2 + ax[2] ** 2)
            if not inside and na > 0.0:
                cos_box = 1.0
                for c in range(8):
                    for a in range(3):
                        w[a] = (hi[a] if (c >> a) & 1 else lo[a]) - o_l[a]
                    cos_box = min(cos_box, (w[0] * ax[0] + w[1] * ax[1] + w[2] * ax[2])
                                  / (na * math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)))
                cos_box = min(cos_box * (1.0 - 1e-12), 1.0)         # past the rounding of the corners
                if cos_box > 0.0 and cos_box > cos_a[k]:
                    for a in range(3):       # Rᵀ R_l a / |a|
                        wa = (link_R[k, a, 0] * ax[0] + link_R[k, a, 1] * ax[1] + link_R[k, a, 2] * ax[2]) / na
                        w[a] = wa
                    for a in range(3):
                        u[k, a] = R[0, a] * w[0] + R[1, a] * w[1] + R[2, a] * w[2]
                    cos_a[k], sin_a[k] = cos_box, math.sqrt(1.0 - cos_box * cos_box)
        if D - reach > reach_max:
            cos_a[k] = 2.0


@njit(cache=True, nogil=True, inline="always")
def _box_entry(s, v, t1, box_lo, box_hi):
    """Slab test of the segment s + t·v, 0 <= t <= t1, against the box [box_lo, box_hi]:
    -> the entry t, or −1 when it misses."""
    t0 = 0.0
    for a in range(3):
        if v[a] != 0.0:
            ta, tb = (box_lo[a] - s[a]) / v[a], (box_hi[a] - s[a]) / v[a]
            if ta > tb:
                ta, tb = tb, ta
            t0, t1 = max(t0, ta), min(t1, tb)
        elif s[a] < box_lo[a] or s[a] > box_hi[a]:
            return -1.0
    return t0 if t0 <= t1 else -1.0


@njit(cache=True, nogil=True, inline="always")
def _bin_meets_cone(b, k, bin_axis, bin_cos, bin_sin, u, cos_a, sin_a):
    """Whether bin b's cone of rays (axis, half-angle β as cos/sin) overlaps link k's cone (axis u_k,
    half-angle α as cos/sin): the angle between the axes is below α + β, or α + β passes π (wide)."""
    c_ab = bin_axis[b, 0] * u[k, 0] + bin_axis[b, 1] * u[k, 1] + bin_axis[b, 2] * u[k, 2]
    lim = cos_a[k] * bin_cos[b] - sin_a[k] * bin_sin[b]
    wide = sin_a[k] * bin_cos[b] + cos_a[k] * bin_sin[b] < 0.0
    return wide or not c_ab < lim         # (not <: a NaN axis keeps the bin, as it always did)


@njit(cache=True, nogil=True)
def bundle_link_rays(o_b, d_b, bin_first, bin_rays, bin_axis, bin_cos, bin_sin, u, cos_a, sin_a, links, M, c,
                     min_range, reach, box_lo, box_hi):
    """The rays of a bundle that can meet each link, in its frame, for links ``links`` in that
    order (index k into u, M, c, box_lo/hi (L, 3)): each ray of the bundle within link k's cone
    whose segment from its start at min_range over ``reach`` meets the link's box (``tighten``
    then cuts by each ray's nearest hit: this needs no cast, so it can run during the terrain's). The bundle's rays
    are read in bin order (origins o_b, directions d_b (n, 3) sensor frame: ray bin_rays[q] is row
    q) and moved straight from the sensor frame into link k's: x_l = M_k x_s + c_k (M_k = R_lᵀR,
    c_k = R_lᵀ(p − p_l)). -> (offsets (len(links) + 1,), count (len(links),): link links[j]'s rays
    are offsets[j] .. offsets[j] + count[j] of: ids, their starts and directions in the link frame
    (float32), and where they enter its box (t, float32))."""
    B, J = bin_axis.shape[0], links.shape[0]
    offsets = np.zeros(J + 1, dtype=np.int64)
    for j in range(J):                   # the rays of the bins the cone overlaps: an upper bound
        k = links[j]
        m = 0
        if cos_a[k] <= 1.0:
            every = cos_a[k] <= -1.0
            for b in range(B):
                if every or _bin_meets_cone(b, k, bin_axis, bin_cos, bin_sin, u, cos_a, sin_a):
                    m += bin_first[b + 1] - bin_first[b]
        offsets[j + 1] = offsets[j] + m
    N = offsets[J]
    ids, entry = np.empty(N, dtype=np.int64), np.empty(N, dtype=np.float32)
    o_l, d_l = np.empty((N, 3), dtype=np.float32), np.empty((N, 3), dtype=np.float32)
    count = np.zeros(J, dtype=np.int64)
    s, v = np.empty(3), np.empty(3)
    for j in range(J):
        k = links[j]
        if offsets[j + 1] == offsets[j]:
            continue
        every = cos_a[k] <= -1.0
        n = offsets[j]
        for b in range(B):
            if not (every or _bin_meets_cone(b, k, bin_axis, bin_cos, bin_sin, u, cos_a, sin_a)):
                continue
            for q in range(bin_first[b], bin_first[b + 1]):
                dx, dy, dz = d_b[q, 0], d_b[q, 1], d_b[q, 2]
                if not every and dx * u[k, 0] + dy * u[k, 1] + dz * u[k, 2] < cos_a[k]:
                    continue
                x, y, z = o_b[q, 0] + min_range * dx, o_b[q, 1] + min_range * dy, o_b[q, 2] + min_range * dz
                for a in range(3):
                    s[a] = M[k, a, 0] * x + M[k, a, 1] * y + M[k, a, 2] * z + c[k, a]
                    v[a] = M[k, a, 0] * dx + M[k, a, 1] * dy + M[k, a, 2] * dz
                t0 = _box_entry(s, v, reach, box_lo[k], box_hi[k])
                if t0 < 0.0:
                    continue
                ids[n], entry[n] = bin_rays[q], t0
                for a in range(3):
                    o_l[n, a], d_l[n, a] = s[a], v[a]
                n += 1
        count[j] = n - offsets[j]
    return offsets, count, ids, o_l, d_l, entry


@njit(cache=True, nogil=True)
def gather_reaching(start, d, far, box_lo, box_hi, keep, start_out, d_out, far_out):
    """The rays (starts, directions (n, 3), far limits: Embree's float32 rays) whose segment up to
    their far limit, 0 <= t <= far, meets the box [box_lo, box_hi] (a scene's bounds), gathered in
    order: their indices into ``keep``, the rays into ``start_out``, ``d_out``, ``far_out``; -> how
    many. The others cannot hit anything in it nearer."""
    n = 0
    for i in range(start.shape[0]):
        t0, t1 = 0.0, float(far[i])
        for j in range(3):               # slab test (as _box_entry), scalars: no array per ray
            a = 2 - j                    # z first: ground's bounds are thinnest in z, most rays leave there
            s, v = float(start[i, a]), float(d[i, a])
            if v != 0.0:
                ta, tb = (box_lo[a] - s) / v, (box_hi[a] - s) / v
                if ta > tb:
                    ta, tb = tb, ta
                t0, t1 = max(t0, ta), min(t1, tb)
            elif s < box_lo[a] or s > box_hi[a]:
                t0 = math.inf
            if t0 > t1:
                break
        if t0 > t1:
            continue
        keep[n] = i
        for a in range(3):
            start_out[n, a], d_out[n, a] = start[i, a], d[i, a]
        far_out[n] = far[i]
        n += 1
    return n


@njit(cache=True, nogil=True)
def scatter_hits(keep, geom_k, prim_k, ng_k, far_k, geom, prim, ng, far):
    """The Embree hits of gathered rays (gather_reaching) back in place: geom, prim, Ng of ray keep[q]
    from row q, its far limit (the hit's t where hit); every other ray a miss (geom −1)."""
    geom[:] = MISS
    prim[:] = MISS
    for q in range(keep.shape[0]):
        i = keep[q]
        geom[i], prim[i], far[i] = geom_k[q], prim_k[q], far_k[q]
        for a in range(3):
            ng[i, a] = ng_k[q, a]


@njit(cache=True, nogil=True)
def tighten(ids, entry, o_l, d_l, best, far):
    """A link's rays (ids, box entry t, link-frame rays) kept, in place, where they enter its box
    before their best hit so far; far = that best (Embree's tfar). -> how many are kept."""
    n = 0
    for q in range(ids.shape[0]):
        i = ids[q]
        if entry[q] > best[i]:
            continue
        ids[n] = i
        for a in range(3):
            o_l[n, a], d_l[n, a] = o_l[q, a], d_l[q, a]
        far[n] = best[i]
        n += 1
    return n


@njit(cache=True, nogil=True)
def link_rays(rays, o, d, min_range, best, R, p, box_lo, box_hi):
    """The rays ``rays`` in a link frame (R, p the link's pose) that meet the link's box
    [box_lo, box_hi] (link frame) before their best hit: -> (those rays, float32 starts o + min_range·d
    and directions in the link frame, far = best: Embree's tfar, so only nearer hits return)."""
    m = rays.shape[0]
    kept = np.empty(m, dtype=np.int64)
    o_l, d_l, far = np.empty((m, 3), np.float32), np.empty((m, 3), np.float32), np.empty(m, np.float32)
    s, v = np.empty(3), np.empty(3)
    n = 0
    for k in range(m):
        i = rays[k]
        x = o[i, 0] + min_range * d[i, 0] - p[0]
        y = o[i, 1] + min_range * d[i, 1] - p[1]
        z = o[i, 2] + min_range * d[i, 2] - p[2]
        for a in range(3):           # Rᵀ·(s − p), Rᵀ·d
            s[a] = R[0, a] * x + R[1, a] * y + R[2, a] * z
            v[a] = R[0, a] * d[i, 0] + R[1, a] * d[i, 1] + R[2, a] * d[i, 2]
        if _box_entry(s, v, float(best[i]), box_lo, box_hi) < 0.0:    # the segment 0 <= t <= best misses
            continue
        kept[n] = i
        for a in range(3):
            o_l[n, a], d_l[n, a] = s[a], v[a]
        far[n] = best[i]
        n += 1
    return kept[:n], o_l[:n], d_l[:n], far[:n]


@njit(cache=True, nogil=True)
def take_link_hits(rays, geom, tfar, prim, ng, R, face_ids, best, src, face, ng_r):
    """A link's hits (Embree's, link frame; cast with far = best, so every hit is nearer) into the
    per-ray best: distance, src = ROBOT, face (the robot's face index), normal R·Ng (world)."""
    for k in range(rays.shape[0]):
        if geom[k] == MISS:
            continue
        i = rays[k]
        best[i] = tfar[k]
        src[i] = ROBOT
        face[i] = face_ids[prim[k]]
        for a in range(3):
            ng_r[i, a] = R[a, 0] * ng[k, 0] + R[a, 1] * ng[k, 1] + R[a, 2] * ng[k, 2]


@njit(cache=True, nogil=True)
def take_mount_hits(tfar, prim, ng, R, best, src, face, ng_r):
    """Hits cast once on the mount link (Embree's, link frame, from the rays' starts: tfar inf on a
    miss, prim the robot face index) into the per-ray best where nearer: distance, src = ROBOT,
    face, normal R·Ng (world)."""
    for i in range(tfar.shape[0]):
        if tfar[i] >= best[i]:
            continue
        best[i] = tfar[i]
        src[i] = ROBOT
        face[i] = prim[i]
        for a in range(3):
            ng_r[i, a] = R[a, 0] * ng[i, 0] + R[a, 1] * ng[i, 1] + R[a, 2] * ng[i, 2]


@njit(cache=True, nogil=True)
def finish_hits(d, min_range, max_range, best, src, face, ng_r, geom_t, prim_t, ng_t,
                albedo_t, color_t, refine_t, material_t, albedo_r, color_r, link_r,
                distance, normal, albedo, color, link, material, refine):
    """Fill the output arrays from the per-ray best: the robot face ``face`` where src is ROBOT,
    else the terrain's Embree hit (geom_t; length 0: no terrain scene), else a miss (inf).
    Distances are from the rays' start plus min_range; hits beyond max_range are misses."""
    n = d.shape[0]
    has_t = geom_t.shape[0] == n
    for i in range(n):
        refine[i] = False
        material[i] = MISS
        link[i] = MISS
        robot = src[i] == ROBOT
        if not robot and not (has_t and geom_t[i] != MISS):
            distance[i] = math.inf
            continue
        r = best[i] + min_range
        if r > max_range:
            distance[i] = math.inf
            continue
        distance[i] = r
        if robot:
            f = face[i]
            nx, ny, nz = ng_r[i, 0], ng_r[i, 1], ng_r[i, 2]
            albedo[i] = albedo_r[f]
            for c in range(3):
                color[i, c] = color_r[f, c]
            link[i] = link_r[f]
        else:
            f = prim_t[i]
            nx, ny, nz = ng_t[i, 0], ng_t[i, 1], ng_t[i, 2]
            albedo[i] = albedo_t[f]
            for c in range(3):
                color[i, c] = color_t[f, c]
            material[i] = material_t[f]
            refine[i] = refine_t[f]
        normal[i, 0], normal[i, 1], normal[i, 2] = unit_facing(nx, ny, nz, d[i, 0], d[i, 1], d[i, 2])


@njit(cache=True, nogil=True, inline="always")
def unit_facing(nx, ny, nz, dx, dy, dz):
    """The normal (nx, ny, nz) made unit and facing the ray d: a surface seen from behind (an open
    mesh, a wall's back) shades as its front. (Scalars only: an inlined helper that takes arrays
    costs a reference count per array per ray.)"""
    s = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz)
    if nx * dx + ny * dy + nz * dz > 0.0:
        s = -s
    return nx * s, ny * s, nz * s


@njit(cache=True, nogil=True)
def develop(pixel, o_z, d_z, d_w, distance, normal, reflect, headlamp, to_sun, intensity, ambient,
            reference_range, shadowed, ray_label, background, image, depth, rng, label):
    """Write each ray's pixel, all of it: its label; where it hit, image[p, :] = reflect·(ambient +
    E·cos θ) (E·(r_ref/r)² for a headlamp, l = −ray; a sun's l = to_sun, 0 where shadowed), range r,
    depth o_z + r·d_z; where not, ``background`` and NaN range and depth (one pass, into arrays not
    filled before: the pixels' writes are the cost)."""
    sx, sy, sz = to_sun[0], to_sun[1], to_sun[2]
    for k in range(pixel.shape[0]):
        p = pixel[k]
        label[p] = ray_label[k]
        r = distance[k]
        if not math.isfinite(r):
            for c in range(image.shape[1]):
                image[p, c] = background
            rng[p] = math.nan
            depth[p] = math.nan
            continue
        if headlamp:
            cos = -(normal[k, 0] * d_w[k, 0] + normal[k, 1] * d_w[k, 1] + normal[k, 2] * d_w[k, 2])
            e = intensity * max(cos, 0.0) * (reference_range / r) ** 2
        elif shadowed[k]:
            e = 0.0
        else:
            cos = normal[k, 0] * sx + normal[k, 1] * sy + normal[k, 2] * sz
            e = intensity * max(cos, 0.0)
        for c in range(image.shape[1]):
            image[p, c] = reflect[k, c] * (ambient + e)
        rng[p] = r
        depth[p] = o_z[k] + r * d_z[k]
