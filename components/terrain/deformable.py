"""Deformable height field (kind ``deformable``): a soft soil (snow, regolith) laid on a base (a plane or
a DEM) that keeps the ruts a robot leaves.

    kind: deformable
    base_height: 0.0          # m, the virgin surface: a horizontal plane at this height (the default, 0), or
    base: fractal-dem         #   a height-field terrain (a name, a file relative to this one, or an inline
                              #   mapping) of kind dem or plane: the virgin surface follows it
    origin: [-10, -10]        # m, the patch's corner (x, y); nodes every ``cell`` m
    size: [20, 20]            # m, the patch (outside it: the base, rigid)
    cell: 0.02                # m, node spacing
    max_tiles: 2048           # tiles of 32 × 32 nodes that may be touched in a run (memory cap)
    initial_state: null       # a run's soil_state.npz (relative to this file): start on its ruts
    bulldozing: null          # {erosion_angle: 35, flow_factor: 1, erosion_iterations: 5}: berms (bulldozing.py)
    soil: {k_c: 4.37e3, k_phi: 196.72e3, n: 1.6, cohesion: 1.03e3, friction_angle: 19.7,
           janosi_k: 0.025, elastic_k: 5.0e5, damping: 0.0, density: 300}    # or {include: soils/snow-us.yaml}

Model: Bekker–Wong pressure–sinkage, Mohr–Coulomb shear strength and Janosi–Hanamoto shear (the
terramechanics contact, components/terramechanics/, reads ``soil``); the nodes' plastic sinkage, yield
memory and heaped soil (deformable_kernels.py: the law and its elastic unloading as in Chrono's SCM) live in
``terrain.state`` and change in place when the contact commits a step (``state.changed``), so the
surface every consumer queries (contact, viewer, lidar) is the rutted one. Storage is sparse: a node
table of tiles, a tile allocated from a pool of ``max_tiles`` on its first load, so a 20 × 20 m patch at
2 cm costs memory where the robot went (a tile is 32 × 32 nodes × 3 arrays × 8 B = 24 KiB; the pool is
allocated with calloc, so untouched tiles are not even resident).

Base: any terrain whose kind gives a height field (``Terrain.height_grid``: dem, plane) is read at the
nodes (bilinearly; a DEM finer than ``cell`` is smoothed to the nodes, one whose samples fall on nodes is
reproduced exactly). The soil law then acts along the base's normal, as SCM's grid over a height map
(deformable_kernels.py).

Query: the unloaded surface base + lift − s_p, bilinear between nodes; distance and normal first-order as a
DEM's (d = (z − h)/√(1 + |∇h|²)). Units SI, world frame, z up.

Bulldozing (``bulldozing:``, off by default: the rut's volume is compacted, as SCM without its option): the
soil a step presses out is heaped on the contact patch's rim and eroded to the angle of repose
(bulldozing.py); berms stand above the base (lift > plastic).

Not modelled here: soil sliding down a slope of itself (the base's slopes are not eroded).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from typing import Literal

from .base import Bounds, Terrain, TerrainMesh, TerrainState
from .bulldozing import BulldozingSpec
from .deformable_kernels import TILE, empty_used, query_surface
from .spec_models import KindSpec, open_quadrant_deg


class SoilSpec(BaseModel):
    """Bekker–Wong, Mohr–Coulomb and Janosi–Hanamoto parameters of one soil (Wong, Theory of Ground
    Vehicles, ch. 2), plus SCM's elastic unloading stiffness and vertical damping, and its bulk density."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    k_c: float = Field(description="N/m^(n+1), cohesive modulus of deformation")
    k_phi: float = Field(description="N/m^(n+2), frictional modulus of deformation")
    n: float = Field(description="exponent of deformation, > 0")
    cohesion: float = Field(ge=0, description="Pa, Mohr–Coulomb cohesion c")
    friction_angle: float = Field(description="deg, Mohr–Coulomb internal friction angle φ, in (0, 90)")
    janosi_k: float = Field(gt=0, description="m, Janosi–Hanamoto shear deformation modulus K")
    elastic_k: float = Field(gt=0, description="Pa/m, elastic unloading/reloading stiffness per area (SCM)")
    damping: float = Field(0.0, ge=0, description="Pa·s/m, vertical damping per area (SCM's damping_R)")
    density: float | None = Field(None, gt=0, description="kg/m³, bulk density: the soil's weight in the rut walls' "
                                                           "passive pressure (soil_body_contact's rut_walls)")

    @field_validator("n")
    @classmethod
    def _n(cls, v):
        if not v > 0:
            raise ValueError(f"n = {v}: the Bekker exponent must be > 0 (typically 0.5 to 1.8)")
        return v

    @field_validator("friction_angle")
    @classmethod
    def _phi(cls, v):
        return open_quadrant_deg(v, "friction_angle", " (the soil's internal friction, Mohr–Coulomb)")


