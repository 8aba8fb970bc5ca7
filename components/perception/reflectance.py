"""Diffuse (Lambertian) reflectance: the one reflection model of the lidar and the cameras.

A surface of albedo ρ lit at incidence θ (between the surface normal n and the direction to
the light l) scatters radiance L = ρ·E·cos θ / π evenly in every direction. Two sources:

    lidar      the beam is its own light (l = −ray): return power ∝ ρ·cos θ / r²; the lidar
               reports ``raw`` intensity ρ·cos θ·(r_ref / r)² (1 for a white surface square-on
               at the reference range r_ref), or ``reflectivity`` ρ·cos θ (range-compensated)
    camera     a ``sun`` (direction, irradiance E) or a ``headlamp`` at the camera (irradiance
               E·(r_ref / r)², l = −ray), plus an ambient term; pixel value
               ρ·(ambient + E·max(cos θ, 0)), the 1/π folded into E (value 1 = a white surface
               square-on to irradiance 1); computed per pixel in .hit_kernels.develop
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def lidar_intensity(albedo, cos_theta, r, reference_range: float, compensated: bool) -> np.ndarray:
    """Diffuse return of each beam: ρ·cos θ, times (r_ref / r)² unless range-compensated (arrays or,
    inside a compiled loop, one beam's scalars)."""
    i = albedo * cos_theta
    return i if compensated else i * (reference_range / r) ** 2
