"""Display mesh of an obstacle field: on the surface, wound towards free space, coloured by region,
and closed where ice meets rock (a ray-casting sensor uses the same mesh)."""

import numpy as np
import pytest

from snakesim.components.terrain import Block, Material, ObstacleField, Rock, load_terrain
from snakesim.components.viz.terrain_geometry import BLOCK_TONE, ICE, ROCK_TONE, SPHERE_CHORD, terrain_mesh

F32 = 1e-5          # vertices are float32
rng = np.random.default_rng(5)

MIXED = ObstacleField(
    0.0,
    [Block((0.6, 0.5, 0.15), (0.4, 0.3, 0.3), yaw=0.4),                       # resting
     Block((1.5, -0.6, 0.05), (0.5, 0.4, 0.3), roll=0.3, pitch=-0.2, yaw=1.0),  # tilted, half sunk
     Block((-0.8, -0.9, 0.4), (0.3, 0.3, 0.2), yaw=0.2),                      # floating: its bottom shows
     Block((-1.0, 1.0, -0.5), (0.3, 0.3, 0.2))],                              # buried: not drawn
    [Rock((1.3, 0.7, -0.1), 0.3), Rock((-0.3, 0.0, 0.12), 0.12),             # boulder; a ball on the ice
     Rock((0.4, -1.2, 0.2), 0.25), Rock((-1.2, 0.2, -0.5), 0.2),              # centre above the ice; buried
     Rock((2.2, 1.8, -0.05), 0.3)],                                           # across the square's edge
    materials=(Material(name="ice"), Material(name="granite"), Material(name="basalt")),
    region_material=(0, 1, 2))

COURSE = load_terrain("obstacle-course")
CASES = {"mixed": (MIXED, (0.3, 0.1, 0.0), 2.0, 0.25),
         "mixed-fine": (MIXED, (0.0, 0.0, 0.0), 1.7, 0.1),
         "obstacle-course": (COURSE, (4.0, 0.0, 0.0), 5.0, 0.25),
         "obstacle-course-one-cell": (COURSE, (4.0, 0.0, 0.0), 5.0, 10.0)}   # as a sensor draws flat ground


def _vertex_tolerance(case):
    # where several footprints share a ground cell, the cut of one may leave ice vertices inside
    # another rock's rim polygon by up to its sagitta (module doc of terrain_geometry)
    return 0.5 * SPHERE_CHORD if case.endswith("one-cell") else F32


