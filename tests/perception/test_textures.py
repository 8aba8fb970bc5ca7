"""The compiled texture pass (apply_textures, in place over a cast's hits) is the NumPy factor
(texture_factor) applied to the hits with a terrain material, and leaves every other ray alone."""

from __future__ import annotations

import numpy as np

from snakesim.components.perception.textures import CHECKER, NONE, apply_textures, texture_factor


def test_the_compiled_pass_is_the_numpy_factor():
    rng = np.random.default_rng(0)
    table = np.array([[NONE, 0.0, 0.0], [CHECKER, 0.25, 0.4], [CHECKER, 1.0, 0.9]])
    n = 20000
    o = rng.uniform(-5, 5, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    distance = rng.uniform(0.1, 20.0, n)
    distance[::97] = np.inf                                  # misses
    material = rng.integers(-1, 3, n)                        # -1: the robot or nothing
    albedo, color = rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, (n, 3))
    a, c = albedo.copy(), color.copy()
    apply_textures(table, material, o, d, distance, a, c)
    on = np.flatnonzero((material >= 0) & np.isfinite(distance))
    f = np.ones(n)
    f[on] = texture_factor(table, material[on], o[on] + distance[on, None] * d[on])
    np.testing.assert_array_equal(a, albedo * f)
    np.testing.assert_array_equal(c, color * f[:, None])
    assert 0.2 < np.mean(f[on] < 1.0) < 0.5                  # the checkers' dark half of their share
