"""Image filters after a camera: each an ordinary component; noise is seeded and has the model's
statistics, vignetting follows cos⁴ of the ray angle, gamma and colour adjust are exact, and a
filter recomputes only when a new frame arrives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes import USES, all_links_at, terrain, world_at
from snakesim.components.perception import Camera, ColorAdjust, Gamma, ImageNoise, Vignetting
from snakesim.framework import Harness

DOWN = (1.0, 0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def frame():
    world = world_at(terrain({"kind": "plane", "materials": [{"name": "ice", "albedo": 0.5}]}),
                     all_links_at((0.0, 0.0, 2.0), DOWN))
    h = Harness(Camera, {"link": "camera_left", "optical": False, "width": 80, "height": 60, "color": True,
                         "model": {"kind": "pinhole", "fov": 100.0},
                         "light": {"kind": "sun", "direction": (0, 0, -1), "ambient": 0.0}}, rate=5.0, uses=USES)
    h.inputs.world = world
    return h.outputs()["frame"]


def run(cls, params, frame):
    h = Harness(cls, params)
    h.inputs.frame_in = frame
    return h, h.outputs()["frame"]


def test_noise_is_seeded_with_shot_and_read_statistics(frame):
    _, a = run(ImageNoise, {"shot": 0.01, "read": 0.02, "seed": 1}, frame)
    _, b = run(ImageNoise, {"shot": 0.01, "read": 0.02, "seed": 1}, frame)
    _, c = run(ImageNoise, {"shot": 0.01, "read": 0.02, "seed": 2}, frame)
    np.testing.assert_array_equal(a.image, b.image)
    assert not np.array_equal(a.image, c.image)
    err = (a.image - frame.image).astype(float)
    std = math.sqrt(frame.image.mean() * 0.01 + 0.02 ** 2)          # uniform image: one std
    assert abs(err.mean()) < 5 * std / math.sqrt(err.size)
    assert abs(err.std() - std) < 5 * std / math.sqrt(2 * err.size)
    assert a.t == frame.t and a.depth is frame.depth                   # only the image changes


def test_vignetting_is_cos4_of_the_ray_angle(frame):
    _, out = run(Vignetting, {}, frame)
    _, d = frame.model.pixel_rays()
    np.testing.assert_allclose(out.image, frame.image * (d[..., 2] ** 4)[..., None], rtol=1e-6)
    _, radial = run(Vignetting, {"cos4": False, "k1": -0.3}, frame)
    np.testing.assert_allclose(radial.image[0, 0], frame.image[0, 0] * 0.7, rtol=1e-6)   # corner: ρ = 1


def test_gamma_and_colour_adjust(frame):
    _, g = run(Gamma, {"gamma": 2.0}, frame)
    np.testing.assert_allclose(g.image, np.sqrt(frame.image), rtol=1e-6)
    _, c = run(ColorAdjust, {"gain": (2.0, 1.0, 0.5), "offset": 0.1, "saturation": 0.0}, frame)
    scaled = frame.image * np.array([2.0, 1.0, 0.5], dtype=np.float32) + 0.1
    np.testing.assert_allclose(c.image, np.repeat(scaled.mean(axis=2, keepdims=True), 3, axis=2), rtol=1e-6)


def test_a_filter_recomputes_only_for_a_new_frame(frame):
    h, first = run(ImageNoise, {"read": 0.1}, frame)
    assert h.outputs()["frame"] is first                              # same input object: memo
    h.inputs.frame_in = frame.with_image(frame.image)
    assert h.outputs()["frame"] is not first
