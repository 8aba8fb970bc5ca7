"""Synthetic scans (components/scan/synthetic.py, scan_files.py, synthetic_cli.py) checked against a shape known in
closed form: terrains/vertical-tube-r0.3.yaml, the cylinder x² + y² = R², R = 0.3 m, axis z.

A beam from o along unit d meets it at t = (−b + √(b² − a c)) / a with a = d_x² + d_y², b = o_xy·d_xy,
c = |o_xy|² − R² (o inside: c < 0, the one positive root), at incidence cos θ = |p_xy·d_xy| / R. Every expected
value below comes from that formula or from the statistics of the noise asked for, never from the code's output.
"""

from __future__ import annotations

import hashlib

import laspy
import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.components.scan.scan_files import LAS_SCALE, poses_path, write_las, write_ply_points
from snakesim.components.scan.synthetic import ScanPattern, ScanSettings, scan_terrain
from snakesim.components.scan.synthetic_cli import scan_command
from snakesim.components.terrain.spec import load_terrain

R = 0.3
TUBE = "vertical-tube-r0.3"
HEAD = ScanPattern(channels=24, columns=128, vertical_fov=(-60.0, 60.0))


@pytest.fixture(scope="module")
def tube():
    return load_terrain(TUBE)


def settings(**kw) -> ScanSettings:
    base = dict(top=-0.5, bottom=-1.5, poses=3, rope=(0.1, -0.05), pattern=HEAD, max_range=3.0, range_noise=0.0,
                dropout=0.0, seed=7)
    return ScanSettings(**{**base, **kw})


def tube_range(o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Closed-form range from o (n, 3) inside the tube along unit d (n, 3) to its wall."""
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1]
    c = o[:, 0] ** 2 + o[:, 1] ** 2 - R * R
    return (-b + np.sqrt(b * b - a * c)) / a


def beams_of(s: ScanSettings):
    """Every beam of the scan, independently: (origins, unit directions) (n, 3), stop by stop, the head yawed by
    the golden angle per stop (the model's statement)."""
    g = HEAD.beams().directions
    golden = np.pi * (3.0 - np.sqrt(5.0))
    o, d = [], []
    for k, z in enumerate(np.linspace(s.top, s.bottom, s.poses)):
        c, sn = np.cos(k * golden), np.sin(k * golden)
        d.append(g @ np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1.0]]).T)
        o.append(np.tile([s.rope[0], s.rope[1], z], (len(g), 1)))
    return np.concatenate(o), np.concatenate(d)


@pytest.fixture(scope="module")
def clean(tube):
    s = settings()
    return s, scan_terrain(tube, s)


