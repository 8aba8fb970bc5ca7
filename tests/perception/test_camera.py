"""Cameras: depth, range and shading against the analytic plane and the Lambertian model, a
rendered checkerboard showing each model's distortion where the model puts its corners (the
paper's figure-7 CAHV, CAHVOR and CAHVORE among them), stereo geometry, sun shadows, and each
class of bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes import F32, USES, all_links_at, terrain, world_at
from snakesim.components.perception import Camera, StereoCamera
from snakesim.components.perception.camera_models import PAPER_FIGURE_7, PAPER_FIGURE_7_SIZE
from snakesim.framework import Harness

DOWN = (1.0, 0.0, 0.0, 0.0)          # link rotated π about x: optical z (optical: false) looks down
H = 3.0


def shoot(world, params, cls=Camera, rate=5.0):
    h = Harness(cls, {"link": "camera_left", "optical": False, "width": 64, "height": 48, **params},
                rate=rate, uses=USES)
    h.inputs.world = world
    return h.outputs()


def ground(**material):
    return terrain({"kind": "plane", "materials": [{"name": "ice", **material}]})


def test_depth_and_range_of_a_plane_below():
    world = world_at(ground(), all_links_at((0.5, -0.3, H), DOWN))
    f = shoot(world, {"model": {"kind": "pinhole", "fov": 90.0}})["frame"]
    np.testing.assert_allclose(f.depth, H, rtol=4 * F32)
    _, d = f.model.pixel_rays()
    np.testing.assert_allclose(f.range, H / d[..., 2], rtol=4 * F32)      # along each pixel's ray
    np.testing.assert_allclose(f.pose[:3], [0.5, -0.3, H])


@pytest.mark.parametrize("light", ["sun", "headlamp"])
def test_lambertian_shading(light):
    albedo, e, amb = 0.6, 0.8, 0.1
    world = world_at(ground(albedo=albedo), all_links_at((0.0, 0.0, H), DOWN))
    spec = {"kind": light, "intensity": e, "ambient": amb, "direction": (0.0, 0.6, -0.8), "reference_range": 2.0}
    f = shoot(world, {"light": spec, "model": {"kind": "pinhole", "fov": 100.0}})["frame"]
    if light == "sun":
        expected = albedo * (amb + e * 0.8) * np.ones_like(f.image)        # cos θ = n·l = 0.8 everywhere
    else:
        r = f.range.astype(float)
        expected = albedo * (amb + e * (H / r) * (2.0 / r) ** 2)           # cos θ = H / r, 1/r² falloff
    np.testing.assert_allclose(f.image, expected, rtol=1e-5)


def test_colour_images_use_the_material_colour():
    world = world_at(ground(color=(0.2, 0.5, 0.9)), all_links_at((0.0, 0.0, H), DOWN))
    f = shoot(world, {"color": True, "light": {"kind": "sun", "direction": (0, 0, -1), "ambient": 0.0}})["frame"]
    assert f.image.shape == (48, 64, 3)
    np.testing.assert_allclose(f.image, np.broadcast_to([0.2, 0.5, 0.9], f.image.shape), rtol=1e-6)


@pytest.mark.parametrize("model", ["pinhole", "fisheye", "cahv", "cahvor", "cahvore"])
def test_a_rendered_checkerboard_shows_the_models_distortion(model):
    """The paper's figure-7 models (H, V of a 620×640 image, camera 35 m above the plane) and
    central models of a wide field: every checker corner in view lies where the model projects it."""
    if model.startswith("cahv"):
        (w, h), spec, height, size = PAPER_FIGURE_7_SIZE, PAPER_FIGURE_7[model], 35.0, 4.0
    else:
        w, h, height, size = 320, 240, 2.0, 0.5
        spec = {"kind": "pinhole", "fov": 100.0} if model == "pinhole" else {"kind": "fisheye", "fov": 200.0}
    plane = ground(texture="checker", texture_size=size, texture_contrast=0.8)
    world = world_at(plane, all_links_at((0.0, 0.0, height), DOWN), extent=80.0)
    f = shoot(world, {"model": spec, "width": w, "height": h,
                      "light": {"kind": "sun", "direction": (0, 0, -1), "ambient": 0.0}})["frame"]
    checked, bad = checker_corners(f, size)
    assert checked >= 20 and bad == 0, (checked, bad)


def checker_corners(f, size):
    """Each checker corner (x, y on the ground) the model projects well inside the image: the
    image at the model's projections of four points around it (0.3 squares off on the diagonals)
    must be light and dark as the squares' parity says (where the probes are ≥ 2 px from the
    edges: the squares are resolved). -> (corners checked, corners wrong)."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_quat(f.pose[3:]).as_matrix()
    p = f.pose[:3]
    k = np.arange(-30, 31) * size
    X, Y = np.meshgrid(k, k)
    checked = bad = 0
    eps = 0.3 * size
    offsets = eps * np.array([[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]])
    for c in np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1):
        probes = c + offsets
        uv, ok = f.model.project((probes - p) @ R)
        if not ok.all():
            continue
        pix = np.rint(uv).astype(int)
        if ((pix < 1) | (pix > [f.model.width - 2, f.model.height - 2])).any():
            continue
        # each probe is 0.3 squares from both edges through the corner: where that is under 2 px
        # (squares foreshortened towards a fisheye's horizon), pixel rounding could cross an edge
        edges, _ = f.model.project((c + np.diag([eps, eps, 0.0]) - p) @ R)
        centre, _ = f.model.project((c[None] - p) @ R)
        if np.linalg.norm(edges[:2] - centre, axis=1).min() < 2.0:
            continue
        values = f.image[pix[:, 1], pix[:, 0]]
        light = (np.floor(probes[:, 0] / size) + np.floor(probes[:, 1] / size)) % 2 == 0
        checked += 1
        bad += int(not np.all((values > 0.5 * values.max()) == light))
    return checked, bad


