"""The terrain map on ROS 2 and in the MCAP recording (``--ros2``, ``--ros2-mcap``).

``ros2_terrain_map`` is a sink that publishes a ``terrain_map`` component's held sample
(components/sensors/terrain_map.py) once per sample, as the mapping stacks do (:mod:`.map_messages`)::

    /terrain_map/costmap     nav_msgs/OccupancyGrid: the ``cost`` port as data, info.origin = map_origin
    /terrain_map/elevation   grid_map_msgs/GridMap: layers ``elevation`` (m) and ``slope`` (rad), as
                             elevation_mapping publishes (Foxglove and RViz's grid_map plugin render it)

frame_id ``world_frame`` (the publisher's, ``world``); stamps (header and map_load_time) the sample's
simulated time (the map's ``sample_time``): the sink ticks with the map (its rate, the same base steps) and
publishes when its inputs hold a sample it has not sent, the one taken at that tick; the run's last tick
runs no update, so its sample goes out in ``after_run``. QoS: reliable, transient local, keep last 1
(:data:`MAP_QOS`, as nav2's map_server latches /map): a node that subscribes late gets the latest map. The
DDS participant opens before the run's first step. ``ros2_terrain_map_mcap`` writes the same bytes into the run's
MCAP file (shared with ``ros2_mcap``: :class:`.mcap_recorder.McapFile`), logged at the sample's time, each
channel with that QoS in its offered_qos_profiles.

:func:`attach_terrain_map` adds (once) the sink for the scene's first ``terrain_map`` component (found by
class, wired by port name: the map's ports are the sink's inputs) at that component's rate;
:func:`attach_terrain_map_mcap` mirrors it into a ``--ros2-mcap`` file. A scene without a terrain map gets
neither.

in   cost[n, n] int8, elevation[n, n] m, slope[n, n] rad, map_origin[3] m, sample_time[] s
out  none
"""

from __future__ import annotations

import dataclasses
import math
import weakref

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input

from .mcap_recorder import McapMirrorParams, open_mirror
from .transport import BridgeRun, ClosedAfterRun, DdsEndpoint, TopicQos

MAP_BRIDGE = "ros2_terrain_map"
MAP_MCAP = "ros2_terrain_map_mcap"
COSTMAP_TOPIC, ELEVATION_TOPIC = "/terrain_map/costmap", "/terrain_map/elevation"
#: latched maps: reliable, transient local, keep last 1 (nav2 map_server's /map)
MAP_QOS = TopicQos(depth=1, transient_local=True)
#: the map's ports the sink reads (same names)
PORTS = ("cost", "elevation", "slope", "map_origin", "sample_time")


class Ros2TerrainMapParams(DdsEndpoint):
    world_frame: str = Field("world", description="frame_id of both maps (the map is axis-aligned in the world)")
    resolution: float = Field(..., gt=0, description="m, the map's cell edge (info.resolution)")
    cells: int = Field(..., ge=1, description="the map's cells along an edge (info.width, info.height)")
    costmap_topic: str = Field(COSTMAP_TOPIC, description="topic of the OccupancyGrid ('' : off)")
    elevation_topic: str = Field(ELEVATION_TOPIC, description="topic of the GridMap ('' : off)")


class Ros2TerrainMap(ClosedAfterRun, Component[Ros2TerrainMapParams]):
    type_name = MAP_BRIDGE
    is_sink = True

    cost = Input(shape=("cells", "cells"), unit="1", dtype=np.int8)
    elevation = Input(shape=("cells", "cells"), unit="m")
    slope = Input(shape=("cells", "cells"), unit="rad")
    map_origin = Input(shape=(3,), unit="m")
    sample_time = Input(shape=(), unit="s")

    def make_cache(self, x, u, y):
        return MapRun()

    def _topics(self) -> list[tuple[str, str]]:
        """(topic, ROS type) of the maps published."""
        from .map_messages import GRID_MAP, OCCUPANCY_GRID

        return [(t, ty) for t, ty in ((self.p.costmap_topic, OCCUPANCY_GRID), (self.p.elevation_topic, GRID_MAP)) if t]

    def _open(self, run: "MapRun") -> None:
        from .map_messages import GRID_MAP, grid_map_type, occupancy_grid_type
        from .template import RawWriter
        from .transport import Ros2Participant

        run.dds = Ros2Participant(self.p.domain_id, self.p.interface)
        types = {GRID_MAP: grid_map_type()}
        run.writers = {topic: RawWriter(run.dds.writer(topic, types.get(ty) or occupancy_grid_type(), MAP_QOS))
                       for topic, ty in self._topics()}
        self.p.announce(run.dds, "snakesim_terrain_map")
        run.finalizer = weakref.finalize(run, run.dds.close)

    def update(self, t, xd, u):
        run = u.cache
        ts = float(u.sample_time)
        if math.isnan(ts) or ts == run.sent:
            return                                     # no sample yet, or this one is out already
        if run.templates is None:
            from .map_messages import GridMapTemplate, OccupancyGridTemplate

            p = self.p
            run.templates = (OccupancyGridTemplate(p.world_frame, p.cells, p.resolution),
                             GridMapTemplate(p.world_frame, p.cells, p.resolution))
        if run.dds is None:
            self._open(run)
        self._stamp(run, ts)
        grid, gmap = run.templates
        p = self.p
        if p.costmap_topic:
            run.writers[p.costmap_topic].write(grid.encode(ts, u.map_origin, u.cost))
        if p.elevation_topic:
            run.writers[p.elevation_topic].write(gmap.encode(ts, u.map_origin, u.elevation, u.slope))
        run.sent = ts
        run.published += 1

    def before_run(self, t0, u):
        """Opened before the clock starts (the participant's endpoints listed with the others; the MCAP file's
        share taken, so a sample sent only at the end never reopens a file the other recorders finished)."""
        if u.cache.dds is None:
            self._open(u.cache)

    def after_run(self, u):
        self.update(None, None, u)                     # a sample the last tick shows that no update sent
        super().after_run(u)

    def _stamp(self, run, t) -> None:
        """Where the sample's time goes besides the messages (the MCAP recorder's log time)."""