class DeformableSpec(KindSpec):
    kind: Literal["deformable"]
    base_height: float | None = Field(None, description="m, the virgin surface, a horizontal plane (default 0)")
    base: str | dict | None = Field(None, description="the virgin surface, a height-field terrain (kind dem or "
                                                      "plane): a terrain name, a file relative to this one, or an "
                                                      "inline mapping; instead of base_height")
    origin: tuple[float, float] = Field((-10.0, -10.0), description="m, the patch's corner")
    size: tuple[float, float] = Field((20.0, 20.0), description="m, the patch's sides (x, y)")
    cell: float = Field(0.02, gt=0, description="m, node spacing")
    max_tiles: int = Field(2048, ge=1, description="tiles of 32 × 32 nodes a run may touch")
    soil: SoilSpec
    bulldozing: BulldozingSpec | None = Field(None, description="heap the rut's soil on its rim and erode it to the "
                                                                "angle of repose (terrain/bulldozing.py); none: the "
                                                                "rut's volume is compacted")
    initial_state: str | None = Field(None, description="soil_state.npz of an earlier run (terramechanics_contact's "
                                                        "--out file; relative to the terrain file): start on its ruts")

    @model_validator(mode="after")
    def _stiffness_positive(self):
        # k_c / b + k_phi > 0 for every patch side b from one cell to the patch: k_c + k_phi·b is linear in
        # b, so its ends decide
        s = self.soil
        for b in (self.cell, max(self.size)):
            if not s.k_c + s.k_phi * b > 0:
                raise ValueError(f"soil: k_c + k_phi·b = {s.k_c + s.k_phi * b:g} N/m^(n+1) at b = {b:g} m is not "
                                 f"positive (k_c = {s.k_c:g}, k_phi = {s.k_phi:g}): the soil would not carry a "
                                 f"load; give k_c + k_phi·b > 0 for b from cell to the patch size")
        if not (self.size[0] > self.cell and self.size[1] > self.cell):
            raise ValueError(f"size = {list(self.size)} m: each side must exceed cell = {self.cell} m")
        if self.base is not None and self.base_height is not None:
            raise ValueError(f"give base_height (a horizontal plane) or base (a height-field terrain), not both: "
                             f"base_height = {self.base_height}, base = {self.base!r}")
        return self


