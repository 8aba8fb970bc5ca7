"""DEM height fields: z = h(x, y) on a regular grid, solid below.

Grid convention: ``z[i, j]`` is the height at x = x0 + j·res, y = y0 + i·res
(rows are y, the first row at the origin's y; for images the top row of the
picture is at y0). Heights are bilinearly interpolated; outside the grid the
edge values extend flat.

Distance: the vertical gap projected on the local normal,

    d = (z − h(x, y)) / sqrt(1 + h_x² + h_y²),   n = (−h_x, −h_y, 1) / sqrt(1 + h_x² + h_y²),

exact for a plane, first-order for curved terrain (n = ∇d on the surface).

Loaders: .npy, .csv (comma or whitespace separated), 8/16-bit grayscale PNG
(Pillow); a "GeoTIFF-like" grid is any of these plus a sidecar
``<stem>.meta.yaml`` with resolution, origin [x0, y0], z_scale, z_offset
(z = z_offset + z_scale · value). Procedural fractal surfaces come from
:func:`fractal_heights` (spectral synthesis, seeded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from snakesim.framework import ConfigError

from .base import Bounds, Terrain

GRID_SUFFIXES = (".npy", ".csv", ".png")


class HeightField(Terrain):
    kind = "dem"
    regions = ("surface",)

    def __init__(self, z: np.ndarray, resolution: float, origin=(0.0, 0.0), source: str = "<array>", **kw):
        super().__init__(**kw)
        z = np.asarray(z, dtype=np.float64)
        check_grid(z, source)
        big = np.abs(z) > MAX_HEIGHT
        if big.any():
            i, j = np.argwhere(big)[0]
            raise ConfigError(f"DEM height {z[i, j]:g} m at row {i}, column {j} (after z_scale and z_offset) is "
                              f"beyond ±{MAX_HEIGHT:g} m, where distances lose their precision ({int(big.sum())} "
                              f"such value(s)); check the grid's units and z_scale", source, "z_scale")
        if not (resolution > 0 and np.isfinite(resolution)):
            raise ConfigError(f"DEM resolution must be > 0 m and finite, got {resolution}", source, "resolution")
        if not np.all(np.isfinite(np.asarray(origin, dtype=float))):
            raise ConfigError(f"DEM origin must be finite, got {list(origin)}", source, "origin")
        self.z, self.res = np.ascontiguousarray(z), float(resolution)
        self.x0, self.y0 = (float(v) for v in origin)
        gy, gx = np.gradient(self.z, self.res)
        self.max_slope = float(np.sqrt(np.max(gx ** 2 + gy ** 2)))
        self.lipschitz = float(np.sqrt(1 + self.max_slope ** 2))

    def height(self, x, y):
        """h, h_x, h_y at points (x, y) (bilinear; flat extension outside the grid)."""
        ny, nx = self.z.shape
        fx = (np.asarray(x) - self.x0) / self.res
        fy = (np.asarray(y) - self.y0) / self.res
        inx = (fx >= 0) & (fx <= nx - 1)
        iny = (fy >= 0) & (fy <= ny - 1)
        fx, fy = np.clip(fx, 0, nx - 1), np.clip(fy, 0, ny - 1)
        j = np.minimum(fx.astype(np.int64), nx - 2)
        i = np.minimum(fy.astype(np.int64), ny - 2)
        tx, ty = fx - j, fy - i
        z = self.z
        z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
        h = (1 - ty) * ((1 - tx) * z00 + tx * z01) + ty * ((1 - tx) * z10 + tx * z11)
        hx = np.where(inx, ((1 - ty) * (z01 - z00) + ty * (z11 - z10)) / self.res, 0.0)
        hy = np.where(iny, ((1 - tx) * (z10 - z00) + tx * (z11 - z01)) / self.res, 0.0)
        return h, hx, hy

    #: the sensors' mesh is the grid cut into triangles, up to |z00 − z01 − z10 + z11|/4 off the bilinear
    #: surface the contact touches, inside a cell: every hit is refined onto it, on any face (the surface
    #: may rise above the mesh in a cell a ray passes over before its mesh hit): ``refiner``
    refine_hits = True
    refine_every_face = True

    def refiner(self, vertices=None, margin=1.0):
        """The exact ray hits of the bilinear surface (perception/refine_kernels.py: DemRefiner)."""
        from snakesim.components.perception.refine_kernels import DemRefiner

        return DemRefiner(self)

    def display_mesh(self, center, extent, cell, cutaway):
        from .display import _dem

        return _dem(self)

    def contact_parts(self, extent=10.0, segments=64, resolution=0.05):
        from .contact_geometry import height_field_parts

        return height_field_parts(self)

    def height_grid(self, lo, hi):
        # the grid itself, wherever the box is: outside it the edges extend flat, as its own query does
        return self.z, self.res, (self.x0, self.y0)

    def _query(self, p):
        h, hx, hy = self.height(p[:, 0], p[:, 1])
        s = np.sqrt(1.0 + hx * hx + hy * hy)
        n = np.column_stack([-hx / s, -hy / s, 1.0 / s])
        return (p[:, 2] - h) / s, n, np.zeros(len(h), dtype=np.int64)

    def bounds(self):
        ny, nx = self.z.shape
        lo = np.array([self.x0, self.y0, self.z.min()])
        hi = np.array([self.x0 + (nx - 1) * self.res, self.y0 + (ny - 1) * self.res, self.z.max()])
        return Bounds(lo, hi)


#: |height| bound of a DEM, m: beyond it float64 distances and slopes lose millimetre precision
MAX_HEIGHT = 1.0e6


def check_grid(z: np.ndarray, source: str) -> None:
    if z.ndim != 2:
        raise ConfigError(f"DEM grid must be 2-D (rows = y, columns = x), got shape {z.shape}", source)
    if min(z.shape) < 2:
        raise ConfigError(f"DEM grid needs at least 2 x 2 samples, got shape {z.shape}", source)
    bad = ~np.isfinite(z)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ConfigError(f"DEM contains {int(bad.sum())} non-finite value(s) (NaN/inf); first at row {i}, "
                          f"column {j} ({z[i, j]})", source)


def read_grid(path: str | Path) -> np.ndarray:
    """Raw 2-D array from .npy, .csv or grayscale .png (8 or 16 bit)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError("DEM file not found", str(path))
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            z = np.load(path, allow_pickle=False)
        elif suffix == ".csv":
            text = path.read_text()
            z = np.loadtxt(path, delimiter="," if "," in text else None, ndmin=2)
        elif suffix == ".png":
            from PIL import Image
            with Image.open(path) as im:
                if im.mode not in ("L", "I;16", "I;16B", "I;16L", "I"):
                    raise ConfigError(f"PNG DEM must be 8- or 16-bit grayscale, got mode {im.mode}", str(path))
                z = np.array(im)
        else:
            raise ConfigError(f"unsupported DEM format '{suffix}'; use one of {', '.join(GRID_SUFFIXES)}", str(path))
    except ConfigError:
        raise
    except Exception as e:  # unreadable file: say which and why, no deep traceback
        raise ConfigError(f"cannot read DEM: {e}", str(path)) from None
    z = np.asarray(z, dtype=np.float64)
    check_grid(z, str(path))
    return z


