"""The compiled refinement of Fourier-cylinder terrains (.refine_kernels) is the terrain's own
distance and the NumPy Newton iteration, written out: same distance and normal as
``terrain.query`` at any point (on the s-table, turned by its Taylor series, and off it, by
sine and cosine), same refined hits as the NumPy iteration, to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from scenes import F32, all_links_at, terrain, world_at
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
    # each evaluation rounds (~1e-16 m, sums reassociated in the compiled one), so where the error a
    # step leaves is within rounding of REFINE_TOLERANCE the two may stop one step apart: the one
    # that stops is then off by about that error (10x for the estimate's slack); all but a few agree
    tol = rc.REFINE_TOLERANCE
    np.testing.assert_allclose(compiled.distance[hit], numpy.distance[hit], rtol=0, atol=10 * tol)
    assert np.mean(np.abs(compiled.distance[hit] - numpy.distance[hit]) <= 1e-13) > 0.999
    # the normal then from points a step apart (a³ < tol·a_prev², a_prev <= 1 cm: a < 1e-5 m) times the
    # wall's curvature (rough: ~10 /m)
    np.testing.assert_allclose(compiled.normal[hit], numpy.normal[hit], rtol=0, atol=10 * (tol * 1e-4) ** (1 / 3))
    assert np.mean(np.abs(compiled.normal[hit] - numpy.normal[hit]).max(axis=1) <= 1e-12) > 0.999
    np.testing.assert_allclose(compiled.albedo[hit], numpy.albedo[hit], rtol=0, atol=0)
    # and the refinement moved the hits off the tessellation onto the surface: iterated to a µm step,
    # (nearly) every hit is within a nm (two fixed steps left 12-15 % of the rough walls' hits off by more;
    # what is left is grazing rays that keep their mesh hit)
    q = t.query(o[hit] + compiled.distance[hit, None] * d[hit])
    assert np.median(np.abs(q.distance)) < 1e-12
    assert np.mean(np.abs(q.distance) < 1e-9) > 0.99


@pytest.mark.parametrize("kind", ["moulin", "rough_tube"])
def test_beyond_the_wall_is_the_sign_of_the_terrains_distance(kind):
    """The test that tells a hit only blocks (from r_s alone, skipping the modes where Σ|A_j| cannot
    reach) is the sign of the terrain's own distance, on the s-table and off it."""
    t = terrain(KINDS[kind])
    rng = np.random.default_rng(4)
    shaft = getattr(t, "shaft", t)
    refiner = FourierRefiner.for_terrain(t, shaft.origin + np.outer([-5.0, 0.0], shaft.R[:, 2]), margin=1.0)
    for span in [(-6.0, 1.0), (-9.0, -6.5)]:
        p = points_near_the_wall(t, 4000, span, rng)
        far = points_near_the_wall(t, 1000, span, rng)
        far = shaft.origin + (far - shaft.origin) * rng.uniform(0.0, 2.0, (len(far), 1))   # axis to 2 radii out
        p = np.vstack([p, far])
        if kind == "moulin":
            p[::7, 2] = rng.uniform(-0.05, 0.3, len(p[::7]))     # about and above the ice surface
        q = t.query(p).distance
        clear = np.abs(q) > 1e-12                            # off the surface by more than rounding
        inside = refiner.beyond_wall(p)
        np.testing.assert_array_equal(inside[clear], q[clear] < 0)
        assert 0.2 < inside.mean() < 0.8                  # both sides sampled


