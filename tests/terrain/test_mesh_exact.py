"""Mesh terrains for open scans (issue 30): the exact band near the surface and the winding-number sign.

Every expected value comes from an independent computation in this file: trimesh's point-triangle closest
points over all faces (brute force), the winding number summed face by face in numpy (Van Oosterom &
Strackee's solid angle), libigl's exact unsigned distance, and a Möller-Trumbore ray cast over all faces.
"""

import numpy as np
import pytest
import trimesh
from pydantic import ValidationError

from snakesim.components.terrain import mesh as mesh_mod
from snakesim.components.terrain import mesh_terrain
from snakesim.components.terrain.spec_models import MeshSpec
from snakesim.framework import ConfigError

R, H, BAND = 0.3, 0.02, 0.03          # sphere radius, grid spacing, exact band (m)


def brute_closest(mesh, p):
    """Closest surface point (n, 3) and distance (n,) of each point, over every face."""
    tri = mesh.triangles
    closest, dist = np.empty_like(p), np.empty(len(p))
    for i, q in enumerate(p):
        c = trimesh.triangles.closest_point(tri, np.repeat(q[None], len(tri), 0))
        d2 = ((c - q) ** 2).sum(1)
        j = int(d2.argmin())
        closest[i], dist[i] = c[j], np.sqrt(d2[j])
    return closest, dist


def winding_number(V, F, p):
    """Σ solid angles / 4π (Van Oosterom & Strackee 1983), every face, every point."""
    a, b, c = (V[F[:, k]][None] - p[:, None] for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
    dot = lambda x, y: np.einsum("ijk,ijk->ij", x, y)            # noqa: E731
    det = dot(a, np.cross(b, c))
    return (2 * np.arctan2(det, la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb)).sum(1) / (4 * np.pi)


@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    """A faceted sphere (1280 faces) with the grid alone and with the exact band."""
    folder = tmp_path_factory.mktemp("sphere")
    path = folder / "sphere.stl"
    trimesh.creation.icosphere(subdivisions=3, radius=R).export(path)
    mesh = trimesh.load(path)
    grid = mesh_terrain(path, resolution=H, padding=0.1, store=folder / "s")
    exact = mesh_terrain(path, resolution=H, padding=0.1, exact_band=BAND, store=folder / "s")
    return mesh, grid, exact


def near_sphere(n, spread, seed):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u * (R + rng.uniform(-spread, spread, n))[:, None]


def test_exact_band_is_the_brute_force_distance_and_normal(sphere):
    mesh, grid, exact = sphere
    p = near_sphere(300, 0.05, 0)
    q, g = exact.query(p), grid.query(p)
    closest, dist = brute_closest(mesh, p)
    d_true = np.where(winding_number(mesh.vertices, mesh.faces, p) > 0.5, -dist, dist)
    band = np.abs(g.distance) < BAND
    assert band.sum() > 150 and (~band).sum() > 50
    np.testing.assert_allclose(q.distance[band], d_true[band], rtol=0, atol=1e-12)
    np.testing.assert_allclose(q.closest[band], closest[band], rtol=0, atol=1e-12)
    n_true = (p - closest) / d_true[:, None]
    np.testing.assert_allclose(q.normal[band], n_true[band], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(q.distance[~band], g.distance[~band])       # outside the band: the grid
    assert np.abs(g.distance[band] - d_true[band]).max() > 1e-4             # ... which the band did improve
    free = mesh_terrain(exact.source, resolution=H, padding=0.1, exact_band=BAND, inside="free",
                        store=mesh_mod.Path(exact.source).parent / "s").query(p)
    np.testing.assert_array_equal(free.distance, -q.distance)               # the other side is the solid
    np.testing.assert_array_equal(free.normal, -q.normal)


def test_on_the_surface_the_normal_is_the_face_normal(sphere):
    mesh, _, exact = sphere
    tri = mesh.triangles[::40]
    q = exact.query(tri.mean(1))
    np.testing.assert_allclose(q.distance, 0.0, atol=1e-15)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(q.normal, normal / np.linalg.norm(normal, axis=1, keepdims=True), atol=1e-12)
    q = exact.query(mesh.vertices[::50])                          # on a vertex: its pseudonormal, outward
    np.testing.assert_allclose(q.distance, 0.0, atol=1e-15)
    assert (np.einsum("ij,ij->i", q.normal, mesh.vertices[::50]) / R > 0.99).all()


def test_the_band_edge_steps_by_at_most_the_grid_error(sphere):
    """Along rays from the centre, bisect where the grid's |d| crosses the band, on either side of the
    surface: the query just inside and just outside differ by the grid's error there, ≤ h."""
    _, grid, exact = sphere
    u = near_sphere(40, 0.0, 1) / R
    for lo_r, hi_r in ((R + 0.5 * BAND, R + 2 * BAND), (R - 2 * BAND, R - 0.5 * BAND)):
        a, b = np.full(len(u), lo_r), np.full(len(u), hi_r)
        inside_at_a = np.abs(grid.distance(u * a[:, None])) < BAND
        for _ in range(45):
            m = 0.5 * (a + b)
            same = (np.abs(grid.distance(u * m[:, None])) < BAND) == inside_at_a
            a, b = np.where(same, m, a), np.where(same, b, m)
        da, db = exact.distance(u * a[:, None]), exact.distance(u * b[:, None])
        assert np.abs(da - db).max() <= H
        assert np.abs(da - db).max() > 1e-6        # a real step: the two sides use different paths


def test_default_keys_keep_the_store_entry_and_the_grid_path(tmp_path, monkeypatch):
    """The default (sign: pseudonormal, exact_band: 0) is today's terrain: the store key's parameters are
    the ones earlier versions wrote (so box-channel's cached grid is reused as is) and no band is made."""
    seen = []
    real_key = mesh_mod._store.content_key
    monkeypatch.setattr(mesh_mod._store, "content_key", lambda data, params: seen.append(params) or
                        real_key(data, params))
    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=[1.0, 0.6, 0.4]).export(path)
    t = mesh_terrain(path, resolution=0.05, store=tmp_path / "s")
    assert t.near_surface is None
    assert len(seen) == 1 and set(seen[0]) == {"v", "lo", "h", "shape", "open"}
    assert mesh_mod.SDF_VERSION == 1


def test_bad_keys_are_errors_naming_them(tmp_path):
    base = {"kind": "mesh", "file": "x.stl"}
    with pytest.raises(ValidationError, match="exact_band"):
        MeshSpec(**base, exact_band=-0.01)
    with pytest.raises(ValidationError, match=r"exact_band = 0\.2 m is larger than padding = 0\.1 m"):
        MeshSpec(**base, exact_band=0.2)
    with pytest.raises(ValidationError, match="sign"):
        MeshSpec(**base, sign="ray_parity")
    assert MeshSpec(**base, exact_band=0.05, sign="winding_number").exact_band == 0.05
    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=[1.0, 0.6, 0.4]).export(path)
    with pytest.raises(ConfigError, match="exact_band = 0.2 m: need 0 <= exact_band <= padding") as e:
        mesh_terrain(path, resolution=0.05, exact_band=0.2, store=tmp_path / "s")
    assert "box.stl" in str(e.value)
    with pytest.raises(ConfigError, match="sign must be one of pseudonormal, winding_number"):
        mesh_terrain(path, resolution=0.05, sign="parity", store=tmp_path / "s")


