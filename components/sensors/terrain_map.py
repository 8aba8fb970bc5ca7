"""Maps from the terrain itself: an elevation map and an obstacle cost map around a robot link, and a
signed-distance volume export (ground truth for mapping, issue 26).

Grid. A square of ``cells`` × ``cells`` cells, ``cells = round(extent / resolution)``, axis-aligned in the
world (x: columns, y: rows, as nav_msgs/OccupancyGrid's data), around the link's origin o (param ``link``,
default the URDF's root). The corner of cell (row 0, col 0) is snapped to the resolution, so cells keep
their place in the world from one sample to the next::

    x0 = resolution · round((o_x − extent/2) / resolution)       (y0 likewise)
    centre of cell (r, c) = (x0 + (c + ½) res, y0 + (r + ½) res)

Elevation. Per cell, the first surface below z_top = o_z + ``height`` along −z, found by sphere tracing on
the terrain's signed distance φ (Terrain.query), all cells at once::

    z ← z − φ(x, y, z) / L          L = terrain.lipschitz (|∇φ| ≤ L: the step never crosses the surface)
    hit when φ ≤ ``tolerance``      elevation = z at the hit

The step is safe, so the reported height lies above the surface by at most tolerance·L/cos(slope)
(a plane tilted by θ: 0 ≤ z − h ≤ tolerance / cos θ). Unknown (NaN) where
- the start point is inside the solid (an overhang or wall higher than ``height`` above the link),
- no surface is found above z_bottom = o_z − ``depth``,
- the trace has not converged in ``max_iterations`` steps (a ray grazing a vertical wall).

Cost (nav_msgs/OccupancyGrid semantics: int8, 0 free … 100 lethal, −1 unknown), per known cell::

    gradient  ∂h/∂x, ∂h/∂y by central differences (one-sided where a neighbour is unknown or off the map)
    slope     s = atan |∇h|                                  rad
    step      the largest |h_n − h| over the 8 neighbours n known
    cost      100 if step ≥ ``max_step``, else rint(100 · min(s / max_slope, 1))
    −1        where the elevation is unknown

Sampled at ``rate`` (Hz; 1 Hz when the assembly gives none), as the lidar samples: the outputs are computed
at the component's ticks (t = 0, 1/rate, ...) from the link's pose at that tick, and the plan holds them in
between, so a reader ticking with the map sees each sample at the tick it is taken (stamped
``sample_time``). The elevation and slope ports declare NaN a value (``may_be_nan``), so they may be
recorded.

in   terrain              Terrain (the terrain component)
     link_poses[nl, 7]    role link_poses, from the multibody
out  elevation[cells, cells]    m, world z of the surface, NaN unknown; row r = y, column c = x
     slope[cells, cells]        rad, NaN unknown
     cost[cells, cells]         int8, OccupancyGrid data (row-major: data[r · cells + c])
     map_origin[3]              m, world corner of cell (0, 0): OccupancyGrid info.origin position
     sample_time[]              s, simulated time of the sample (the stamp a publisher gives it:
                                components/ros2/terrain_map_attach.py)
     (feedthrough from both inputs: a sample is the terrain under the link's pose of its tick)
uses robot: RobotModel (the multibody's): the link row

:func:`export_sdf_volume` writes the terrain's signed distance on a regular 3-D grid as ``.npz``
(format: :data:`SDF_VOLUME_FORMAT`), a reference for scoring TSDF/ESDF mappers (voxblox, nvblox);
:func:`load_sdf_volume` reads it back; ``snakesim terrain sdf`` is its command (components/terrain/cli.py).
``snakesim run --terrain-map`` adds the map to any robot scene (components/sensors/terrain_map_cli.py): on ROS 2 with
``--ros2`` (components/ros2/terrain_map_attach.py), saved with ``--out`` (.terrain_map_files).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.components.terrain.base import Bounds, Terrain
from snakesim.framework import Component, Input, Output, Params, Uses

#: Hz, the sample rate when the assembly gives none
DEFAULT_RATE = 1.0
#: the most cells a map may have (1000 × 1000): each sample queries every cell per trace step
MAX_CELLS = 1_000_000
#: the most grid points an SDF volume may have (float64: 400 MB)
MAX_VOXELS = 50_000_000
#: points per terrain query when exporting a volume
_CHUNK = 1 << 18


class TerrainMapParams(Params):
    link: str | None = Field(None, description="link the map is centred on (default: the URDF's root link)")
    resolution: float = Field(0.1, gt=0, description="m, cell edge")
    extent: float = Field(4.0, gt=0, description="m, edge of the square map (cells = round(extent / resolution))")
    height: float = Field(1.0, ge=0, description="m, the search starts this far above the link's origin")
    depth: float = Field(2.0, gt=0, description="m, no surface found this far below the link's origin: unknown")
    tolerance: float = Field(1e-4, gt=0, description="m, a trace stops where the signed distance is below this")
    max_iterations: int = Field(200, ge=1, description="sphere-tracing steps per sample; not converged: unknown")
    max_slope: float = Field(0.5, gt=0, lt=math.pi / 2,
                             description="rad, slope of cost 100 (cost = 100·slope/max_slope)")
    max_step: float = Field(0.1, gt=0, description="m, a height jump to a neighbouring cell of this or more: cost 100")

    @model_validator(mode="after")
    def _size(self):
        n = cells_of(self.extent, self.resolution)
        if n < 1:
            raise ValueError(f"extent = {self.extent} m is less than half a cell of resolution = "
                             f"{self.resolution} m: the map has no cell")
        if n * n > MAX_CELLS:
            raise ValueError(f"extent / resolution = {self.extent} / {self.resolution} gives {n} × {n} cells, "
                             f"more than {MAX_CELLS}: raise resolution or lower extent")
        return self


def cells_of(extent: float, resolution: float) -> int:
    """Cells along one edge of a map of ``extent`` m at ``resolution`` m."""
    r = extent / resolution
    return int(round(r)) if math.isfinite(r) and r < 1e12 else 2 ** 62


def map_corner(center_xy, extent: float, resolution: float) -> np.ndarray:
    """World (x, y) of the corner of cell (0, 0), snapped to the resolution (module docstring)."""
    c = np.asarray(center_xy, dtype=float)
    return resolution * np.round((c - 0.5 * extent) / resolution)


def trace_down(terrain: Terrain, xy: np.ndarray, z_top: float, z_bottom: float, tolerance: float,
               max_iterations: int) -> np.ndarray:
    """Height (m) of the first surface below ``z_top`` at each (x, y) of ``xy`` (n, 2), by sphere tracing
    along −z (module docstring); NaN where the start is inside the solid, nothing is found above
    ``z_bottom`` or the trace has not converged."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    n = len(xy)
    out = np.full(n, np.nan)
    L = float(terrain.lipschitz)
    if not (np.isfinite(L) and L > 0):
        raise ValueError(f"{terrain!r}: lipschitz = {L}, needs a finite positive number to trace")
    idx = np.arange(n)
    z = np.full(n, float(z_top))
    pts = np.empty((n, 3))
    pts[:, :2] = xy
    for it in range(max_iterations):
        if not idx.size:
            break
        pts[idx, 2] = z
        d = terrain.distance(pts[idx])
        keep = np.isfinite(d)
        if it == 0:
            keep &= d >= -tolerance                     # inside the solid at the start: covered, unknown
        hit = keep & (d <= tolerance)
        out[idx[hit]] = z[hit]
        keep &= ~hit
        z = z - np.where(keep, d, 0.0) / L
        keep &= z >= z_bottom
        idx, z = idx[keep], z[keep]
    return out


