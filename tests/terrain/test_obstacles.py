"""Obstacle field (kind obstacles): distances against hand-derived values, normals against the
gradient, closest points, regions, the numba kernel against the NumPy implementation it replaced,
the seeded random course, schema errors, the shipped course."""

import numpy as np
import pytest
from surface_checks import assert_distance_lower_bound_holds, fd_gradient

from snakesim.components.terrain import Block, ObstacleField, Rock, build_terrain, load_terrain, scatter_obstacles
from snakesim.components.terrain.base import unit
from snakesim.components.terrain.obstacles import buried_sides, rpy_matrix
from snakesim.framework import ConfigError

rng = np.random.default_rng(7)
FAR = -100.0      # a ground height that never wins near the obstacles: each solid on its own


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


# -- distances and normals by hand ----------------------------------------------------------

BOX = Block(center=(0.0, 0.0, 0.0), size=(2.0, 1.0, 0.5))        # half sizes 1, 0.5, 0.25

# local point, distance, normal: derived from the half sizes (1, 0.5, 0.25)
BOX_CASES = [
    ((0.3, 0.2, 0.65), 0.4, (0, 0, 1)),                     # 0.4 above the top face
    ((1.3, 0.1, 0.65), 0.5, (0.6, 0, 0.8)),                 # beyond the +x/top edge: hypot(0.3, 0.4)
    ((1.1, 0.7, 0.45), 0.3, (1 / 3, 2 / 3, 2 / 3)),         # beyond the corner: |(0.1, 0.2, 0.2)|
    ((-1.0, 0.0, 0.0), 0.0, (-1, 0, 0)),                    # on the -x face
    ((0.9, 0.0, 0.0), -0.1, (1, 0, 0)),                     # inside, 0.1 from the +x face
    ((0.0, -0.1, 0.2), -0.05, (0, 0, 1)),                   # inside, nearer the top than the -y side
    ((0.0, -0.4, 0.0), -0.1, (0, -1, 0)),                   # inside, nearer the -y side
]


@pytest.mark.parametrize("local,dist,normal", BOX_CASES)
@pytest.mark.parametrize("rpy", [(0, 0, 0), (0, 0, np.pi / 6), (0.3, -0.5, 2.0)])
def test_box_distance_and_normal_by_hand(local, dist, normal, rpy):
    roll, pitch, yaw = rpy
    center = np.array([0.5, -1.0, 2.0])
    t = ObstacleField(FAR, [Block(tuple(center), BOX.size, yaw=yaw, roll=roll, pitch=pitch)])
    R = _rot(2, yaw) @ _rot(1, pitch) @ _rot(0, roll)          # fixed axes x, then y, then z
    np.testing.assert_allclose(rpy_matrix(roll, pitch, yaw), R, atol=1e-15)
    q = t.query(center + R @ np.array(local))
    assert q.distance[0] == pytest.approx(dist, abs=1e-12)
    np.testing.assert_allclose(q.normal[0], R @ np.array(normal), atol=1e-12)


def test_rock_and_ground_by_hand():
    t = ObstacleField(0.0, rocks=[Rock((3.0, 0.0, -0.1), 0.3)])          # a boulder 0.2 m high
    p = np.array([[3.0, 0.0, 1.0],                  # above the top: 1.1 − 0.3
                  [3.0 + 0.6, 0.0, -0.1 + 0.8],     # up and out: |(0.6, 0.8)| − 0.3 = 0.7
                  [3.1, 0.0, 0.0],                  # in the rock, at ice level: 0.3 − |(0.1, 0.1)| deep
                  [10.0, 10.0, 0.7],                # far from it: the ice, 0.7 below
                  [10.0, 10.0, -0.2]])              # in the ice
    q = t.query(p)
    np.testing.assert_allclose(q.distance, [0.8, 0.7, np.hypot(0.1, 0.1) - 0.3, 0.7, -0.2], atol=1e-12)
    np.testing.assert_allclose(q.normal[:2], [[0, 0, 1], [0.6, 0, 0.8]], atol=1e-12)
    np.testing.assert_allclose(q.normal[2], np.array([0.1, 0, 0.1]) / np.hypot(0.1, 0.1), atol=1e-12)
    np.testing.assert_allclose(q.normal[3:], [[0, 0, 1]] * 2)