# -- an open scanned shaft: an elliptic tube, both ends open, a hole in its wall ---------------------------

A, B, LENGTH = 0.6, 0.35, 3.0                     # semi-axes and length of the tube (m)
HOLE = (0.65, 0.6, 0.5)                           # centre and half-width of its angle (rad), half-height (m)


def open_tube(nt=64, nz=31):
    """Faces whose normals point into the void (as a scan's, towards the scanner), a hole cut at mid-depth
    near the narrow end, where the wall curves (its curvature tilts the hole edges' normals)."""
    th, z = np.linspace(0, 2 * np.pi, nt, endpoint=False), np.linspace(0, LENGTH, nz)
    TH, Z = np.meshgrid(th, z, indexing="ij")
    V = np.stack([A * np.cos(TH), B * np.sin(TH), Z], -1).reshape(-1, 3)
    i, j = (x.ravel() for x in np.meshgrid(np.arange(nt), np.arange(nz - 1), indexing="ij"))
    a, b, c, d = i * nz + j, (i + 1) % nt * nz + j, (i + 1) % nt * nz + j + 1, i * nz + j + 1
    F = np.concatenate([np.stack([a, c, b], 1), np.stack([a, d, c], 1)])
    centre = V[F].mean(1)
    angle = np.angle(np.exp(1j * (np.arctan2(centre[:, 1] / B, centre[:, 0] / A) - HOLE[0])))
    hole = (np.abs(angle) < HOLE[1]) & (np.abs(centre[:, 2] - LENGTH / 2) < HOLE[2])
    return trimesh.Trimesh(V, F[~hole], process=False)