@dataclasses.dataclass(eq=False)
class MapRun(BridgeRun):
    """One run's state (``u.cache``): the message templates, the participant and writers, the last sample sent."""

    sent: float = math.nan


class Ros2TerrainMapMcapParams(Ros2TerrainMapParams, McapMirrorParams):
    pass


class Ros2TerrainMapMcap(Ros2TerrainMap):
    """The terrain-map bridge's messages, byte for byte, into an MCAP file (``--ros2-mcap FILE``)."""

    type_name = MAP_MCAP
    Params = Ros2TerrainMapMcapParams

    def _open(self, run: MapRun) -> None:
        from .map_messages import register_grid_map

        register_grid_map()                            # the GridMap schema text comes from the typestore
        open_mirror(run, self.p, {topic: (ty, MAP_QOS) for topic, ty in self._topics()})

    def _stamp(self, run, t) -> None:
        run.now_ns = int(t * 1e9 + 0.5) if t > 0 else 0


# -- adding them to a resolved scene ------------------------------------------------------------------
def _first_terrain_map(resolved, registry):
    """(name, spec, class) of the scene's first terrain_map component, or None."""
    from snakesim.components.sensors.terrain_map import TerrainMap

    for comp, spec, cls in registry.classes_in(resolved):
        if isinstance(cls, type) and issubclass(cls, TerrainMap):
            return comp, spec, cls
    return None


def attach_terrain_map(resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_terrain_map`` sink for the scene's first ``terrain_map`` component, wired port by port,
    at its rate (rounded to whole base steps); update its params (``params``: the publisher's shared DDS keys,
    ``world_frame``). Its name, or None when the scene has no terrain map."""
    from snakesim.components.sensors.terrain_map import DEFAULT_RATE, cells_of
    from snakesim.framework.assembly import ComponentSpec
    from snakesim.framework.rates import nearest_period
    from snakesim.framework.registry import default_registry

    from .attach import _free_name, _update_existing

    existing = _update_existing(resolved, MAP_BRIDGE, params)
    if existing is not None:
        return existing
    found = _first_terrain_map(resolved, registry or default_registry())
    if found is None:
        return None
    comp, spec, cls = found
    try:
        prm = cls.Params(**(spec.params or {}))
    except Exception:                # the build reports the map's invalid params, naming file and key
        prm = cls.Params()
    grid = {"resolution": prm.resolution, "cells": cells_of(prm.extent, prm.resolution)}
    name = _free_name(resolved, MAP_BRIDGE)
    rate = 1.0 / (nearest_period(spec.rate or DEFAULT_RATE, resolved.sim.dt) * resolved.sim.dt)
    resolved.components[name] = ComponentSpec(type=MAP_BRIDGE, params={**(params or {}), **grid},
                                              rate=rate)
    resolved.connections.extend((f"{comp}.{port}", f"{name}.{port}", "--ros2") for port in PORTS)
    resolved.where[name] = "--ros2"
    return name


def attach_terrain_map_mcap(resolved, path: str, registry=None) -> str | None:
    """Mirror the ``--ros2`` terrain-map sink (added if the scene has a terrain map) into the ``--ros2-mcap``
    file ``path`` as a ``ros2_terrain_map_mcap``. Its name, or None without a terrain map."""
    from .attach import _existing
    from .mcap_recorder import _mirror

    bridge = _existing(resolved, MAP_BRIDGE) or attach_terrain_map(resolved, registry)
    if bridge is None:
        return None
    return _mirror(resolved, bridge, MAP_MCAP, path)


def ros2_terrain_map_components() -> tuple:
    """The component classes this module defines (registered through components/plugin.py's hook)."""
    return (Ros2TerrainMap, Ros2TerrainMapMcap)