def sidecar(path: str | Path) -> dict:
    """Metadata from ``<stem>.meta.yaml`` next to a grid file ({} when absent)."""
    from snakesim.framework.yaml_source import load_yaml, plain
    meta = Path(path).with_suffix(".meta.yaml")
    if not meta.is_file():
        return {}
    data = plain(load_yaml(meta))
    allowed = {"resolution", "origin", "z_scale", "z_offset"}
    extra = set(data) - allowed
    if extra:
        raise ConfigError(f"unknown key(s) {sorted(extra)}; valid: {sorted(allowed)}", str(meta))
    return data


def fractal_heights(n: int, hurst: float, rms: float, seed: int) -> np.ndarray:
    """n x n fractal (fBm) surface by spectral synthesis: |Z(f)| ∝ f^-(H+1), random phases.

    Deterministic for a seed (numpy Generator); zero mean, RMS ``rms`` (m).
    """
    rng = np.random.default_rng(seed)
    f = np.fft.fftfreq(n)
    fr = np.hypot(*np.meshgrid(f, f, indexing="ij"))
    amp = np.zeros_like(fr)
    amp[fr > 0] = fr[fr > 0] ** -(hurst + 1.0)
    coef = amp * (rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n)))
    z = np.fft.ifft2(coef).real
    z -= z.mean()
    std = z.std()
    return z * (rms / std) if std > 0 else z
