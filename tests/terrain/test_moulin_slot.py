"""Slot and elliptic moulins (terrain kind ``moulin`` with ``cross_section``; analytic.superellipse_section):
the shaft wall against the analytic superellipse, the signed distance against an independent brute-force
distance to the analytic curve, the normal against finite differences, and the inclined axis."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.terrain import analytic
from snakesim.components.terrain.spec import build_terrain
from snakesim.framework import ConfigError

A, B, P = 1.2, 0.175, 6.0


def _slot(inclination=0.0, heading=0.0, exponent=P, roughness=None):
    spec = {"kind": "moulin", "cross_section": {"semi_axes": [A, B], "exponent": exponent, "max_order": 128,
                                                "tolerance": 2e-5},
            "inclination": inclination, "heading": heading, "surface": False,
            "roughness": roughness or {"rms": 0.0, "n_modes": 0}}
    return build_terrain(spec)


def _curve(n=200_000):
    """Dense points of the analytic superellipse |x/A|^P + |y/B|^P = 1 (x along the heading)."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = analytic.superellipse_radius(th, A, B, P)
    return np.column_stack([r * np.cos(th), r * np.sin(th)])


def test_wall_points_of_the_analytic_superellipse_are_at_distance_zero():
    t = _slot()
    th = np.linspace(0, 2 * np.pi, 997)
    r = analytic.superellipse_radius(th, A, B, P)
    pts = np.column_stack([r * np.cos(th), r * np.sin(th), np.full(len(th), -2.0)])
    # the series' own truncation bound (2e-5 m), through the first-order distance (|d| <= |r_s - r|)
    assert np.abs(t.distance(pts)).max() < 2e-5
    assert np.abs(r * np.sin(th)).max() == pytest.approx(B, rel=1e-4)       # the curve's own extent
    assert np.abs(r * np.cos(th)).max() == pytest.approx(A, rel=1e-4)


def test_distance_matches_the_brute_force_distance_to_the_curve():
    t = _slot()
    C = _curve()
    rng = np.random.default_rng(1)
    # inside the flat part of the slot, up to 5 cm from a wall, and 2 cm into the ice
    x = rng.uniform(-0.8, 0.8, 400)
    y = rng.choice([-1, 1], 400) * rng.uniform(B - 0.05, B + 0.02, 400)
    pts = np.column_stack([x, y, np.full(400, -1.0)])
    d = t.distance(pts)
    # brute force: distance to the nearest curve point, sign from inside/outside the curve
    dist = np.sqrt(((pts[:, None, :2] - C[None, ::20]) ** 2).sum(-1)).min(1)
    inside = (np.abs(x / A) ** P + np.abs(y / B) ** P) < 1
    exact = np.where(inside, dist, -dist)
    # first-order distance: exact on a flat wall, O(d² κ) off it (κ <= the curve's curvature here, < 3 1/m)
    assert np.abs(d - exact).max() < 3.0 * 0.05 ** 2 + 5e-5


def test_normal_is_the_distance_gradient_near_the_wall():
    t = _slot(roughness={"rms": 0.01, "n_modes": 12, "wavelength_min": 1.0, "wavelength_max": 5.0,
                         "m_min": 0, "m_max": 2, "seed": 3})
    rng = np.random.default_rng(2)
    th = rng.uniform(0, 2 * np.pi, 200)
    s = rng.uniform(-5, -1, 200)
    rs, _, _ = t.shaft.wall_radius(th, s)
    # points 1 mm inside the wall along the shaft frame's radial: the first-order normal is ∇d to O(d)
    R = t.shaft.R
    pts = t.shaft.origin + np.column_stack([(rs - 1e-3) * np.cos(th), (rs - 1e-3) * np.sin(th), s]) @ R.T
    q = t.query(pts)
    assert np.abs(q.distance).max() < 1.5e-3
    h = 1e-6
    grad = np.column_stack([(t.distance(pts + h * e) - t.distance(pts - h * e)) / (2 * h) for e in np.eye(3)])
    # O(d·κ_θ) with the slot's end curvature (1/B · A/B ~ 40 1/m at 1 mm): a few per cent
    assert np.abs(grad - q.normal).max() < 0.05
    assert np.allclose(np.linalg.norm(q.normal, axis=1), 1.0)