def test_resting_block_pushes_out_sideways_at_its_foot():
    """The bottom of a block on the ice is not surface: just inside its side near the ice the
    depth is to the side face, not down through the (buried) bottom."""
    t = ObstacleField(0.0, [Block((0.0, 0.0, 0.2), (0.4, 0.4, 0.4), yaw=0.0)])
    q = t.query([[0.19, 0.0, 0.005], [0.0, 0.0, 0.05]])
    np.testing.assert_allclose(q.distance, [-0.01, -0.2], atol=1e-12)     # side, then the nearest side
    np.testing.assert_allclose(q.normal[0], [1, 0, 0])
    assert abs(q.normal[1, 2]) < 1e-12
    # outside it is the plain box: beside the foot the ice and the side are both 0.005 and 0.01 away
    q = t.query([[0.21, 0.0, 0.005], [0.0, 0.0, 0.45]])
    np.testing.assert_allclose(q.distance, [0.005, 0.05], atol=1e-12)
    np.testing.assert_allclose(q.normal, [[0, 0, 1], [0, 0, 1]], atol=1e-12)


def test_regions_map_to_materials():
    t = build_terrain({"kind": "obstacles",
                       "boxes": [{"center": [1, 0, 0.2], "size": [0.4, 0.4, 0.4]}],
                       "spheres": [{"center": [3, 0, -0.05], "radius": 0.2}],
                       "materials": [{"name": "ice", "mu": 0.1}, {"name": "granite", "mu": 0.7},
                                     {"name": "basalt", "mu": 0.5}],
                       "regions": {"blocks": "granite", "rocks": "basalt"}})
    assert t.regions == ("ground", "blocks", "rocks")
    q = t.query([[1.0, 0.0, 0.5], [3.0, 0.0, 0.3], [6.0, 0.0, 0.3]])
    assert [t.materials[i].name for i in q.material] == ["granite", "basalt", "ice"]


# -- the field as a distance function ---------------------------------------------------------

def _course():
    blocks = [Block((1.0, 0.6, 0.15), (0.4, 0.3, 0.3), yaw=0.4),
              Block((1.8, -0.5, 0.3), (0.3, 0.3, 0.3), roll=0.3, pitch=0.5, yaw=1.0),   # tilted, floating
              Block((2.6, 0.5, 0.05), (0.5, 0.4, 0.3), roll=0.2)]                         # tilted, half sunk
    rocks = [Rock((1.5, 0.3, -0.08), 0.2), Rock((2.4, -0.6, 0.3), 0.12), Rock((3.2, 0.0, -0.1), 0.25)]
    return ObstacleField(0.0, blocks, rocks)


def _solo_distances(t, p):
    """Each solid's own distance (columns: ground, blocks, rocks)."""
    cols = [p[:, 2] - t.ground_height]
    cols += [ObstacleField(FAR, [b]).distance(p) for b in t.blocks]
    cols += [ObstacleField(FAR, rocks=[r]).distance(p) for r in t.rocks]
    return np.column_stack(cols)


def test_distance_is_the_least_solid_distance_and_normal_its_gradient():
    t = _course()
    p = np.column_stack([rng.uniform(0.5, 3.6, 3000), rng.uniform(-1, 1, 3000), rng.uniform(-0.2, 0.6, 3000)])
    solo = np.sort(_solo_distances(t, p), axis=1)
    q = t.query(p)
    # outside, the least distance over the solids; inside some solid iff inside the field (the
    # depth itself is measured past buried faces, see test_resting_block_pushes_out_sideways...)
    out = solo[:, 0] >= 0
    np.testing.assert_allclose(q.distance[out], solo[out, 0], atol=1e-14)
    assert (q.distance[~out] < 0).all() and (~out).sum() > 100
    np.testing.assert_allclose(np.linalg.norm(q.normal, axis=1), 1.0, atol=1e-12)
    # outside, each solid's distance is C1 (distance to a convex set): away from ties between
    # solids (the union's creases) the central difference (step 1e-6) matches to O(step)
    free = (q.distance > 1e-3) & (solo[:, 1] - solo[:, 0] > 1e-4)
    assert free.sum() > 2000
    np.testing.assert_allclose(q.normal[free], fd_gradient(t.distance, p[free]), atol=1e-6)


