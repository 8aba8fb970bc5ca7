"""Analytic kinds against closed forms derived from the geometry."""

import numpy as np
import pytest
from surface_checks import assert_distance_lower_bound_holds, fd_gradient, onto_surface

from snakesim.components.terrain import build_terrain, load_terrain

rng = np.random.default_rng(42)


def test_flat_plane_distance_is_height():
    t = load_terrain("flat-ice")
    p = rng.uniform(-2, 2, (50, 3))
    q = t.query(p)
    np.testing.assert_allclose(q.distance, p[:, 2], atol=1e-14)
    np.testing.assert_allclose(q.normal, np.tile([0, 0, 1.0], (50, 1)))
    np.testing.assert_allclose(q.closest[:, 2], 0, atol=1e-14)


@pytest.mark.parametrize("tilt,azimuth", [(np.radians(20), 0.0), (0.3, 1.1), (-0.5, 2.5)])
def test_tilted_plane(tilt, azimuth):
    t = build_terrain({"kind": "plane", "tilt": tilt, "azimuth": azimuth, "origin": [1, 2, 3]})
    # surface: z - 3 = tan(tilt) * (horizontal offset along the azimuth direction)
    p = rng.uniform(-2, 2, (40, 3))
    along = (p[:, 0] - 1) * np.cos(azimuth) + (p[:, 1] - 2) * np.sin(azimuth)
    gap = p[:, 2] - 3 - np.tan(tilt) * along            # vertical gap above the surface
    q = t.query(p)
    np.testing.assert_allclose(q.distance, gap * np.cos(tilt), atol=1e-12)
    # the normal makes the tilt angle with z and leans away from the uphill direction
    np.testing.assert_allclose(q.normal[:, 2], np.cos(tilt))
    np.testing.assert_allclose(q.normal[:, 0] * np.cos(azimuth) + q.normal[:, 1] * np.sin(azimuth), -np.sin(tilt))


def test_tilted_plane_file_is_20_degrees():
    n = load_terrain("tilted-plane-20deg").query([0, 0, 1]).normal[0]
    assert np.degrees(np.arccos(n[2])) == pytest.approx(20.0)


def test_parallel_walls_distance():
    t = load_terrain("parallel-walls-0.35")
    p = rng.uniform(-0.5, 0.5, (60, 3))
    q = t.query(p)
    np.testing.assert_allclose(q.distance, 0.175 - np.abs(p[:, 1]), atol=1e-14)
    np.testing.assert_allclose(q.normal[:, 1], -np.sign(p[:, 1]))
    np.testing.assert_array_equal(q.material, 0)


def test_parallel_walls_tilt_and_yaw():
    gap, tilt = 0.4, np.radians(15)
    t = build_terrain({"kind": "parallel_walls", "gap": gap, "tilt": tilt, "yaw": np.pi / 2})
    # channel along y, so walls cross the x axis. At z = 0 the horizontal width is gap/cos(tilt);
    # one metre higher both walls have shifted by tan(tilt) towards +x (lean: positive tilt
    # rotates the walls' normal about the channel axis +y, which carries their tops towards +x)
    w = gap / np.cos(tilt)
    assert np.allclose(t.distance([[w / 2, 0, 0], [-w / 2, 0, 0]]), 0, atol=1e-12)
    z1 = t.distance([[-w / 2 + np.tan(tilt), 3.0, 1.0], [w / 2 + np.tan(tilt), -2.0, 1.0]])
    np.testing.assert_allclose(z1, 0, atol=1e-12)
    # perpendicular distance between the walls is the gap: the centre point is gap/2 from both
    assert t.distance([[0, 0, 0]])[0] == pytest.approx(gap / 2)


@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 0, 1), (1, 1, 0.5)])
def test_smooth_tube(axis):
    a = np.array(axis, float) / np.linalg.norm(axis)
    o = np.array([0.2, -0.1, 0.3])
    t = build_terrain({"kind": "tube", "radius": 0.3, "axis": list(axis), "origin": o.tolist()})
    p = o + rng.uniform(-0.6, 0.6, (80, 3))
    radial = (p - o) - np.outer((p - o) @ a, a)
    r = np.linalg.norm(radial, axis=1)
    q = t.query(p)
    np.testing.assert_allclose(q.distance, 0.3 - r, atol=1e-12)
    np.testing.assert_allclose(q.normal, -radial / r[:, None], atol=1e-12)


def test_u_channel_distance_and_regions():
    t = load_terrain("u-channel")      # width 0.4, floor axis at z = 0.2
    p = np.array([[0.0, 0.1, 0.5],     # between the walls, 0.1 from the left wall
                  [1.0, -0.15, 0.9],   # 0.05 from the right wall
                  [0.0, 0.0, 0.05],    # above the bottom: 0.05 from the floor
                  [0.0, 0.0, -0.1],    # 0.1 under the bottom (penetration)
                  [2.0, 0.3, 0.2]])    # in the left wall at the axis height
    q = t.query(p)
    rho = np.hypot(0.0, 0.05 - 0.2)
    np.testing.assert_allclose(q.distance, [0.1, 0.05, 0.2 - rho, -0.1, -0.1], atol=1e-12)
    floor, walls = [m.name for m in t.materials].index("dirty-ice"), [m.name for m in t.materials].index("ice")
    assert q.material.tolist() == [walls, walls, floor, floor, walls]
    np.testing.assert_allclose(q.normal[2], [0, 0, 1], atol=1e-12)