class DeformableTerrain(Terrain):
    """The deformable height field (module docstring). ``grid`` [x0, y0, cell, base, nx, ny, dem x0, y0,
    spacing, slope bound], ``base_z`` (the base's heights; 1 × 1 on a horizontal plane) and ``soil`` [k_c,
    k_phi, n, c, tan φ, K, K_e, R] are the float64 records the kernels read; ``source`` the file."""

    kind = "deformable"
    regions = ("surface",)
    refine_hits = True
    #: |∇d| bound: ruts steeper than about 70° are not expected (a rut's wall is at most the soil's
    #: slope between two nodes); the broad phase subtracts lipschitz × radius
    lipschitz = 3.0

    def __init__(self, base_height: float, origin, size, cell: float, soil: SoilSpec, max_tiles: int = 2048,
                 source: str = "<deformable terrain>", base_grid=None, bulldozing: BulldozingSpec | None = None,
                 **kw):
        """``base_grid``: (z, spacing, (x0, y0)) of a height-field base (Terrain.height_grid), or None: the
        plane z = ``base_height``; ``bulldozing``: the rut's soil heaped on its rim (bulldozing.py), or None."""
        nx = int(math.floor(size[0] / cell)) + 1
        ny = int(math.floor(size[1] / cell)) + 1
        ntx, nty = -(-nx // TILE), -(-ny // TILE)
        state = TerrainState(tile_of=np.full((ntx, nty), -1, dtype=np.int64),
                             plastic=np.zeros((max_tiles, TILE, TILE)),
                             yield_p=np.zeros((max_tiles, TILE, TILE)),
                             lift=np.zeros((max_tiles, TILE, TILE)),
                             used=empty_used(max_tiles))
        super().__init__(state=state, **kw)
        if base_grid is None:
            self.base_z = np.zeros((1, 1))
            dem = (0.0, 0.0, 0.0, 0.0)          # spacing 0: the plane
            self.base_range = (float(base_height), float(base_height))
        else:
            z, res, (bx, by) = base_grid
            self.base_z = np.ascontiguousarray(z, dtype=np.float64)
            dx, dy = np.abs(np.diff(self.base_z, axis=1)), np.abs(np.diff(self.base_z, axis=0))
            slope = math.hypot(float(dx.max(initial=0.0)), float(dy.max(initial=0.0))) / res
            dem = (float(bx), float(by), float(res), slope)
            self.base_range = (float(self.base_z.min()), float(self.base_z.max()))
            self.lipschitz = max(self.lipschitz, math.sqrt(1.0 + slope * slope))
        self.grid = np.array([origin[0], origin[1], cell, base_height, nx, ny, *dem], dtype=np.float64)
        self.cell, self.base_height, self.source = float(cell), float(base_height), source
        self._virgin = np.full_like(state.tile_of, -1)       # a tile table with nothing touched: the base
        self.soil_spec = soil
        self.bulldozing = bulldozing
        self.soil = np.array([soil.k_c, soil.k_phi, soil.n, soil.cohesion, math.tan(math.radians(soil.friction_angle)),
                              soil.janosi_k, soil.elastic_k, soil.damping], dtype=np.float64)
        self.max_tiles = int(max_tiles)

    # -- state ----------------------------------------------------------------
    def tiles_used(self) -> int:
        return int(self.state.used[0])

    def snapshot(self) -> dict[str, np.ndarray]:
        """Copies of the state arrays (only the used tiles of the pool): what a run saves."""
        k = self.tiles_used()
        st = self.state
        return {"tile_of": st.tile_of.copy(), "plastic": st.plastic[:k].copy(), "yield_p": st.yield_p[:k].copy(),
                "lift": st.lift[:k].copy(), "used": st.used.copy()}

    def restore(self, snap: dict[str, np.ndarray], t: float | None = None) -> None:
        """Put a :meth:`snapshot` back, in place (bound buffers see it), and bump the version."""
        st = self.state
        k = int(snap["used"][0])
        if snap["tile_of"].shape != st.tile_of.shape or k > self.max_tiles:
            raise ValueError(f"{self.source}: snapshot of another grid (tiles {snap['tile_of'].shape}, {k} used) "
                             f"than this terrain's (tiles {st.tile_of.shape}, max_tiles {self.max_tiles})")
        st.tile_of[...] = snap["tile_of"]
        st.plastic[:k] = snap["plastic"]
        st.plastic[k:] = 0.0
        st.yield_p[:k] = snap["yield_p"]
        st.yield_p[k:] = 0.0
        st.lift[:k] = snap["lift"]
        st.lift[k:] = 0.0
        st.used[...] = snap["used"]
        st.changed(t)

    def surface_height(self, x, y, virgin: bool = False) -> np.ndarray:
        """Height (m) of the unloaded surface at points (x, y) (broadcast); ``virgin``: of the base as the
        nodes read it, before any rut."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        p = np.zeros((x.size, 3))
        p[:, 0], p[:, 1] = x.ravel(), y.ravel()
        d, n = np.empty(x.size), np.empty((x.size, 3))
        st = self.state
        query_surface(self.grid, self.base_z, self._virgin if virgin else st.tile_of, st.plastic, st.lift, p, d, n)
        return (-d / n[:, 2]).reshape(x.shape)        # d = (0 − h)/√(1 + |∇h|²), n_z = 1/√(…)

    def rut_depth(self, x, y) -> np.ndarray:
        """Depth (m, vertical) of the unloaded surface below the base at points (x, y): base − h (the rut's
        plastic sinkage; negative on a berm bulldozing heaped)."""
        return self.surface_height(x, y, virgin=True) - self.surface_height(x, y)

    # -- the Terrain interface ---------------------------------------------------
    def _query(self, p):
        d = np.empty(p.shape[0])
        n = np.empty((p.shape[0], 3))
        st = self.state
        query_surface(self.grid, self.base_z, st.tile_of, st.plastic, st.lift, p, d, n)
        return d, n, np.zeros(p.shape[0], dtype=np.int64)

    def bounds(self) -> Bounds:
        # the base extends beyond the patch (rigid there): unbounded in x, y; ruts at most 1 m deep, berms (with
        # bulldozing) at most 1 m high
        lo, hi = self.base_range
        top = hi + (1.0 if self.bulldozing is not None else 0.0)
        return Bounds(np.array([-np.inf, -np.inf, lo - 1.0]), np.array([np.inf, np.inf, top]))

    def display_mesh(self, center, extent, cell, cutaway) -> TerrainMesh:
        """The surface as it is now (ruts drawn) on a grid of max(cell, terrain cell) over ``extent`` m
        around ``center``, at most 512 nodes a side."""
        from .display import _quads

        c = np.asarray(center, dtype=float)
        step = max(float(cell), self.cell, 2.0 * extent / 511)
        k = max(2, int(math.ceil(2 * extent / step)) + 1)
        xs = c[0] - extent + step * np.arange(k)
        ys = c[1] - extent + step * np.arange(k)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        P = np.stack([X, Y, self.surface_height(X, Y)], axis=-1)
        depth = np.clip((self.surface_height(X, Y, virgin=True) - P[..., 2]) / 0.1, 0.0, 1.0)
        dc = 0.25 * (depth[:-1, :-1] + depth[1:, :-1] + depth[:-1, 1:] + depth[1:, 1:])
        high, low = np.array([240.0, 248.0, 255.0]), np.array([150.0, 170.0, 200.0])
        tones = (high + dc[..., None] * (low - high)).astype(np.uint8)      # ruts darker
        return _quads(P, tones=tones)

    def sensor_cell(self, extent: float, cell: float) -> float:
        return max(cell, self.cell)


def build_deformable(spec: DeformableSpec, context, **kw) -> DeformableTerrain:
    base_grid = None if spec.base is None else _base_grid(spec, context)
    terrain = DeformableTerrain(spec.base_height or 0.0, spec.origin, spec.size, spec.cell, spec.soil,
                                spec.max_tiles, source=str(context.source), base_grid=base_grid,
                                bulldozing=spec.bulldozing, **kw)
    if spec.initial_state is not None:
        import zipfile
        from pathlib import Path

        from snakesim.framework import ConfigError

        from .deformable_files import load_state

        path = Path(context.base_dir) / spec.initial_state      # an absolute path stays as it is
        if not path.is_file():
            raise ConfigError(f"initial_state: no file {path} (a soil_state.npz an earlier run's --out wrote)",
                              str(context.source), "initial_state")
        try:
            load_state(terrain, path)
        except (ValueError, KeyError, OSError, zipfile.BadZipFile) as e:
            raise ConfigError(f"initial_state: {e}", str(context.source), "initial_state") from None
    return terrain


def _base_grid(spec: DeformableSpec, context):
    """The height grid of ``spec.base`` (a terrain name, a file relative to the terrain file, or an inline
    mapping), over the patch; a ConfigError naming ``base`` when it is not a height field."""
    from pathlib import Path

    from snakesim.framework import ConfigError

    from .spec import build_terrain, load_terrain

    ref = spec.base
    try:
        if isinstance(ref, dict):
            base = build_terrain(ref, Path(context.base_dir), f"{context.source} (base)", store=context.store)
        else:
            local = Path(context.base_dir) / Path(ref).expanduser()
            base = load_terrain(str(local) if local.is_file() else ref, store=context.store)
    except ConfigError as e:
        raise ConfigError(f"base: {e}", str(context.source), "base") from None
    lo = (spec.origin[0], spec.origin[1])
    hi = (spec.origin[0] + spec.size[0], spec.origin[1] + spec.size[1])
    grid = base.height_grid(lo, hi)
    if grid is None:
        raise ConfigError(f"base = {ref if isinstance(ref, str) else 'the inline terrain'} is a terrain of kind "
                          f"'{base.kind}', not a height field: a soil is laid on a kind whose surface is z = h(x, y) "
                          f"(dem, or a plane less steep than 80°)", str(context.source), "base")
    return grid


def deformable_kind():
    from .kinds import TerrainKind

    return TerrainKind("deformable", DeformableSpec, DeformableTerrain, build_deformable)
