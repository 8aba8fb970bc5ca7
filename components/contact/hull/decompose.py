"""Convex decomposition of a collision mesh by axial slabs (paper fig. 4), and coal shapes.

A mesh (the screw's core drum and helical blades, robots/screw_mesh.py) is cut into
``n`` slabs of equal width along an axis; each slab's piece is replaced by its convex
hull. The hull of a clipped solid is the hull of its clipped surface, whose vertices are
the mesh vertices inside the slab plus the points where mesh edges cross the two cut
planes, so no capping is needed.

Why slabs, not a general approximate convex decomposition (V-HACD, CoACD): a screw is
a sweep along its axis, slabs keep the pieces in axial order (one contact per piece,
like the SDF back end's sample rings), and the accuracy/performance trade of fig. 4 is
one integer. Two properties follow from the construction:

  * the hulls lie in disjoint slabs, so their union's volume is the sum of their volumes;
  * refining n -> k·n slices every slab further, and the hull of a subset is inside the
    hull of the set, so the covered volume (and its excess over the true volume) can
    only shrink: the error decreases monotonically along n, 2n, 4n, ...

It does not go to zero for a helical blade: a thin slab of a blade is an annular
sector, which is not convex (its hull fills the chord). The excess volume
excess volume (Σ V_hull − V_mesh) / V_mesh and the largest distance from a hull's
surface to the mesh are what :func:`hull_error` reports.

coal v3.0.3 here is built without qhull (``coal.WITH_QHULL`` is False), so
``coal.ConvexBase.convexHull`` is unavailable; hulls come from trimesh (scipy's qhull)
and enter coal as ``coal.Convex(points, triangles)``.
"""

from __future__ import annotations

import numpy as np


def to_coal_convex(vertices, faces):
    """coal.Convex from hull vertices (m,3) and outward triangles (t,3)."""
    import coal

    pts = coal.StdVec_Vec3s()
    pts.extend([np.asarray(v, dtype=np.float64) for v in vertices])
    tris = coal.StdVec_Triangle()
    tris.extend([coal.Triangle(int(a), int(b), int(c)) for a, b, c in faces])
    return coal.Convex(pts, tris)


def slab_hulls(mesh, n: int, axis=(1.0, 0.0, 0.0)):
    """Convex hulls (list of trimesh.Trimesh) of ``mesh`` cut into ``n`` ≥ 1 equal slabs
    along ``axis`` (unit, mesh frame). Empty slabs are dropped."""
    import trimesh

    if int(n) < 1:
        raise ValueError(f"the number of convex hulls must be ≥ 1, got {n}")
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    verts = np.asarray(mesh.vertices, dtype=float)
    s = verts @ axis
    edges = np.asarray(mesh.edges_unique)
    v0, v1 = verts[edges[:, 0]], verts[edges[:, 1]]
    s0, s1 = s[edges[:, 0]], s[edges[:, 1]]
    cuts = np.linspace(s.min(), s.max(), int(n) + 1)
    # where each edge crosses each cut plane (the clipped solid's new vertices)
    crossings = []
    for c in cuts:
        hit = (s0 - c) * (s1 - c) < 0.0
        f = ((c - s0[hit]) / (s1[hit] - s0[hit]))[:, None]
        crossings.append(v0[hit] + f * (v1[hit] - v0[hit]))
    hulls = []
    for i in range(int(n)):
        a, b = cuts[i], cuts[i + 1]
        inside = verts[(s >= a) & (s <= b)]
        pts = np.concatenate([inside, crossings[i], crossings[i + 1]])
        if len(pts) < 4:
            continue
        hull = trimesh.convex.convex_hull(pts)
        if hull.volume > 0:
            hulls.append(hull)
    return hulls


def hull_error(mesh, hulls, samples: int = 400, seed: int = 0) -> dict:
    """Geometric error of a decomposition against the mesh it replaces.

    volume_excess  (Σ V_hull − V_mesh) / V_mesh   (≥ 0: the hulls cover the mesh)
    max_gap        m, the largest distance from a point of the hulls' surfaces to the
                   mesh (one-sided Hausdorff, from ``samples`` seeded surface samples per
                   hull): how far a terrain point can touch a hull and miss the blades
    """
    import igl

    v_mesh = float(abs(mesh.volume))
    v_hull = float(sum(h.volume for h in hulls))
    rng = np.random.default_rng(seed)
    pts = []
    for h in hulls:
        tri = np.asarray(h.triangles)
        area = np.asarray(h.area_faces)
        face = rng.choice(len(tri), size=samples, p=area / area.sum())
        a, b = rng.random((2, samples))
        flip = a + b > 1.0
        a, b = np.where(flip, 1.0 - a, a), np.where(flip, 1.0 - b, b)
        t = tri[face]
        pts.append(t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0]))
    pts = np.concatenate(pts)
    sd = igl.signed_distance(pts, np.asarray(mesh.vertices, dtype=np.float64),
                             np.asarray(mesh.faces, dtype=np.int64))[0]
    return {"hulls": len(hulls), "volume_mesh": v_mesh, "volume_hulls": v_hull,
            "volume_excess": (v_hull - v_mesh) / v_mesh, "max_gap": float(np.maximum(sd, 0.0).max())}


def screw_mesh(geometry):
    """The screw's solid (core + blades) as a trimesh.Trimesh in the screw link frame
    (x = spin axis), from robots.screw_mesh (exact blade sweep, 48 segments per turn)."""
    import trimesh

    from snakesim.robots.screw_mesh import screw_triangles

    tri = screw_triangles(geometry)
    return trimesh.Trimesh(tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), process=True)