def test_closest_points_lie_on_the_surface():
    t = _course()
    p = np.column_stack([rng.uniform(0.5, 3.6, 2000), rng.uniform(-1, 1, 2000), rng.uniform(0.0, 0.6, 2000)])
    q = t.query(p)
    out = q.distance > 0
    np.testing.assert_allclose(t.distance(q.closest[out]), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(p - q.closest, axis=1), np.abs(q.distance), atol=1e-12)
    # inside, it is on the surface of the solid the point is deepest in (which another solid
    # may cover: the depth is a bound there, see the module doc)
    inside = q.distance < 0
    assert inside.sum() > 20
    np.testing.assert_allclose(np.abs(_solo_distances(t, q.closest[inside])).min(axis=1), 0.0, atol=1e-12)


def test_chunked_query_and_broad_phase_match_the_reference():
    t = _course()
    p = np.vstack([rng.uniform(-1, 4, (40_000, 3)),
                   np.column_stack([rng.uniform(0.5, 3.5, 3000), rng.uniform(-1, 1, 3000),
                                    rng.uniform(-0.05, 0.05, 3000)])])      # near the ice, some under it
    q = t.query(p)
    for i in rng.choice(len(p), 50, replace=False):                 # one point at a time: a chunk of one
        one = t.query(p[i])
        assert one.distance[0] == q.distance[i]
        assert np.array_equal(one.normal[0], q.normal[i])
    # small queries (a robot's contact points) where the broad phase drops most obstacles
    clusters = [c + rng.normal(0, 0.03, (10, 3)) for c in
                np.column_stack([rng.uniform(0.5, 3.5, 300), rng.uniform(-1, 1, 300), rng.uniform(-0.05, 0.3, 300)])]
    small = [t.query(c) for c in clusters]
    t.broad_phase = False                                           # every obstacle for every point
    for got, ref in [(q, t.query(p))] + [(s, t.query(c)) for s, c in zip(small, clusters)]:
        assert np.array_equal(got.distance, ref.distance)          # the same arithmetic: bit for bit
        assert np.array_equal(got.normal, ref.normal)
        assert np.array_equal(got.material, ref.material)


def test_bounds():
    t = _course()
    b = t.bounds()
    assert np.isinf(b.lo[:2]).all() and np.isinf(b.hi[:2]).all() and b.lo[2] == 0.0
    tops = [blk.corners()[:, 2].max() for blk in t.blocks] + [r.center[2] + r.radius for r in t.rocks]
    assert b.hi[2] == pytest.approx(max(tops))
    assert t.lipschitz == 1.0


def test_distance_lower_bound_is_conservative():
    t = _course()
    c = np.column_stack([rng.uniform(0.5, 3.5, 40), rng.uniform(-1, 1, 40), rng.uniform(-0.1, 0.5, 40)])
    r = rng.uniform(0.02, 0.2, 40)
    assert_distance_lower_bound_holds(t, c, r, rng, samples=300)


# -- the numba kernel against the NumPy implementation it replaced ------------------------------

def _numpy_reference(t, p):
    """The former vectorised ObstacleField._query, every obstacle for every point (no broad
    phase): -> distance, normal, region. One change: the local coordinates are Rᵀ(p − c), where
    it took p·R − Rᵀc, whose cancellation (~1e-15 m at |p| ~ 8 m) tilted normals near an edge
    by up to ~2e-12 (the normal there turns by 1 over the distance to the edge); the kernel's
    are within ~2e-14 of an extended-precision evaluation at those points."""
    k, nb = len(p), len(t.blocks)
    above = p[:, 2] - t.ground_height
    candidates = [above[:, None]]
    if nb:
        rot = np.array([b.rotation for b in t.blocks])
        half = 0.5 * np.array([b.size for b in t.blocks], dtype=float)
        box_side = np.array([buried_sides(b, t.ground_height) for b in t.blocks])
        center = np.array([b.center for b in t.blocks], dtype=float)
        local = np.einsum("mij,kmi->kmj", rot, p[:, None, :] - center)
        side = np.where(box_side != 0, box_side, np.where(local >= 0, 1.0, -1.0))
        excess = side * local - half
        beyond = np.maximum(excess, 0.0)
        candidates.append(np.sqrt(np.einsum("kmj,kmj->km", beyond, beyond)) + np.minimum(excess.max(axis=2), 0.0))
    if t.rocks:
        offset = p[:, None, :] - np.array([r.center for r in t.rocks], dtype=float)
        candidates.append(np.sqrt(np.einsum("kmj,kmj->km", offset, offset)) - np.array([r.radius for r in t.rocks]))
    dist = np.concatenate(candidates, axis=1)
    winner = dist.argmin(axis=1)
    d = dist[np.arange(k), winner]
    normal = np.tile([0.0, 0.0, 1.0], (k, 1))
    region = np.zeros(k, dtype=np.int64)
    on_block = (winner >= 1) & (winner <= nb)
    if on_block.any():
        j = winner[on_block] - 1
        sd, ex = side[on_block, j], excess[on_block, j]
        rows, face = np.arange(len(sd)), ex.argmax(axis=1)
        inside = np.zeros_like(sd)
        inside[rows, face] = sd[rows, face]
        n_local = np.where((ex.max(axis=1) > 0)[:, None], unit(sd * np.maximum(ex, 0.0)), inside)
        normal[on_block] = np.einsum("kij,kj->ki", rot[j], n_local)
        region[on_block] = ObstacleField.BLOCKS
    on_rock = winner > nb
    if on_rock.any():
        normal[on_rock] = unit(offset[on_rock, winner[on_rock] - 1 - nb])
        region[on_rock] = ObstacleField.ROCKS
    return d, normal, region


