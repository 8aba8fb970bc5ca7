"""Localisation-degradation knobs against their models: dust or fog's range noise σ(r) = σ0 + k·r and
intensity exp(−2αr) with weak returns lost below a threshold, burst packet loss, and feature-poor ice
(texture contrast scaled). Statistics are checked within bounds from the sample count (4 standard
errors: a false failure about once in 16 000 runs; the draws are seeded, so a run is reproducible)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes import USES, all_links_at, terrain, world_at
from snakesim.components.perception import Camera, Lidar
from snakesim.components.perception.lidar import DROPOUT, RETURN, WEAK
from snakesim.framework import Harness

Z = 4.0
WALLS = terrain({"kind": "parallel_walls", "gap": 0.8})
RING = {"kind": "grid", "channels": 1, "horizontal_samples": 360, "vertical_fov": (0.0, 0.0)}
GRID = {"kind": "grid", "channels": 16, "horizontal_samples": 90, "vertical_fov": (-80.0, -5.0)}


def lidar(world, **params):
    h = Harness(Lidar, {"link": "lidar", "max_range": 60.0, **params}, rate=10.0, uses=USES)
    h.inputs.world = world
    return h.c


def test_range_noise_grows_with_range():
    world = world_at(WALLS, all_links_at((0.0, 0.1, 0.0)))
    sigma0, slope = 0.002, 0.01
    clean = lidar(world, beams=RING).sample(world, 0.0, 0)
    noisy = lidar(world, beams=RING, range_noise=sigma0, range_noise_slope=slope, seed=7)
    ok = clean.status == RETURN                                      # (beams along the walls see nothing)
    r = clean.range[ok].astype(float)
    assert ok.sum() > 300 and r.min() < 0.5 and r.max() > 10.0                         # σ spans a factor of ~15
    z = np.array([(noisy.sample(world, 0.0, k).range[ok] - r) / (sigma0 + slope * r) for k in range(20)])
    n = z.size
    assert abs(z.mean()) < Z / math.sqrt(n)
    assert abs(z.var() - 1.0) < Z * math.sqrt(2.0 / n)
    # normalised by a constant σ instead, near and far beams would differ by far more than that
    near, far = r < 1.0, r > 5.0
    n_near, n_far = 20 * near.sum(), 20 * far.sum()
    assert abs(z[:, near].std() / z[:, far].std() - 1.0) < Z * math.sqrt(1.0 / (2 * n_near) + 1.0 / (2 * n_far))
    # consecutive samples draw fresh noise (the counter is not Philox's block word: no shifted repeats)
    a, b = z[0], z[1]
    assert abs(np.corrcoef(a[4:], b[:-4])[0, 1]) < Z / math.sqrt(len(a) - 4)


@pytest.mark.parametrize("mode", ["raw", "reflectivity"])
def test_attenuation_and_weak_returns(mode):
    albedo, h0, alpha, threshold = 0.5, 2.0, 0.05, 0.02
    ground = terrain({"kind": "plane", "materials": [{"name": "snow", "albedo": albedo}]})
    world = world_at(ground, all_links_at((0.0, 0.0, h0)))
    base = {"beams": GRID, "intensity": mode}
    clean = lidar(world, **base).sample(world, 0.0, 0)
    fog = lidar(world, **base, attenuation=alpha, detection_threshold=threshold).sample(world, 0.0, 0)
    r = clean.range.astype(float)
    power = albedo * (h0 / r) / r ** 2 * np.exp(-2 * alpha * r)          # ρ cos θ (r_ref/r)² e^(−2αr), r_ref 1 m
    weak = power < threshold
    assert 0 < weak.sum() < len(r)                                        # some beams lost, some kept
    np.testing.assert_array_equal(fog.status == WEAK, weak)
    assert np.all(np.isnan(fog.range[weak])) and np.all(fog.intensity[weak] == 0)
    keep = ~weak
    np.testing.assert_allclose(fog.intensity[keep], clean.intensity[keep] * np.exp(-2 * alpha * r[keep]), rtol=1e-5)
    np.testing.assert_array_equal(fog.range[keep], clean.range[keep])


def test_packets_are_lost_whole():
    world = world_at(terrain({"kind": "plane"}), all_links_at((0.0, 0.0, 1.0)))
    beams = {"kind": "grid", "channels": 4, "horizontal_samples": 256, "vertical_fov": (-60.0, -30.0)}
    p, packets, samples = 0.3, 32, 25
    c = lidar(world, beams=beams, packet_loss=p, packets=packets, seed=2)
    lost = np.array([(c.sample(world, 0.0, k).status == DROPOUT).reshape(4, packets, 8) for k in range(samples)])
    whole = lost.all(axis=(1, 3))
    np.testing.assert_array_equal(lost.any(axis=(1, 3)), whole)      # a packet: every channel, 8 columns
    n = whole.size
    assert abs(whole.mean() - p) < Z * math.sqrt(p * (1 - p) / n)


def test_texture_contrast_makes_ice_featureless():
    """A checker ice (contrast C) seen straight down under a sun from above: every pixel is ρ·f·(ambient + E)
    with f = 1 or 1 − c·C, c the camera's texture_contrast; the lidar's reflectivity ρ·f·cos θ likewise."""
    C, albedo = 0.6, 0.7
    ice = terrain({"kind": "plane", "materials": [{"name": "ice", "albedo": albedo, "texture": "checker",
                                                   "texture_size": 0.25, "texture_contrast": C}]})
    down = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))
    world = world_at(ice, all_links_at((0.0, 0.0, 2.0), down))
    for c in (1.0, 0.5, 0.0):
        h = Harness(Camera, {"link": "camera_left", "width": 64, "height": 48, "texture_contrast": c,
                             "light": {"kind": "sun", "direction": (0.0, 0.0, -1.0), "ambient": 0.1}},
                    rate=5.0, uses=USES)
        h.inputs.world = world
        f = h.outputs()["frame"].image / (albedo * 1.1)
        dark = f < 1.0 - 1e-5
        assert dark.mean() == pytest.approx(0.5, abs=0.15) if c > 0 else not dark.any()
        np.testing.assert_allclose(f[~dark], 1.0, rtol=1e-5)
        np.testing.assert_allclose(f[dark], 1.0 - c * C, rtol=1e-5)
        s = lidar(world, beams=GRID, intensity="reflectivity", texture_contrast=c).sample(world, 0.0, 0)
        ret = s.status == RETURN
        g = s.intensity[ret] / (albedo * 2.0 / s.range[ret])           # cos θ = h/r looking at level ground
        levels = np.array([1.0, 1.0 - c * C])
        nearest = np.abs(g[:, None] - levels).argmin(axis=1)
        np.testing.assert_allclose(g, levels[nearest], rtol=1e-5)
        assert set(nearest.tolist()) == ({0, 1} if c > 0 else {0})


@pytest.mark.parametrize("params, words", [
    ({"packet_loss": 1.0}, ["packet_loss", "less than 1"]),
    ({"packets": 0}, ["packets", "greater than or equal to 1"]),
    ({"texture_contrast": 1.5}, ["texture_contrast", "less than or equal to 1"]),
    ({"attenuation": -0.1}, ["attenuation", "greater than or equal to 0"]),
    ({"range_noise_slope": -1.0}, ["range_noise_slope"]),
    ({"motion_distortion": "sometimes"}, ["motion_distortion"]),
])
def test_bad_knobs_are_named(params, words):
    with pytest.raises(Exception) as e:
        Harness(Lidar, {"link": "lidar", "preset": "spinning-32", **params}, rate=10.0, uses=USES)
    for w in words:
        assert w in str(e.value)
