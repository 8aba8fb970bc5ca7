"""Scan files as field scanners write them, and as the importer (.readers) reads them back.

    LAS 1.4 / LAZ   point format 6 (laspy; LAZ compressed by lazrs), coordinates in metres at ``scale`` (0.1 mm
                    by default) from an offset at the cloud's lower corner, a WKT coordinate-system VLR whose
                    unit is the metre (``LOCAL_WKT``: a local engineering frame, z up; the global encoding's WKT
                    bit set, as LAS 1.4 asks of formats 6-10); per point the extra-bytes float64 dimensions
                    ``scanner_x``, ``scanner_y``, ``scanner_z`` (the scanner's position, same frame),
                    ``point_source_id`` the pose (stop) index, ``gps_time`` s, ``intensity`` uint16 (a
                    reflectivity in [0, 1] times 65535)
    PLY             binary little endian, vertices only: x, y, z float64, scanner_x, scanner_y, scanner_z
                    float32
    poses CSV       ``<scan>.poses.csv`` next to the scan: ``pose,x,y,z,time`` (index, m, m, m, s), one stop a
                    line

Every file is written whole or not at all (framework/output_files.py). Units m, s.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from snakesim.framework.output_files import write_file

#: the frame of every synthetic scan: the terrain's world frame, metres, z up (WKT 1, LOCAL_CS)
LOCAL_WKT = ('LOCAL_CS["snakesim terrain frame (z up)",LOCAL_DATUM["snakesim terrain origin",0],'
             'UNIT["metre",1],AXIS["X",EAST],AXIS["Y",NORTH],AXIS["Z",UP]]')
#: m, the LAS coordinates' resolution (integers times this)
LAS_SCALE = 1e-4
SCANNER_DIMENSIONS = ("scanner_x", "scanner_y", "scanner_z")
#: the file suffixes a scan may be written as
SCAN_SUFFIXES = (".las", ".laz", ".ply")


def write_las(path, points, scanner, pose=None, time=None, intensity=None, scale: float = LAS_SCALE,
              wkt: str = LOCAL_WKT) -> Path:
    """A LAS 1.4 file (LAZ if ``path`` ends in .laz) of ``points`` (n, 3) m measured from ``scanner`` (n, 3) m;
    ``pose`` (n,) int stop indices (0..65535), ``time`` (n,) s, ``intensity`` (n,) in [0, 1] (module docstring)."""
    import laspy

    path = Path(path)
    points, scanner = _xyz(points, "points"), _xyz(scanner, "scanner")
    if len(scanner) != len(points):
        raise ValueError(f"{path}: {len(points)} points but {len(scanner)} scanner positions")
    header = laspy.LasHeader(version="1.4", point_format=6)
    header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=np.float64, description="scanner position, m")
                           for n in SCANNER_DIMENSIONS])
    header.scales = np.full(3, scale)
    # the lower corner, rounded to the scale: every coordinate a small non-negative integer
    header.offsets = np.floor(points.min(axis=0) / scale) * scale if len(points) else np.zeros(3)
    header.vlrs.append(laspy.vlrs.known.WktCoordinateSystemVlr(wkt))
    header.global_encoding.wkt = True
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    for a, name in enumerate(SCANNER_DIMENSIONS):
        las[name] = scanner[:, a]
    n = len(points)
    las.point_source_id = np.zeros(n, np.uint16) if pose is None else np.asarray(pose).astype(np.uint16)
    las.gps_time = np.zeros(n) if time is None else np.asarray(time, dtype=np.float64)
    if intensity is not None:
        las.intensity = np.round(np.clip(np.asarray(intensity, dtype=np.float64), 0.0, 1.0) * 65535).astype(np.uint16)
    buf = io.BytesIO()
    las.write(buf, do_compress=path.suffix.lower() == ".laz")
    return write_file(path, buf.getvalue())


def write_ply_points(path, points, scanner) -> Path:
    """A binary little-endian PLY point cloud (no faces): x, y, z float64 m; scanner_x, _y, _z float32 m."""
    points, scanner = _xyz(points, "points"), _xyz(scanner, "scanner")
    if len(scanner) != len(points):
        raise ValueError(f"{path}: {len(points)} points but {len(scanner)} scanner positions")
    vertex = np.empty(len(points), dtype=[("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("scanner_x", "<f4"),
                                          ("scanner_y", "<f4"), ("scanner_z", "<f4")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    vertex["scanner_x"], vertex["scanner_y"], vertex["scanner_z"] = scanner.T
    header = ("ply\nformat binary_little_endian 1.0\ncomment snakesim synthetic scan, metres\n"
              f"element vertex {len(points)}\nproperty double x\nproperty double y\nproperty double z\n"
              "property float scanner_x\nproperty float scanner_y\nproperty float scanner_z\nend_header\n")
    return write_file(path, header.encode("ascii") + vertex.tobytes())


def poses_path(scan_path) -> Path:
    """``<scan>.poses.csv`` beside the scan file (its suffix replaced)."""
    p = Path(scan_path)
    return p.with_name(p.stem + ".poses.csv")


def write_poses_csv(path, stops, times) -> Path:
    """``pose,x,y,z,time``: one line per stop, m and s (module docstring)."""
    stops = _xyz(stops, "stops")
    lines = ["pose,x,y,z,time"] + [f"{k},{x:.6f},{y:.6f},{z:.6f},{t:.6f}"
                                   for k, ((x, y, z), t) in enumerate(zip(stops, np.asarray(times, dtype=float)))]
    return write_file(path, "\n".join(lines) + "\n")


def _xyz(a, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{what}: expected an (n, 3) array of m, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{what}: {int((~np.isfinite(a)).any(axis=1).sum())} rows are not finite")
    return a
