"""Procedural albedo textures of terrain materials (Material.texture): what gives a flat
surface features a camera can see (a checkerboard for calibration, texture for stereo).

    checker   factor 1 or 1 − contrast by the parity of ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s + ½⌋ (world m,
              s = texture_size): cubes in space, squares on any surface; the cubes are offset
              by half a size in z so a horizontal ground at z = 0 (the common case) lies
              mid-cube, not on a face where rounding would flip the parity

The factor multiplies the material's albedo and colour at the hit point (``apply_textures``,
compiled, in place over a cast's hits; ``texture_factor`` the same in NumPy).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

NONE, CHECKER = 0, 1
KINDS = {"none": NONE, "checker": CHECKER}
_HALF_Z = np.array([0.0, 0.0, 0.5])


def texture_table(materials) -> np.ndarray:
    """(k, 3) per material: kind code, size m, contrast."""
    return np.array([[KINDS[m.texture], m.texture_size, m.texture_contrast] for m in materials],
                    dtype=np.float64).reshape(-1, 3)


def texture_factor(table: np.ndarray, material: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Albedo factor (n,) at world points (n, 3) of the given materials (n,)."""
    f = np.ones(len(points))
    row = table[material]
    checker = row[:, 0] == CHECKER
    if checker.any():
        cells = np.floor(points[checker] / row[checker, 1:2] + _HALF_Z).astype(np.int64).sum(axis=1)
        f[checker] = np.where(cells % 2 == 0, 1.0, 1.0 - row[checker, 2])
    return f


@njit(cache=True, nogil=True)
def apply_textures(table, material, o, d, distance, albedo, color):
    """In place, for each ray with a terrain material (material >= 0) and a finite distance: albedo
    and colour times the factor of ``texture_factor`` at the hit point o + distance·d (world m)."""
    for i in range(material.shape[0]):
        mat = material[i]
        if mat < 0 or table[mat, 0] != CHECKER or not math.isfinite(distance[i]):
            continue
        size, r = table[mat, 1], distance[i]
        cells = 0
        for a in range(3):
            cells += int(math.floor((o[i, a] + r * d[i, a]) / size + (0.5 if a == 2 else 0.0)))
        if cells & 1:                  # odd parity (two's complement: also for negative sums)
            f = 1.0 - table[mat, 2]
            albedo[i] *= f
            for c in range(color.shape[1]):
                color[i, c] *= f
