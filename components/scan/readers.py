"""Scan files read as they are: points (or a mesh) in the file's own units and frame.

    .ply          points, or a mesh when it has a face element (trimesh's PLY parser, ASCII or binary)
    .pcd          points (Open3D)
    .xyz          text, one point a row: x y z [nx ny nz] ('#' starts a comment)
    .las / .laz   points (laspy; .laz through the lazrs codec)
    .stl / .obj   meshes (trimesh)

Scanner positions (where each point was seen from, the file's frame and units) are read when the file
has them: the per-point properties ``scanner_x, scanner_y, scanner_z`` (PLY vertex properties, LAS
extra bytes), what ``snakesim terrain scan`` writes. A LAS file may instead carry one row per scan
position in a CSV (``x,y,z`` rows) indexed by each point's ``point_source_id``: :func:`scanner_csv`.

A LAS file's linear unit comes from its coordinate system: the WKT VLR's ``UNIT[...]`` /
``LENGTHUNIT[...]`` entries, or the GeoTIFF keys ProjLinearUnitsGeoKey (3076) and VerticalUnitsGeoKey
(4099) with EPSG unit codes 9001 metre, 9002 foot, 9003 US survey foot. Other formats carry no unit.
Nothing here scales or rotates: frames.py does (units, up axis, offset).
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np

from .errors import ScanError

POINT_SUFFIXES = (".ply", ".pcd", ".xyz", ".las", ".laz")
MESH_SUFFIXES = (".ply", ".stl", ".obj")
KNOWN_SUFFIXES = (".ply", ".pcd", ".xyz", ".las", ".laz", ".stl", ".obj")
SCANNER_FIELDS = ("scanner_x", "scanner_y", "scanner_z")

#: metres per unit of each EPSG linear unit code a GeoKey may name
EPSG_UNITS = {9001: ("metre", 1.0), 9002: ("foot", 0.3048), 9003: ("US survey foot", 1200.0 / 3937.0)}
_ANGULAR = ("degree", "radian", "grad", "arc")


@dataclasses.dataclass(frozen=True)
class RawScan:
    """A scan file's content in its own units and frame.

    points (n, 3); normals (n, 3) or None (a file's own normals: an orientation hint); scanner (n, 3) or
    None (per-point scanner position); faces (m, 3) int or None (a mesh); header_offset (3,) or None
    (a LAS header's offset); unit (name, metres per unit) or None when the file does not say;
    source_id (n,) int or None (LAS point_source_id).
    """

    path: Path
    points: np.ndarray
    normals: np.ndarray | None = None
    scanner: np.ndarray | None = None
    faces: np.ndarray | None = None
    header_offset: np.ndarray | None = None
    unit: tuple[str, float] | None = None
    source_id: np.ndarray | None = None

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None


def read_raw(path) -> RawScan:
    """The file at ``path`` by its suffix; a :class:`ScanError` naming the file for a missing, unknown,
    unreadable, empty or non-finite one."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in KNOWN_SUFFIXES:
        raise ScanError(path, f"unknown scan format '{path.suffix or '(no suffix)'}'; known: "
                              f"{', '.join(KNOWN_SUFFIXES)} (points: {', '.join(POINT_SUFFIXES)}; "
                              f"meshes: {', '.join(MESH_SUFFIXES)})")
    if not path.is_file():
        raise ScanError(path, "no such file")
    reader = _READERS[suffix]
    try:
        raw = reader(path)
    except ScanError:
        raise
    except Exception as e:   # noqa: BLE001 -- every parser's own exception: the file is corrupt
        raise ScanError(path, f"cannot read this {suffix} file (corrupt or not a {suffix} file): "
                              f"{type(e).__name__}: {e}") from None
    _check_points(raw)
    return raw


def _check_points(raw: RawScan) -> None:
    n = len(raw.points)
    if n == 0:
        raise ScanError(raw.path, "the file holds no points (an empty cloud): nothing to import")
    bad = ~np.isfinite(raw.points).all(axis=1)
    if bad.any():
        first = int(np.argmax(bad))
        verb = "has" if bad.sum() == 1 else "have"
        raise ScanError(raw.path, f"{int(bad.sum())} of {n} points {verb} NaN or infinite coordinates (the first "
                                  f"is point {first}: {raw.points[first].tolist()}); remove them from the file")
    if raw.scanner is not None and not np.isfinite(raw.scanner).all():
        first = int(np.argmax(~np.isfinite(raw.scanner).all(axis=1)))
        raise ScanError(raw.path, f"scanner positions ({', '.join(SCANNER_FIELDS)}) are not finite, first at "
                                  f"point {first}")
    if raw.faces is not None:
        if len(raw.faces) == 0:
            raise ScanError(raw.path, "the mesh holds no triangles")
        if raw.faces.min() < 0 or raw.faces.max() >= n:
            raise ScanError(raw.path, f"faces index vertices outside 0..{n - 1}")


# -- formats -------------------------------------------------------------------

def _read_ply(path: Path) -> RawScan:
    from trimesh.exchange.ply import load_ply

    with open(path, "rb") as f:
        kw = load_ply(f)
    elements = kw.get("metadata", {}).get("_ply_raw", {})
    vertex = elements.get("vertex")
    if vertex is None or not vertex.get("length"):
        return RawScan(path, np.zeros((0, 3)))
    data = vertex["data"]
    names = data.dtype.names or ()
    points = np.column_stack([np.asarray(data[a], dtype=np.float64) for a in "xyz"])
    normals = np.column_stack([np.asarray(data[a], dtype=np.float64) for a in ("nx", "ny", "nz")]) \
        if {"nx", "ny", "nz"} <= set(names) else None
    scanner = np.column_stack([np.asarray(data[a], dtype=np.float64) for a in SCANNER_FIELDS]) \
        if set(SCANNER_FIELDS) <= set(names) else None
    faces = kw.get("faces")
    faces = None if faces is None or len(faces) == 0 else np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    return RawScan(path, points, normals, scanner, faces)


def _read_pcd(path: Path) -> RawScan:
    declared = _pcd_declared_points(path)
    from .open3d_loader import import_open3d

    o3d = import_open3d()
    cloud = o3d.io.read_point_cloud(str(path), format="pcd", remove_nan_points=False,
                                    remove_infinite_points=False)
    points = np.asarray(cloud.points, dtype=np.float64)
    if len(points) == 0 and declared:
        # Open3D logs a warning and returns an empty cloud for a file it cannot parse
        raise ScanError(path, f"cannot read this .pcd file: its header declares {declared} points but none "
                              "could be parsed (corrupt or truncated)")
    normals = np.asarray(cloud.normals, dtype=np.float64) if cloud.has_normals() else None
    return RawScan(path, points, normals)


def _pcd_declared_points(path: Path) -> int:
    """POINTS of a PCD header; a ScanError if there is no PCD header (not a .pcd file)."""
    with open(path, "rb") as f:
        head = f.read(4096).decode("latin-1")
    m = re.search(r"^POINTS\s+(\d+)", head, re.MULTILINE)
    if m is None or not re.search(r"^DATA\s+\w+", head, re.MULTILINE):
        raise ScanError(path, "cannot read this .pcd file: no PCD header (POINTS and DATA lines) in its "
                              "first 4 kB")
    return int(m.group(1))


def _read_xyz(path: Path) -> RawScan:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # numpy warns on an empty file; we report it ourselves
        table = np.loadtxt(path, comments="#", ndmin=2, dtype=np.float64)
    if table.size == 0:
        return RawScan(path, np.zeros((0, 3)))
    if table.shape[1] not in (3, 6):
        raise ScanError(path, f"an .xyz row is 'x y z' or 'x y z nx ny nz', this file has {table.shape[1]} "
                              "columns")
    return RawScan(path, table[:, :3].copy(), table[:, 3:6].copy() if table.shape[1] == 6 else None)


def _read_las(path: Path) -> RawScan:
    import laspy

    las = laspy.read(path)
    points = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]).astype(np.float64)
    extra = set(las.point_format.extra_dimension_names)
    scanner = np.column_stack([np.asarray(las[a], dtype=np.float64) for a in SCANNER_FIELDS]) \
        if set(SCANNER_FIELDS) <= extra else None
    return RawScan(path, points, None, scanner, None, np.asarray(las.header.offsets, dtype=np.float64),
                   las_unit(las.header.vlrs, path), np.asarray(las.point_source_id, dtype=np.int64))


