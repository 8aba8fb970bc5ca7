"""The compiled refinement of Fourier-cylinder terrains (.refine_kernels) is the terrain's own
distance and the NumPy Newton iteration, written out: same distance and normal as
``terrain.query`` at any point (on the s-table, turned by its Taylor series, and off it, by
sine and cosine), same refined hits as the NumPy iteration, to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from scenes import all_links_at, terrain, world_at
from snakesim.components.perception import ray_caster as rc
from snakesim.components.perception.refine_kernels import FourierRefiner

ROUGH = {"rms": 0.04, "n_modes": 24, "wavelength_min": 0.3, "wavelength_max": 5.0, "m_min": 0, "m_max": 5}
KINDS = {
    "moulin": {"kind": "moulin", "radius": 0.5, "roughness": ROUGH},
    "rough_tube": {"kind": "tube", "radius": 0.45, "axis": (1.0, 0.2, 0.1), "roughness": {**ROUGH, "m_min": 1}},
    "tube": {"kind": "tube", "radius": 0.45},
}


def points_near_the_wall(t, n, span, rng):
    """Points within ±5 cm of the mean wall, s over ``span`` along the cylinder's axis."""
    shaft = getattr(t, "shaft", t)
    th, s = rng.uniform(0, 2 * np.pi, n), rng.uniform(*span, n)
    r = shaft.radius + rng.uniform(-0.05, 0.05, n)
    local = np.stack([r * np.cos(th), r * np.sin(th), s], axis=1)
    return shaft.origin + local @ shaft.R.T


@pytest.mark.parametrize("kind", KINDS)
def test_the_compiled_distance_is_the_terrains(kind):
    t = terrain(KINDS[kind])
    rng = np.random.default_rng(0)
    shaft = getattr(t, "shaft", t)
    # the table spans s in [-6, 1] m: points on it and past both ends
    mesh = shaft.origin + np.outer([-5.0, 0.0], shaft.R[:, 2])
    refiner = FourierRefiner.for_terrain(t, mesh, margin=1.0)
    for span in [(-6.0, 1.0), (-9.0, -6.5), (1.5, 3.0)]:
        p = points_near_the_wall(t, 4000, span, rng)
        if kind == "moulin":
            p[::7, 2] = rng.uniform(0.0, 0.3, len(p[::7]))     # above the ice surface: its region
        d, n, mat = refiner.query(p)
        q = t.query(p)
        np.testing.assert_allclose(d, q.distance, rtol=0, atol=1e-13)
        np.testing.assert_allclose(n, q.normal, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(mat, q.material)


@pytest.mark.parametrize("kind", ["moulin", "rough_tube"])
def test_compiled_refinement_equals_the_numpy_iteration(kind, monkeypatch):
    t = terrain(KINDS[kind])
    shaft = getattr(t, "shaft", t)
    inside = shaft.origin - 2.0 * shaft.R[:, 2]                     # on the axis, 2 m in
    world = world_at(t, all_links_at(inside), extent=8.0)
    ter = world.terrain
    assert ter.refiner is not None
    rng = np.random.default_rng(1)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(inside, d.shape) + rng.normal(scale=0.05, size=d.shape)
    compiled = world.cast(o, d, 20.0)
    monkeypatch.setattr(ter, "refiner", None)                       # the NumPy iteration
    numpy = world.cast(o, d, 20.0)
    hit = np.isfinite(numpy.distance)
    assert hit.mean() > 0.9
    np.testing.assert_array_equal(np.isfinite(compiled.distance), hit)
    np.testing.assert_allclose(compiled.distance[hit], numpy.distance[hit], rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled.normal[hit], numpy.normal[hit], rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled.albedo[hit], numpy.albedo[hit], rtol=0, atol=0)
    # and the refinement moved the hits off the tessellation: the distance along the ray is ~0
    q = t.query(o[hit] + compiled.distance[hit, None] * d[hit])
    assert np.median(np.abs(q.distance)) < 1e-9


def test_other_kinds_keep_the_numpy_iteration():
    assert FourierRefiner.for_terrain(terrain({"kind": "u_channel", "width": 0.5})) is None
    assert FourierRefiner.for_terrain(terrain({"kind": "plane"})) is None
    assert rc.FourierRefiner is FourierRefiner
