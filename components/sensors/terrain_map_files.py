"""``terrain_map_files``: a terrain map saved in a run's folder (``snakesim run --terrain-map --out DIR``).

A sink beside a ``terrain_map`` component (components/sensors/terrain_map.py) that keeps the latest sample
and the path of the map's link, and writes two files into ``directory``::

    terrain_map.npz   the latest sample and the path (format: :data:`FORMAT`)
    terrain_map.png   the elevation, the cost over it (lethal red, costly orange, unknown grey) and the path

The latest sample, not every one: a run's maps are in its ``--ros2-mcap`` file, one OccupancyGrid and one
GridMap per sample (components/ros2/terrain_map_attach.py); the folder keeps what a person opens. Each file
goes through :func:`snakesim.framework.output_files.write_file` (a temporary name moved into place): a
reader never sees half a file. The .npz is rewritten when a new sample has arrived and ``flush_period``
wall seconds have passed since the last write (a killed run keeps its map up to about that long before the
kill, as signals.csv keeps its rows; a write costs ~1 ms at 40 × 40 cells); the picture (~0.15 s to draw)
every ``picture_period`` wall seconds from the run's start, and both at the end of the run (``after_run``),
whatever ended it.

The path is the link's origin at the sink's ticks (its ``rate``, 10 Hz by default: finer than the map's).

in   elevation[n, n] m, slope[n, n] rad, cost[n, n] int8, map_origin[3] m, sample_time[] s (the map's)
     link_poses[nl, 7]  role link_poses, from the multibody
out  none
uses robot: RobotModel (the multibody's): the path's link row
"""

from __future__ import annotations

import dataclasses
import io
import math
import time
from pathlib import Path

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.framework import Component, Input, Params, Uses

NPZ, PNG = "terrain_map.npz", "terrain_map.png"
#: Hz, the path's sample rate when the assembly gives none
DEFAULT_RATE = 10.0

FORMAT = """\
snakesim terrain map (.npz, numpy; no pickled objects): the latest sample of a terrain_map and the path
  elevation   float64 [n, n]  m, world z of the surface per cell, NaN unknown; row r along +y, column c along +x
  slope       float64 [n, n]  rad, NaN unknown
  cost        int8    [n, n]  nav_msgs/OccupancyGrid data: 0 free .. 100 lethal, -1 unknown
  origin      float64 [3]     m, world corner of cell (0, 0): centre of cell (r, c) = origin + resolution·(c + ½, r + ½)
  resolution  float64 []      m, cell edge
  t           float64 []      s, simulated time of the sample (NaN: no sample yet)
  sample_t    float64 [k]     s, the times of every sample seen; sample_origin float64 [k, 3] their origins
  path_t      float64 [m]     s; path float64 [m, 3] m: the link's world position at the sink's ticks
  link        str             the link the map and the path follow
  max_slope   float64 []      rad, max_step float64 [] m: the cost thresholds
  format      str             this text
"""


class TerrainMapFilesParams(Params):
    directory: str = Field(..., description="folder the files go to (the run's --out)")
    link: str | None = Field(None, description="link of the path (default: the URDF's root link): the map's link")
    resolution: float = Field(..., gt=0, description="m, the map's cell edge")
    cells: int = Field(..., ge=1, description="the map's cells along an edge")
    max_slope: float = Field(..., gt=0, description="rad, the map's max_slope (saved with the map)")
    max_step: float = Field(..., gt=0, description="m, the map's max_step (saved with the map)")
    flush_period: float = Field(1.0, gt=0, description="wall s at least between two writes of the .npz")
    picture_period: float = Field(10.0, gt=0, description="wall s at least between two writes of the .png")


@dataclasses.dataclass(eq=False)
class FilesRun:
    """One run's state (``u.cache``): the latest sample, the samples' times and origins, the path."""

    sample: dict | None = None
    sample_t: list = dataclasses.field(default_factory=list)
    sample_origin: list = dataclasses.field(default_factory=list)
    path: list = dataclasses.field(default_factory=list)
    dirty: bool = False
    next_npz: float = 0.0
    next_png: float = 0.0


