"""The import's pieces alone: frames (units, up axis, offset), LAS reading (scanner positions, units,
point_source_id), boundary loops, decimation, ball pivoting, and Open3D kept out of the core."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from snakesim.components.scan import frames, readers
from snakesim.components.scan.errors import ScanError


def raw(points, **kw):
    return readers.RawScan("scan.xyz", np.asarray(points, dtype=float), **kw)


@pytest.mark.parametrize("up", sorted(frames.UP_AXES))
def test_up_axis_becomes_plus_z_by_a_proper_rotation(up):
    rot = np.asarray(frames.UP_AXES[up], dtype=float)
    axis = np.zeros(3)
    axis["xyz".index(up[1])] = 1.0 if up[0] == "+" else -1.0
    assert np.allclose(rot @ axis, [0, 0, 1])
    assert np.allclose(rot @ rot.T, np.eye(3)) and np.isclose(np.linalg.det(rot), 1.0)


def test_offset_is_removed_in_file_units_before_scaling_and_turning():
    p = np.array([[1000.0, 2000.0, 3100.0], [1000.0, 2500.0, 3000.0]])           # mm, y up
    scan = frames.to_terrain_frame(raw(p, scanner=p + [0, 0, 100]), units="mm", up="+y",
                                   offset=[1000, 2000, 3000])
    # (x, y, z) -> (x, -z, y) after (p - offset) * 1e-3
    assert np.allclose(scan.points, [[0, -0.1, 0], [0, 0, 0.5]])
    assert np.allclose(scan.scanner - scan.points, [[0, -0.1, 0]] * 2)


def test_unknown_units_and_up_name_the_valid_ones():
    with pytest.raises(ScanError, match="valid units are m, mm, cm, ft, us-ft"):
        frames.to_terrain_frame(raw([[0, 0, 0]]), units="inch")
    with pytest.raises(ScanError, match=r"valid up axes are \+z"):
        frames.to_terrain_frame(raw([[0, 0, 0]]), up="up")


def _las(path, points, scanner=None, source_id=None, geokey_unit=None, offsets=(500_000.4, 7_000_000.6, 100.0)):
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = list(offsets)
    header.scales = [1e-4, 1e-4, 1e-4]
    if scanner is not None:
        header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=np.float64) for n in readers.SCANNER_FIELDS])
    if geokey_unit is not None:
        vlr = laspy.vlrs.known.GeoKeyDirectoryVlr()
        vlr.geo_keys_header.key_directory_version, vlr.geo_keys_header.number_of_keys = 1, 1
        key = vlr.geo_keys[0]
        key.id, key.tiff_tag_location, key.count, key.value_offset = 3076, 0, 1, geokey_unit
        header.vlrs.append(vlr)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    if scanner is not None:
        for name, column in zip(readers.SCANNER_FIELDS, scanner.T):
            las[name] = column
    if source_id is not None:
        las.point_source_id = source_id
    las.write(path)


def test_las_scanner_extra_bytes_and_rounded_header_offset(tmp_path):
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 5, (50, 3)) + [500_000.0, 7_000_000.0, 100.0]
    s = p + [0.0, 0.0, 1.0]
    _las(tmp_path / "a.las", p, scanner=s)
    r = readers.read_raw(tmp_path / "a.las")
    assert np.allclose(r.points, p, atol=1e-4) and np.allclose(r.scanner, s)
    scan = frames.to_terrain_frame(r)
    assert np.allclose(scan.offset, [500_000.0, 7_000_001.0, 100.0])   # the header's, rounded
    assert np.allclose(scan.points, p - scan.offset, atol=1e-4)


def test_las_in_local_coordinates_keeps_its_frame(tmp_path):
    p = np.random.default_rng(1).uniform(-3, 3, (20, 3))             # a site frame, the header offset its own
    _las(tmp_path / "local.las", p, offsets=(-3.2, 0.4, -2.7))
    scan = frames.to_terrain_frame(readers.read_raw(tmp_path / "local.las"))
    assert np.allclose(scan.offset, 0) and np.allclose(scan.points, p, atol=1e-4)


def test_las_geokey_feet_is_refused_without_units_and_scaled_with_them(tmp_path):
    p = np.array([[500_001.0, 7_000_001.0, 101.0]] * 3)
    _las(tmp_path / "ft.las", p, geokey_unit=9002)
    r = readers.read_raw(tmp_path / "ft.las")
    assert r.unit == ("foot", 0.3048)
    with pytest.raises(ScanError, match=r"in foot .* --units"):
        frames.to_terrain_frame(r)
    scan = frames.to_terrain_frame(r, units="ft")
    assert np.allclose(scan.points, (p - np.round(r.header_offset)) * 0.3048, atol=1e-4)


def test_scanner_csv_rows_by_point_source_id(tmp_path):
    p = np.array([[500_001.0, 7_000_001.0, 101.0], [500_002.0, 7_000_001.0, 101.0], [500_003.0, 7_000_001.0, 99.0]])
    _las(tmp_path / "ids.las", p, source_id=np.array([1, 0, 1]))
    (tmp_path / "pos.csv").write_text("x,y,z\n1,2,3\n4,5,6\n")
    r = readers.read_raw(tmp_path / "ids.las")
    assert np.allclose(readers.scanner_csv(tmp_path / "pos.csv", r), [[4, 5, 6], [1, 2, 3], [4, 5, 6]])
    (tmp_path / "short.csv").write_text("1,2,3\n4,5,6\n")
    _las(tmp_path / "far.las", p, source_id=np.array([0, 1, 2]))
    with pytest.raises(ScanError, match="point_source_id of far.las runs 0..2 but there are 2"):
        readers.scanner_csv(tmp_path / "short.csv", readers.read_raw(tmp_path / "far.las"))


def _square_with_hole(n=10, hole=(4, 6)):
    """A unit square of n x n cells (two triangles each) without the cells hole[0] <= i, j < hole[1]."""
    g = np.linspace(0, 1, n + 1)
    x, y = np.meshgrid(g, g, indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    faces = []
    for i in range(n):
        for j in range(n):
            if hole[0] <= i < hole[1] and hole[0] <= j < hole[1]:
                continue
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
            faces += [(a, b, c), (a, c, d)]
    return v, np.array(faces)


def test_boundary_loops_measured_and_told_apart():
    from snakesim.components.scan.holes import find_holes

    v, f = _square_with_hole()
    holes = find_holes(v, f, v, band=0.05)
    assert len(holes) == 2
    outer, inner = holes
    assert outer.rim and not inner.rim
    assert np.isclose(outer.perimeter, 4.0) and np.isclose(outer.area, 1.0)
    assert np.isclose(inner.perimeter, 0.8) and np.isclose(inner.area, 0.04)
    assert np.allclose(inner.centre, [0.5, 0.5, 0.0]) and inner.edges == 8


def test_decimation_keeps_the_shape_within_the_budget():
    import trimesh

    from snakesim.components.scan.decimation import decimate

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.0)              # 5120 faces
    v, f = decimate(np.asarray(sphere.vertices), np.asarray(sphere.faces), 1000)
    assert len(f) <= 1000 and len(f) > 900
    assert np.abs(np.linalg.norm(v, axis=1) - 1.0).max() < 0.02                 # vertices stay on the sphere
    assert trimesh.Trimesh(v, f).is_watertight


def test_ball_pivoting_fits_a_noisy_cylinder():
    from snakesim.components.scan import cleaning, normals, reconstruction

    rng = np.random.default_rng(3)
    t, z = rng.uniform(0, 2 * np.pi, 6000), rng.uniform(0, 1.0, 6000)
    r = 0.3 + rng.normal(0, 0.002, 6000)
    p = np.c_[r * np.cos(t), r * np.sin(t), z]
    n, rule = normals.estimate_normals(p)
    assert rule == "void axis"
    assert np.all(np.einsum("ij,ij->i", n, -p * [1, 1, 0]) > 0)                 # all face the axis
    settings = reconstruction.ReconstructionSettings(cleaning.mean_spacing(p))
    v, f, _ = reconstruction.reconstruct("ball_pivoting", p, n, settings)
    centre = v[f].mean(axis=1)
    # a face's centre lies inside the circle through its corners: up to the chord sag, a few mm here
    assert np.abs(np.hypot(centre[:, 0], centre[:, 1]) - 0.3).mean() < 0.004
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    assert area > 0.8 * 2 * np.pi * 0.3 * 1.0                                   # most of the wall is covered
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.mean(np.einsum("ij,ij->i", face_n, -centre * [1, 1, 0]) > 0) > 0.95   # wound into the void


def test_missing_open3d_names_the_extra(monkeypatch):
    from snakesim.components.scan import open3d_loader

    monkeypatch.setitem(sys.modules, "open3d", None)                   # import open3d -> ImportError
    open3d_loader.import_open3d.cache_clear()
    try:
        with pytest.raises(open3d_loader.ScanExtraMissing, match=r"pip install 'snakesim\[scan\]'"):
            open3d_loader.import_open3d()
    finally:
        open3d_loader.import_open3d.cache_clear()


def test_the_core_does_not_import_open3d():
    code = ("import sys\n"
            "import snakesim.components.terrain.cli, snakesim.components.terrain.spec\n"
            "import snakesim.components.scan, snakesim.components.scan.import_cli\n"
            "assert 'open3d' not in sys.modules and 'laspy' not in sys.modules, 'imported'\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
