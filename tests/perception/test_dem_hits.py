"""On a height field the sensors see the surface the contact touches: the grid's bilinear
interpolation (``HeightField.height``), not the triangles Embree casts. ``terrain_hits: exact``
refines each hit onto it (refine_kernels.DemRefiner): the hit lies on the bilinear surface, and
no crossing of it lies earlier along the ray (checked by dense sampling of z_ray − h, the
contact's own height query as the reference)."""

from __future__ import annotations

import numpy as np
import pytest

from scenes import all_links_at, world_at
from snakesim.components.perception.refine_kernels import NO_CROSSING, STARTS_INSIDE, DemRefiner
from snakesim.components.terrain.dem import HeightField, fractal_heights

RES = 0.05


@pytest.fixture(scope="module")
def dem():
    """A 1.6 m square fractal patch, 3 cm RMS: cells twisted by up to ~2 cm (|z00 − z01 − z10 + z11|)."""
    return HeightField(fractal_heights(33, hurst=0.7, rms=0.03, seed=3), RES, origin=(-0.8, -0.8))


def gap(t, p):
    """z − h(x, y) at points p (n, 3): the contact's height query."""
    return p[..., 2] - t.height(p[..., 0], p[..., 1])[0]


def rays_over(t, n, rng):
    """Origins 5-15 cm above the surface over the middle of the grid; directions down at 0.5-60°
    below the horizontal (grazing ones included) and some straight down."""
    o = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), np.zeros(n)])
    o[:, 2] = t.height(o[:, 0], o[:, 1])[0] + rng.uniform(0.05, 0.15, n)
    az, el = rng.uniform(0, 2 * np.pi, n), np.radians(rng.uniform(0.5, 60.0, n))
    d = np.column_stack([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), -np.sin(el)])
    d[: n // 20] = [0.0, 0.0, -1.0]
    return o, d


def test_exact_hits_lie_on_the_bilinear_surface_and_are_the_first_crossing(dem):
    world = world_at(dem, all_links_at((0.0, 0.0, 1.0)), extent=4.0)
    assert world.terrain.surfaces.refine.all() and isinstance(world.terrain.refiner, DemRefiner)
    rng = np.random.default_rng(0)
    o, d = rays_over(dem, 2500, rng)
    exact = world.cast(o, d, 5.0).distance
    mesh = world.cast_from(np.eye(3), np.zeros(3), o, d, 5.0, exact=False)[0].distance
    hit = np.isfinite(exact) & np.isfinite(mesh)
    assert hit.mean() > 0.8                                              # grazing rays may leave the grid
    # the mesh is off the surface by up to a quarter of a cell's twist (millimetres here): the knob matters
    assert np.abs(gap(dem, o[hit] + mesh[hit, None] * d[hit])).max() > 1e-4
    # a hit is kept from the mesh only where the bilinear crossing lies farther than refine_limit past
    # it or past the grid's edge (a grazing ray through a triangle that bulges above the patch)
    on = np.abs(gap(dem, o + np.where(hit, exact, 0.0)[:, None] * d)) <= 1e-9
    assert np.mean(on[hit]) > 0.995
    kept = hit & ~on
    np.testing.assert_array_equal(exact[kept], mesh[kept])
    assert np.all(np.abs(d[kept, 2]) < 0.2)                               # grazing, all of them
    # no earlier crossing: z_ray − h >= 0 at 0.5 mm steps up to the hit (a crossing in between
    # dips the ray at least 1e-9 m below unless it is within rounding of the sampled points)
    r = np.flatnonzero(on)
    for part in np.array_split(r, 8):
        s = np.linspace(0.0, 1.0, 4001)[None, :] * exact[part, None]    # ≤ 0.5 mm apart (hits < 2 m)
        assert np.all(exact[part] < 2.0)
        g = gap(dem, o[part, None] + s[..., None] * d[part, None])
        assert g[:, :-1].min() >= -1e-9


def test_a_tilted_plane_grid_returns_the_planes_range():
    """A DEM sampled from a plane is that plane (every cell untwisted): each hit is the analytic
    ray-plane intersection, in float64 (Embree's float32 range refined)."""
    n = np.array([0.2, -0.1, 1.0])
    y, x = np.mgrid[0:21, 0:21] * 0.1 - 1.0
    z = 0.3 - (n[0] * x + n[1] * y) / n[2]
    plane = HeightField(z, 0.1, origin=(-1.0, -1.0))
    world = world_at(plane, all_links_at((0.0, 0.0, 2.0)), extent=4.0)
    rng = np.random.default_rng(1)
    d = rng.normal(size=(3000, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 0.3
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.column_stack([rng.uniform(-0.5, 0.5, (3000, 2)), np.full(3000, 1.0)])
    t = world.cast(o, d, 10.0).distance
    expected = (n[2] * (0.3 - o[:, 2]) - n[0] * o[:, 0] - n[1] * o[:, 1]) / (d @ n)
    inside = np.all(np.abs((o + expected[:, None] * d)[:, :2]) < 1.0 - 1e-9, axis=1)
    assert inside.mean() > 0.5
    np.testing.assert_allclose(t[inside], expected[inside], rtol=0, atol=1e-12)


def test_the_walk_reports_rays_that_start_inside_or_meet_nothing(dem):
    ref = DemRefiner(dem)
    below = np.array([[0.1, 0.2, dem.height(0.1, 0.2)[0] - 0.01]])
    up = np.array([[0.0, 0.0, 1.0]])
    assert ref.first_crossing(below, -up, 1.0)[0] == STARTS_INSIDE
    assert ref.first_crossing(below + [0, 0, 0.02], up, 1.0)[0] == NO_CROSSING         # going up
    assert ref.first_crossing(below + [0, 0, 0.02], -up, 0.005)[0] == NO_CROSSING      # ends 5 mm short
    t = ref.first_crossing(below + [0, 0, 0.02], -up, 1.0)[0]
    np.testing.assert_allclose(t, 0.01, rtol=0, atol=1e-12)                          # straight down: 1 cm
    off_grid = np.array([[5.0, 0.0, -1.0]])                                          # beside the grid, low
    assert ref.first_crossing(off_grid, np.array([[0.0, 1.0, 0.0]]), 10.0)[0] == NO_CROSSING


def test_a_lidars_blocking_hits_nearer_than_its_minimum_range_are_kept(dem):
    """refine_beyond (a lidar's minimum range): a mesh hit nearer than it whose ray is below the
    surface there is kept as it is; every other hit is refined as without it."""
    world = world_at(dem, all_links_at((0.0, 0.0, 1.0)), extent=4.0)
    rng = np.random.default_rng(2)
    o, d = rays_over(dem, 2000, rng)
    near = 0.2
    exact = world.cast(o, d, 5.0).distance.copy()
    mesh = world.cast_from(np.eye(3), np.zeros(3), o, d, 5.0, exact=False)[0].distance.copy()
    cut = world.cast_from(np.eye(3), np.zeros(3), o, d, 5.0, refine_beyond=near)[0].distance
    kept = cut != exact
    assert kept.sum() > 100
    np.testing.assert_array_equal(cut[kept], mesh[kept])
    assert np.all(gap(dem, o[kept] + near * d[kept]) < 0)


def test_rays_along_the_grid_lines_and_edges_find_the_first_crossing(dem):
    """The walk's borders: origins on grid lines and corners (the grid's edges among them), beams
    along the axes and diagonals (their other components the rounding of cos 90°), level to
    straight down: each first crossing on the surface, and none earlier (dense sampling, 0.5 mm)."""
    ref = DemRefiner(dem)
    rng = np.random.default_rng(3)
    n = 400
    j, i = rng.integers(0, 33, (2, n))
    az = np.radians(rng.choice(np.arange(0, 360, 45), n))
    # along the grid's side edges: cos 270° < 0 and cos 90° > 0 step the beam off by rounding
    j[:50], az[:50], j[50:100], az[50:100] = 0, np.radians(270.0), 32, np.radians(90.0)
    x, y = dem.x0 + j * RES, dem.y0 + i * RES
    x[100::3] += rng.uniform(0.0, RES, len(x[100::3]))
    o = np.column_stack([x, y, dem.height(x, y)[0] + rng.uniform(0.001, 0.1, n)])
    el = rng.choice([0.0, -0.01, -0.1, -0.5, -np.pi / 2 + 1e-9], n)
    d = np.column_stack([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)])
    t = ref.first_crossing(o, d, 1.5)
    s = np.arange(0.0, 1.5, 5e-4)
    q = o[:, None] + s[None, :, None] * d[:, None]
    on_grid = np.all((q[..., :2] >= dem.x0) & (q[..., :2] <= dem.x0 + 32 * RES), axis=-1)
    below = (gap(dem, q) < -1e-9) & on_grid
    first = np.where(below.any(1), s[below.argmax(1)], np.inf)
    found = t >= 0
    assert found.mean() > 0.5
    assert np.all(np.isinf(first[~found]))                                        # none missed
    np.testing.assert_allclose(gap(dem, o[found] + t[found, None] * d[found]), 0.0, rtol=0, atol=1e-9)
    assert np.all(first[found] >= t[found] - 5e-4)                                # none earlier