def _sample(t, lo, hi, n=60, skip=None):
    p = rng.uniform(lo, hi, (n, 3))
    return p if skip is None else p[~skip(p)]


CASES = {
    "flat-ice": lambda: _sample(load_terrain("flat-ice"), -1, 1),
    "tilted-plane-20deg": lambda: _sample(None, -1, 1),
    "parallel-walls-0.35": lambda: _sample(None, -0.4, 0.4, skip=lambda p: np.abs(p[:, 1]) < 1e-3),
    "tube-r0.3": lambda: _sample(None, -0.5, 0.5, skip=lambda p: np.hypot(p[:, 1], p[:, 2]) < 1e-3),
    "u-channel": lambda: _sample(None, -0.5, 0.5, skip=lambda p: np.abs(p[:, 1]) < 1e-3),
}


@pytest.mark.parametrize("name", list(CASES))
def test_exact_kinds_normal_is_gradient_and_closest_on_surface(name):
    t = load_terrain(name)
    p = CASES[name]()
    q = t.query(p)
    g = fd_gradient(t.distance, p)
    np.testing.assert_allclose(q.normal, g, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(p - q.closest, axis=1), np.abs(q.distance), atol=1e-12)
    np.testing.assert_allclose(t.distance(q.closest), 0, atol=1e-12)


@pytest.mark.parametrize("name", ["rough-tube", "moulin"])
def test_rough_kinds_normal_is_gradient_on_surface(name):
    t = load_terrain(name)
    p = rng.uniform(-0.25, 0.25, (80, 3))
    p[:, 2] = rng.uniform(-3, -0.3, 80) if name == "moulin" else p[:, 2]
    s = onto_surface(t, p)
    q = t.query(s)
    assert np.abs(q.distance).max() < 1e-9
    g = fd_gradient(t.distance, s)
    np.testing.assert_allclose(q.normal, g, atol=1e-5)
    # first-order distance: the closest point of a nearby point is on the surface to second order
    p2 = s + 0.01 * q.normal
    q2 = t.query(p2)
    assert np.all(np.abs(q2.distance - 0.01) < 2e-3)
    assert np.abs(t.distance(q2.closest)).max() < 1e-3


def test_rough_tube_is_seeded_and_has_the_requested_roughness():
    base = {"kind": "tube", "radius": 0.3, "roughness": {"rms": 0.02, "n_modes": 20, "seed": 1}}
    t1, t1b = build_terrain(base), build_terrain(base)
    t2 = build_terrain({**base, "roughness": {"rms": 0.02, "n_modes": 20, "seed": 2}})
    s = np.linspace(0, 50, 4000)
    th = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    TH, S = np.meshgrid(th[::40], s)
    rs = t1.wall_radius(TH.ravel(), S.ravel())[0]
    assert np.std(rs) == pytest.approx(0.02, rel=0.15)
    assert np.array_equal(t1.modes, t1b.modes) and not np.array_equal(t1.modes, t2.modes)
    # on the axis the distance is the wall radius straight out (to first order)
    assert t1.distance([[0, 0, 0]])[0] == pytest.approx(0.3, abs=0.1)


def test_moulin_radius_varies_with_depth_and_surface_region():
    t = load_terrain("moulin")
    shaft = t.shaft
    z = np.linspace(-20, -1, 200)
    r_depth = shaft.wall_radius(np.zeros_like(z), z)[0]
    r_angle = shaft.wall_radius(np.linspace(0, 2 * np.pi, 200), np.full(200, -5.0))[0]
    assert np.ptp(r_depth) > 0.05 and np.ptp(r_angle) > 0.02
    # mean radius narrows with depth by the slope: r(−20) ≈ 0.5 − 0.2
    assert np.mean(shaft.wall_radius(np.linspace(0, 2 * np.pi, 64), np.full(64, -20.0))[0]) < 0.45
    q = t.query([[3.0, 0, 0.2], [3.0, 0, -0.2], [0, 0, -5.0]])
    names = [t.materials[i].name for i in q.material]
    assert names == ["snow-ice", "snow-ice", "ice"]
    np.testing.assert_allclose(q.distance[:2], [0.2, -0.2])


@pytest.mark.parametrize("name", ["flat-ice", "tube-r0.3", "u-channel", "rough-tube", "moulin", "fractal-dem"])
def test_distance_lower_bound_is_conservative(name):
    t = load_terrain(name)
    c = rng.uniform(-0.3, 0.3, (30, 3))
    r = rng.uniform(0.01, 0.1, 30)
    assert_distance_lower_bound_holds(t, c, r, rng, samples=200)