def off_the_wall(n, lo, hi, seed):
    """Points at lo…hi m from the elliptic wall (along its normal) on either side, mid-depth; their
    parameter angle, and whether they are in the void (inside the ellipse)."""
    rng = np.random.default_rng(seed)
    th, z = rng.uniform(-np.pi, np.pi, n), rng.uniform(1.2, 1.8, n)
    delta = rng.uniform(lo, hi, n) * rng.choice([-1.0, 1.0], n)
    normal = np.stack([np.cos(th) / A, np.sin(th) / B], 1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    xy = np.stack([A * np.cos(th), B * np.sin(th)], 1) + delta[:, None] * normal
    return np.column_stack([xy, z]), th, (xy[:, 0] / A) ** 2 + (xy[:, 1] / B) ** 2 < 1


@pytest.fixture(scope="module")
def tube(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tube")
    path = folder / "tube.ply"
    mesh = open_tube()
    assert not mesh.is_watertight
    assert (np.einsum("ij,ij->i", mesh.face_normals[:, :2], mesh.triangles_center[:, :2]) < 0).all()   # into the void
    mesh.export(path)
    mesh = trimesh.load(path, process=False)                     # as stored: float32 vertices
    kw = dict(resolution=0.03, padding=0.25, store=folder / "s")
    return path, mesh, kw


def test_winding_number_signs_an_open_tube_where_the_pseudonormal_fails(tube):
    """10-20 cm off the wall at mid-depth, void and ice, behind the hole too: the winding number's sign
    (inside: free, the enclosed void) is right everywhere; the pseudonormal's (inside: solid, since the
    normals point into the void) is wrong behind the hole, where the edges' normals face the point."""
    path, mesh, kw = tube
    winding = mesh_terrain(path, inside="free", sign="winding_number", **kw)        # no open_surface needed
    pseudo = mesh_terrain(path, inside="solid", open_surface=True, **kw)
    p, _, void = off_the_wall(3000, 0.10, 0.20, 2)
    assert 1000 < void.sum() < 2000
    assert ((winding.distance(p) > 0) == void).all()
    wrong = (pseudo.distance(p) > 0) != void
    assert wrong.sum() >= 5 and not (wrong & void).any()          # ice behind the hole, counted free
    w = winding_number(mesh.vertices, mesh.faces, p[wrong])
    assert (np.abs(w) < 0.5).all()                                # the independent winding number agrees


def test_winding_number_with_the_exact_band_near_the_wall(tube):
    """1-4 cm off the wall, away from the hole's edges and the open ends: the sign is the side, the
    distance libigl's exact one (the band's pseudonormal sign oriented like the winding number)."""
    import igl

    path, mesh, kw = tube
    t = mesh_terrain(path, inside="free", sign="winding_number", exact_band=0.05, **kw)
    assert t.near_surface.sign == 1.0         # normals into the enclosed void (o = −1), inside: free (−1)
    p, th, void = off_the_wall(3000, 0.01, 0.04, 3)
    angle = np.abs(np.angle(np.exp(1j * (th - HOLE[0]))))
    off_hole = (angle > HOLE[1] + 0.25) | (np.abs(p[:, 2] - LENGTH / 2) > HOLE[2] + 0.1)
    p, void = p[off_hole], void[off_hole]
    q = t.query(p)
    assert ((q.distance > 0) == void).all()
    dist = np.sqrt(igl.point_mesh_squared_distance(p, mesh.vertices.astype(float), mesh.faces.astype(np.int64))[0])
    np.testing.assert_allclose(np.abs(q.distance), dist, rtol=0, atol=1e-12)


def test_the_lidar_sees_the_imported_mesh_of_an_open_shaft(tube):
    """Rays from the axis at mid-depth hit the wall where the mesh is (refine_hits False: the file's
    triangles, not the grid's level set), and display_mesh returns the file's triangles."""
    from snakesim.components.perception import SensorScene
    from snakesim.framework import Harness

    path, mesh, kw = tube
    t = mesh_terrain(path, inside="free", sign="winding_number", exact_band=0.05, **kw)
    assert t.refine_hits is False
    shown = t.display_mesh(np.zeros(3), 10.0, 0.05, None)
    got = np.sort(np.asarray(shown.vertices, dtype=float)[shown.faces].reshape(-1, 9), axis=0)
    np.testing.assert_allclose(got, np.sort(mesh.triangles.reshape(-1, 9), axis=0), atol=1e-6)

    scene = Harness(SensorScene, {"extent": 5.0})
    scene.inputs.terrain = t
    phi = np.linspace(-np.pi, np.pi, 73)[:-1] + 0.013
    origins = np.tile([0.05, -0.02, 1.1], (len(phi), 1))
    dirs = np.column_stack([np.cos(phi), np.sin(phi), np.full(len(phi), 0.1)])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    hits = scene.outputs()["world"].cast(origins, dirs, max_range=5.0)
    expected = ray_mesh(mesh, origins, dirs)
    assert 0 < np.isinf(expected).sum() < 20                        # the rays through the hole miss
    np.testing.assert_array_equal(hits.hit, np.isfinite(expected))
    np.testing.assert_allclose(hits.distance[hits.hit], expected[hits.hit], rtol=0, atol=2e-6)


def ray_mesh(mesh, o, d):
    """Nearest hit distance of each ray over every face (Möller & Trumbore 1997), inf on a miss."""
    v0, v1, v2 = (mesh.triangles[:, k][None] for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    pv = np.cross(d[:, None], e2)
    det = np.einsum("ijk,ijk->ij", e1, pv)
    tv = o[:, None] - v0
    u = np.einsum("ijk,ijk->ij", tv, pv) / det
    qv = np.cross(tv, e1)
    v = np.einsum("ijk,ijk->ij", np.broadcast_to(d[:, None], qv.shape), qv) / det
    t = np.einsum("ijk,ijk->ij", np.broadcast_to(e2, qv.shape), qv) / det
    ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(ok, t, np.inf).min(1)
