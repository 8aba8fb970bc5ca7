"""Mesh terrains: SDF grid against an analytic box, the terrain store, bad meshes."""

import numpy as np
import pytest
import trimesh
from surface_checks import fd_gradient

from snakesim.components.terrain import load_terrain, mesh_terrain
from snakesim.components.terrain import mesh as mesh_mod
from snakesim.components.terrain.meshgen import box_channel_mesh
from snakesim.framework import ConfigError

EXT = np.array([1.0, 0.6, 0.4])


def box_sdf(p, half):
    q = np.abs(p) - half
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


@pytest.fixture
def box_file(tmp_path):
    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=EXT).export(path)
    return path


def test_box_sdf_matches_analytic(box_file, tmp_path):
    h = 0.02
    t = mesh_terrain(box_file, resolution=h, padding=0.1, store=tmp_path / "s")
    p = np.random.default_rng(0).uniform(-EXT / 2 - 0.09, EXT / 2 + 0.09, (2000, 3))
    q = t.query(p)
    exact = box_sdf(p, EXT / 2)
    assert np.abs(q.distance - exact).max() <= h          # trilinear error <= grid spacing
    # on the middle of each face the normal is the face normal
    face_pts = np.array([[0.5, 0, 0], [0, -0.3, 0], [0, 0, 0.2]]) + np.array([[0.01, 0, 0], [0, -0.01, 0], [0, 0, 0.01]])
    np.testing.assert_allclose(t.query(face_pts).normal, [[1, 0, 0], [0, -1, 0], [0, 0, 1]], atol=1e-6)
    # normal is the normalised gradient of the interpolated distance
    g = fd_gradient(t.distance, p[:50], eps=1e-7)
    np.testing.assert_allclose(q.normal[:50], g / np.linalg.norm(g, axis=1, keepdims=True), atol=1e-5)


def test_inside_free_flips_the_sign(box_file, tmp_path):
    a = mesh_terrain(box_file, resolution=0.05, store=tmp_path / "s")
    b = mesh_terrain(box_file, resolution=0.05, inside="free", store=tmp_path / "s")
    p = np.array([[0.0, 0.0, 0.0], [0.1, 0.1, 0.1]])
    np.testing.assert_allclose(b.distance(p), -a.distance(p))
    assert b.distance(p)[0] == pytest.approx(0.2, abs=0.05)


def test_second_load_reads_the_store(box_file, tmp_path, monkeypatch):
    store = tmp_path / "s"
    n0 = mesh_mod.compute_count
    first = mesh_terrain(box_file, resolution=0.05, store=store)
    assert mesh_mod.compute_count == n0 + 1
    assert len(list(store.glob("*.npz"))) == 1

    def boom(*a, **k):
        raise AssertionError("SDF recomputed despite a cached entry")

    monkeypatch.setattr(mesh_mod, "compute_sdf_grid", boom)
    second = mesh_terrain(box_file, resolution=0.05, store=store)
    np.testing.assert_array_equal(second.values, first.values)
    # other grid parameters are another entry
    with pytest.raises(AssertionError, match="recomputed"):
        mesh_terrain(box_file, resolution=0.04, store=store)


def test_store_from_environment(box_file, tmp_path, monkeypatch):
    monkeypatch.setenv("SNAKESIM_TERRAIN_STORE", str(tmp_path / "env-store"))
    mesh_terrain(box_file, resolution=0.05)
    assert len(list((tmp_path / "env-store").glob("*.npz"))) == 1


def test_non_watertight_mesh_is_rejected(tmp_path):
    m = trimesh.creation.box(extents=EXT)
    open_mesh = trimesh.Trimesh(m.vertices, m.faces[:-1])
    path = tmp_path / "open.ply"
    open_mesh.export(path)
    with pytest.raises(ConfigError, match=r"open\.ply: mesh is not watertight"):
        mesh_terrain(path, resolution=0.05)
    t = mesh_terrain(path, resolution=0.05, open_surface=True)      # opted in: signed by face orientation
    assert t.distance([[0, 0, 0.35]])[0] == pytest.approx(0.15, abs=0.05)


def test_missing_mesh_file(tmp_path):
    with pytest.raises(ConfigError, match="mesh file not found"):
        mesh_terrain(tmp_path / "nope.obj")


def test_obj_and_direct_path(tmp_path):
    path = tmp_path / "b.obj"
    trimesh.creation.box(extents=EXT).export(path)
    t = load_terrain(str(path))
    assert t.distance([[0, 0, 0.4]])[0] == pytest.approx(0.2, abs=0.02)


def test_shipped_box_channel_is_the_generator_output_and_loads():
    t = load_terrain("box-channel")
    ref = box_channel_mesh()
    shipped = trimesh.load(mesh_mod.Path(t.source), force="mesh")
    assert shipped.is_watertight and shipped.volume == pytest.approx(ref.volume)
    # in the middle of the channel floor, 0.1 m up: 0.1 from the floor, 0.2 from each wall
    assert t.distance([[1.5, 0.0, 0.1]])[0] == pytest.approx(0.1, abs=t.h)
    assert t.distance([[1.5, 0.15, 0.3]])[0] == pytest.approx(0.05, abs=t.h)


def test_a_grid_too_large_for_memory_is_refused_before_computing(box_file, tmp_path, monkeypatch):
    """Issue 17: a resolution needing hundreds of GB is refused, naming the limit and a resolution that fits."""
    before = mesh_mod.compute_count
    with pytest.raises(ConfigError) as e:
        mesh_terrain(box_file, resolution=1e-4, store=tmp_path / "s")
    msg = str(e.value)
    assert str(box_file) in msg and "resolution" in msg and "resolution 0.0001 m" in msg and "GB" in msg
    assert mesh_mod.compute_count == before               # nothing was computed
    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", "1e6")
    with pytest.raises(ConfigError) as e:
        mesh_terrain(box_file, resolution=0.02, store=tmp_path / "s")
    h_fit = float(str(e.value).split("at least ")[1].split(" m")[0])
    mesh_terrain(box_file, resolution=h_fit, store=tmp_path / "s")    # the suggestion fits