def test_noise_free_points_lie_on_the_tube_and_on_their_beams(clean):
    s, scan = clean
    o, d = beams_of(s)
    assert scan.counts["returns"] == scan.counts["beams"] == len(d) == len(scan)  # every beam meets the wall
    radial = np.hypot(scan.points[:, 0], scan.points[:, 1])
    assert np.abs(radial - R).max() < 1e-6
    # each point on the beam from the scanner position it carries, at the closed-form range
    rel = scan.points - scan.scanner
    r = np.linalg.norm(rel, axis=1)
    assert np.abs(rel / r[:, None] - scan.direction).max() < 1e-9
    assert np.abs(r - tube_range(scan.scanner, scan.direction)).max() < 1e-6
    # the scanner positions are the stops on the rope, in the order of the stops
    z = np.linspace(s.top, s.bottom, s.poses)
    np.testing.assert_array_equal(scan.scanner[:, :2], np.tile(s.rope, (len(scan), 1)))
    np.testing.assert_array_equal(scan.scanner[:, 2], z[scan.pose])
    # the beams are the pattern's, stop by stop (the set of directions of each stop)
    for k in range(s.poses):
        mine = np.sort(np.round(scan.direction[scan.pose == k], 9), axis=0)
        theirs = np.sort(np.round(d[k * len(d) // s.poses:(k + 1) * len(d) // s.poses], 9), axis=0)
        np.testing.assert_allclose(mine, theirs, atol=1e-8)
    # times: stop k from k·dwell, within one turn of the head
    assert np.all((scan.time >= s.dwell * scan.pose) & (scan.time < s.dwell * scan.pose + s.period))
    # reflectivity ρ cos θ: the tube's material albedo times the closed-form incidence
    cos = np.abs(np.einsum("ij,ij->i", scan.points[:, :2], scan.direction[:, :2])) / R
    np.testing.assert_allclose(scan.intensity, 0.6 * cos, atol=1e-5)


def test_range_noise_has_the_asked_deviation_growing_with_range(tube):
    a, slope = 0.003, 0.01
    s = settings(range_noise=a, range_noise_slope=slope, poses=4, bottom=-2.0)
    scan = scan_terrain(tube, s)
    true = tube_range(scan.scanner, scan.direction)
    measured = np.linalg.norm(scan.points - scan.scanner, axis=1)
    z = (measured - true) / (a + slope * true)             # standard normal if σ(r) = a + slope·r
    n = len(z)
    assert n > 10000
    assert abs(z.mean()) < 4 / np.sqrt(n)
    assert abs(z.std() - 1.0) < 4 / np.sqrt(2 * n)
    # and the noise moves the point along its beam only
    rel = scan.points - scan.scanner
    assert np.abs(rel / np.linalg.norm(rel, axis=1)[:, None] - scan.direction).max() < 1e-9


def test_dropout_fraction_within_binomial_bounds(tube):
    p = 0.1
    scan = scan_terrain(tube, settings(dropout=p, poses=8, bottom=-4.0))
    c = scan.counts
    eligible = c["returns"] - c["grazing"] - c["masked"]
    assert c["returns"] == c["beams"]
    assert abs(c["dropout"] - p * eligible) < 4 * np.sqrt(eligible * p * (1 - p))
    assert len(scan) == eligible - c["dropout"]


def test_grazing_and_masked_returns_are_lost_where_the_geometry_says(tube):
    s0 = settings()
    o, d = beams_of(s0)
    hit = o + tube_range(o, d)[:, None] * d
    incidence = np.degrees(np.arccos(np.abs(np.einsum("ij,ij->i", hit[:, :2], d[:, :2])) / R))
    limit, mask = 55.0, (R, 0.0, -1.0, 0.12)
    in_mask = np.linalg.norm(hit - mask[:3], axis=1) <= mask[3]
    graze = incidence > limit
    assert graze.sum() > 100 and (in_mask & ~graze).sum() > 50         # both cases really occur
    scan = scan_terrain(tube, settings(grazing=limit, masks=(mask,)))
    assert scan.counts["grazing"] == graze.sum()
    assert scan.counts["masked"] == (in_mask & ~graze).sum()
    assert len(scan) == (~graze & ~in_mask).sum()
    kept_hits = scan.points                       # noise free: the true hits
    assert np.linalg.norm(kept_hits - mask[:3], axis=1).min() > mask[3]
    cos = np.abs(np.einsum("ij,ij->i", kept_hits[:, :2], scan.direction[:, :2])) / R
    assert np.degrees(np.arccos(np.minimum(cos, 1.0))).max() <= limit


def test_thinning_keeps_one_true_hit_per_voxel_and_the_noise_unbiased(tube):
    edge, sigma = 0.02, 0.003
    full = scan_terrain(tube, settings(range_noise=sigma))
    thin = scan_terrain(tube, settings(range_noise=sigma, thin=edge))
    true_hit = thin.scanner + tube_range(thin.scanner, thin.direction)[:, None] * thin.direction
    cells = np.floor(true_hit / edge).astype(np.int64)
    assert len(np.unique(cells, axis=0)) == len(thin)                 # one a voxel
    all_cells = np.floor((full.scanner + tube_range(full.scanner, full.direction)[:, None] * full.direction) / edge)
    assert len(thin) == len(np.unique(all_cells.astype(np.int64), axis=0))    # every voxel with a return keeps one
    assert thin.counts["thinned"] == len(full) - len(thin)
    err = np.linalg.norm(thin.points - thin.scanner, axis=1) - tube_range(thin.scanner, thin.direction)
    assert abs(err.std() - sigma) < 4 * sigma / np.sqrt(2 * len(err))


def test_same_seed_same_bytes_other_seed_other_scan(tube, tmp_path):
    s = settings(range_noise=0.003, dropout=0.05)
    a, b = scan_terrain(tube, s), scan_terrain(tube, s)
    files = []
    for k, scan in enumerate((a, b)):
        files.append(write_las(tmp_path / f"s{k}.laz", scan.points, scan.scanner, scan.pose, scan.time,
                               scan.intensity).read_bytes())
        files.append(write_ply_points(tmp_path / f"s{k}.ply", scan.points, scan.scanner).read_bytes())
    assert files[0] == files[2] and files[1] == files[3]
    other = scan_terrain(tube, settings(range_noise=0.003, dropout=0.05, seed=8))
    assert len(other) != len(a) or not np.array_equal(other.points, a.points)


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_round_trip(clean, tmp_path, suffix):
    _, scan = clean
    noisy_time = scan.time + 1234.5
    path = write_las(tmp_path / f"scan{suffix}", scan.points, scan.scanner, scan.pose, noisy_time, scan.intensity)
    las = laspy.read(path)
    assert str(las.header.version) == "1.4" and las.header.point_format.id == 6
    assert las.header.global_encoding.wkt
    wkt = [v for v in las.header.vlrs if isinstance(v, laspy.vlrs.known.WktCoordinateSystemVlr)]
    assert len(wkt) == 1 and 'UNIT["metre",1]' in wkt[0].string
    np.testing.assert_allclose(las.header.scales, LAS_SCALE)
    xyz = np.column_stack([las.x, las.y, las.z])
    assert np.abs(xyz - scan.points).max() <= LAS_SCALE / 2 + 1e-12
    back = np.column_stack([las["scanner_x"], las["scanner_y"], las["scanner_z"]])
    np.testing.assert_array_equal(back, scan.scanner)
    np.testing.assert_array_equal(las.point_source_id, scan.pose)
    np.testing.assert_array_equal(las.gps_time, noisy_time)
    assert np.abs(las.intensity / 65535.0 - scan.intensity).max() <= 0.5 / 65535 + 1e-7


def test_ply_round_trip_read_independently(clean, tmp_path):
    _, scan = clean
    raw = write_ply_points(tmp_path / "scan.ply", scan.points, scan.scanner).read_bytes()
    head, _, body = raw.partition(b"end_header\n")
    lines = head.decode("ascii").splitlines()
    assert lines[:2] == ["ply", "format binary_little_endian 1.0"]
    assert f"element vertex {len(scan)}" in lines and not any(line.startswith("element face") for line in lines)
    props = [line.split()[1:] for line in lines if line.startswith("property")]
    assert props == [["double", "x"], ["double", "y"], ["double", "z"], ["float", "scanner_x"],
                     ["float", "scanner_y"], ["float", "scanner_z"]]
    v = np.frombuffer(body, dtype=[("p", "<f8", 3), ("s", "<f4", 3)])
    np.testing.assert_array_equal(v["p"], scan.points)
    np.testing.assert_array_equal(v["s"], scan.scanner.astype(np.float32))


def test_cli_writes_scan_and_poses(tmp_path):
    out = tmp_path / "tube.laz"
    r = CliRunner().invoke(scan_command, [TUBE, "-o", str(out), "--poses", "2", "--top", "-0.5", "--bottom", "-1",
                                          "--channels", "8", "--columns", "64", "--max-range", "2", "--seed", "3"])
    assert r.exit_code == 0, r.output
    las = laspy.read(out)
    # 2 stops × 8 × 64 beams, 1 % lost at random at most a few
    assert 1000 < len(las.points) <= 1024
    assert set(np.unique(las.point_source_id)) == {0, 1}
    rows = poses_path(out).read_text().splitlines()
    assert rows[0] == "pose,x,y,z,time"
    np.testing.assert_allclose(np.array([list(map(float, row.split(","))) for row in rows[1:]]),
                               [[0, 0, 0, -0.5, 0.0], [1, 0, 0, -1.0, 5.0]])
    again = tmp_path / "again.laz"
    CliRunner().invoke(scan_command, [TUBE, "-o", str(again), "--poses", "2", "--top", "-0.5", "--bottom", "-1",
                                      "--channels", "8", "--columns", "64", "--max-range", "2", "--seed", "3"])
    assert hashlib.sha256(again.read_bytes()).digest() == hashlib.sha256(out.read_bytes()).digest()


@pytest.mark.parametrize("args, option, words", [
    (["--range-noise", "-0.001"], "--range-noise", ">= 0"),
    (["--dropout", "1"], "--dropout", "[0, 1)"),
    (["--dropout", "-0.1"], "--dropout", "[0, 1)"),
    (["--poses", "0"], "--poses", "at least 1"),
    (["--top", "-3", "--bottom", "-1"], "--top", "below"),
    (["--rope", "0.5,0"], "--rope", "inside the terrain"),
    (["--rope", "0.1"], "--rope", "X,Y"),
    (["--mask", "0,0,-1,-0.1"], "--mask", "radius"),
    (["--grazing", "95"], "--grazing", "(0, 90]"),
])
def test_bad_options_name_the_option(tmp_path, args, option, words):
    r = CliRunner().invoke(scan_command, [TUBE, "-o", str(tmp_path / "x.las"), "--channels", "4", "--columns",
                                          "8"] + args)
    assert r.exit_code == 2, r.output
    assert option in r.output and words in r.output
    assert not (tmp_path / "x.las").exists()


def test_unknown_suffix_is_refused(tmp_path):
    r = CliRunner().invoke(scan_command, [TUBE, "-o", str(tmp_path / "x.pcd")])
    assert r.exit_code == 2 and "--output" in r.output and ".pcd" in r.output and ".laz" in r.output


def test_settings_refuse_bad_values_in_python():
    with pytest.raises(ValueError, match="dropout"):
        ScanSettings(dropout=1.0)
    with pytest.raises(ValueError, match="top"):
        ScanSettings(top=-5.0, bottom=-1.0)
    with pytest.raises(ValueError, match="range_noise"):
        ScanSettings(range_noise=-1.0)
    with pytest.raises(ValueError, match="poses"):
        ScanSettings(poses=0)


def test_shipped_moulin_scan_matches_its_provenance_and_its_truth():
    """terrains/scans/moulin-slot-scan.laz: the checksum and counts its .md states, stops on the rope the poses CSV
    lists, and every point within the 3 mm noise of terrains/moulin-slot.yaml's wall (the noise is along the beam:
    its component along the wall's normal is at most the range error)."""
    import re
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "terrains" / "scans"
    laz, md = folder / "moulin-slot-scan.laz", (folder / "moulin-slot-scan.md").read_text()
    assert hashlib.sha256(laz.read_bytes()).hexdigest() in md
    las = laspy.read(laz)
    n = len(las.points)
    assert f"{n:,}".replace(",", " ") in md and 150_000 <= n <= 400_000
    stops = np.loadtxt(folder / "moulin-slot-scan.poses.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(stops[:, 1:3], np.tile([1.2, 0.0], (15, 1)))
    np.testing.assert_allclose(stops[:, 3], np.linspace(-0.5, -7.5, 15), atol=1e-9)
    scanner = np.column_stack([las["scanner_x"], las["scanner_y"], las["scanner_z"]])
    np.testing.assert_allclose(scanner, stops[np.asarray(las.point_source_id), 1:4], atol=1e-6)
    points = np.column_stack([las.x, las.y, las.z])
    d = load_terrain("moulin-slot").query(points).distance
    sigma = float(re.search(r"σ = (\d+) mm", md).group(1)) * 1e-3
    assert np.abs(d).max() < 6 * sigma + LAS_SCALE and d.std() < sigma
