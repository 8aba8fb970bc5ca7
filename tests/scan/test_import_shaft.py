"""`snakesim terrain import` on a scan of a known shape, made here with numpy only (not the project's lidar).

The shape: an elliptic shaft x²/a² + y²/b² = 1, a = 0.6 m, b = 0.35 m, z from −3 to 0 m, open at both
ends, its wall sampled uniformly by arc length with 3 mm Gaussian noise along the normal, a 0.3 × 0.3 m
patch of the wall (centred on (a, 0, −1.5)) left unsampled (an occlusion hole), and every point's scanner
on the axis. The imported mesh is compared with the ellipse by an independent point–ellipse distance
(Newton's method on the ellipse's parameter), its report with the cut hole, and the terrain's signed
distance with the known sides of the wall.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from click.testing import CliRunner

A, B, DEPTH, NOISE = 0.6, 0.35, 3.0, 0.003
HOLE_CENTRE, HOLE_SIZE = np.array([A, 0.0, -1.5]), 0.3
RESOLUTION = 0.04


def elliptic_shaft(n: int, seed: int = 1):
    """(points, scanner positions) of the shaft (module docstring)."""
    rng = np.random.default_rng(seed)
    m = 4 * n
    t = rng.uniform(0, 2 * np.pi, m)
    z = rng.uniform(-DEPTH, 0, m)
    speed = np.hypot(A * np.sin(t), B * np.cos(t))          # |dp/dt|: rejection sampling makes it arc length
    keep = rng.uniform(0, speed.max(), m) < speed
    t, z = t[keep][:n], z[keep][:n]
    normal = np.c_[B * np.cos(t), A * np.sin(t), np.zeros_like(t)]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    p = np.c_[A * np.cos(t), B * np.sin(t), z] + normal * rng.normal(0, NOISE, len(t))[:, None]
    cut = (np.abs(p[:, 2] - HOLE_CENTRE[2]) < HOLE_SIZE / 2) & (p[:, 0] > 0) & (np.abs(p[:, 1]) < HOLE_SIZE / 2)
    p = p[~cut]
    scanner = np.c_[np.zeros(len(p)), np.zeros(len(p)), np.round(p[:, 2] * 2) / 2]   # stations every 0.5 m
    return p, scanner


def write_ply(path, points, scanner) -> None:
    """Binary PLY with the per-point scanner_x, scanner_y, scanner_z vertex properties."""
    names = ["x", "y", "z", "scanner_x", "scanner_y", "scanner_z"]
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\n"
              + "".join(f"property double {q}\n" for q in names) + "end_header\n")
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.hstack([points, scanner]).astype("<f8").tobytes())


def ellipse_distance(x, y):
    """Distance from (x, y) to the ellipse: the foot's parameter t solves (p − e(t)) · e'(t) = 0 (Newton)."""
    t = np.arctan2(A * y, B * x)
    for _ in range(8):
        ex, ey, dx, dy = A * np.cos(t), B * np.sin(t), -A * np.sin(t), B * np.cos(t)
        g = (x - ex) * dx + (y - ey) * dy
        dg = -(dx * dx + dy * dy) + (x - ex) * (-ex) + (y - ey) * (-ey)
        t = t - g / dg
    return np.hypot(x - A * np.cos(t), y - B * np.sin(t))


def ellipse_perimeter(n=100_000):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return float(np.mean(np.hypot(A * np.sin(t), B * np.cos(t))) * 2 * np.pi)


# the import (Open3D's import, Poisson at depth 7, the SDF grid) takes ~6 s on a loaded 2-core machine
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    from snakesim.components.scan.import_cli import import_command

    folder = tmp_path_factory.mktemp("shaft")
    scan = folder / "shaft.ply"
    write_ply(scan, *elliptic_shaft(20_000))
    out = folder / "terrain" / "shaft-scan.yaml"
    store = folder / "store"
    result = CliRunner().invoke(import_command, [str(scan), "-o", str(out), "--resolution", str(RESOLUTION)],
                                env={"SNAKESIM_TERRAIN_STORE": str(store)})
    assert result.exit_code == 0, result.output
    return {"scan": scan, "yaml": out, "store": store, "output": result.output}


def _mesh(imported):
    import trimesh

    return trimesh.load(imported["yaml"].with_suffix(".ply"), process=False)


def test_surface_lies_within_5mm_rms_of_the_ellipse(imported):
    mesh = _mesh(imported)
    samples = mesh.sample(20_000, seed=0)
    away = (samples[:, 2] < -0.1) & (samples[:, 2] > -DEPTH + 0.1)       # the cropped ends: up to a cell off
    d = ellipse_distance(samples[away, 0], samples[away, 1])
    rms = float(np.sqrt(np.mean(d ** 2)))
    print(f"RMS to the ellipse {rms * 1e3:.2f} mm, max {d.max() * 1e3:.2f} mm, area {mesh.area:.3f} m²")
    assert rms < 0.005, f"RMS distance to the true ellipse {rms * 1e3:.2f} mm"
    # the mesh covers the wall: its area is the wall's (perimeter x depth) less the hole, within 5 %
    wall = ellipse_perimeter() * DEPTH - HOLE_SIZE ** 2
    assert abs(mesh.area - wall) < 0.05 * wall, (mesh.area, wall)


def test_the_occlusion_hole_is_reported_where_it_was_cut(imported):
    from snakesim.components.scan.holes import find_holes

    out = imported["output"]
    assert "1 interior, 2 outer rim(s)" in out, out
    mesh = _mesh(imported)
    holes = find_holes(np.asarray(mesh.vertices), np.asarray(mesh.faces), np.asarray(mesh.vertices), band=0.05)
    interior = [h for h in holes if not h.rim]
    assert len(interior) == 1, interior
    hole = interior[0]
    print(f"hole {hole}")
    assert np.linalg.norm(np.array(hole.centre) - HOLE_CENTRE) < 0.05, hole
    # the loop runs around the cut: between the trimmed-in and the cut square's perimeter, give or take jags
    assert 0.4 < hole.perimeter < 2.0 and 0.02 < hole.area < HOLE_SIZE ** 2 * 1.1, hole
    rims = sorted((h for h in holes if h.rim), key=lambda h: h.centre[2])
    assert len(rims) == 2
    assert abs(rims[0].centre[2] + DEPTH) < 0.05 and abs(rims[1].centre[2]) < 0.05, rims
    assert all(abs(h.area - np.pi * A * B) < 0.1 * np.pi * A * B for h in rims), rims   # a rim spans the section


def test_signed_distance_is_free_inside_the_void_and_ice_behind_the_wall(imported):
    from snakesim.components.terrain.spec import load_terrain

    terrain = load_terrain(str(imported["yaml"]), store=imported["store"])
    t, z = np.meshgrid(np.linspace(0, 2 * np.pi, 24, endpoint=False), np.linspace(-2.6, -0.4, 9))
    t, z = t.ravel(), z.ravel()
    wall = np.c_[A * np.cos(t), B * np.sin(t), z]
    normal = np.c_[B * np.cos(t), A * np.sin(t), np.zeros_like(t)]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    clear = np.linalg.norm(wall - HOLE_CENTRE, axis=1) > 0.35          # away from the hole
    void, ice = wall[clear] - 0.05 * normal[clear], wall[clear] + 0.05 * normal[clear]
    d_void, d_ice = terrain.distance(void), terrain.distance(ice)
    assert (d_void > 0).all(), f"{(d_void <= 0).sum()} void points not free: {d_void.min()}"
    assert (d_ice < 0).all(), f"{(d_ice >= 0).sum()} ice points not solid: {d_ice.max()}"
    # 5 cm from the true wall (curvature radius >= b²/a = 0.2 m): |d| = 5 cm less the surface's own error
    assert np.abs(np.abs(np.r_[d_void, d_ice]) - 0.05).max() < 0.012


def test_terrain_file_records_its_provenance(imported):
    text = imported["yaml"].read_text()
    digest = hashlib.sha256(imported["scan"].read_bytes()).hexdigest()
    assert f"sha256 {digest}" in text
    assert "# command: snakesim terrain import" in text and "inside: free" in text and "open_surface: true" in text
    assert "rms" in imported["output"] and "coverage" in imported["output"]


def test_a_mesh_scan_keeps_its_shape_and_frees_the_void(tmp_path):
    """The exact shaft as an STL (its faces wound towards the void): no reconstruction, the void-axis rule
    winds it, and the terrain is free inside and ice behind the wall."""
    import trimesh

    from snakesim.components.scan.import_cli import import_command
    from snakesim.components.terrain.spec import load_terrain

    t, z = np.linspace(0, 2 * np.pi, 97)[:-1], np.linspace(-DEPTH, 0, 31)
    tt, zz = np.meshgrid(t, z, indexing="ij")
    v = np.c_[A * np.cos(tt.ravel()), B * np.sin(tt.ravel()), zz.ravel()]
    i, j = np.meshgrid(np.arange(len(t)), np.arange(len(z) - 1), indexing="ij")
    a, b = (i * len(z) + j).ravel(), (((i + 1) % len(t)) * len(z) + j).ravel()
    faces = np.r_[np.c_[a, a + 1, b + 1], np.c_[a, b + 1, b]]
    n = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    if np.sum(np.einsum("ij,ij->i", n, v[faces[:, 0]] * [1, 1, 0])) > 0:     # make them face the axis
        faces = faces[:, ::-1]
    scan = tmp_path / "shaft.stl"
    trimesh.Trimesh(v, faces, process=False).export(scan)
    out = tmp_path / "mesh-shaft.yaml"
    r = CliRunner().invoke(import_command, [str(scan), "-o", str(out), "--resolution", "0.05"],
                           env={"SNAKESIM_TERRAIN_STORE": str(tmp_path / "store")})
    assert r.exit_code == 0, r.output
    assert "0 interior, 2 outer rim(s)" in r.output, r.output
    terrain = load_terrain(str(out), store=tmp_path / "store")
    k = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    wall = np.c_[A * np.cos(k), B * np.sin(k), np.full(len(k), -1.5)]
    normal = np.c_[B * np.cos(k), A * np.sin(k), np.zeros(len(k))]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    assert (terrain.distance(wall - 0.05 * normal) > 0).all() and (terrain.distance(wall + 0.05 * normal) < 0).all()