def _neighbour(h: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """h shifted so that entry (r, c) holds h[r + dr, c + dc]; NaN off the map."""
    out = np.full_like(h, np.nan)
    R, C = h.shape
    rs, re = max(0, -dr), min(R, R - dr)
    cs, ce = max(0, -dc), min(C, C - dc)
    if rs < re and cs < ce:
        out[rs:re, cs:ce] = h[rs + dr:re + dr, cs + dc:ce + dc]
    return out


def _gradient(h: np.ndarray, resolution: float, axis: int) -> np.ndarray:
    """∂h along ``axis`` (0: rows = y, 1: columns = x): central, else one-sided, else 0; NaN where h is."""
    plus = _neighbour(h, *((1, 0) if axis == 0 else (0, 1)))
    minus = _neighbour(h, *((-1, 0) if axis == 0 else (0, -1)))
    central = (plus - minus) / (2.0 * resolution)
    forward = (plus - h) / resolution
    backward = (h - minus) / resolution
    g = np.where(np.isfinite(central), central, np.where(np.isfinite(forward), forward, backward))
    return np.where(np.isfinite(h), np.nan_to_num(g, nan=0.0), np.nan)


def slope_of(h: np.ndarray, resolution: float) -> np.ndarray:
    """Slope atan |∇h| (rad) of an elevation grid (rows y, columns x), NaN where h is unknown."""
    with np.errstate(invalid="ignore"):
        return np.arctan(np.hypot(_gradient(h, resolution, 1), _gradient(h, resolution, 0)))


def step_of(h: np.ndarray) -> np.ndarray:
    """Largest |h_n − h| over the known 8-neighbours n (0 where none is known), NaN where h is unknown."""
    step = np.zeros_like(h)
    with np.errstate(invalid="ignore"):
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if dr or dc:
                    step = np.fmax(step, np.abs(_neighbour(h, dr, dc) - h))
    return np.where(np.isfinite(h), step, np.nan)


def cost_of(h: np.ndarray, resolution: float, max_slope: float, max_step: float,
            slope: np.ndarray | None = None) -> np.ndarray:
    """OccupancyGrid costs (int8: 0..100, −1 unknown) of an elevation grid (module docstring)."""
    s = slope_of(h, resolution) if slope is None else slope
    known = np.isfinite(h)
    with np.errstate(invalid="ignore"):
        c = np.rint(100.0 * np.minimum(np.nan_to_num(s, nan=0.0) / max_slope, 1.0))
        c = np.where(step_of(h) >= max_step, 100.0, c)
    return np.where(known, c, -1.0).astype(np.int8)


class TerrainMap(Component[TerrainMapParams]):
    """Elevation map (sphere-traced along −z) and OccupancyGrid cost map (slope, step) of the terrain around a
    link, sampled at a rate; see the module docstring."""

    type_name = "terrain_map"
    robot = Uses(RobotModel)

    terrain = Input(type=Terrain)
    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    elevation = Output(shape=lambda c: c.grid_shape, unit="m", feedthrough=True, may_be_nan=True,
                       doc="world z of the surface per cell, NaN unknown; rows y, columns x")
    slope = Output(shape=lambda c: c.grid_shape, unit="rad", feedthrough=True, may_be_nan=True,
                   doc="local slope, NaN unknown")
    cost = Output(shape=lambda c: c.grid_shape, unit="1", dtype=np.int8, feedthrough=True,
                  doc="OccupancyGrid data: 0 free .. 100 lethal, -1 unknown")
    map_origin = Output(shape=(3,), unit="m", feedthrough=True, names=("x", "y", "z"),
                        doc="world corner of cell (0, 0) (z = 0): OccupancyGrid info.origin")
    sample_time = Output(shape=(), unit="s", feedthrough=True, doc="simulated time of the sample")

    @property
    def grid_shape(self) -> tuple[int, int]:
        n = cells_of(self.p.extent, self.p.resolution)
        return (n, n)

    def setup(self):
        p = self.p
        self.link, self._i = self.robot.mounted_link(p.link, self.name)
        if self.rate is None:
            self.rate = DEFAULT_RATE
        n = self.grid_shape[0]
        centres = (np.arange(n) + 0.5) * p.resolution
        cx, cy = np.meshgrid(centres, centres)             # [row, col]: row = y, col = x
        self._offsets = np.column_stack([cx.ravel(), cy.ravel()])

    def discrete_state(self):
        return np.zeros(1)                                 # sample counter

    def sample(self, terrain: Terrain, center) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(elevation, slope, cost, origin) of the map around the world point ``center`` (3,)."""
        p = self.p
        o = np.asarray(center, dtype=float)
        corner = map_corner(o[:2], p.extent, p.resolution)
        h = trace_down(terrain, corner + self._offsets, o[2] + p.height, o[2] - p.depth, p.tolerance,
                       p.max_iterations).reshape(self.grid_shape)
        s = slope_of(h, p.resolution)
        c = cost_of(h, p.resolution, p.max_slope, p.max_step, slope=s)
        return h, s, c, np.array([corner[0], corner[1], 0.0])

    def output(self, t, x, u, y):
        # run at the component's ticks only (its rate); the plan holds the buffers in between
        y.elevation[:], y.slope[:], y.cost[:], y.map_origin[:] = self.sample(u.terrain, u.link_poses[self._i, :3])
        y.sample_time[...] = t

    def update(self, t, xd, u):
        xd[0] += 1.0


# -- the signed-distance volume ---------------------------------------------------------------------------

SDF_VOLUME_FORMAT = """\
snakesim signed-distance volume (.npz, numpy; no pickled objects)
  distance    float64 [nx, ny, nz]  m, the terrain's signed distance (Terrain.query): > 0 in free space,
                                    < 0 inside the solid; distance[i, j, k] is at origin + resolution·(i, j, k)
  origin      float64 [3]           m, world position of grid point (0, 0, 0) (a point, not a voxel corner)
  resolution  float64 []            m, spacing of the grid points on every axis
  terrain     str                   the terrain's name
  format      str                   this text
Exact for the analytic kinds (plane, walls, obstacles); first-order (|∇| ≤ lipschitz) for height fields
and rough surfaces, as Terrain.query documents. For TSDF/ESDF scoring (voxblox, nvblox): sample a
mapper's voxel centres by trilinear interpolation here, or query the terrain directly.
"""


def _bounds_arrays(bounds) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(bounds, Bounds):
        lo, hi = bounds.lo, bounds.hi
    else:
        lo, hi = bounds
    lo, hi = np.asarray(lo, dtype=float).ravel(), np.asarray(hi, dtype=float).ravel()
    if lo.shape != (3,) or hi.shape != (3,) or not (np.isfinite(lo).all() and np.isfinite(hi).all()) \
            or (hi < lo).any():
        raise ValueError(f"bounds = ({lo.tolist()}, {hi.tolist()}): need two finite 3-vectors (lo, hi), lo <= hi")
    return lo, hi


def sdf_grid(bounds, resolution: float) -> tuple[np.ndarray, tuple[int, int, int]]:
    """(origin, shape) of the grid points lo + resolution·(i, j, k) inside ``bounds`` (lo, hi)."""
    if not (isinstance(resolution, (int, float, np.floating, np.integer)) and np.isfinite(resolution)
            and resolution > 0):
        raise ValueError(f"resolution = {resolution!r} m: needs a finite number > 0")
    lo, hi = _bounds_arrays(bounds)
    counts = np.floor((hi - lo) / float(resolution) + 1e-9) + 1
    total = float(np.prod(counts))
    if total > MAX_VOXELS:
        raise ValueError(f"bounds {lo.tolist()} .. {hi.tolist()} m at resolution = {resolution} m give "
                         f"{' × '.join(str(int(c)) for c in counts)} points, more than {MAX_VOXELS}: "
                         f"raise resolution or shrink bounds")
    return lo, tuple(int(c) for c in counts)


def sdf_volume(terrain: Terrain, bounds, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """(distance [nx, ny, nz], origin [3]): the terrain's signed distance at the grid points."""
    origin, shape = sdf_grid(bounds, resolution)
    axes = [origin[a] + float(resolution) * np.arange(shape[a]) for a in range(3)]
    total = shape[0] * shape[1] * shape[2]
    dist = np.empty(total)
    for s in range(0, total, _CHUNK):
        flat = np.arange(s, min(s + _CHUNK, total))
        i, j, k = np.unravel_index(flat, shape)
        dist[s:s + len(flat)] = terrain.distance(np.column_stack([axes[0][i], axes[1][j], axes[2][k]]))
    return dist.reshape(shape), origin


def export_sdf_volume(terrain: Terrain, bounds, resolution: float, path) -> str:
    """Write the terrain's signed distance on the grid (``bounds`` = (lo, hi) m or a Bounds, ``resolution``
    m) to ``path`` (.npz, format :data:`SDF_VOLUME_FORMAT`), whole or not at all (framework/output_files.py:
    an OutputError names the file and the cause); returns the path written."""
    import io

    from snakesim.framework.output_files import write_file

    dist, origin = sdf_volume(terrain, bounds, resolution)
    buf = io.BytesIO()                       # a file object: numpy appends no second ".npz"
    np.savez_compressed(buf, distance=dist, origin=origin, resolution=np.float64(resolution),
                        terrain=np.str_(terrain.name), format=np.str_(SDF_VOLUME_FORMAT))
    write_file(path, buf.getvalue())
    return str(path)


def load_sdf_volume(path) -> dict:
    """Read a volume written by :func:`export_sdf_volume`: distance, origin, resolution, terrain, format."""
    with np.load(path, allow_pickle=False) as z:
        missing = {"distance", "origin", "resolution", "format"} - set(z.files)
        if missing:
            raise ValueError(f"{path}: not a snakesim SDF volume (missing {', '.join(sorted(missing))})")
        return {"distance": z["distance"], "origin": z["origin"], "resolution": float(z["resolution"]),
                "terrain": str(z["terrain"]) if "terrain" in z.files else "", "format": str(z["format"])}
