"""``snakesim run --terrain-map [LINK]``: a ``terrain_map`` (components/sensors/terrain_map.py) on any robot scene.

``--terrain-map [LINK]`` adds ``terrain_map`` on LINK (default: the root link), wired to the robot's link poses
and to the scene's terrain (the first output of type Terrain), with its grid's size and cost thresholds
from these options (each needs ``--terrain-map``; the component's other params keep their defaults)::

    --terrain-map-resolution M   cell edge (default 0.1 m)
    --terrain-map-extent M       edge of the square map (default 4 m; at most 1000 cells a side)
    --terrain-map-rate HZ        samples a second (default 1)
    --terrain-map-max-slope RAD  the slope of cost 100 (default 0.5 rad, below pi/2)
    --terrain-map-max-step M     a height jump to a neighbour that is lethal (default 0.1 m)

With ``--out DIR`` it adds a ``terrain_map_files`` sink too (components/sensors/terrain_map_files.py:
DIR/terrain_map.npz and DIR/terrain_map.png); ``--ros2`` publishes the maps on /terrain_map/costmap and
/terrain_map/elevation and ``--ros2-mcap`` records them (components/ros2/terrain_map_attach.py). Values out
of range are click's usage errors; a grid too large, an option without ``--terrain-map``, a scene without a
robot or terrain are errors naming the option before anything is built; a link the robot lacks is the build's
error listing the robot's links.
"""

from __future__ import annotations

import click

from .cli import ROOT, robot_with_link_ports


MAP_OPTION = "--terrain-map"
MAP_NAME = "terrain_map"
MAP_FILES = "terrain_map_files"
#: the --terrain-map-* options (click parameter names) -> the terrain_map param each sets
MAP_PARAMS = {"terrain_map_resolution": "resolution", "terrain_map_extent": "extent",
              "terrain_map_max_slope": "max_slope", "terrain_map_max_step": "max_step"}
MAP_RATE = "terrain_map_rate"


def _terrain_source(resolved, registry) -> str:
    """``comp.port`` of the scene's first output of type Terrain."""
    from snakesim.components.terrain.base import Terrain
    from snakesim.framework.errors import ConfigError

    for comp, _spec, cls in registry.classes_in(resolved):
        for port, out in cls.outputs.items():
            kind = getattr(out.signal, "cls", None) if out.structured else None
            if isinstance(kind, type) and issubclass(kind, Terrain):
                return f"{comp}.{port}"
    raise ConfigError("the terrain map needs a terrain: no component of the scene outputs one", MAP_OPTION)


def attach_terrain_map(resolved, link: str | None = None, params: dict | None = None, rate: float | None = None,
                       out_dir=None, registry=None) -> str:
    """Add the ``terrain_map`` component on ``link`` (None or '': the robot's root), with ``params``
    (checked here: an error names the option) at ``rate`` Hz (None: its default), wired to the robot's link
    poses and the scene's terrain; with ``out_dir`` a ``terrain_map_files`` sink writing there. Its name."""
    from pydantic import ValidationError

    from snakesim.framework.assembly import ComponentSpec
    from snakesim.framework.errors import ConfigError
    from snakesim.framework.registry import default_registry

    from .terrain_map import DEFAULT_RATE, TerrainMapParams, cells_of

    registry = registry or default_registry()
    if MAP_NAME in resolved.components:
        raise ConfigError(f"the scene already has a component named '{MAP_NAME}'", MAP_OPTION)
    robot, poses, _vels = robot_with_link_ports(resolved, registry, MAP_OPTION)
    terrain = _terrain_source(resolved, registry)
    prm = {**({"link": link} if link else {}), **(params or {})}
    try:
        checked = TerrainMapParams(**prm)
    except ValidationError as e:
        opts = {v: "--" + k.replace("_", "-") for k, v in MAP_PARAMS.items()}
        size = "--terrain-map-extent / --terrain-map-resolution"          # the grid's size: both options
        why = "; ".join(f"{opts.get(str(err['loc'][0]), err['loc'][0]) if err['loc'] else size}: "
                        f"{err['msg'].removeprefix('Value error, ')}" for err in e.errors())
        raise ConfigError(why, MAP_OPTION) from None
    resolved.components[MAP_NAME] = ComponentSpec(type="terrain_map", rate=rate or DEFAULT_RATE, params=prm,
                                                  uses={"robot": robot})
    resolved.connections.append((terrain, f"{MAP_NAME}.terrain", MAP_OPTION))
    resolved.connections.append((f"{robot}.{poses}", f"{MAP_NAME}.link_poses", MAP_OPTION))
    resolved.where[MAP_NAME] = MAP_OPTION
    if out_dir:
        from snakesim.framework.rates import nearest_period

        from .terrain_map_files import DEFAULT_RATE as PATH_RATE

        # the path at 10 Hz (or the map's rate, if faster), rounded to whole base steps
        dt = resolved.sim.dt
        files_rate = 1.0 / (nearest_period(max(PATH_RATE, rate or DEFAULT_RATE), dt) * dt)
        files = {"directory": str(out_dir), "resolution": checked.resolution,
                 "cells": cells_of(checked.extent, checked.resolution), "max_slope": checked.max_slope,
                 "max_step": checked.max_step, **({"link": link} if link else {})}
        resolved.components[MAP_FILES] = ComponentSpec(type=MAP_FILES, rate=files_rate, params=files,
                                                       uses={"robot": robot})
        resolved.connections.extend((f"{MAP_NAME}.{port}", f"{MAP_FILES}.{port}", MAP_OPTION) for port in
                                    ("elevation", "slope", "cost", "map_origin", "sample_time"))
        resolved.connections.append((f"{robot}.{poses}", f"{MAP_FILES}.link_poses", MAP_OPTION))
        resolved.where[MAP_FILES] = MAP_OPTION
    return MAP_NAME


