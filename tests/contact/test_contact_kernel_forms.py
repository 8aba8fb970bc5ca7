"""Hand-unrolled contact kernels against their plain definitions: the lever quadratic Xᵀ D X of a point
derivative (jacobian_kernels.add_lever_quadratic, and add_lever_rank1 for a rank-one D) against the matrix
product, and the max_depth watch's least distance (sdf_kernels.least_distance) against ``ndarray.min`` (NaN
and no rows included)."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.contact.jacobian_kernels import add_lever_quadratic, add_lever_rank1
from snakesim.components.contact.sdf_kernels import least_distance


def _lever(r):
    """X = [I, L], L = −[r]× (3×6): the velocity of a point at r from a link origin given its twist [v, ω]."""
    L = -np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return np.hstack([np.eye(3), L])


@pytest.mark.parametrize("seed", range(5))
def test_lever_quadratic_adds_xt_d_x(seed):
    rng = np.random.default_rng(seed)
    r, D = rng.normal(size=3) * 0.2, rng.normal(size=(3, 3)) * 1e4     # lever ~ a screw radius, k-sized slopes
    before = rng.normal(size=(6, 6))
    out = before.copy()
    add_lever_quadratic(r, D, out)
    X = _lever(r)
    want = X.T @ D @ X
    # round-off of a 3-term product on entries of size |D| |r|²
    np.testing.assert_allclose(out - before, want, rtol=0, atol=1e-12 * np.abs(D).max() * (1 + (r @ r)) + 1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_lever_rank1_adds_xt_g_mt_x(seed):
    """The depth derivative g ⊗ m (rank one) through the lever: X^T (g m^T) X, as the plain product."""
    rng = np.random.default_rng(10 + seed)
    r, g, m = rng.normal(size=3) * 0.2, rng.normal(size=3), rng.normal(size=3) * 1e4
    before = rng.normal(size=(6, 6))
    out = before.copy()
    add_lever_rank1(r, g, m, out)
    X = _lever(r)
    want = X.T @ np.outer(g, m) @ X
    np.testing.assert_allclose(out - before, want, rtol=0,
                               atol=1e-12 * np.abs(g).max() * np.abs(m).max() * (1 + (r @ r)) + 1e-12)


def test_lever_quadratic_at_the_origin_is_d_in_the_force_block():
    D = np.arange(9.0).reshape(3, 3)
    out = np.zeros((6, 6))
    add_lever_quadratic(np.zeros(3), D, out)
    assert np.array_equal(out[:3, :3], D) and not out[3:].any() and not out[:, 3:].any()


@pytest.mark.parametrize("values, m", [([0.3, -0.002, 0.1, -0.5], 3), ([0.3, np.nan, -1.0], 3),
                                       ([-0.1, 0.2], 0), ([np.inf, 2.0], 2), ([-0.0, 0.0], 2)])
def test_least_distance_is_ndarray_min_over_the_rows(values, m):
    d = np.array(values)
    counts = np.zeros(7, dtype=np.int64)
    counts[4] = m
    got = least_distance(d, counts)
    want = d[:m].min() if m else np.inf
    assert (np.isnan(got) and np.isnan(want)) or got == want
