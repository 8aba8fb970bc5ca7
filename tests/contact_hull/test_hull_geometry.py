"""coal geometry of the hull back end: cylinder–plane penetration against the analytic
value, the convex decomposition's accuracy against the hull count, terrain kinds."""

import math

import numpy as np
import pytest

from snakesim.components.contact.hull import hull_error, screw_mesh, slab_hulls, terrain_parts
from snakesim.components.contact.hull.narrow import Narrowphase
from snakesim.components.terrain import load_terrain
from snakesim.robots.screw_mesh import ScrewGeometry, blade_volume

R_Z_TO_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # coal cylinders lie along z


def _rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@pytest.mark.parametrize("tilt", [0.0, 0.2, 0.7])
def test_cylinder_on_plane_matches_analytic_penetration(tilt):
    import coal

    r, L, h = 0.09, 0.15, 0.085
    # axis along x, tilted by `tilt` about y
    R = _rot_y(tilt) @ R_Z_TO_X
    centre = np.array([0.3, -0.2, h])
    plane = terrain_parts(load_terrain({"kind": "plane"}))[0]
    hit = Narrowphase().collide(coal.Cylinder(r, L), coal.Transform3s(R, centre), plane.geom, plane.transform, False)
    depth_exact = r * math.cos(tilt) + 0.5 * L * math.sin(tilt) - h
    assert hit is not None
    depth, normal, point = hit
    assert depth == pytest.approx(depth_exact, abs=1e-7)
    np.testing.assert_allclose(-normal, [0, 0, 1], atol=1e-7)        # coal: robot -> terrain
    # contact point: half the depth below the surface, under the lowest rim point (tilted:
    # the rim of the lower end cap, at +L/2 along the axis) or mid-contact-line (level)
    axis = _rot_y(tilt) @ np.array([1.0, 0.0, 0.0])          # (cos, 0, −sin): +x end is lower
    down = _rot_y(tilt) @ np.array([0.0, 0.0, -1.0])
    lowest = centre + (0.5 * L * axis if tilt else 0.0) + r * down
    np.testing.assert_allclose(point[:2], lowest[:2], atol=1e-6)
    assert point[2] == pytest.approx(-0.5 * depth_exact, abs=1e-7)


def test_cylinder_above_plane_is_apart():
    import coal

    plane = terrain_parts(load_terrain({"kind": "plane"}))[0]
    assert Narrowphase().collide(coal.Cylinder(0.09, 0.15), coal.Transform3s(R_Z_TO_X, np.array([0, 0, 0.0901])),
                                 plane.geom, plane.transform, False) is None


def test_tilted_plane_normal():
    import coal

    tilt = 0.35
    terrain = load_terrain({"kind": "plane", "tilt": tilt})
    part = terrain_parts(terrain)[0]
    # a sphere centred 0.05 m above the plane (along its normal), radius 0.06: depth 0.01
    c = 0.05 * terrain.n + np.array([0.4, 0.0, 0.4 * math.tan(tilt)])
    depth, normal, _ = Narrowphase().collide(coal.Sphere(0.06), coal.Transform3s(np.eye(3), c),
                                             part.geom, part.transform, False)
    assert depth == pytest.approx(0.01, abs=1e-9)
    np.testing.assert_allclose(-normal, terrain.n, atol=1e-9)


GEOM = ScrewGeometry("right", 0.35, 0.09, 0.0675, 0.15, 3, 0.004)


def test_screw_mesh_volume_is_the_true_volume():
    mesh = screw_mesh(GEOM)
    assert mesh.is_watertight
    # exact: core drum + swept blades; the mesh's 48 facets per turn lose at most the
    # inscribed 48-gon's area deficit 1 − (48/2π) sin(2π/48) = 0.29 % of the core (63 % of V)
    exact = math.pi * GEOM.core_radius ** 2 * GEOM.length + blade_volume(GEOM)
    assert mesh.volume == pytest.approx(exact, rel=0.0029 * 0.63 + 1e-4)


def test_hull_count_trades_accuracy_monotonically():
    mesh = screw_mesh(GEOM)
    excess = []
    for n in (1, 2, 4, 8, 16):
        hulls = slab_hulls(mesh, n)
        assert len(hulls) == n
        e = hull_error(mesh, hulls, samples=50)
        # the hulls cover the mesh: they can only add volume
        assert e["volume_hulls"] >= e["volume_mesh"] * (1 - 1e-9)
        excess.append(e["volume_excess"])
    # nested refinement: each hull of 2n lies in a hull of n, so the excess never grows
    assert all(b < a for a, b in zip(excess, excess[1:])), excess
    # and stays inside the envelope cylinder (convex, contains the mesh, so every hull):
    # the decomposition is always at least as accurate as the envelope the SDF back end uses
    envelope = math.pi * GEOM.outer_radius ** 2 * GEOM.length
    assert (1 + excess[0]) * mesh.volume <= envelope


def test_hull_count_must_be_positive():
    with pytest.raises(ValueError, match="convex hulls must be ≥ 1"):
        slab_hulls(screw_mesh(GEOM), 0)


@pytest.mark.parametrize("name", ["parallel-walls-0.35", "u-channel", "tube-r0.3", "rough-tube", "fractal-dem",
                                  "box-channel"])
def test_every_supported_terrain_kind_builds_and_touches(name):
    """A sphere pushed 5 mm into the terrain's surface (found with the terrain's own query)
    collides with the coal geometry at about that depth and normal."""
    import coal

    terrain = load_terrain(name)
    parts = terrain_parts(terrain, extent=1.0, resolution=0.02)
    # a free-space point near the surface: start at a known-free point and walk down the gradient
    start = {"parallel-walls-0.35": [0.3, 0.1, 0.2], "u-channel": [0.3, 0.05, -0.1], "tube-r0.3": [0.2, 0.1, 0.15],
             "rough-tube": [0.2, 0.1, 0.1], "fractal-dem": [0.2, 0.3, 2.0], "box-channel": [1.5, 0.1, 0.25]}[name]
    q = terrain.query(np.array([start]))
    surface = q.closest[0]
    r = 0.03
    centre = surface + (r - 0.005) * q.normal[0]
    narrow = Narrowphase()
    best = None
    for part in parts:
        hit = narrow.collide(coal.Sphere(r), coal.Transform3s(np.eye(3), centre), part.geom, part.transform,
                             part.triangles)
        if hit is not None and (best is None or hit[0] > best[0]):
            best = hit
    assert best is not None
    # meshed surfaces: chord and grid errors of a few mm at most (triangle spacing ≤ 2 cm)
    assert best[0] == pytest.approx(0.005, abs=2.5e-3)
    assert abs(np.dot(best[1], q.normal[0])) > 0.9


def test_unsupported_terrain_kind_is_named():
    with pytest.raises(ValueError, match="terrain kind 'moulin'.*supported kinds: plane"):
        terrain_parts(load_terrain("moulin"))
