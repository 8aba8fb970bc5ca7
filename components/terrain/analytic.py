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

Slot moulins: a non-round cross-section (the superellipse |x/a|^p + |y/b|^p = 1,
an ellipse at p = 2, a rounded slot at p ≥ 4) enters r_s as its polar radius
ρ(θ) = (|cos θ/a|^p + |sin θ/b|^p)^(−1/p), written as the even cosine series
ρ(θ) = ρ_0 + Σ_m c_m cos(m(θ − α)) (the ``section`` modes, k = 0), truncated
at ``max_order`` with its largest error checked against ρ itself; the
roughness adds on top. The wall is then still r = r_s(θ, s) and every user of
the modes (distance, ray refinement, viewer mesh) sees the same surface.
Caveat of the polar distance on a slender section: it is exact where the ray
from the axis meets the nearest wall (a flat side seen from within it), but
where that ray runs along the slot to an end while a side is nearer (points on
or near the long centre line, e.g. the axis itself: d = a, not b) it
overestimates the distance. Contact near the walls is unaffected; such points
are far inside the free space.
"""

from __future__ import annotations

import numpy as np

from .base import Bounds, Terrain, frame_from_axis, unit
from .slot_kernels import half_turns, s_table, slot_query

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

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _plane

        return _plane(self, center, extent, cell)

    def sensor_cell(self, extent, cell):
        return extent / 4          # flat: a few large quads are exact

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        from .contact_geometry import plane_parts

        return plane_parts(self)

    def height_grid(self, lo, hi, reach: float = 1000.0):
        """Two samples a side, ``reach`` m beyond the box (a square: one spacing both ways): bilinear
        interpolation reproduces a plane exactly, to rounding. None for a plane steeper than 80° (not a
        height field one could lay soil on)."""
        if self.n[2] < np.cos(np.radians(80.0)):
            return None
        side = max(hi[0] - lo[0], hi[1] - lo[1]) + 2.0 * reach
        x = np.array([lo[0] - reach, lo[0] - reach + side])
        y = np.array([lo[1] - reach, lo[1] - reach + side])
        X, Y = np.meshgrid(x, y)                               # rows y, columns x
        o, n = self.origin, self.n
        z = o[2] - (n[0] * (X - o[0]) + n[1] * (Y - o[1])) / n[2]
        return z, float(side), (float(x[0]), float(y[0]))

    def fast_plane(self):
        # a subclass that keeps the plane's query keeps the compiled plane kernels
        return (self.origin, self.n) if type(self)._query is PlaneTerrain._query else None

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

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _walls

        return _walls(self, center, extent, cell, cutaway)

    def sensor_cell(self, extent, cell):
        return extent / 4          # flat: a few large quads are exact

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        from .contact_geometry import walls_parts

        return walls_parts(self)

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

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _u_channel

        return _u_channel(self, center, extent, cell)

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        from .contact_geometry import u_channel_parts

        return u_channel_parts(self, extent, segments, resolution)

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
                 modes: np.ndarray | None = None, section: np.ndarray | None = None, **kw):
        """``modes``: roughness rows (A m, m, k 1/m, phase); ``section``: the cross-section's rows (A, m, 0,
        phase) about the mean ``radius`` (see :func:`superellipse_section`), stored first in ``modes``."""
        super().__init__(**kw)
        self.radius, self.slope = float(radius), float(slope)
        self.origin = np.asarray(origin, dtype=float)
        self.R = frame_from_axis(axis)          # columns e1, e2, axis
        # modes: rows (A, m, k, phase)
        rough = np.zeros((0, 4)) if modes is None else np.asarray(modes, dtype=float).reshape(-1, 4)
        section = np.zeros((0, 4)) if section is None else np.asarray(section, dtype=float).reshape(-1, 4)
        if np.any(section[:, 2] != 0.0):
            raise ValueError("section modes are a cross-section: their axial wavenumbers k must be 0")
        self.modes = np.vstack([section, rough])
        amp = np.abs(rough[:, 0]).sum()
        base_min, base_turn = self.radius, 0.0          # least section radius, max |dρ/dθ|
        if len(section):
            th = np.linspace(0.0, 2 * np.pi, 8 * int(section[:, 1].max()) + 64, endpoint=False)
            arg = np.multiply.outer(th, section[:, 1]) + section[:, 3]
            base_min = float((self.radius + np.cos(arg) @ section[:, 0]).min())
            base_turn = float(np.abs(np.sin(arg) @ (section[:, 0] * section[:, 1])).max())
        if base_min - amp <= 0:
            raise ValueError(f"radius {base_min:.4g} m (least over the cross-section) minus the roughness amplitude "
                             f"sum {amp:.3g} m must be > 0")
        r_min = base_min - amp
        self.lipschitz = float(np.sqrt(1.0 + ((base_turn + np.abs(rough[:, 0] * rough[:, 1]).sum()) / r_min) ** 2
                                       + (abs(self.slope) + np.abs(rough[:, 0] * rough[:, 2]).sum()) ** 2))

    def wall_radius(self, theta, s):
        """r_s(θ, s) and its partial derivatives ∂r_s/∂θ, ∂r_s/∂s."""
        A, m, k, ph = (self.modes[:, i] for i in range(4))
        arg = np.multiply.outer(theta, m) + np.multiply.outer(s, k) + ph
        c, sn = np.cos(arg), np.sin(arg)
        rs = self.radius + self.slope * s + c @ A
        return rs, -(sn @ (A * m)), self.slope - (sn @ (A * k))

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _cylinder

        return _cylinder(self, center, extent, cell, cutaway, s_range=None)

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        from .contact_geometry import cylinder_parts

        return cylinder_parts(self, extent, segments, resolution)

    def refiner(self, vertices=None, margin=1.0):
        from snakesim.components.perception.refine_kernels import FourierRefiner

        return FourierRefiner.for_shaft(self, False, 0.0, self.region_material, vertices, margin)

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


def superellipse_radius(theta, a: float, b: float, exponent: float, angle: float = 0.0):
    """Polar radius (m) of the superellipse |x/a|^p + |y/b|^p = 1 whose ``a`` semi-axis points at ``angle``."""
    c, s = np.abs(np.cos(theta - angle)) / a, np.abs(np.sin(theta - angle)) / b
    return (c ** exponent + s ** exponent) ** (-1.0 / exponent)


def superellipse_section(a: float, b: float, exponent: float = 2.0, angle: float = 0.0, max_order: int = 128,
                         tolerance: float = 1e-5) -> tuple[float, np.ndarray, float]:
    """The superellipse's polar radius as a cosine series (module doc): (mean radius ρ_0 m, section modes
    (A m, m, 0, −m·angle) for even m <= ``max_order``, largest error m against ρ on 16·max_order angles).

    ρ has the symmetries of the shape (even in θ − angle, period π), so only even cosine terms appear.
    Raises ValueError when the truncation misses ρ by more than ``tolerance`` m (a slimmer or squarer shape
    needs a higher ``max_order``)."""
    if not (a > 0 and b > 0 and exponent >= 2):
        raise ValueError(f"superellipse semi_axes [{a}, {b}] must be > 0 and exponent {exponent} >= 2 "
                         f"(2: ellipse, 4+: rounded slot)")
    n = max(4096, 16 * int(max_order))
    th = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    rho = superellipse_radius(th, a, b, exponent)                 # shape about its own axes
    c = np.fft.rfft(rho).real / n
    m = np.arange(2, int(max_order) + 1, 2)
    A = 2.0 * c[m]
    series = c[0] + np.cos(np.multiply.outer(th, m)) @ A
    err = float(np.abs(series - rho).max())
    if err > tolerance:
        raise ValueError(f"superellipse a = {a}, b = {b}, exponent {exponent}: angular orders up to {max_order} "
                         f"miss its radius by {err:.3g} m > tolerance {tolerance} m; raise max_order")
    keep = np.abs(A) > 1e-12
    modes = np.column_stack([A[keep], m[keep], np.zeros(keep.sum()), -m[keep] * angle])
    return float(c[0]), modes, err


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

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _moulin

        return _moulin(self, center, extent, cell, cutaway)

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        raise NotImplementedError("a shaft through a plane has no convex part and needs a holed surface mesh")

    def refiner(self, vertices=None, margin=1.0):
        from snakesim.components.perception.refine_kernels import FourierRefiner

        return FourierRefiner.for_shaft(self.shaft, self.surface, self.top, self.region_material, vertices, margin)

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


class SlotMoulin(Terrain):
    """Glacier moulin with a slot section: a shaft whose cross-section is a stadium (two flat walls ``2 b``
    apart joined by half-round ends, ``2 a`` long), with rough walls, under a flat ice surface.

    In the shaft frame (u along the slot, v across it, s along the upward ``axis``; origin on the axis at the
    surface) the free space is the set of points within the half-width h of the core segment |u| <= L = a − b,
    v = c(s), which meanders sideways with depth, c(s) = Σ_j M_j cos(k_j s + φ_j) (``meander`` modes (M, 0, k,
    φ)): both walls move together, the width stays h₊ + h₋. With v' = v − c(s), t = clamp(u, −L, L),
    δ = (u − t, v'), ρ = |δ|, ν = δ_v/ρ (±1 on the flat walls, blending round the ends)::

        h(t, s, ν) = b + slope·s + ½(1 + ν) R(t, s, +1) + ½(1 − ν) R(t, s, −1)
        R(t, s, σ) = Σ_i A_i cos(m_i π t / a + k_i s + φ_i + σ m_i π/2)

    (the roughness modes (A, m, k, φ) of :func:`fourier_modes`: m half-waves along the slot's length, the
    far wall shifted by a quarter of them, so m = 0 modes change the width with depth and the others make the
    walls differ). The distance is first order, d = g/‖∇g‖, normal ∇g/‖∇g‖: along the flat walls (|u| <= L)
    the nearer of g± = h(t, s, ±1) ∓ v (∇g± = ∂h±/∂t û ∓ v̂ + ∂h±/∂s ŝ), round the ends g = h − ρ
    (∇g = ∂h/∂ν ∇ν + ∂h/∂s ŝ − δ̂). Exact for a smooth slot (R = 0, slope 0: d = b − ρ), exact in the wall,
    O(d²·curvature) off it. The meander enters by the chain rule, ∂g/∂s += −c'(s) ∂g/∂v'. The surface is as
    :class:`Moulin`'s:
    d = max(d_surface, d_shaft). Regions: wall, surface. The query is compiled (slot_kernels.slot_query, one
    cosine and sine per mode and point); :meth:`half_width` and :meth:`centre` give h and c in NumPy (the
    viewer's wall points).
    """

    kind = "moulin"
    regions = ("wall", "surface")

    def __init__(self, a: float, b: float, origin=(0, 0, 0), axis=(0, 0, 1), along=(1, 0, 0), slope: float = 0.0,
                 modes: np.ndarray | None = None, surface: bool = True, meander: np.ndarray | None = None, **kw):
        super().__init__(**kw)
        self.a, self.b, self.slope = float(a), float(b), float(slope)
        self.meander = np.zeros((0, 4)) if meander is None else np.asarray(meander, dtype=float).reshape(-1, 4)
        if not (self.b > 0 and self.a >= self.b):
            raise ValueError(f"slot semi_axes [{a}, {b}]: need b > 0 and a >= b (a: half-length, b: half-width)")
        self.L = self.a - self.b
        self.origin = np.asarray(origin, dtype=float)
        ax = unit(np.asarray(axis, dtype=float)[None])[0]
        u = np.asarray(along, dtype=float) - (np.asarray(along, dtype=float) @ ax) * ax
        if np.linalg.norm(u) < 1e-9:
            raise ValueError(f"slot direction {list(along)} is parallel to the shaft axis {ax.tolist()}")
        u /= np.linalg.norm(u)
        self.R = np.column_stack([u, np.cross(ax, u), ax])          # columns û, v̂, ŝ
        self.modes = np.zeros((0, 4)) if modes is None else np.asarray(modes, dtype=float).reshape(-1, 4)
        A, m, k, _ = self.modes.T
        amp = np.abs(A).sum()
        if self.b - amp <= 0:
            raise ValueError(f"slot half-width {self.b} m minus the roughness amplitude sum {amp:.3g} m must be > 0")
        self.surface, self.top = bool(surface), float(self.origin[2])
        kt = np.pi * m / self.a
        turn = np.abs(self.meander[:, 0] * self.meander[:, 2]).sum()      # max |c'(s)|
        self.lipschitz = float(np.sqrt(1.0 + (np.abs(A * kt).sum() + amp / (self.b - amp)) ** 2
                                       + (abs(self.slope) + np.abs(A * k).sum() + turn) ** 2))
        # the compiled query's contiguous copies (slot_kernels.slot_query)
        self._Rc, self._modes_c = np.ascontiguousarray(self.R), np.ascontiguousarray(self.modes)
        self._meander_c, self._half_turn = np.ascontiguousarray(self.meander), half_turns(self.modes)
        self._s0, self._h, self._rough_tab, self._meander_tab = s_table(self.modes, self.meander)

    def centre(self, s):
        """The slot's sideways offset c(s) (m) and c'(s)."""
        M, _, k, ph = (self.meander[:, i] for i in range(4))
        arg = np.multiply.outer(s, k) + ph
        return np.cos(arg) @ M, -(np.sin(arg) @ (M * k))

    def half_width(self, t, s, nu):
        """h(t, s, ν) (m) and ∂h/∂t, ∂h/∂s, ∂h/∂ν."""
        A, m, k, ph = (self.modes[:, i] for i in range(4))
        kt = np.pi * m / self.a
        base = np.multiply.outer(t, kt) + np.multiply.outer(s, k) + ph
        out = []
        for sg in (1.0, -1.0):
            arg = base + sg * 0.5 * np.pi * m
            c, sn = np.cos(arg), np.sin(arg)
            out.append((c @ A, -(sn @ (A * kt)), -(sn @ (A * k))))
        (Rp, Rpt, Rps), (Rm, Rmt, Rms) = out
        wp, wm = 0.5 * (1 + nu), 0.5 * (1 - nu)
        h = self.b + self.slope * s + wp * Rp + wm * Rm
        return h, wp * Rpt + wm * Rmt, self.slope + wp * Rps + wm * Rms, 0.5 * (Rp - Rm)

    def wall_points(self, s_range: tuple[float, float], cell: float) -> np.ndarray:
        """Points on the wall (world, m), a grid (n_loop + 1, n_s + 1, 3) once round the section (the +v̂
        wall, the +û end, the −v̂ wall, the −û end: counter-clockwise about ŝ) by ~``cell`` m, and along s over
        ``s_range``: each at core point (t, 0) + h·δ̂ with ν = δ̂_v, so exactly on the wall (``_query`` d = 0)."""
        n_flat = max(2, int(np.ceil(2 * self.L / cell)))
        n_cap = max(4, int(np.ceil(np.pi * self.b / cell)))
        tt = np.linspace(self.L, -self.L, n_flat + 1)
        cap = np.linspace(0.5 * np.pi, 1.5 * np.pi, n_cap + 1)[1:-1]
        t = np.concatenate([tt, np.full(len(cap), -self.L), -tt, np.full(len(cap), self.L), tt[:1]])
        du = np.concatenate([0 * tt, np.cos(cap), 0 * tt, -np.cos(cap), [0.0]])
        dv = np.concatenate([1 + 0 * tt, np.sin(cap), -1 + 0 * tt, -np.sin(cap), [1.0]])
        s = np.linspace(s_range[0], s_range[1], max(2, int(np.ceil((s_range[1] - s_range[0]) / cell))) + 1)
        T, S = np.meshgrid(t, s, indexing="ij")
        DU, DV = np.meshgrid(du, s, indexing="ij")[0], np.meshgrid(dv, s, indexing="ij")[0]
        h = self.half_width(T.ravel(), S.ravel(), DV.ravel())[0].reshape(T.shape) if len(self.modes) else \
            self.b + self.slope * S
        c = self.centre(S.ravel())[0].reshape(S.shape)
        loc = np.stack([T + h * DU, c + h * DV, S], axis=-1)
        return self.origin + loc @ self.R.T

    def shaft_distance(self, p) -> np.ndarray:
        """The shaft's signed distance alone (no surface), m."""
        surface, self.surface = self.surface, False
        try:
            return self._query(np.asarray(p, dtype=float).reshape(-1, 3))[0]
        finally:
            self.surface = surface

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _slot_moulin

        return _slot_moulin(self, center, extent, cell, cutaway)

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        raise NotImplementedError("a shaft through a plane has no convex part and needs a holed surface mesh")

    def _query(self, p):
        # the docstring's formulas, compiled over points and modes (slot_kernels.slot_query)
        n = len(p)
        d, normal, region = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64)
        slot_query(np.ascontiguousarray(p), self.origin, self._Rc, self.a, self.b, self.L, self.slope, self._modes_c,
                   self._half_turn, self._meander_c, self._s0, self._h, self._rough_tab, self._meander_tab,
                   self.surface, self.top, d, normal, region)
        return d, normal, region