def _read_trimesh(path: Path) -> RawScan:
    import trimesh

    # process=True merges an STL's repeated corners, so edges are shared and winding can be checked
    mesh = trimesh.load(path, force="mesh", process=True)
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ScanError(path, f"cannot read this {path.suffix} file: no triangles could be parsed (empty, "
                              f"corrupt or not a {path.suffix} mesh)")
    return RawScan(path, np.asarray(mesh.vertices, dtype=np.float64), None, None,
                   np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3))


_READERS = {".ply": _read_ply, ".pcd": _read_pcd, ".xyz": _read_xyz, ".las": _read_las, ".laz": _read_las,
            ".stl": _read_trimesh, ".obj": _read_trimesh}


# -- LAS units -----------------------------------------------------------------

def las_unit(vlrs, path) -> tuple[str, float] | None:
    """(name, metres per unit) of a LAS file's coordinate system, None when it names no linear unit; a
    ScanError when horizontal and vertical units differ."""
    found: dict[float, str] = {}
    for vlr in vlrs:
        kind = type(vlr).__name__
        if kind == "WktCoordinateSystemVlr":
            for name, factor in re.findall(r'(?:LENGTH)?UNIT\s*\[\s*"([^"]+)"\s*,\s*([0-9.eE+-]+)', vlr.string):
                if not any(a in name.lower() for a in _ANGULAR):
                    found.setdefault(round(float(factor), 9), name)
        elif kind == "GeoKeyDirectoryVlr":
            for key in vlr.geo_keys:
                if key.id in (3076, 4099) and key.tiff_tag_location == 0 and key.value_offset in EPSG_UNITS:
                    name, factor = EPSG_UNITS[key.value_offset]
                    found.setdefault(round(factor, 9), name)
    if not found:
        return None
    if len(found) > 1:
        raise ScanError(path, f"the coordinate system names several linear units ({', '.join(found.values())}); "
                              "give the one to use with --units")
    factor, name = next(iter(found.items()))
    return name, factor


