"""Seeded white noise (sensors/noise.py): independent from sample to sample and unit-variance.

Each sample's draw must not reuse another sample's numbers: Philox's first counter word advances once
per four 64-bit outputs, so a tick kept in that word made a 6-vector sample repeat the next sample's
first two values (an IMU's gyro and accelerometer noise then correlated across samples)."""

from __future__ import annotations

import numpy as np

from snakesim.components.sensors.noise import white_noise

N = 4000


def test_consecutive_samples_share_no_values_and_are_uncorrelated():
    draws = np.array([white_noise(7, k, np.ones(6)) for k in range(N)])
    assert not (draws[1:, :, None] == draws[:-1, None, :]).any()     # no value of sample k again in k + 1
    # lag-1 cross-correlation of every element pair: ~N(0, 1/N) for independent samples (4.5 σ bound)
    a, b = draws[:-1] - draws.mean(0), draws[1:] - draws.mean(0)
    r = (a.T @ b) / (N - 1) / np.outer(a.std(0), b.std(0))
    assert np.abs(r).max() < 4.5 / np.sqrt(N)
    # unit variance per element, to the chi-square spread of N draws (4.5 σ of the variance estimate)
    assert np.abs(draws.var(0) - 1.0).max() < 4.5 * np.sqrt(2.0 / N)


def test_the_same_seed_and_tick_give_the_same_draw_and_seeds_differ():
    std = np.array([0.1, 0.2, 0.3])
    np.testing.assert_array_equal(white_noise(3, 12, std), white_noise(3, 12, std))
    assert not np.allclose(white_noise(3, 12, std), white_noise(4, 12, std))