def test_stereo_pair_sees_the_disparity_of_its_baseline():
    """Fronto-parallel textured plane at H: the right image is the left shifted by f·b/H pixels
    (pinhole, fov 90° across 64 px: f = 32 px; b = 0.375 m, H = 3 m: 4 px)."""
    plane = ground(texture="checker", texture_size=0.3, texture_contrast=0.8)
    world = world_at(plane, all_links_at((0.1, 0.2, H), DOWN))
    out = shoot(world, {"baseline": 0.375, "model": {"kind": "pinhole", "fov": 90.0},
                        "light": {"kind": "sun", "direction": (0, 0, -1)}}, cls=StereoCamera)
    left, right = out["left"], out["right"]
    np.testing.assert_allclose(right.pose[:3] - left.pose[:3], [0.375, 0.0, 0.0], atol=1e-15)  # optical x = world x
    np.testing.assert_array_equal(right.depth, left.depth)
    same = np.isclose(right.image[:, :-4], left.image[:, 4:], rtol=1e-6)
    # a pixel whose ray lands within rounding of a checker edge may fall either side
    assert same.mean() > 0.995, same.mean()
    assert left.seq == right.seq and left.t == right.t


def test_sun_shadows_of_a_rock():
    """A rock (sphere r = 0.5 m, centre 1 m up) under a sun at 45°: its shadow on the ground is
    the ellipse of semi-axes (r·√2, r) centred 1 m down-sun of its foot; inside it the ground gets
    ambient light only."""
    r, zc = 0.5, 1.0
    field = terrain({"kind": "obstacles", "spheres": [{"center": (0.0, 0.0, zc), "radius": r}],
                     "materials": [{"name": "ice", "albedo": 0.5}]})
    sun = {"kind": "sun", "direction": (1.0, 0.0, -1.0), "intensity": 1.0, "ambient": 0.1, "shadows": True}
    world = world_at(field, all_links_at((1.0, 0.0, 6.0), DOWN))
    f = shoot(world, {"model": {"kind": "pinhole", "fov": 60.0}, "width": 160, "height": 120, "light": sun})["frame"]
    from scipy.spatial.transform import Rotation

    R = Rotation.from_quat(f.pose[3:]).as_matrix()
    _, d = f.model.pixel_rays()
    hit = f.pose[:3] + f.range[..., None] * (d @ R.T)
    on_ground = np.abs(hit[..., 2]) < 1e-6
    ex = ((hit[..., 0] - zc) / (r * math.sqrt(2))) ** 2 + (hit[..., 1] / r) ** 2      # < 1 inside the shadow
    lit = 0.5 * (0.1 + math.sqrt(0.5))
    shade = 0.5 * 0.1
    inside, outside = on_ground & (ex < 0.9 ** 2), on_ground & (ex > 1.1 ** 2)
    assert inside.sum() > 100 and outside.sum() > 100
    np.testing.assert_allclose(f.image[inside], shade, rtol=1e-6)
    np.testing.assert_allclose(f.image[outside], lit, rtol=1e-6)


def test_pixels_without_a_ray_are_background():
    world = world_at(ground(), all_links_at((0.0, 0.0, H), DOWN))
    f = shoot(world, {"model": {"kind": "fisheye", "fov": 360.0}, "width": 64, "height": 64, "background": 0.25,
                      "light": {"kind": "sun", "direction": (0, 0, -1)}})["frame"]
    assert f.image[0, 0] == np.float32(0.25) and np.isnan(f.range[0, 0])       # the corner: beyond 360°
    assert np.isfinite(f.range[32, 32])


@pytest.mark.parametrize("params, words", [
    ({"link": "antenna"}, ["antenna", "link"]),
    ({"model": {"kind": "pinhole", "fov": 180.0}}, ["fov", "180"]),
    ({"model": {"kind": "pinhole", "fx": float("nan"), "fy": 1.0, "cx": 1.0, "cy": 1.0}}, ["fx"]),
    ({"model": {"kind": "cahv", "c": (0, 0, 0), "a": (0, 0, 1), "h": (0, 0, 1), "v": (0, 1, 0)}}, ["h"]),
    ({"model": {"kind": "orthographic"}}, ["orthographic", "pinhole"]),
    ({"near": 5.0, "max_range": 1.0}, ["near", "max_range"]),
    ({"width": 0}, ["width"]),
    ({"light": {"kind": "sun", "direction": (0, 0, 0)}}, ["direction"]),
    ({"terrain_hits": "approximate"}, ["terrain_hits", "exact", "mesh"]),
])
def test_bad_camera_parameters_are_named(params, words):
    with pytest.raises(Exception) as e:
        Harness(Camera, {"link": "camera_left", **params}, rate=5.0, uses=USES)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_a_camera_needs_a_rate():
    with pytest.raises(ValueError, match="rate"):
        Harness(Camera, {"link": "camera_left"}, uses=USES)
