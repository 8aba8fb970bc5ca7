"""Analytic terrains: plane, parallel walls, U-channel (exact distances) and
Fourier-perturbed cylinders: tube and glacier moulin (first-order distances).

Conventions: distance > 0 in free space; the solid is the ice. For a tube the
solid is everything outside radius r_s, so the distance is r_s - r and the
normal points towards the axis.

Rough cylinders (tube with roughness, moulin). In the cylinder's local frame
(radius r, angle θ, axial coordinate s) the wall is r = r_s(θ, s) with

    r_s(θ, s) = R + slope·s + Σ_i A_i cos(m_i θ + k_i s + φ_i)

(m_i integer so the wall closes; k_i = ±2π/λ_i; seeded amplitudes scaled to
the requested RMS roughness). With g = r_s − r, the reported distance is the
first-order (tangent-plane) distance

    d = g / ‖∇g_s‖,   ∇g_s = −r̂ + (∂r_s/∂θ / r_s) θ̂ + (∂r_s/∂s) ŝ,

i.e. ∇g evaluated on the wall point straight out along the ray, and the
normal is ∇g_s/‖∇g_s‖. On the wall (g = 0) this normal equals ∇d exactly;
off the wall d is accurate to O(d²·curvature) and the normal to O(d).
"""

from __future__ import annotations

import numpy as np

from .base import Bounds, Terrain, frame_from_axis, unit

_Z = np.array([0.0, 0.0, 1.0])


class PlaneTerrain(Terrain):
    """Half-space below a plane through ``origin``, rising by ``tilt`` (rad) towards azimuth ``azimuth`` (rad)."""

    kind = "plane"
    regions = ("surface",)

    def __init__(self, origin=(0, 0, 0), tilt: float = 0.0, azimuth: float = 0.0, **kw):
        super().__init__(**kw)
        self.origin = np.asarray(origin, dtype=float)
        st, ct = np.sin(tilt), np.cos(tilt)
        self.n = np.array([-st * np.cos(azimuth), -st * np.sin(azimuth), ct])

    def _query(self, p):
        d = (p - self.origin) @ self.n
        return d, np.broadcast_to(self.n, p.shape).copy(), np.zeros(len(d), dtype=np.int64)

    def bounds(self):
        lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        if abs(self.n[2]) == 1.0:  # horizontal: the surface is at one height
            lo[2] = hi[2] = self.origin[2]
        return Bounds(lo, hi)


def _channel_frame(yaw: float, tilt: float = 0.0):
    """Axis a (horizontal, heading yaw), lateral l (left of a, leaning by tilt), up-ish u = a × l."""
    a = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    lat = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    lat = np.cos(tilt) * lat + np.sin(tilt) * _Z
    return a, lat, np.cross(a, lat)


class ParallelWalls(Terrain):
    """Two parallel planar walls ``gap`` apart, free space between (a crevasse).

    The channel runs along heading ``yaw``; ``tilt`` leans both walls from
    vertical (rotation about the channel axis). Exact distance.
    Regions: left (the wall on the +lateral side), right.
    """

    kind = "parallel_walls"
    regions = ("left", "right")

    def __init__(self, gap: float, origin=(0, 0, 0), yaw: float = 0.0, tilt: float = 0.0, **kw):
        super().__init__(**kw)
        self.gap, self.origin = float(gap), np.asarray(origin, dtype=float)
        _, self.lat, _ = _channel_frame(yaw, tilt)

    def _query(self, p):
        s = (p - self.origin) @ self.lat
        side = np.where(s >= 0, 1.0, -1.0)
        d = 0.5 * self.gap - np.abs(s)
        return d, -side[:, None] * self.lat, (side < 0).astype(np.int64)


class UChannel(Terrain):
    """Two vertical walls ``width`` apart above a half-cylinder floor of radius width/2.

    ``origin`` is on the floor's axis (the bottom of the U is width/2 below
    it); the channel runs along heading ``yaw``. Free space is the set of
    points within width/2 of the upward ray from the axis, so the distance
    is exact: width/2 − |y| above the axis, width/2 − hypot(y, z) below.
    Regions: walls (above the axis), floor (below).
    """

    kind = "u_channel"
    regions = ("walls", "floor")

    def __init__(self, width: float, origin=(0, 0, 0), yaw: float = 0.0, **kw):
        super().__init__(**kw)
        self.width, self.origin = float(width), np.asarray(origin, dtype=float)
        _, self.lat, self.up = _channel_frame(yaw)

    def _query(self, p):
        q = p - self.origin
        y, z = q @ self.lat, q @ self.up
        below = z < 0
        zc = np.where(below, z, 0.0)          # offset from the nearest point of the ray
        rho = np.hypot(y, zc)
        d = 0.5 * self.width - rho
        dirn = unit(y[:, None] * self.lat + zc[:, None] * self.up, fallback=self.lat)
        return d, -dirn, below.astype(np.int64)

    def bounds(self):
        lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        lo[2] = self.origin[2] - 0.5 * self.width
        return Bounds(lo, hi)


