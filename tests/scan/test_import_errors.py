"""`snakesim terrain import` refuses bad scans with a message naming the file and what would be valid."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner


def run_import(scan, tmp_path, *args):
    """(exit code, output) of the command on ``scan`` (terrain store in tmp_path)."""
    from snakesim.components.scan.import_cli import import_command

    out = tmp_path / "terrain" / "scan.yaml"
    r = CliRunner().invoke(import_command, [str(scan), "-o", str(out), *args],
                           env={"SNAKESIM_TERRAIN_STORE": str(tmp_path / "store")})
    assert not isinstance(r.exception, Exception) or isinstance(r.exception, SystemExit), repr(r.exception)
    return r.exit_code, r.output


def expect_error(scan, tmp_path, *fragments, args=()):
    code, out = run_import(scan, tmp_path, *args)
    assert code != 0, out
    assert str(scan) in out, out                     # the message names the file
    for fragment in fragments:
        assert fragment in out, (fragment, out)
    assert not (tmp_path / "terrain" / "scan.yaml").exists()   # nothing written
    return out


def write_las(path, points, wkt: str | None = None):
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(points.min(axis=0))
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    if wkt is not None:
        header.vlrs.append(laspy.vlrs.known.WktCoordinateSystemVlr(wkt))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    las.write(path)


def test_unknown_format_lists_the_known_suffixes(tmp_path):
    scan = tmp_path / "moulin.e57"
    scan.write_bytes(b"\0" * 16)
    expect_error(scan, tmp_path, "unknown scan format '.e57'", ".ply, .pcd, .xyz, .las, .laz, .stl, .obj")


@pytest.mark.parametrize("name, content", [("empty.xyz", b""), ("comments.xyz", b"# x y z\n"),
                                           ("empty.ply", b"ply\nformat ascii 1.0\nelement vertex 0\n"
                                                         b"property float x\nproperty float y\nproperty float z\n"
                                                         b"end_header\n")])
def test_empty_cloud(tmp_path, name, content):
    scan = tmp_path / name
    scan.write_bytes(content)
    expect_error(scan, tmp_path, "holds no points")


def test_nan_points_are_counted_and_the_first_named(tmp_path):
    scan = tmp_path / "cloud.xyz"
    rows = np.arange(15, dtype=float).reshape(5, 3)
    rows[2, 1] = np.nan
    rows[4, 0] = np.inf
    np.savetxt(scan, rows)
    expect_error(scan, tmp_path, "2 of 5 points have NaN or infinite coordinates", "the first is point 2")


def test_too_sparse_cloud_reports_the_density_found_and_needed(tmp_path):
    # 120 points on a cylinder of radius 1 m, 3 m long: no extent of it exceeds its diagonal sqrt(3² + 2²) m,
    # so a mean nearest-neighbour spacing above diagonal / MIN_POINTS_ACROSS is too sparse whatever its axes
    rng = np.random.default_rng(0)
    t, z = rng.uniform(0, 2 * np.pi, 120), rng.uniform(-3, 0, 120)
    pts = np.c_[np.cos(t), np.sin(t), z]
    scan = tmp_path / "sparse.xyz"
    np.savetxt(scan, pts)
    from snakesim.components.scan.cleaning import MIN_POINTS_ACROSS, mean_spacing

    spacing, need = mean_spacing(pts), np.hypot(3.0, 2.0) / MIN_POINTS_ACROSS
    assert spacing > need                          # the premise: the cloud really is too sparse
    out = expect_error(scan, tmp_path, "too sparse to reconstruct", "points/m²", "needs a spacing of at most",
                       args=("--outliers", "none"))
    assert f"{spacing * 1e3:.3g} mm" in out


def test_mesh_with_inconsistent_winding(tmp_path):
    scan = tmp_path / "flipped.obj"
    # two triangles sharing the edge 1-2, both listing it 1 -> 2: their normals disagree across it
    scan.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 3 4\n")
    expect_error(scan, tmp_path, "winding is inconsistent")


def test_las_in_feet_needs_units(tmp_path):
    wkt = ('PROJCS["NAD83 / Alaska zone 4 (ftUS)",GEOGCS["NAD83",DATUM["North_American_Datum_1983",'
           'SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],'
           'PROJECTION["Transverse_Mercator"],UNIT["US survey foot",0.304800609601219]]')
    rng = np.random.default_rng(1)
    scan = tmp_path / "moulin.las"
    write_las(scan, rng.uniform(0, 10, (200, 3)) + [1.5e6, 2.0e6, 300.0], wkt)
    expect_error(scan, tmp_path, "US survey foot", "--units", "us-ft")


@pytest.mark.parametrize("name", ["corrupt.las", "corrupt.ply", "corrupt.pcd", "corrupt.stl", "corrupt.laz"])
def test_corrupt_file(tmp_path, name):
    scan = tmp_path / name
    scan.write_bytes(b"this is not a scan \x00\x01\x02" * 20)
    out = expect_error(scan, tmp_path)
    assert "cannot read" in out or "holds no" in out, out


def test_corrupt_xyz_row(tmp_path):
    scan = tmp_path / "cloud.xyz"
    scan.write_text("0 0 0\n1 2\n")
    expect_error(scan, tmp_path, "cannot read")


def test_unknown_reconstruction_lists_the_registered_ones(tmp_path):
    scan = tmp_path / "shaft.xyz"
    np.savetxt(scan, np.random.default_rng(2).uniform(0, 1, (500, 3)))
    expect_error(scan, tmp_path, "reconstruction 'marching'", "poisson, ball_pivoting",
                 args=("--reconstruction", "marching"))


@pytest.mark.parametrize("option, value, fragment", [("--outliers", "20", "K,STD"),
                                                     ("--outliers", "0,2", "K is a whole"),
                                                     ("--offset", "1,2", "X,Y,Z")])
def test_malformed_options_say_what_is_expected(tmp_path, option, value, fragment):
    scan = tmp_path / "cloud.xyz"
    np.savetxt(scan, np.zeros((3, 3)))
    code, out = run_import(scan, tmp_path, option, value)
    assert code == 2 and option in out and fragment in out, out
