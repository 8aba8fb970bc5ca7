"""Display meshes: the terrain mesh lies on the surface the contact model queries, faces free
space, and the robot's link meshes have the URDF's dimensions."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from snakesim.components.terrain import SdfGrid, available_terrains, load_terrain
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.viz.robot_geometry import link_meshes, meshes_from_urdf
from snakesim.components.viz.terrain_geometry import terrain_mesh

F32 = 1e-5      # vertices are float32: ~1e-7 relative over a few metres


@pytest.mark.parametrize("name", available_terrains())
def test_terrain_mesh_lies_on_the_surface_and_faces_free_space(name):
    t = load_terrain(name)
    m = terrain_mesh(t, center=(0.5, 0.0, 0.0), extent=2.0, cell=0.25)
    v = m.vertices.astype(float)
    d = t.query(v).distance
    if t.kind == "moulin":
        # the surface square keeps whole cells around the shaft's mouth: those corners are in the open
        shaft = v[:, 2] < t.top - 1e-9
        assert np.abs(d[shaft]).max() < F32 and d[~shaft].min() > -F32
    else:
        assert np.abs(d).max() < F32
    # a step along the normal goes into free space (distance grows by about the step); an SDF
    # grid rounds edges within a cell, and an obstacle field's seams (ice meets rock) are concave
    # creases whose vertices step into the neighbouring solid, so there the step starts from face centres
    step = 0.01
    if t.kind in ("mesh", "obstacles"):
        v = v[m.faces].mean(axis=1)
        n = m.normals[m.faces[:, 0]]
    else:
        n = m.normals
    grown = t.query(v + step * n).distance - t.query(v).distance
    assert np.mean(grown > 0.5 * step) > 0.99


def test_cutaway_removes_the_wall_facing_the_viewer():
    t = load_terrain("tube-r0.3")                         # axis x through the origin
    cut = (0.0, -0.6, 0.8)
    v = terrain_mesh(t, cutaway=cut).vertices
    assert (v[:, 1:] @ np.array(cut[1:]) <= 0.3 * 0.2).all()    # nothing well on the viewer's side
    full = terrain_mesh(t, cutaway=None).vertices
    assert len(v) < 0.6 * len(full)


def test_grid_without_its_mesh_file_draws_the_zero_crossing():
    """A sphere of radius 0.5 as an SDF grid with no source mesh: voxel faces within one cell of it."""
    h, n = 0.05, 41
    ax = -1.0 + h * np.arange(n)
    X, Y, Z = np.meshgrid(ax, ax, ax, indexing="ij")
    grid = SdfGrid(np.sqrt(X ** 2 + Y ** 2 + Z ** 2) - 0.5, (-1.0, -1.0, -1.0), h, source="<no file>")
    m = terrain_mesh(grid)
    r = np.linalg.norm(m.vertices, axis=1)
    assert np.abs(r - 0.5).max() <= np.sqrt(3) * h


def test_link_meshes_match_the_urdf_visuals():
    from snakesim.robots import load_robot

    desc = load_robot("eels-1.0", modules=2)
    root = ET.fromstring(desc.urdf)
    meshes = {m.link: m for m in link_meshes(RobotModel.load(design="eels-1.0", modules=2))}
    assert list(meshes) == [ln.get("name") for ln in root.findall("link") if ln.find("visual") is not None]
    # a module shell: a cylinder along x (rpy 0 pi/2 0) from its origin to x = length
    el = root.find("link[@name='module_00']/visual/geometry/cylinder")
    r, length = float(el.get("radius")), float(el.get("length"))
    v = meshes["module_00"].vertices
    np.testing.assert_allclose([v[:, 0].min(), v[:, 0].max()], [0.0, length], atol=F32)
    np.testing.assert_allclose(np.hypot(v[:, 1], v[:, 2]).max(), r, atol=F32)
    # a screw: the STL blade reaches the screw's outer radius from the metadata
    screw = desc.metadata["screws"][0]
    s = meshes[screw["link"]].vertices
    assert np.hypot(s[:, 1], s[:, 2]).max() == pytest.approx(screw["radius"], abs=1e-3)


def test_missing_mesh_file_is_reported_and_skipped(tmp_path, capsys):
    urdf = """<robot name="r"><link name="a"><visual><geometry><mesh filename="../meshes/nope.stl"/>
              </geometry></visual><visual><geometry><box size="1 2 3"/></geometry></visual></link></robot>"""
    (m,) = meshes_from_urdf(urdf, tmp_path)
    np.testing.assert_allclose(np.ptp(m.vertices, axis=0), [1, 2, 3], atol=F32)     # the box alone
    assert "visual mesh '../meshes/nope.stl' not found" in capsys.readouterr().err
