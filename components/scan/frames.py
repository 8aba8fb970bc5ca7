"""From a file's frame to the terrain's: units, up axis and a georeferenced offset.

    p_terrain = R_up · s · (p_file − offset)          (m; offset in file units, s metres per file unit)

``offset`` is subtracted in the file's own units and frame, in float64, before anything else: survey
coordinates (UTM eastings ~5e5 m) would otherwise leave float32 steps of 3–6 cm in the mesh and the
ray-casting. The default, for coordinates beyond 10 km of the origin, is a LAS header's
offset rounded to a whole file unit (the writer's own choice of origin), else the points' rounded minimum
corner; a scan in a local frame (a synthetic one, a site grid) keeps its coordinates. ``R_up`` is a
proper rotation taking the file's up axis to +z (snakesim's gravity is −z): ``+y`` (the usual mesh-export
convention) maps (x, y, z) → (x, −z, y). Scanner positions go through the same map.

Units: m, mm, cm, ft (international foot, 0.3048 m), us-ft (US survey foot, 1200/3937 m). A LAS file
whose coordinate system names a non-metre unit is refused unless ``units`` is given (a silent factor
of 3.28 would place the robot in a shaft three times too large).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .errors import ScanError
from .readers import RawScan

#: file units from the origin beyond which coordinates are georeferenced (survey eastings, northings) and an
#: offset is subtracted by default: 10 km, where float32 still resolves 1 mm
GEOREFERENCED = 1.0e4

UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "ft": 0.3048, "us-ft": 1200.0 / 3937.0}

#: rows of R_up for each up axis: R_up @ up = +z, det = +1
UP_AXES = {
    "+z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-z": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),
    "+y": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "-y": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    "+x": ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    "-x": ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
}


@dataclasses.dataclass(frozen=True)
class Scan:
    """A scan in the terrain frame (m, z up): points (n, 3), scanner (n, 3) or None, normals (n, 3) or
    None (the file's own, rotated), faces (m, 3) or None; and how it got there (for the report and the
    provenance): units, metres per file unit, up axis, offset (file units), notes (what was assumed)."""

    path: object
    points: np.ndarray
    scanner: np.ndarray | None
    normals: np.ndarray | None
    faces: np.ndarray | None
    units: str
    scale: float
    up: str
    offset: np.ndarray
    notes: tuple[str, ...] = ()

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None


def resolve_units(raw: RawScan, units: str | None) -> tuple[str, float, str]:
    """(name, metres per file unit, note): ``units`` when given, else the LAS file's own unit when it is
    metres, else metres for formats that carry no unit; a ScanError for a LAS file in another unit."""
    if units is not None:
        if units not in UNITS:
            raise ScanError(raw.path, f"units = '{units}': valid units are {', '.join(UNITS)}")
        note = f"units {units} (given)"
        if raw.unit is not None and abs(raw.unit[1] - UNITS[units]) > 1e-9:
            note += f", overriding the file's {raw.unit[0]}"
        return units, UNITS[units], note
    if raw.unit is None:
        return "m", 1.0, "units m (assumed: the file names none; use --units otherwise)"
    name, factor = raw.unit
    if abs(factor - 1.0) > 1e-9:
        raise ScanError(raw.path, f"the file's coordinate system is in {name} ({factor:.10g} m), not metres; "
                                  f"give its unit with --units ({', '.join(UNITS)}), e.g. "
                                  f"--units {'us-ft' if 'survey' in name.lower() else 'ft'}")
    return "m", 1.0, f"units m (from the file's coordinate system: {name})"


def resolve_offset(raw: RawScan, offset) -> tuple[np.ndarray, str]:
    """(offset in file units, note): ``offset`` when given (3 numbers, or 'none'); else, for georeferenced
    coordinates (beyond GEOREFERENCED file units of the origin), the LAS header's offset rounded to whole
    units (the points' rounded minimum corner when the header's is zero or not there); else none, so a
    scan in a local frame keeps it."""
    if isinstance(offset, str):
        if offset.strip().lower() != "none":
            raise ScanError(raw.path, f"offset = '{offset}': give X,Y,Z (file units) or 'none'")
        return np.zeros(3), "offset none (given)"
    if offset is not None:
        off = np.asarray(offset, dtype=np.float64).reshape(-1)
        if off.shape != (3,) or not np.isfinite(off).all():
            raise ScanError(raw.path, f"offset = {list(off)}: give three finite numbers X,Y,Z (file units)")
        return off, f"offset {off.tolist()} (given)"
    if np.abs(raw.points).max() <= GEOREFERENCED:
        return np.zeros(3), "offset none (local coordinates; --offset X,Y,Z to shift them)"
    if raw.header_offset is not None and np.any(np.round(raw.header_offset) != 0):
        off, whose = np.round(raw.header_offset), "the LAS header's, rounded"
    else:
        off, whose = np.round(raw.points.min(axis=0)), "the points' minimum corner, rounded"
    return off, f"offset {off.tolist()} ({whose}: georeferenced coordinates; --offset none keeps them)"


def to_terrain_frame(raw: RawScan, units: str | None = None, up: str = "+z", offset=None,
                     scanner: np.ndarray | None = None) -> Scan:
    """``raw`` in metres, z up, offset removed (module docstring); ``scanner`` (file frame) overrides the
    file's own scanner positions."""
    if up not in UP_AXES:
        raise ScanError(raw.path, f"up = '{up}': valid up axes are {', '.join(UP_AXES)}")
    name, scale, unit_note = resolve_units(raw, units)
    off, offset_note = resolve_offset(raw, offset)
    rot = np.asarray(UP_AXES[up], dtype=np.float64)

    def place(p):
        return None if p is None else ((p - off) * scale) @ rot.T

    normals = None if raw.normals is None else raw.normals @ rot.T
    scanner = raw.scanner if scanner is None else scanner
    return Scan(raw.path, place(raw.points), place(scanner), normals, raw.faces, name, scale, up, off,
                (unit_note, offset_note, f"up {up}"))