def scanner_csv(path, raw: RawScan) -> np.ndarray:
    """Per-point scanner positions from a CSV of ``x,y,z`` rows (a header row is skipped): one row for
    every point, or row i for the LAS points whose point_source_id is i."""
    path = Path(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rows = np.genfromtxt(path, delimiter=",", dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as e:
        raise ScanError(path, f"cannot read scanner positions: {e}") from None
    rows = rows[np.isfinite(rows).all(axis=1)] if rows.size else rows   # a header row reads as NaN
    if rows.ndim != 2 or rows.shape[0] == 0 or rows.shape[1] != 3:
        raise ScanError(path, "scanner positions are rows 'x,y,z' (file units and frame), one per scan position")
    if len(rows) == 1:
        return np.repeat(rows, len(raw.points), axis=0)
    if raw.source_id is None:
        raise ScanError(path, f"{len(rows)} scanner positions but {raw.path.name} has no point_source_id to "
                              "say which point was seen from which (only LAS files do); give one row")
    sid = raw.source_id
    if sid.min() < 0 or sid.max() >= len(rows):
        raise ScanError(path, f"point_source_id of {raw.path.name} runs {sid.min()}..{sid.max()} but there are "
                              f"{len(rows)} scanner positions (row i is point_source_id i)")
    return rows[sid]