class TerrainMapFiles(Component[TerrainMapFilesParams]):
    """The latest terrain-map sample and the link's path as terrain_map.npz and terrain_map.png (module
    docstring)."""

    type_name = "terrain_map_files"
    is_sink = True
    robot = Uses(RobotModel)

    elevation = Input(shape=("cells", "cells"), unit="m")
    slope = Input(shape=("cells", "cells"), unit="rad")
    cost = Input(shape=("cells", "cells"), unit="1", dtype=np.int8)
    map_origin = Input(shape=(3,), unit="m")
    sample_time = Input(shape=(), unit="s")
    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)

    def setup(self):
        self.link, self._i = self.robot.mounted_link(self.p.link, self.name)
        if self.rate is None:
            self.rate = DEFAULT_RATE
        self.directory = Path(self.p.directory)

    def make_cache(self, x, u, y):
        return FilesRun()

    def before_run(self, t0, u):
        # the first picture after picture_period: matplotlib's import (~0.5 s) and a render (~0.15 s) stay out
        # of a short run's timed loop; the end of the run draws it anyway
        u.cache.next_png = time.monotonic() + self.p.picture_period

    def _take(self, run: FilesRun, u) -> None:
        """Keep the map's held sample when it is a new one."""
        t = float(u.sample_time)
        if math.isnan(t) or (run.sample_t and t == run.sample_t[-1]):
            return
        run.sample = {"elevation": np.array(u.elevation, dtype=float), "slope": np.array(u.slope, dtype=float),
                      "cost": np.array(u.cost, dtype=np.int8), "origin": np.array(u.map_origin, dtype=float),
                      "t": t}
        run.sample_t.append(t)
        run.sample_origin.append(run.sample["origin"])
        run.dirty = True

    def update(self, t, xd, u):
        run = u.cache
        run.path.append((t, *u.link_poses[self._i, :3]))
        self._take(run, u)
        now = time.monotonic()
        if run.dirty and now >= run.next_npz:
            self.write_npz(run)
            run.next_npz = now + self.p.flush_period
        if run.sample is not None and now >= run.next_png:
            self.write_png(run)
            run.next_png = time.monotonic() + self.p.picture_period

    def after_run(self, u):
        run = u.cache
        self._take(run, u)                 # a sample the last tick's outputs show, when no update saw it
        self.write_npz(run)
        self.write_png(run)

    def report(self, run: FilesRun, summary: dict) -> dict | None:
        """The run summary's line (framework/run_reports.py): the files and the samples they saw."""
        if run is None:
            return None
        files = [str(self.directory / f) for f in (NPZ, PNG) if (self.directory / f).exists()]
        return {"files": files, "samples": len(run.sample_t),
                "last_sample_t": run.sample_t[-1] if run.sample_t else None}

    @staticmethod
    def format_report(report: dict) -> list[str]:
        if not report.get("files"):
            return ["terrain map: no sample reached the files (a run shorter than the map's first tick)"]
        return [f"terrain map: wrote {', '.join(report['files'])} ({report['samples']} samples, the last at "
                f"t = {report['last_sample_t']:g} s)"]

    # -- the files -------------------------------------------------------------------------------------
    def arrays(self, run: FilesRun) -> dict:
        """What terrain_map.npz holds (:data:`FORMAT`)."""
        p = self.p
        s = run.sample
        if s is None:                      # no sample yet: an empty map says so (t NaN)
            s = {"elevation": np.zeros((0, 0)), "slope": np.zeros((0, 0)), "cost": np.zeros((0, 0), np.int8),
                 "origin": np.full(3, np.nan), "t": math.nan}
        path = np.array(run.path, dtype=float).reshape(-1, 4)
        return {**s, "t": np.float64(s["t"]), "resolution": np.float64(p.resolution),
                "sample_t": np.array(run.sample_t, dtype=float),
                "sample_origin": np.array(run.sample_origin, dtype=float).reshape(-1, 3),
                "path_t": path[:, 0], "path": path[:, 1:], "link": np.str_(self.link),
                "max_slope": np.float64(p.max_slope), "max_step": np.float64(p.max_step), "format": np.str_(FORMAT)}

    def write_npz(self, run: FilesRun) -> Path:
        from snakesim.framework.output_files import write_file

        buf = io.BytesIO()
        np.savez_compressed(buf, **self.arrays(run))
        run.dirty = False
        return write_file(self.directory / NPZ, buf.getvalue(), fsync=False)

    def write_png(self, run: FilesRun) -> Path | None:
        from snakesim.framework.output_files import write_file

        if run.sample is None:
            return None
        return write_file(self.directory / PNG, picture(self.arrays(run)), fsync=False)


def picture(a: dict) -> bytes:
    """PNG bytes: the elevation (colour), the cost over it and the path, from :meth:`TerrainMapFiles.arrays`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    h, cost, res, o = a["elevation"], a["cost"], float(a["resolution"]), a["origin"]
    n = h.shape[0]
    box = [o[0], o[0] + n * res, o[1], o[1] + n * res]
    fig = Figure(figsize=(7, 6), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    im = ax.imshow(np.ma.masked_invalid(h), origin="lower", extent=box, cmap="terrain", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="elevation, m")
    # the cost over it: costly cells orange (alpha by cost), lethal red, unknown grey
    overlay = np.zeros((n, n, 4))
    c = cost.astype(float)
    mid = (c > 0) & (c < 100)
    overlay[mid] = [1.0, 0.55, 0.0, 0.0]
    overlay[mid, 3] = 0.15 + 0.45 * c[mid] / 100.0
    overlay[c >= 100] = [0.85, 0.0, 0.0, 0.55]
    overlay[c < 0] = [0.5, 0.5, 0.5, 0.8]
    ax.imshow(overlay, origin="lower", extent=box, interpolation="nearest")
    path = a["path"]
    if len(path):
        ax.plot(path[:, 0], path[:, 1], color="black", lw=1.5, label=f"path of {a['link']}")
        ax.plot(path[-1, 0], path[-1, 1], "o", color="black", ms=5)
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    ax.set_aspect("equal")
    ax.set_title(f"terrain map, t = {float(a['t']):.3g} s, {n}×{n} cells of {res:g} m\n"
                 f"red: lethal, orange: costly, grey: unknown", fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def load_terrain_map(path) -> dict:
    """Read a terrain_map.npz (:data:`FORMAT`) into a dict of arrays (str entries as str)."""
    with np.load(path, allow_pickle=False) as z:
        missing = {"elevation", "cost", "origin", "resolution", "format"} - set(z.files)
        if missing:
            raise ValueError(f"{path}: not a snakesim terrain map (missing {', '.join(sorted(missing))})")
        return {k: (str(z[k]) if z[k].dtype.kind == "U" else z[k]) for k in z.files}