def test_inclined_slot_axis_and_orientation():
    inc, head = 0.8758, np.pi
    t = _slot(inclination=inc, heading=head)
    up = np.array([-np.sin(inc) * np.cos(head), -np.sin(inc) * np.sin(head), np.cos(inc)])
    along = np.array([np.cos(inc) * np.cos(head), np.cos(inc) * np.sin(head), np.sin(inc)])   # the a axis
    across = np.cross(up, along)                                                              # the b axis
    c = -3.0 * up                                                           # on the axis, 3 m down the shaft
    # off the axis towards a long wall, the ray meets the nearest wall: distance b − offset
    assert t.distance((c + 0.05 * across)[None])[0] == pytest.approx(B - 0.05, abs=2e-5)
    for u, half in ((across, B), (along, A)):
        for sgn in (1, -1):
            assert t.distance((c + sgn * half * u)[None])[0] == pytest.approx(0.0, abs=2e-5)
    # a flat stretch of wall seen along the ray from the axis (the polar distance's exact case, module doc):
    # the normal is ∓ the b axis, the distance b − offset
    p = c + 0.05 * along + 0.1 * across
    q = t.query(p[None])
    assert q.distance[0] == pytest.approx(B - 0.1, abs=1e-3)
    assert q.normal[0] @ -across == pytest.approx(1.0, abs=2e-3)


def test_round_moulin_is_unchanged_and_bad_sections_are_named():
    round_ = build_terrain({"kind": "moulin", "radius": 0.5, "roughness": {"rms": 0.0, "n_modes": 0}})
    assert round_.distance(np.array([[0.2, 0.0, -1.0]]))[0] == pytest.approx(0.3)
    with pytest.raises(ConfigError, match="exactly one of 'radius'"):
        build_terrain({"kind": "moulin", "radius": 0.5, "cross_section": {"semi_axes": [1.0, 0.2]}})
    with pytest.raises(ConfigError, match="raise max_order"):
        build_terrain({"kind": "moulin", "cross_section": {"semi_axes": [1.2, 0.1], "exponent": 8, "max_order": 16}})


# -- the slot section (analytic.SlotMoulin): flat walls 2b apart, half-round ends, exact distance -----------------

SA, SB = 1.2, 0.175
ROUGH = {"rms": 0.005, "n_modes": 24, "wavelength_min": 1.0, "wavelength_max": 5.0, "m_min": 0, "m_max": 3, "seed": 3}


def _stadium(roughness=None, inclination=0.0, heading=0.0, surface=False):
    return build_terrain({"kind": "moulin", "cross_section": {"shape": "slot", "semi_axes": [SA, SB]},
                          "inclination": inclination, "heading": heading, "surface": surface,
                          "roughness": roughness or {"rms": 0.0, "n_modes": 0}})


def test_smooth_slot_distance_is_exact_everywhere():
    t = _stadium()
    assert isinstance(t, analytic.SlotMoulin)
    rng = np.random.default_rng(4)
    p = np.column_stack([rng.uniform(-1.5, 1.5, 2000), rng.uniform(-0.4, 0.4, 2000), rng.uniform(-5, -0.5, 2000)])
    # independent: distance to the segment |x| <= a − b on the axis plane, by dense sampling of the segment
    seg = np.linspace(-(SA - SB), SA - SB, 40001)
    rho = np.sqrt((p[:, None, 0] - seg[None]) ** 2 + p[:, None, 1] ** 2).min(1)
    assert np.abs(t.distance(p) - (SB - rho)).max() < 1e-4          # the sampling's own spacing (6e-5 m)
    h = 1e-6
    grad = np.column_stack([(t.distance(p + h * e) - t.distance(p - h * e)) / (2 * h) for e in np.eye(3)])
    assert np.abs(grad - t.query(p).normal).max() < 1e-6


def test_rough_slot_walls_follow_the_mode_sum_and_the_normal_is_the_gradient():
    t = _stadium(ROUGH)
    modes = build_terrain({"kind": "moulin", "radius": 1.0, "roughness": ROUGH}).shaft.modes   # same seeded modes
    A, m, k, ph = modes.T
    rng = np.random.default_rng(5)
    x, s = rng.uniform(-0.9, 0.9, 300), rng.uniform(-6, -1, 300)
    for side in (1.0, -1.0):
        # the wall on the +y (side +1) / −y side: b + Σ A cos(m π x / a + k s + φ + side m π/2)
        R = np.cos(np.multiply.outer(x, np.pi * m / SA) + np.multiply.outer(s, k) + ph + side * m * np.pi / 2) @ A
        wall = np.column_stack([x, side * (SB + R), s])
        assert np.abs(t.distance(wall)).max() < 1e-12
        inner = wall - np.column_stack([0 * x, side * 0.002 * np.ones_like(x), 0 * x])   # 2 mm into the free space
        q = t.query(inner)
        assert np.abs(q.distance - 0.002).max() < 2e-4                 # first order: the wall's slope is small
        h = 1e-6
        grad = np.column_stack([(t.distance(inner + h * e) - t.distance(inner - h * e)) / (2 * h) for e in np.eye(3)])
        assert np.abs(grad - q.normal).max() < 5e-3                      # O(d · curvature), d = 2 mm
        assert np.all(q.normal[:, 1] * side < -0.99)                     # into the slot


