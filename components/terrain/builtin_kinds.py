"""snakesim's own terrain kinds: each spec model (spec_models.py) with its Terrain class and factory,
registered in :func:`builtin_terrain_kinds` (components/plugin.py registers them through the same hook
as a plugin's kinds, terrain/kinds.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from snakesim.framework import ConfigError

from . import analytic, dem, mesh, obstacles
from .base import Terrain
from .spec_models import DemSpec, MeshSpec, MoulinSpec, ObstaclesSpec, PlaneSpec, TubeSpec, UChannelSpec, WallsSpec


def _build_plane(spec: PlaneSpec, ctx, **kw) -> Terrain:
    return analytic.PlaneTerrain(spec.origin, spec.tilt, spec.azimuth, **kw)


def _build_tube(spec: TubeSpec, ctx, **kw) -> Terrain:
    modes = spec.roughness.modes() if spec.roughness else None
    return analytic.FourierCylinder(spec.radius, spec.origin, spec.axis, modes=modes, **kw)


def _build_walls(spec: WallsSpec, ctx, **kw) -> Terrain:
    return analytic.ParallelWalls(spec.gap, spec.origin, spec.yaw, spec.tilt, **kw)


def _build_u_channel(spec: UChannelSpec, ctx, **kw) -> Terrain:
    return analytic.UChannel(spec.width, spec.origin, spec.yaw, **kw)


def _build_moulin(spec: MoulinSpec, ctx, **kw) -> Terrain:
    shaft = _moulin_shaft(spec)
    if isinstance(shaft, tuple):                        # a slot: its own exact class
        (a, b), axis, along = shaft
        mz = spec.meander
        meander = None if mz is None else analytic.fourier_modes(
            mz.seed, mz.n_modes, mz.rms, mz.wavelength_min, mz.wavelength_max, 0, 0, mz.hurst)
        return analytic.SlotMoulin(a, b, spec.origin, axis, along, spec.slope, spec.roughness.modes(),
                                   spec.surface, meander, **kw)
    return analytic.Moulin(shaft, spec.surface, **kw)


def _build_mesh(spec: MeshSpec, ctx, **kw) -> Terrain:
    return mesh.mesh_terrain(ctx.base_dir / spec.file, spec.cells, spec.resolution, spec.padding, spec.inside,
                             spec.open_surface, store=ctx.store, sign=spec.sign, exact_band=spec.exact_band, **kw)


def builtin_terrain_kinds() -> tuple:
    """snakesim's own kinds, in the order the schema lists them (components/plugin.py registers them)."""
    from .deformable import deformable_kind
    from .kinds import TerrainKind

    return (TerrainKind("plane", PlaneSpec, analytic.PlaneTerrain, _build_plane),
            TerrainKind("tube", TubeSpec, analytic.FourierCylinder, _build_tube),
            TerrainKind("parallel_walls", WallsSpec, analytic.ParallelWalls, _build_walls),
            TerrainKind("u_channel", UChannelSpec, analytic.UChannel, _build_u_channel),
            TerrainKind("moulin", MoulinSpec, analytic.Moulin, _build_moulin),
            TerrainKind("dem", DemSpec, dem.HeightField,
                        lambda spec, ctx, **kw: _build_dem(spec, ctx.base_dir, ctx.source, kw)),
            TerrainKind("obstacles", ObstaclesSpec, obstacles.ObstacleField,
                        lambda spec, ctx, **kw: _build_obstacles(spec, ctx.source, kw)),
            TerrainKind("mesh", MeshSpec, mesh.SdfGrid, _build_mesh),
            deformable_kind())         # soft soil keeping ruts (terrain/deformable.py, terramechanics)


def _moulin_shaft(spec: MoulinSpec):
    """The shaft: its axis (upward, tilted ``inclination`` away from the ``heading``), round or with the
    cross-section's a axis in the heading's vertical plane (perpendicular to the axis). A slot: the tuple
    ((a, b), axis, a axis) for analytic.SlotMoulin."""
    si, ci, sh, ch = np.sin(spec.inclination), np.cos(spec.inclination), np.sin(spec.heading), np.cos(spec.heading)
    axis = (-si * ch, -si * sh, ci)
    if spec.cross_section is None:
        return analytic.FourierCylinder(spec.radius, spec.origin, axis, spec.slope, modes=spec.roughness.modes())
    x = spec.cross_section
    R = analytic.frame_from_axis(axis)
    along = np.array([ci * ch, ci * sh, si])                     # the a axis, ⟂ the shaft axis
    if x.shape == "slot":
        return x.semi_axes, axis, along
    angle = float(np.arctan2(along @ R[:, 1], along @ R[:, 0]))
    rho0, section, _ = analytic.superellipse_section(x.semi_axes[0], x.semi_axes[1], x.exponent, angle,
                                                     x.max_order, x.tolerance)
    return analytic.FourierCylinder(rho0, spec.origin, axis, spec.slope, modes=spec.roughness.modes(),
                                    section=section)


def _build_obstacles(spec: ObstaclesSpec, source: str, kw) -> Terrain:
    blocks = [obstacles.Block(b.center, b.size, b.yaw, b.roll, b.pitch) for b in spec.boxes]
    rocks = [obstacles.Rock(s.center, s.radius) for s in spec.spheres]
    r = spec.random
    if r is not None:
        clear = None if r.keep_clear is None else (r.keep_clear.center, r.keep_clear.radius)
        try:
            more_blocks, more_rocks = obstacles.scatter_obstacles(
                r.count, r.seed, r.area, r.size, tuple(r.kinds), clear, r.burial, r.min_gap, spec.ground_height,
                occupied=blocks + rocks)
        except ValueError as e:
            raise ConfigError(str(e), source, "random.count") from None
        blocks, rocks = blocks + more_blocks, rocks + more_rocks
    try:
        return obstacles.ObstacleField(spec.ground_height, blocks, rocks, **kw)
    except ValueError as e:
        raise ConfigError(str(e), source) from None


def _build_dem(spec: DemSpec, base_dir: Path, source: str, kw) -> Terrain:
    if spec.fractal is not None:
        f = spec.fractal
        z, meta, where = dem.fractal_heights(f.size, f.hurst, f.rms, f.seed), {}, source
    else:
        path = base_dir / spec.file
        z, meta, where = dem.read_grid(path), dem.sidecar(path), str(path)
    res = spec.resolution if spec.resolution is not None else meta.get("resolution")
    if res is None:
        raise ConfigError("DEM needs 'resolution' (m per sample), in the terrain file or a .meta.yaml sidecar",
                          source, "resolution")
    scale = spec.z_scale if spec.z_scale is not None else meta.get("z_scale", 1.0)
    offset = spec.z_offset if spec.z_offset is not None else meta.get("z_offset", 0.0)
    origin = spec.origin if spec.origin is not None else tuple(meta.get("origin", (0.0, 0.0)))
    if spec.fractal is not None and spec.origin is None:   # centre procedural patches on the origin
        origin = (-0.5 * (z.shape[1] - 1) * res, -0.5 * (z.shape[0] - 1) * res)
    return dem.HeightField(offset + scale * z, res, origin, source=where, **kw)