def _sunk(x, size, roll, pitch, yaw, below):
    """A block at (x, 0.3) sunk so that its ``below``-th lowest corner touches z = −0.01."""
    b = Block((0.0, 0.0, 0.0), size, yaw=yaw, roll=roll, pitch=pitch)
    return Block((x, 0.3, -np.sort(b.corners()[:, 2])[below] - 0.01), size, yaw=yaw, roll=roll, pitch=pitch)


def _tricky_course():
    """Blocks extended through 1, 2 and 3 buried faces, one through a face all but vertical,
    floating and resting blocks, solids overlapping (a thin slab before a tall post on it: inside
    both, just above the ice, the post is deeper than the slab though its bounding sphere is
    not), a rock in a block, a boulder."""
    blocks = [Block((0.0, 0.0, 0.2), (0.4, 0.4, 0.4), yaw=0.3),                     # resting: 1 face
              _sunk(1.0, (0.3, 0.25, 0.35), 0.6, 0.5, 0.2, -3),                     # 2 faces
              _sunk(2.0, (0.4, 0.3, 0.25), 0.7, 0.0, 0.4, -3),                      # 2 faces
              _sunk(3.0, (0.3, 0.25, 0.35), 0.6, 0.5, 0.2, -2),                     # 3 faces
              _sunk(4.0, (0.4, 0.3, 0.3), 0.3, 0.2, 0.0, -2),                       # 3 faces
              _sunk(5.0, (0.4, 0.3, 0.3), 1.5, 0.0, 0.3, 5),                        # 2, one 4° off vertical
              Block((6.0, 0.0, 0.5), (0.3, 0.3, 0.3), roll=0.3, pitch=0.5, yaw=1.0),   # floating
              Block((7.0, 0.0, 0.05), (0.5, 0.4, 0.3), roll=0.2),                   # tilted, half sunk
              Block((8.0, 0.0, 0.025), (1.0, 1.0, 0.05)),                           # the slab ...
              Block((8.1, 0.1, 1.0), (0.2, 0.2, 2.0), yaw=0.2)]                     # ... and the post on it
    rocks = [Rock((7.0, 0.1, 0.1), 0.15), Rock((9.0, 0.0, -0.1), 0.3), Rock((6.0, 0.0, 0.5), 0.1)]
    return ObstacleField(0.0, blocks, rocks)


