"""Lidar against analytic ranges (plane at a known height and tilt, inside a tube, between
parallel walls), intensity against the diffuse model, self-occlusion by a known link, misses
marked, seeded noise and dropouts, and each class of bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes import F32, ROBOT, USES, all_links_at, initial_link_poses, terrain, world_at
from snakesim.components.perception import Lidar
from snakesim.components.perception.beam_patterns import BeamGrid
from snakesim.components.perception.lidar import DROPOUT, NO_RETURN, RETURN, TOO_CLOSE
from snakesim.framework import Harness

GRID = {"kind": "grid", "channels": 16, "horizontal_samples": 90, "vertical_fov": (-60.0, 10.0)}


def scan(world, params, rate=10.0):
    h = Harness(Lidar, {"link": "lidar", **params}, rate=rate, uses=USES)
    h.inputs.world = world
    return h.outputs()["scan"], h


def grid_directions(spec) -> np.ndarray:
    return BeamGrid(**{k: v for k, v in spec.items() if k != "kind"}).beams().directions


def test_plane_ranges_at_known_height_and_tilt():
    h0, tilt, az = 1.3, 0.2, 0.7
    ground = terrain({"kind": "plane", "tilt": tilt, "azimuth": az})
    world = world_at(ground, all_links_at((0.4, -0.2, h0)), extent=60.0)     # the plane covers the range
    s, _ = scan(world, {"beams": GRID, "max_range": 50.0})
    n = ground.n
    d = s.points / np.linalg.norm(s.points, axis=1, keepdims=True)      # NaN rows stay NaN
    o = np.array([0.4, -0.2, h0])
    dirs = grid_directions(GRID)
    dn = dirs @ n
    expected = np.where(dn < 0, -(o @ n) / np.where(dn < 0, dn, -1.0), np.inf)
    expected[expected > 50.0] = np.inf
    ret = s.status == RETURN
    np.testing.assert_array_equal(ret, np.isfinite(expected))
    # flat terrain is cast in float32 (Embree): rounding of coordinates up to ~50 m
    np.testing.assert_allclose(s.range[ret], expected[ret], rtol=0, atol=16 * F32 * 50.0)
    assert np.all(np.isnan(s.points[~ret])) and np.all(s.status[~ret] == NO_RETURN)
    np.testing.assert_allclose(d[ret], dirs[ret], atol=1e-6)


def test_inside_a_tube_of_known_radius():
    radius = 0.45
    tube = terrain({"kind": "tube", "radius": radius, "axis": (1.0, 0.0, 0.0)})
    world = world_at(tube, all_links_at((2.0, 0.0, 0.0)))
    s, _ = scan(world, {"beams": {**GRID, "vertical_fov": (-80.0, 80.0)}, "max_range": 20.0})
    dirs = grid_directions({**GRID, "vertical_fov": (-80.0, 80.0)})
    radial = np.hypot(dirs[:, 1], dirs[:, 2])
    expected = radius / radial                          # from the axis: r·|d_⊥| = R
    ret = s.status == RETURN
    assert ret.all()
    # curved analytic terrain: mesh hits refined by Newton onto the exact surface (float64)
    np.testing.assert_allclose(s.range, expected, rtol=2 * F32)      # stored as float32


def test_mesh_terrain_hits_are_the_tessellations():
    """terrain_hits: mesh returns the tube's faces, off the exact ranges by at most the faces' own
    distance from the surface (found by sampling them) over the beam's radial part, and off by
    more than rounding (the knob does skip the refinement)."""
    radius = 0.45
    tube = terrain({"kind": "tube", "radius": radius, "axis": (1.0, 0.0, 0.0)})
    world = world_at(tube, all_links_at((2.0, 0.0, 0.0)))
    beams = {**GRID, "vertical_fov": (-80.0, 80.0)}
    exact, _ = scan(world, {"beams": beams, "max_range": 20.0})
    mesh, _ = scan(world, {"beams": beams, "max_range": 20.0, "terrain_hits": "mesh"})
    surf = world.terrain.surfaces
    tri = surf.vertices[surf.faces]                                   # (m, 3, 3)
    w = np.array([(a, b, 10 - a - b) for a in range(11) for b in range(11 - a)]) / 10.0
    sag = np.abs(tube.query((w @ tri).reshape(-1, 3)).distance).max()
    radial = np.hypot(*grid_directions(beams)[:, 1:].T)
    assert np.all(mesh.status == RETURN)
    err = np.abs(mesh.range.astype(float) - exact.range)
    assert np.all(err * radial <= sag * (1 + 1e-6) + 1e-6)
    assert err.max() > 100 * F32 * radius


def test_between_parallel_walls():
    gap = 0.8
    walls = terrain({"kind": "parallel_walls", "gap": gap})
    world = world_at(walls, all_links_at((0.0, 0.1, 0.0)))
    beams = {"kind": "grid", "channels": 1, "horizontal_samples": 36, "vertical_fov": (0.0, 0.0)}
    s, _ = scan(world, {"beams": beams, "max_range": 100.0})
    az = np.radians(180.0 - (np.arange(36) + 0.5) * 10.0)
    sy = np.sin(az)
    expected = np.where(sy > 0, (gap / 2 - 0.1) / np.where(sy > 0, sy, 1), (gap / 2 + 0.1) / np.where(sy < 0, -sy, 1))
    np.testing.assert_allclose(s.range, expected, rtol=8 * F32)


@pytest.mark.parametrize("mode", ["raw", "reflectivity"])
def test_intensity_is_diffuse_reflectance(mode):
    albedo, h0 = 0.35, 2.0
    ground = terrain({"kind": "plane", "materials": [{"name": "snow", "albedo": albedo}]})
    world = world_at(ground, all_links_at((0.0, 0.0, h0)))
    s, _ = scan(world, {"beams": GRID, "intensity": mode, "reference_range": 1.5, "max_range": 100.0})
    ret = s.status == RETURN
    r = s.range[ret].astype(float)
    cos = h0 / r                                                   # incidence on a horizontal plane
    expected = albedo * cos * ((1.5 / r) ** 2 if mode == "raw" else 1.0)
    np.testing.assert_allclose(s.intensity[ret], expected, rtol=1e-5)
    assert np.all(s.intensity[~ret] == 0)


@pytest.mark.parametrize("geometry", ["visual", "collision"])
def test_self_occlusion_by_the_head(geometry):
    poses = initial_link_poses()
    head = poses[ROBOT.link_index("head")]
    ground = terrain({"kind": "plane", "origin": (0.0, 0.0, -1.0)})
    down = {"kind": "grid", "channels": 1, "horizontal_samples": 1, "vertical_fov": (-90.0, -90.0),
            "horizontal_fov": 1.0}
    # 0.2 m above the head's top, over its middle (head: a cylinder r 0.0675 along x from 0 to 0.25 m)
    mount = {"link": "head", "xyz": (0.125, 0.0, 0.0675 + 0.2), "beams": down, "min_range": 0.05}
    s, _ = scan(world_at(ground, poses, robot_visible=True, robot_geometry=geometry), mount)
    assert s.status[0] == RETURN
    # the top of a 32-sided cylinder lies between R·cos(π/32) and R
    sag = 0.0675 * (1 - math.cos(math.pi / 32))
    assert 0.2 - 1e-6 <= s.range[0] <= 0.2 + sag + 1e-6
    s2, _ = scan(world_at(ground, poses, robot_visible=False), mount)
    np.testing.assert_allclose(s2.range[0], head[2] + 0.0675 + 0.2 + 1.0, rtol=4 * F32)
    # 2 cm above the head: the head blocks the beam inside min_range (no return, marked)
    s3, _ = scan(world_at(ground, poses, robot_visible=True, robot_geometry=geometry), {**mount, "xyz": (0.125, 0.0, 0.0675 + 0.02)})
    assert s3.status[0] == TOO_CLOSE and np.isnan(s3.range[0])


def test_noise_and_dropouts_are_seeded_and_marked():
    ground = terrain({"kind": "plane"})
    world = world_at(ground, all_links_at((0.0, 0.0, 1.0)))
    base = {"beams": GRID, "max_range": 100.0}
    clean, _ = scan(world, base)
    noisy, _ = scan(world, {**base, "range_noise": 0.01, "dropout": 0.2, "seed": 3})
    again, _ = scan(world, {**base, "range_noise": 0.01, "dropout": 0.2, "seed": 3})
    other, _ = scan(world, {**base, "range_noise": 0.01, "dropout": 0.2, "seed": 4})
    np.testing.assert_array_equal(noisy.range, again.range)
    assert not np.array_equal(np.nan_to_num(noisy.range), np.nan_to_num(other.range))
    lost = noisy.status == DROPOUT
    had = clean.status == RETURN
    assert np.all(had[lost]) and np.all(np.isnan(noisy.range[lost]))
    # dropout fraction and noise spread within 5 standard errors of the model
    n = had.sum()
    assert abs(lost.sum() / n - 0.2) < 5 * math.sqrt(0.2 * 0.8 / n)
    both = noisy.status == RETURN
    err = noisy.range[both].astype(float) - clean.range[both]
    assert abs(err.std() - 0.01) < 5 * 0.01 / math.sqrt(2 * both.sum())


def test_presets_turn_on_with_one_line():
    ground = terrain({"kind": "plane"})
    world = world_at(ground, all_links_at((0.0, 0.0, 1.0)))
    for preset, n in [("spinning-32", 32 * 1024), ("solid-state-rosette", 10000)]:
        s, _ = scan(world, {"preset": preset})
        assert len(s.range) == n and (s.status == RETURN).any()


@pytest.mark.parametrize("params, words", [
    ({"link": "no_such_link", "preset": "spinning-32"}, ["no_such_link", "lidar"]),
    ({"preset": "velodyne-9000"}, ["velodyne-9000", "spinning-32"]),
    ({}, ["beams", "preset"]),
    ({"preset": "spinning-32", "min_range": 5.0, "max_range": 2.0}, ["min_range", "max_range"]),
    ({"beams": {"kind": "grid", "channels": 4, "horizontal_samples": 4, "vertical_fov": (10.0, -10.0)}},
     ["vertical_fov"]),
    ({"preset": "spinning-32", "dropout": 1.5}, ["dropout"]),
    ({"preset": "spinning-32", "terrain_hits": "fast"}, ["terrain_hits", "exact", "mesh"]),
])
def test_bad_parameters_are_named(params, words):
    with pytest.raises(Exception) as e:
        Harness(Lidar, {"link": "lidar", **params}, rate=10.0, uses=USES)
    for w in words:
        assert w in str(e.value)


def test_a_lidar_needs_a_rate():
    with pytest.raises(ValueError, match="rate"):
        Harness(Lidar, {"preset": "spinning-32"}, uses=USES)


def test_beam_files(tmp_path):
    good = tmp_path / "beams.csv"
    good.write_text("ox,oy,oz,dx,dy,dz\n0,0,0,0,0,-1\n0.1,0,0,0.6,0,-0.8\n")
    ground = terrain({"kind": "plane"})
    world = world_at(ground, all_links_at((0.0, 0.0, 1.0)))
    s, _ = scan(world, {"beams": {"kind": "file", "path": str(good)}})
    np.testing.assert_allclose(s.range, [1.0, 1.0 / 0.8], rtol=4 * F32)
    np.testing.assert_allclose(s.points[1], [0.1 + 0.6 / 0.8, 0.0, -1.0], atol=1e-6)
    bad = {"nonunit.csv": ("0,0,-2\n", ["row 0", "length 2"]),
           "zero.csv": ("0,0,0\n", ["row 0", "length 0"]),
           "nan.csv": ("0,nan,1\n", ["row 0", "not finite"]),
           "cols.csv": ("0,1\n", ["shape", "(n, 3)"]),
           "missing.csv": (None, ["not found"])}
    for name, (text, words) in bad.items():
        f = tmp_path / name
        if text is not None:
            f.write_text(text)
        with pytest.raises(ValueError) as e:
            Harness(Lidar, {"link": "lidar", "beams": {"kind": "file", "path": str(f)}}, rate=10.0, uses=USES)
        for w in [name] + words:
            assert w in str(e.value), (name, str(e.value))