def test_hits_that_only_block_are_kept_and_the_rest_refined_as_before():
    """refine_beyond (a lidar's minimum range): a mesh hit nearer than it, on a ray inside the
    terrain there, keeps its mesh distance; every other hit is refined exactly as without it, so
    which hits lie nearer than refine_beyond does not change."""
    t = terrain(KINDS["moulin"])
    world = world_at(t, all_links_at(np.array([0.3, 0.0, -2.0])), extent=8.0)     # 20 cm from the wall
    rng = np.random.default_rng(5)
    d = rng.normal(size=(30000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to([0.3, 0.0, -2.0], d.shape)
    near = 0.3
    exact = world.cast(o, d, 20.0).distance.copy()
    mesh = world.cast_from(np.eye(3), np.zeros(3), o, d, 20.0, exact=False)[0].distance.copy()
    cut = world.cast_from(np.eye(3), np.zeros(3), o, d, 20.0, refine_beyond=near)[0].distance
    kept = cut != exact
    assert kept.sum() > 1000                                  # the rays that see the wall within 30 cm
    np.testing.assert_array_equal(cut[kept], mesh[kept])
    assert np.all(cut[kept] < near) and np.all(exact[kept] < near)
    np.testing.assert_array_equal(cut < near, exact < near)


def test_other_kinds_keep_the_numpy_iteration():
    assert FourierRefiner.for_terrain(terrain({"kind": "u_channel", "width": 0.5})) is None
    assert FourierRefiner.for_terrain(terrain({"kind": "plane"})) is None
    assert rc.FourierRefiner is FourierRefiner


def test_mesh_hits_are_off_by_the_sag_over_the_grazing_sine():
    """terrain_hits: mesh on a curved wall: a face lies within ``sag`` of the surface (found by sampling
    the faces), so along a ray meeting the wall at grazing angle θ (sin θ = |n·d|, n at the exact hit)
    the mesh hit is off by sag/sin θ to first order. Exactly, inside a tube (the faces are chords,
    in front of the wall): the ray's distance from the wall a length l before its exact hit is at
    least l·sin θ − κ·l²/2, κ = |d_⊥|²/R the wall's curvature along the ray, so the error l is at most
    2·sag / (sin θ + √(sin²θ − 2κ·sag)) (≤ 2·sag/sin θ). Near-axial rays in a 0.3 m tube graze at
    sin θ ~ 0.01: tens of centimetres, ~100x the sag, as the issue measured (118 mm)."""
    radius = 0.3
    tube = terrain({"kind": "tube", "radius": radius, "axis": (1.0, 0.0, 0.0)})
    world = world_at(tube, all_links_at((2.0, 0.0, 0.0)))
    surf = world.terrain.surfaces
    tri = surf.vertices[surf.faces]
    tri = tri[np.abs(tri[:, :, 0].mean(axis=1) - 2.0) < 0.2]          # one ring of faces: each ring is alike
    w = np.array([(a, b, 20 - a - b) for a in range(21) for b in range(21 - a)]) / 20.0
    sag = np.abs(tube.query((w @ tri).reshape(-1, 3)).distance).max()
    rng = np.random.default_rng(6)
    n = 20000
    o = np.column_stack([rng.uniform(0.0, 4.0, n), rng.uniform(-0.1, 0.1, (n, 2))])     # ≤ 0.14 m off the axis
    d = rng.normal(size=(n, 3))
    d[n // 2:, 0] = np.sign(d[n // 2:, 0]) * 10 ** rng.uniform(0.0, 2.5, n - n // 2)      # half near-axial
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    exact = world.cast(o, d, 20.0).distance.copy()
    mesh = world.cast_from(np.eye(3), np.zeros(3), o, d, 20.0, exact=False)[0].distance
    hit = np.isfinite(exact) & np.isfinite(mesh)                      # not out of the mesh's ends
    assert hit.mean() > 0.8
    o, d, exact, mesh = o[hit], d[hit], exact[hit], mesh[hit]
    sin = np.abs(np.einsum("ij,ij->i", tube.query(o + exact[:, None] * d).normal, d))
    kappa = (d[:, 1] ** 2 + d[:, 2] ** 2) / radius
    assert np.all(sin ** 2 > 2 * kappa * sag)              # from this close to the axis no ray skims the faces
    bound = 2 * sag / (sin + np.sqrt(sin ** 2 - 2 * kappa * sag))
    err = np.abs(mesh - exact)
    # Embree's float32 hit: ≈1e-7 of the coordinates (< 5 m)
    assert np.all(err <= bound + 16 * F32 * 5.0)
    # the first-order bound, sag/sin θ, is what the error reaches: the worst rays come within 1 % of it
    # (a ray through a chord's middle), and it is 100x the sag itself on the most grazing rays
    ratio = err / (sag / sin)
    assert 0.99 < ratio.max() < 1.01
    assert err.max() > 30 * sag