def _faces(m):
    tri = m.vertices.astype(float)[m.faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(n, axis=1)
    return tri, n / np.maximum(2 * area, 1e-300)[:, None], area


@pytest.mark.parametrize("case", list(CASES))
def test_vertices_on_the_surface_and_faces_towards_free_space(case):
    t, center, extent, cell = CASES[case]
    m = terrain_mesh(t, center=center, extent=extent, cell=cell)
    assert np.abs(t.distance(m.vertices.astype(float))).max() < _vertex_tolerance(case)
    tri, n, area = _faces(m)
    assert area.min() > 1e-10                                   # no degenerate triangles
    c = tri.mean(axis=1)
    # flat faces lie on the surface; a rock's facets dip inside its sphere by at most about the chord
    dc = t.distance(c)
    assert dc.min() > -1.2 * SPHERE_CHORD and dc.max() < F32
    # every face's winding normal points up the distance field, towards free space ...
    eps = 2.5 * SPHERE_CHORD
    assert (t.distance(c + eps * n) > t.distance(c - eps * n)).all()
    # ... and a step past the chord error reaches it, but in the acute creases under overhanging
    # rocks (centre above the ice) and leaning blocks, where a face is within a step of the ice and
    # of the obstacle
    free = t.distance(c + eps * n) > 0
    assert np.mean(free) > 0.99
    tight = c[~free]
    solo = [ObstacleField(-100.0, [b]) for b in t.blocks] + [ObstacleField(-100.0, rocks=[r]) for r in t.rocks]
    to_obstacle = np.min([np.abs(o.distance(tight)) for o in solo], axis=0) if len(tight) else 0.0
    assert (tight[:, 2] - t.ground_height < 2 * eps).all() and np.all(to_obstacle < 2 * eps)
    # and the stored (display) normals agree with the winding
    assert (np.einsum("ij,ij->i", m.normals[m.faces[:, 0]], n) > 0.9).all()


@pytest.mark.parametrize("case", list(CASES))
def test_vertical_rays_find_the_surface_everywhere(case):
    """No gaps: a ray straight down anywhere over the ground square, and in particular along
    every seam where the ice meets a block or a rock, first hits the terrain's surface."""
    t, center, extent, cell = CASES[case]
    m = terrain_mesh(t, center=center, extent=extent, cell=cell)
    c = np.asarray(center)
    xy = [c[:2] + rng.uniform(-extent, extent, (1500, 2))]
    h, off = t.ground_height, rng.choice([-1e-5, 1e-5, -1e-4, 1e-4], 200)     # m either side of a seam
    for r in t.rocks:                                           # around each rim
        rho = r.footprint_radius(h)
        if r.center[2] - r.radius < h:
            a = rng.uniform(0, 2 * np.pi, 200)
            xy.append(np.asarray(r.center[:2]) + (rho + off)[:, None] * np.column_stack([np.cos(a), np.sin(a)]))
    for b in t.blocks:                                          # along each side of a resting block's foot
        foot = b.corners()[b.corners()[:, 2] <= h + 1e-9, :2]
        if len(foot) != 4:
            continue
        mid = foot.mean(axis=0)
        foot = foot[np.argsort(np.arctan2(*(foot - mid).T[::-1]))]
        for p, q in zip(foot, np.roll(foot, -1, axis=0)):
            out = np.array([q[1] - p[1], p[0] - q[0]]) / np.linalg.norm(q - p)
            s = rng.uniform(0, 1, 200)[:, None]
            xy.append(p + s * (q - p) + off[:, None] * out)
    xy = np.vstack(xy)
    xy = xy[(np.abs(xy - c[:2]) < extent - 1e-6).all(axis=1)]
    top = _top_hits(m, xy)
    assert np.isfinite(top).all(), f"{np.sum(~np.isfinite(top))} of {len(xy)} rays miss the mesh"
    # the first hit is on the surface: through a gap the ray would reach ice under a rock or block
    # (inside the solid by far more than the chord error), or nothing
    hit = np.column_stack([xy, top])
    assert np.abs(t.distance(hit)).max() < 1.2 * SPHERE_CHORD


def _top_hits(m, xy, chunk=64):
    """Height of the highest triangle under each (x, y) (-inf where none)."""
    tri = m.vertices.astype(float)[m.faces]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    flat = np.abs(det) > 1e-14                                   # seen from above (not vertical)
    a, b, c, det = a[flat], b[flat], c[flat], det[flat]
    lo, hi = np.minimum(np.minimum(a, b), c)[:, :2], np.maximum(np.maximum(a, b), c)[:, :2]
    order = np.lexsort((xy[:, 1], np.floor(xy[:, 0] / 0.5)))         # nearby rays together
    out = np.full(len(xy), -np.inf)
    for s in range(0, len(xy), chunk):
        idx = order[s:s + chunk]
        near = ((lo <= xy[idx].max(axis=0) + 1e-6) & (hi >= xy[idx].min(axis=0) - 1e-6)).all(axis=1)
        A, B, C, D = a[near], b[near], c[near], det[near]
        px, py = xy[idx, 0:1], xy[idx, 1:2]
        u = ((px - A[:, 0]) * (C[:, 1] - A[:, 1]) - (C[:, 0] - A[:, 0]) * (py - A[:, 1])) / D
        v = ((B[:, 0] - A[:, 0]) * (py - A[:, 1]) - (px - A[:, 0]) * (B[:, 1] - A[:, 1])) / D
        inside = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
        z = np.where(inside, A[:, 2] + u * (B[:, 2] - A[:, 2]) + v * (C[:, 2] - A[:, 2]), -np.inf)
        out[idx] = z.max(axis=1, initial=-np.inf)
    return out


def test_colours_follow_the_regions_and_every_obstacle_is_drawn():
    m = terrain_mesh(MIXED, center=(0.3, 0.1, 0.0), extent=2.0, cell=0.25)
    tri, _, _ = _faces(m)
    # the solids each face lies on (its vertices on that solid's own surface)
    v = tri.reshape(-1, 3)
    on = {"ground": np.abs(v[:, 2] - MIXED.ground_height) < F32,
          "blocks": np.any([np.abs(ObstacleField(-100.0, [b]).distance(v)) < F32 for b in MIXED.blocks], axis=0),
          "rocks": np.any([np.abs(ObstacleField(-100.0, rocks=[r]).distance(v)) < F32 for r in MIXED.rocks], axis=0)}
    on = {k: x.reshape(-1, 3).all(axis=1) for k, x in on.items()}
    tone = m.colors[m.faces[:, 0], :3]
    assert (m.colors[:, 3] == 255).all()
    painted = {"ground": (tone == ICE[0]).all(axis=1) | (tone == ICE[1]).all(axis=1),
               "blocks": (tone == BLOCK_TONE).all(axis=1), "rocks": (tone == ROCK_TONE).all(axis=1)}
    assert sum(x.sum() for x in painted.values()) == len(tone)
    for region in MIXED.regions:
        assert painted[region].any() and on[region][painted[region]].all(), region
    # every obstacle above the ice shows (the one across the square's edge whole), the buried ones do not
    v = m.vertices.astype(float)
    for r in MIXED.rocks:
        near = np.abs(np.linalg.norm(v - r.center, axis=1) - r.radius) < F32
        assert near.any() == (r.center[2] + r.radius > 0)
    for b in MIXED.blocks:
        on = np.abs(ObstacleField(-100.0, [b]).distance(v)) < F32
        assert on.any() == (b.corners()[:, 2].max() > 0)
    assert v[:, 2].min() > -F32                                      # all clipped at the ice


def test_ground_is_cut_to_the_extent_and_obstacles_are_not():
    t = COURSE
    m = terrain_mesh(t, center=(0.0, 0.0, 0.0), extent=1.0, cell=0.25)
    v = m.vertices.astype(float)
    ice = (m.colors[:, :3] == ICE[0]).all(axis=1) | (m.colors[:, :3] == ICE[1]).all(axis=1)
    assert (np.abs(v[ice, :2]) <= 1.0 + F32).all()
    assert v[~ice, 0].max() > 7.5                                    # the far end of the course