class FourierCylinder(Terrain):
    """Solid outside a (possibly rough) cylinder wall r = r_s(θ, s); see the module doc.

    Smooth (no modes, slope 0): exact distance R − r.
    """

    kind = "tube"
    regions = ("wall",)

    def __init__(self, radius: float, origin=(0, 0, 0), axis=(1, 0, 0), slope: float = 0.0,
                 modes: np.ndarray | None = None, **kw):
        super().__init__(**kw)
        self.radius, self.slope = float(radius), float(slope)
        self.origin = np.asarray(origin, dtype=float)
        self.R = frame_from_axis(axis)          # columns e1, e2, axis
        # modes: rows (A, m, k, phase)
        self.modes = np.zeros((0, 4)) if modes is None else np.asarray(modes, dtype=float).reshape(-1, 4)
        amp = np.abs(self.modes[:, 0]).sum()
        if self.radius - amp <= 0:
            raise ValueError(f"radius {self.radius} m minus the roughness amplitude sum {amp:.3g} m must be > 0")
        r_min = self.radius - amp
        self.lipschitz = float(np.sqrt(1.0 + (np.abs(self.modes[:, 0] * self.modes[:, 1]).sum() / r_min) ** 2
                                       + (abs(self.slope) + np.abs(self.modes[:, 0] * self.modes[:, 2]).sum()) ** 2))

    def wall_radius(self, theta, s):
        """r_s(θ, s) and its partial derivatives ∂r_s/∂θ, ∂r_s/∂s."""
        A, m, k, ph = (self.modes[:, i] for i in range(4))
        arg = np.multiply.outer(theta, m) + np.multiply.outer(s, k) + ph
        c, sn = np.cos(arg), np.sin(arg)
        rs = self.radius + self.slope * s + c @ A
        return rs, -(sn @ (A * m)), self.slope - (sn @ (A * k))

    def _query(self, p):
        loc = (p - self.origin) @ self.R
        u, v, s = loc[:, 0], loc[:, 1], loc[:, 2]
        r = np.hypot(u, v)
        theta = np.arctan2(v, u)
        ct, st = np.cos(theta), np.sin(theta)
        if len(self.modes) == 0 and self.slope == 0.0:
            d = self.radius - r
            n_loc = np.column_stack([-ct, -st, np.zeros_like(r)])
        else:
            rs, drs_t, drs_s = self.wall_radius(theta, s)
            gt = drs_t / rs
            n_loc = np.column_stack([-ct - gt * st, -st + gt * ct, drs_s])   # ∇g_s = −r̂ + gt θ̂ + gs ŝ
            norm = np.linalg.norm(n_loc, axis=1)
            d = (rs - r) / norm
            n_loc /= norm[:, None]
        return d, n_loc @ self.R.T, np.zeros(len(d), dtype=np.int64)


def fourier_modes(seed: int, n_modes: int, rms: float, wavelength_min: float, wavelength_max: float,
                  m_min: int, m_max: int, hurst: float = 0.8) -> np.ndarray:
    """Seeded random modes (A, m, k, phase) whose sum has RMS ``rms`` (m).

    Wavelengths are log-uniform in [wavelength_min, wavelength_max]; raw
    amplitudes ∝ λ^hurst (longer waves are larger, as in fractal surfaces).
    """
    if n_modes == 0 or rms == 0.0:
        return np.zeros((0, 4))
    rng = np.random.default_rng(seed)
    lam = np.exp(rng.uniform(np.log(wavelength_min), np.log(wavelength_max), n_modes))
    m = rng.integers(m_min, m_max + 1, n_modes).astype(float)
    k = 2 * np.pi / lam * rng.choice([-1.0, 1.0], n_modes)
    ph = rng.uniform(0, 2 * np.pi, n_modes)
    A = (lam / wavelength_max) ** hurst
    A *= rms / np.sqrt(0.5 * np.sum(A ** 2))
    return np.column_stack([A, m, k, ph])


class Moulin(Terrain):
    """Glacier moulin: a vertical shaft of rough, depth-varying radius under a flat ice surface.

    The shaft wall is a :class:`FourierCylinder` about the vertical axis
    through ``origin`` (x, y, z of the surface); free space is the shaft
    united with the half-space above the surface, so the distance is
    max(d_surface, d_shaft): exact in the ice (penetration), a lower bound in
    the open. Regions: wall, surface.
    """

    kind = "moulin"
    regions = ("wall", "surface")

    def __init__(self, shaft: FourierCylinder, surface: bool = True, **kw):
        super().__init__(**kw)
        self.shaft, self.surface = shaft, surface
        self.top = float(shaft.origin[2])
        self.lipschitz = shaft.lipschitz

    def _query(self, p):
        d, n, _ = self.shaft._query(p)
        region = np.zeros(len(d), dtype=np.int64)
        if self.surface:
            ds = p[:, 2] - self.top
            use = ds > d
            d = np.where(use, ds, d)
            n = np.where(use[:, None], _Z, n)
            region = use.astype(np.int64)
        return d, n, region