def test_inclined_slot_runs_down_its_heading():
    inc, head = 0.8758, np.pi
    t = _stadium(inclination=inc, heading=head, surface=True)
    up = np.array([-np.sin(inc) * np.cos(head), -np.sin(inc) * np.sin(head), np.cos(inc)])
    along = np.array([np.cos(inc) * np.cos(head), np.cos(inc) * np.sin(head), np.sin(inc)])
    across = np.cross(up, along)
    c = -3.0 * up
    assert t.distance(c[None])[0] == pytest.approx(SB)
    assert t.distance((c + 0.1 * across + 0.7 * along)[None])[0] == pytest.approx(SB - 0.1)
    assert t.distance((c + SA * along)[None])[0] == pytest.approx(0.0, abs=1e-12)
    assert t.query((c + 0.1 * across)[None]).normal[0] @ -across == pytest.approx(1.0)
    above = np.array([[5.0, 0.0, 0.3]])                                  # over the ice surface, far from the mouth
    assert t.query(above).distance[0] == pytest.approx(0.3) and t.query(above).material[0] == t.region_material[1]


def test_bad_slot_is_named():
    with pytest.raises(ConfigError, match="a >= b"):
        build_terrain({"kind": "moulin", "cross_section": {"shape": "slot", "semi_axes": [0.1, 0.2]}})
    with pytest.raises(ConfigError, match="roughness amplitude"):
        build_terrain({"kind": "moulin", "cross_section": {"shape": "slot", "semi_axes": [1.0, 0.02]},
                       "roughness": {"rms": 0.05, "n_modes": 12}})


def test_meander_moves_both_walls_together_and_the_distance_is_continuous():
    meander = {"rms": 0.02, "n_modes": 6, "wavelength_min": 1.5, "wavelength_max": 6.0, "seed": 5}
    t = build_terrain({"kind": "moulin", "cross_section": {"shape": "slot", "semi_axes": [SA, SB]},
                       "surface": False, "roughness": {"rms": 0.0, "n_modes": 0}, "meander": meander})
    M = analytic.fourier_modes(5, 6, 0.02, 1.5, 6.0, 0, 0)                 # the same seeded modes
    s = np.linspace(-6, -1, 201)
    c = np.cos(np.multiply.outer(s, M[:, 2]) + M[:, 3]) @ M[:, 0]
    # the slot's v axis in world: its walls at v = c ± b, i.e. world points c·v̂ ± b·v̂
    v = t.R[:, 1]
    for side in (1.0, -1.0):
        wall = t.origin + np.outer(s, t.R[:, 2]) + np.outer(c + side * SB, v) + 0.3 * t.R[:, 0]
        assert np.abs(t.distance(wall)).max() < 1e-12
    # the walls tilt by c'(s) along the shaft: the normal there is the wall's, unit, and ∇d (finite differences)
    inner = t.origin + np.outer(s, t.R[:, 2]) + np.outer(c + SB - 0.002, v)
    q = t.query(inner)
    h = 1e-6
    grad = np.column_stack([(t.distance(inner + h * e) - t.distance(inner - h * e)) / (2 * h) for e in np.eye(3)])
    # first order: the normal is the wall's, ∇d differs by O(d·|c''|) at d = 2 mm
    assert np.abs(grad - q.normal).max() < 0.002 * np.abs(M[:, 0] * M[:, 2] ** 2).sum()
    assert np.abs(q.distance - 0.002).max() < 0.002 * np.abs(M[:, 0] * M[:, 2]).sum() ** 2 + 1e-9
    # across the centre plane of a rough slot the nearer wall changes, the distance does not jump
    rough = _stadium(ROUGH)
    p = np.column_stack([np.full(100, 0.4), np.linspace(-0.01, 0.01, 100), np.full(100, -2.0)])
    d = rough.distance(p)
    assert np.abs(np.diff(d)).max() < 2 * 0.02 / 99 + 1e-9                 # Lipschitz 1 across the 2 cm


