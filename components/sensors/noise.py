"""Seeded, reproducible sensor noise: one white-noise draw per sample tick.

Randomness is never global (np.random.seed) and never lives on the
component object: sample k's noise is drawn from a Philox generator keyed by
the ``seed`` parameter with counter k in the counter's second word, where k is
the sample counter kept in the component's discrete state. Not the first word:
Philox advances that word once per four 64-bit draws, so with k there a sample of
more than four values would reuse the next sample's first values. The same assembly and seed therefore give
bit-identical readings in every run of a session, whatever else runs, and
two sensors with different seeds have independent noise.
"""

from __future__ import annotations

import numpy as np


def white_noise(seed: int, tick: float, std: np.ndarray) -> np.ndarray:
    """Zero-mean Gaussian noise with standard deviations ``std`` (any shape) for sample ``tick``."""
    gen = np.random.Generator(np.random.Philox(key=int(seed), counter=[0, int(tick), 0, 0]))
    return gen.standard_normal(std.shape) * std


def noise_needs_rate(owner: str, rate, *stds) -> None:
    if rate is None and any(np.any(np.asarray(s) > 0) for s in stds):
        raise ValueError(f"{owner}: noise needs a sample rate: give the component a 'rate' (Hz) in the assembly "
                         "(noise is drawn once per sample and held, not per integrator stage)")
