"""Lidar beam patterns: where each beam starts and points, in the lidar frame (REP-103:
x forward, y left, z up; m).

    grid     a scanning lidar's rows and columns: ``channels`` elevations evenly over
             ``vertical_fov`` [lo, hi] deg, ``horizontal_samples`` azimuths over
             ``horizontal_fov`` deg centred on +x (360: the full turn, no repeated seam);
             beam (ring i, column j) is row-major index i·columns + j (an organised cloud),
             direction (cos e cos a, cos e sin a, sin e), azimuth a decreasing with j
             (left to right seen from above, as a spinning unit sweeps clockwise); the
             column at azimuth a fires at fraction ((π − a) mod 2π)/2π of the period (the sweep
             starts behind, at ±180°, and turns clockwise: a 360° grid's column j at (j + ½)/columns)
    file     user beams: CSV (header line optional; 3 columns dx, dy, dz or 6 columns
             ox, oy, oz, dx, dy, dz) or .npy of shape (n, 3) or (n, 6); directions must be
             unit (|d| within 1e-6 of 1) and finite
    rosette  a Risley-prism solid-state scanner's non-repeating petals (Livox-like):
             deflection (a_y, a_z) = (A/2)·(cos 2πfs + cos 2πgs, sin 2πfs − sin 2πgs),
             s = k/n over one frame, A the half field of view; forward-looking; beam k fires at
             fraction s of the frame

Firing fractions s ∈ [0, 1) place each beam in the sample's period T (.lidar: beam k fires at
t − (1 − s_k)·T, t the sample's stamp); a file gives none (every beam at the stamp).

PRESETS are the head lidars of the EELS designs, turned on with ``preset: NAME``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

UNIT_TOL = 1e-6


@dataclasses.dataclass(frozen=True)
class BeamPattern:
    """origins (n, 3) m and unit directions (n, 3), lidar frame; ring (n,) channel index;
    ``shape`` (rows, columns) when the beams form an organised grid, else None; ``fire`` (n,) the
    fraction of the period at which each beam fires (module docstring), None when unknown."""

    origins: np.ndarray
    directions: np.ndarray
    ring: np.ndarray
    shape: tuple[int, int] | None
    fire: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.directions)


class _Spec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class BeamGrid(_Spec):
    kind: Literal["grid"] = "grid"
    channels: int = Field(..., ge=1, description="rows (elevations)")
    horizontal_samples: int = Field(..., ge=1, description="columns (azimuths) per scan")
    vertical_fov: tuple[float, float] = Field(..., description="deg, [lowest, highest] elevation")
    horizontal_fov: float = Field(360.0, gt=0, le=360, description="deg, centred on +x")

    @field_validator("vertical_fov")
    @classmethod
    def _vfov(cls, v):
        lo, hi = v
        if not (math.isfinite(lo) and math.isfinite(hi) and -90.0 <= lo <= hi <= 90.0):
            raise ValueError(f"vertical_fov = {list(v)} must be [lo, hi] deg with -90 <= lo <= hi <= 90")
        return v

    def beams(self) -> BeamPattern:
        lo, hi = np.radians(self.vertical_fov)
        el = np.full(1, 0.5 * (lo + hi)) if self.channels == 1 else np.linspace(hi, lo, self.channels)
        h, fov = self.horizontal_samples, math.radians(self.horizontal_fov)
        if self.horizontal_fov == 360.0 or h == 1:
            az = fov / 2 - (np.arange(h) + 0.5) * fov / h
        else:
            az = np.linspace(fov / 2, -fov / 2, h)
        E, A = np.meshgrid(el, az, indexing="ij")
        d = np.stack([np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E)], axis=-1).reshape(-1, 3)
        ring = np.repeat(np.arange(self.channels), h)
        fire = np.tile(np.mod(np.pi - az, 2 * np.pi) / (2 * np.pi), self.channels)
        return BeamPattern(np.zeros_like(d), d, ring, (self.channels, h), fire)


class BeamRosette(_Spec):
    kind: Literal["rosette"] = "rosette"
    points: int = Field(..., ge=1, description="beams per frame")
    fov: float = Field(..., gt=0, lt=180, description="deg, full circular field of view")
    petal_frequencies: tuple[float, float] = Field((97.0, 89.0), description="the two prisms' turns per frame")

    def beams(self) -> BeamPattern:
        s = np.arange(self.points) / self.points
        f, g = (2 * np.pi * np.asarray(self.petal_frequencies))[:, None] * s
        a = math.radians(self.fov) / 2
        ay = 0.5 * a * (np.cos(f) + np.cos(g))
        az = 0.5 * a * (np.sin(f) - np.sin(g))
        d = np.stack([np.ones_like(ay), np.tan(ay), np.tan(az)], axis=1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return BeamPattern(np.zeros_like(d), d, np.zeros(len(d), dtype=np.int64), None, s)


class BeamFile(_Spec):
    kind: Literal["file"] = "file"
    path: str = Field(..., description="CSV or .npy of directions (n, 3) or origins and directions (n, 6)")

    def beams(self) -> BeamPattern:
        return beams_from_file(self.path)


BeamSpec = BeamGrid | BeamRosette | BeamFile

#: the head lidars of the EELS designs: beams and range limits (m)
PRESETS: dict[str, dict] = {
    # EELS 1.0/1.5 head: a spinning 32-channel unit, wide vertical field for tubes and moulins
    "spinning-32": {"beams": BeamGrid(channels=32, horizontal_samples=1024, vertical_fov=(-45.0, 45.0)),
                    "min_range": 0.3, "max_range": 35.0},
    # the benchmark's and long-range variant: 64 channels
    "spinning-64": {"beams": BeamGrid(channels=64, horizontal_samples=1024, vertical_fov=(-22.5, 22.5)),
                    "min_range": 0.3, "max_range": 100.0},
    # forward-looking solid-state unit (Risley prisms), 70° circular field, 10 000 points per frame
    "solid-state-rosette": {"beams": BeamRosette(points=10000, fov=70.0), "min_range": 0.5, "max_range": 90.0},
}


def beams_from_file(path) -> BeamPattern:
    """Load user beams (see the module docstring); a ValueError names the file, row and value."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"beam pattern file '{p}' not found (a CSV or .npy of directions (n, 3) or "
                         "origins and directions (n, 6))")
    try:
        if p.suffix == ".npy":
            a = np.load(p, allow_pickle=False)
        else:
            text = p.read_text().splitlines()
            skip = 1 if text and not _numeric(text[0]) else 0
            a = np.loadtxt(p, delimiter=",", skiprows=skip, ndmin=2)
    except ValueError as e:
        raise ValueError(f"beam pattern file '{p}': not a table of numbers ({e})") from None
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] not in (3, 6) or len(a) == 0:
        raise ValueError(f"beam pattern file '{p}': shape {a.shape}; expected (n, 3) directions or (n, 6) "
                         "origins and directions, n >= 1")
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if bad.size:
        raise ValueError(f"beam pattern file '{p}': row {bad[0]} = {a[bad[0]].tolist()} is not finite")
    o, d = (np.zeros((len(a), 3)), a) if a.shape[1] == 3 else (a[:, :3], a[:, 3:])
    norm = np.linalg.norm(d, axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > UNIT_TOL)
    if bad.size:
        i = bad[0]
        raise ValueError(f"beam pattern file '{p}': direction of row {i} = {d[i].tolist()} has length {norm[i]:.9g}; "
                         f"directions must be unit (within {UNIT_TOL:g}); {bad.size} row(s) are not")
    return BeamPattern(o.copy(), d.copy(), np.zeros(len(a), dtype=np.int64), None)


def _numeric(line: str) -> bool:
    try:
        [float(v) for v in line.split(",")]
        return True
    except ValueError:
        return False