def _probe_points(t, n):
    """n points per kind: at corners and edges, inside the blocks (and past their buried faces),
    on the rocks, near and under the ground, anywhere, far away."""
    pts = []
    for b in t.blocks:
        R, c, half = b.rotation, np.asarray(b.center), 0.5 * np.asarray(b.size)
        corners = b.corners()
        mids = 0.5 * (corners[:, None] + corners[None, :]).reshape(-1, 3)        # edge and face centres
        near = np.vstack([corners, mids])[rng.integers(0, 72, n)] + rng.normal(0, 0.01, (n, 3))
        local = rng.uniform(-1.2, 1.2, (n, 3)) * half
        local[: n // 2, 2] -= rng.uniform(0, 3, n // 2) * half[2]               # down past the bottom
        pts += [near, c + local @ R.T]
    for r in t.rocks:
        u = rng.standard_normal((n, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        pts.append(np.asarray(r.center) + u * r.radius * rng.uniform(0.5, 1.3, (n, 1)))
    lo = np.array([-1.0, -1.5, -0.5])
    hi = np.array([1.0 + max(b.center[0] for b in (*t.blocks, *t.rocks)), 2.0, 1.0])
    pts.append(rng.uniform(lo, hi, (10 * n, 3)))
    pts.append(np.column_stack([rng.uniform(lo[0], hi[0], 10 * n), rng.uniform(lo[1], hi[1], 10 * n),
                                rng.normal(t.ground_height, 0.03, 10 * n)]))
    pts.append(rng.uniform(-1e3, 1e3, (n, 3)))
    p = np.vstack(pts)
    return p[rng.permutation(len(p))]


@pytest.mark.parametrize("course", ["tricky", "shipped"])
def test_kernel_matches_the_numpy_reference(course):
    t = _tricky_course() if course == "tricky" else load_terrain("obstacle-course")
    sides = np.array([buried_sides(b, t.ground_height) for b in t.blocks])
    if course == "tricky":       # the course has what it says
        assert sorted(np.count_nonzero(sides, axis=1).tolist()) == [0, 1, 1, 1, 1, 2, 2, 2, 3, 3]
    p = _probe_points(t, 2000)
    q = t.query(p)
    d, normal, region = _numpy_reference(t, p)
    assert np.array_equal(q.material, t.region_material[region])
    np.testing.assert_allclose(q.distance, d, rtol=0, atol=1e-12)
    np.testing.assert_allclose(q.normal, normal, rtol=0, atol=1e-12)
    # every kind of winner, and points inside, was tried
    assert np.bincount(region, minlength=3).min() > 1000 and (d < 0).sum() > 1000
    # the same points in strips 0.2 m wide along x, sorted along y (a chunk's points lie close
    # together, as a screw's samples do: the broad phase drops the most)
    order = np.lexsort((p[:, 1], np.floor(p[:, 0] / 0.2)))
    s = t.query(p[order])
    assert np.array_equal(s.distance, q.distance[order]) and np.array_equal(s.normal, q.normal[order])
    # a robot's contact samples: rings of points 3 cm around paths across the course, near the
    # ground, in order along the path (chunks of neighbours whose farthest point is a few cm up)
    x = np.linspace(-1.0, 10.0, 4000)
    rings = [np.column_stack([x, np.full_like(x, y), np.full_like(x, z)]) + 0.03 * rng.standard_normal((4000, 3))
             for y in np.linspace(-1.0, 1.0, 9) for z in (-0.02, 0.0, 0.03)]
    p = np.vstack(rings)
    q = t.query(p)
    d, normal, region = _numpy_reference(t, p)
    assert np.array_equal(q.material, t.region_material[region]) and (region != ObstacleField.GROUND).sum() > 1000
    np.testing.assert_allclose(q.distance, d, rtol=0, atol=1e-12)
    np.testing.assert_allclose(q.normal, normal, rtol=0, atol=1e-12)


def test_non_finite_points_and_empty_queries():
    """A point with a nan or inf coordinate gets distance nan and the region numpy's argmin gave
    it (the first solid whose distance is nan); the other points of its chunk are unaffected."""
    t = _tricky_course()
    p = _probe_points(t, 20)[:40]
    bad = p.copy()
    bad[[3, 5, 17, 18, 30], [0, 2, 2, 0, 1]] = [np.nan, np.inf, -np.inf, np.inf, np.nan]
    q, ref = t._query(bad), t._query(p)
    odd = [3, 5, 17, 18, 30]
    assert np.isnan(q[0][odd]).all()
    with np.errstate(invalid="ignore"):
        assert np.array_equal(q[2][odd], _numpy_reference(t, bad[odd])[2])
    good = np.setdiff1d(np.arange(40), odd)
    for got, want in zip(q, ref):
        assert np.array_equal(got[good], want[good])
    assert len(t.query(np.zeros((0, 3)))) == 0
    flat = ObstacleField(0.5).query([[1.0, 2.0, 3.0], [0.0, 0.0, 0.2]])
    np.testing.assert_allclose(flat.distance, [2.5, -0.3])
    np.testing.assert_allclose(flat.normal, [[0, 0, 1]] * 2)


# -- the seeded random course ------------------------------------------------------------------

RANDOM = {"kind": "obstacles", "ground_height": 0.1,
          "boxes": [{"center": [3.0, 0.0, 0.3], "size": [0.5, 0.5, 0.4]}],
          "random": {"count": 25, "seed": 3, "area": [-4, 4, -3, 3], "size": [0.2, 0.5],
                     "keep_clear": {"center": [0.5, -0.5], "radius": 1.2}, "min_gap": 0.05}}


def _discs(t):
    h = t.ground_height
    return ([(b.center[0], b.center[1], b.footprint_radius()) for b in t.blocks]
            + [(r.center[0], r.center[1], r.footprint_radius(h)) for r in t.rocks])


def test_random_course_is_reproducible_by_seed():
    a, b = build_terrain(RANDOM), build_terrain(RANDOM)
    c = build_terrain({**RANDOM, "random": {**RANDOM["random"], "seed": 4}})
    assert a.blocks == b.blocks and a.rocks == b.rocks
    assert (a.blocks, a.rocks) != (c.blocks, c.rocks)
    assert len(a.blocks) + len(a.rocks) == 26 and a.blocks[0] == Block((3.0, 0.0, 0.3), (0.5, 0.5, 0.4))
    assert len(a.blocks) > 3 and len(a.rocks) > 3            # both kinds drawn
    for blk in a.blocks[1:]:                                 # blocks rest on the ground, edges in range
        assert min(blk.corners()[:, 2]) == pytest.approx(0.1) and 0.2 <= min(blk.size) <= max(blk.size) <= 0.5
    for rock in a.rocks:                                     # centres 0 to 0.5 radii below the ground
        assert 0.1 <= 2 * rock.radius <= 0.5 and 0.1 - 0.5 * rock.radius <= rock.center[2] <= 0.1


def test_random_course_keeps_clear_and_does_not_overlap():
    t = build_terrain(RANDOM)
    d = _discs(t)
    for i, (x, y, r) in enumerate(d):
        assert np.hypot(x - 0.5, y + 0.5) >= 1.2 + r
        assert -4 <= x <= 4 and -3 <= y <= 3
        for x2, y2, r2 in d[i + 1:]:
            assert np.hypot(x - x2, y - y2) >= r + r2 + 0.05 - 1e-12
    # in the keep-clear disc only the ice answers
    ang, rad = rng.uniform(0, 2 * np.pi, 500), 1.2 * np.sqrt(rng.uniform(0, 1, 500))
    p = np.column_stack([0.5 + rad * np.cos(ang), -0.5 + rad * np.sin(ang), np.full(500, 0.1 + 1e-3)])
    q = t.query(p)
    np.testing.assert_allclose(q.distance, 1e-3, atol=1e-12)


def test_random_kinds_select_the_obstacles():
    blocks, rocks = scatter_obstacles(10, 0, (0, 10, 0, 10), (0.2, 0.4), kinds=("sphere",))
    assert not blocks and len(rocks) == 10


# -- schema errors name the key, the value and what is valid ------------------------------------

@pytest.mark.parametrize("body,match", [
    ("spheres: [{center: [0, 0, 0], radius: 0}]",
     r"o\.yaml:2: spheres\.0\.radius: Input should be greater than 0 \(got 0\)"),
    ("boxes:\n  - {center: [0, 0, 0.2], size: [0.4, 0.4, 0.4]}\n  - {center: [1, 0, 0], size: [1, 1, -0.1]}",
     r"o\.yaml:4: boxes\.1\.size\.2: Input should be greater than 0 \(got -0\.1\)"),
    ("boxes: [{center: [0, .nan, 0], size: [1, 1, 1]}]",
     r"o\.yaml:2: boxes\.0\.center\.1: Input should be a finite number \(got nan\)"),
    ("ground_height: .inf", r"o\.yaml:2: ground_height: Input should be a finite number \(got inf\)"),
    ("boxes: [{center: [0, 0], size: [1, 1, 1]}]", r"boxes\.0\.center: needs 3 values, got 2: \[0, 0\]"),
    ("boxes: [{center: [0, 0, 0], size: [1, 1, 1], yawn: 1}]",
     r"boxes\.0\.yawn: unknown key 'yawn'; did you mean 'yaw'\? valid keys: center, size, yaw, roll, pitch"),
    ("sphere: []", r"o\.yaml:2: sphere: unknown key 'sphere'; did you mean 'spheres'\?"),
    ("random: {count: 3, area: [8, 1, -2, 2], size: [0.2, 0.5]}",
     r"random: area = \[8\.0, 1\.0, -2\.0, 2\.0\] m: need \[xmin, xmax, ymin, ymax\] with xmin < xmax"),
    ("random: {count: 3, area: [1, 8, -2, 2], size: [0.5, 0.2]}",
     r"random: size = \[0\.5, 0\.2\] m: need \[min, max\] with 0 < min <= max"),
    ("random: {count: 3, area: [1, 8, -2, 2], size: [0.2, 0.5], kinds: [cone]}",
     r"random\.kinds\.0: Input should be 'box' or 'sphere' \(got 'cone'\)"),
    ("random: {count: 3, area: [1, 8, -2, 2], size: [0.2, 0.5], burial: [0.2, 1.0]}",
     r"random: burial = \[0\.2, 1\.0\]: need \[min, max\] with 0 <= min <= max < 1"),
    ("random: {count: 3, area: [1, 8, -2, 2], size: [0.2, 0.5], keep_clear: {center: [0, 0], radiu: 1}}",
     r"random\.keep_clear\.radiu: unknown key 'radiu'; did you mean 'radius'\? valid keys: center, radius"),
    ("random: {count: -1, area: [1, 8, -2, 2], size: [0.2, 0.5]}",
     r"random\.count: Input should be greater than or equal to 0 \(got -1\)"),
    ("random: {count: 200, area: [1, 2, -0.5, 0.5], size: [0.2, 0.5]}",
     r"o\.yaml: random\.count: placed only \d+ of count = 200 random obstacles: no room left .*enlarge the area"),
    ("regions: {walls: ice}", r"unknown region 'walls' for kind obstacles; regions: ground, blocks, rocks"),
])
def test_bad_input_names_key_value_and_what_is_valid(tmp_path, body, match):
    f = tmp_path / "o.yaml"
    f.write_text(f"kind: obstacles\n{body}\n")
    with pytest.raises(ConfigError, match=match):
        load_terrain(str(f))


def test_bad_obstacles_given_directly_are_refused():
    with pytest.raises(ValueError, match=r"block 0: .*size \[1\.0, 0\.0, 1\.0\].*every edge > 0"):
        ObstacleField(0.0, [Block((0, 0, 0), (1.0, 0.0, 1.0))])
    with pytest.raises(ValueError, match=r"rock 0: .*radius nan m"):
        ObstacleField(0.0, rocks=[Rock((0, 0, 0), float("nan"))])


# -- the shipped course ---------------------------------------------------------------------------

def test_obstacle_course_loads_by_name():
    t = load_terrain("obstacle-course")
    assert isinstance(t, ObstacleField) and t.name == "obstacle-course" and t.ground_height == 0.0
    assert 6 <= len(t.blocks) <= 10 and 6 <= len(t.rocks) <= 10
    names = {r: t.materials[t.region_material[i]] for i, r in enumerate(t.regions)}
    assert (names["ground"].name, names["ground"].k, names["ground"].c, names["ground"].mu) == ("ice", 1e5, 1e3, 0.1)
    for r in ("blocks", "rocks"):
        assert (names[r].name, names[r].k, names[r].c, names[r].mu) == ("rock", 1e6, 500.0, 0.6)
    # spread over x in [1, 8], y in [-2, 2]; rocks are boulders (centres below the ice)
    for x, y, r in _discs(t):
        assert 1 <= x <= 8 and -2 <= y - r and y + r <= 2
    assert all(rock.center[2] < 0 < rock.center[2] + rock.radius for rock in t.rocks)
    assert all(min(b.corners()[:, 2]) == pytest.approx(0.0) and 0.2 <= max(b.size) <= 0.5 for b in t.blocks)
    # a 0.8 m corridor along y = 0 from the start to past the last obstacle: only the ice answers
    x, y = np.meshgrid(np.linspace(-1, 9, 401), np.linspace(-0.4, 0.4, 33))
    p = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 1e-3)])
    np.testing.assert_allclose(t.distance(p), 1e-3, atol=1e-12)
    # and it is an obstacle course: off the corridor the robot meets rock
    assert (t.query([[b.center[0], b.center[1], 0.01] for b in t.blocks]).distance < 0).all()