def _numpy_query(t, p):
    """SlotMoulin's formulas (its docstring) in NumPy over (points × modes) arrays, with its NumPy h (half_width)
    and c (centre): the reference of the compiled query (slot_kernels.slot_query)."""
    loc = (p - t.origin) @ t.R
    u, v, s = loc[:, 0], loc[:, 1], loc[:, 2]
    c, c_s = t.centre(s)
    v = v - c
    tt = np.clip(u, -t.L, t.L)
    du = u - tt
    rho = np.hypot(du, v)
    safe = np.where(rho > 0, rho, 1.0)
    eu, ev = np.where(rho > 0, du / safe, 0.0), np.where(rho > 0, v / safe, 1.0)
    h, _, h_s, h_nu = t.half_width(tt, s, ev)                               # the ends
    n_loc = np.column_stack([h_nu * (-ev * eu / safe) - eu, h_nu * (eu * eu / safe) - ev, h_s])
    g = h - rho
    flat = np.abs(u) <= t.L                                                 # the flat walls: the nearer of g±
    one = np.ones(flat.sum())
    hp, hp_t, hp_s, _ = t.half_width(tt[flat], s[flat], one)
    hm, hm_t, hm_s, _ = t.half_width(tt[flat], s[flat], -one)
    gp, gm = np.column_stack([hp_t, -one, hp_s]), np.column_stack([hm_t, one, hm_s])
    plus = (hp - v[flat]) / np.linalg.norm(gp, axis=1) <= (hm + v[flat]) / np.linalg.norm(gm, axis=1)
    g[flat] = np.where(plus, hp - v[flat], hm + v[flat])
    n_loc[flat] = np.where(plus[:, None], gp, gm)
    n_loc[:, 2] -= c_s * n_loc[:, 1]
    norm = np.linalg.norm(n_loc, axis=1)
    d, n = g / norm, (n_loc / norm[:, None]) @ t.R.T
    use = t.surface & (p[:, 2] - t.top > d)
    return np.where(use, p[:, 2] - t.top, d), np.where(use[:, None], [0.0, 0.0, 1.0], n), use.astype(np.int64)


@pytest.mark.parametrize("rough, meander, slope, inclination", [
    (None, None, 0.0, 0.0), (ROUGH, None, 0.0, 0.6),
    ({**ROUGH, "m_max": 5}, {"rms": 0.02, "n_modes": 6, "wavelength_min": 1.5, "wavelength_max": 6.0, "seed": 5},
     0.01, 1.0154)])
def test_compiled_query_equals_the_numpy_formulas(rough, meander, slope, inclination):
    spec = {"kind": "moulin", "cross_section": {"shape": "slot", "semi_axes": [SA, SB]}, "surface": True,
            "inclination": inclination, "heading": 2.0, "slope": slope,
            "roughness": rough or {"rms": 0.0, "n_modes": 0}}
    if meander:
        spec["meander"] = meander
    t = build_terrain(spec)
    rng = np.random.default_rng(7)
    n = 3000
    # shaft-frame points: across the whole section and 5 cm into the ice, past the ends, on the flat walls'
    # centre line, on the core (ρ = 0) and 1 mm past its ends (ν = 0; nearer, ∇ν ~ 1/ρ makes the first-order
    # distance of the ends meaningless, b from any wall), a few above the surface
    u = np.concatenate([rng.uniform(-1.4, 1.4, n), rng.choice([-1, 1], n) * rng.uniform(SA - SB, SA + 0.05, n),
                        rng.uniform(-0.9, 0.9, 200), [0.0, SA - SB + 1e-3, -(SA - SB + 1e-3)]])
    v = np.concatenate([rng.uniform(-0.25, 0.25, n), rng.uniform(-0.25, 0.25, n), np.zeros(200), [0.0, 0.0, 0.0]])
    # s: on slot_kernels' table of e^{i(k s + φ)} (down to TABLE_DEPTH) and off it (above the mouth, below 40 m)
    s = np.where(np.arange(len(u)) % 10 == 0, rng.uniform(-45.0, -40.0, len(u)), rng.uniform(-6.0, 0.3, len(u)))
    c = t.centre(s)[0]
    p = t.origin + np.column_stack([u, v + c * (np.arange(len(u)) >= 2 * n), s]) @ t.R.T
    d, nrm, region = _numpy_query(t, p)
    q = t.query(p)
    assert region.any() and (region == 0).sum() > 5000                      # both regions are exercised
    assert np.abs(q.distance - d).max() < 1e-12
    # on the centre line between the flat walls (|v'| ~ 1e-17 here) both walls are b away and the nearer one's
    # normal is a round-off's choice: the distance is checked there, the normal off it
    tie = (np.abs(((p - t.origin) @ t.R)[:, 1] - c) < 1e-9) & (np.abs(u) <= SA - SB)
    assert tie.sum() >= 200
    assert np.abs(q.normal - nrm)[~tie].max() < 1e-12
    assert np.array_equal(q.material, t.region_material[region])