def _command_params() -> dict:
    ctx = click.get_current_context(silent=True)
    return ctx.params if ctx is not None else {}


def _terrain_map(resolved, value):
    if value is None:
        return
    given = _command_params()
    params = {key: given[opt] for opt, key in MAP_PARAMS.items() if given.get(opt) is not None}
    attach_terrain_map(resolved, value or None, params, rate=given.get(MAP_RATE), out_dir=given.get("out_dir"))


def _needs_terrain_map(resolved, value):
    """Read by --terrain-map's own apply; alone, an error."""
    if value is not None and _command_params().get("terrain_map") is None:
        from snakesim.framework.errors import ConfigError

        given = [f"--{k.replace('_', '-')}" for k in (*MAP_PARAMS, MAP_RATE) if _command_params().get(k) is not None]
        raise ConfigError(f"{', '.join(given) or 'this option'} set the terrain map's grid: add --terrain-map [LINK]",
                          MAP_OPTION)


_terrain_map.for_check = _needs_terrain_map.for_check = True


def terrain_map_options():
    positive = click.FloatRange(min=0, min_open=True)
    return [
        (click.Option([MAP_OPTION], is_flag=False, flag_value=ROOT, default=None, metavar="[LINK]",
                      help="Add a terrain map around LINK (default: the robot's root link): elevation, slope and an "
                           "OccupancyGrid cost from the terrain itself; with --out DIR terrain_map.npz and .png; on "
                           "/terrain_map/costmap and /terrain_map/elevation with --ros2 / --ros2-mcap"), _terrain_map),
        (click.Option(["--terrain-map-resolution"], type=positive, default=None, metavar="M",
                      help="--terrain-map: cell edge, m (default 0.1)"), _needs_terrain_map),
        (click.Option(["--terrain-map-extent"], type=positive, default=None, metavar="M",
                      help="--terrain-map: edge of the square map, m (default 4; at most 1000 cells a side)"),
         _needs_terrain_map),
        (click.Option(["--terrain-map-rate"], type=positive, default=None, metavar="HZ",
                      help="--terrain-map: samples a second (default 1)"), _needs_terrain_map),
        (click.Option(["--terrain-map-max-slope"], type=click.FloatRange(min=0, max=1.5707963267948966, min_open=True,
                                                                         max_open=True), default=None, metavar="RAD",
                      help="--terrain-map: slope of cost 100, rad (default 0.5)"), _needs_terrain_map),
        (click.Option(["--terrain-map-max-step"], type=positive, default=None, metavar="M",
                      help="--terrain-map: a height jump to a neighbouring cell that is lethal, m (default 0.1)"),
         _needs_terrain_map),
    ]
