"""Adds a viewer sink to a resolved scene: what ``snakesim run --viz TARGET`` does before the build.

Components are found by what their classes declare, never by their names or port names:

    robot      the component that provides the RobotModel resource (``Provides(RobotModel)``:
               the multibody or placed_multibody; with several, the first, named in the
               sink's ``uses: {robot: NAME}``). The sink uses that robot (its links and URDF
               visuals), its output of role LINK_POSES (components/port_roles.py) is wired in
               and its name is the robot's entity name (world/physical/<name>)
    terrain    the first structured output of type Terrain
    contacts   the first structured output of type ContactSet (any contact back end)
    attraction the first structured output of type AttractionSet (placement_settle's springs)
    tethers    a ``tethers`` component (class Tethers): its ropes (params ``tethers``: link,
               offset, anchor) drawn as straight lines from the link poses
    sensors    every output of role LIDAR_SCAN or CAMERA_FRAME (a lidar's scan, a camera's frame,
               a stereo pair's left and right, an image filter's frame), one sensor input each:
               drawn under world/sensors/<comp>/<port>. Wiring a sensor to the viewer keeps it
               running (the viewer is a sink), so --viz costs its ray casting even when nothing
               else reads it
    series     every recorded signal ('comp.port'), one plot each, its legend the element names the
               port declares (planar_pose's pose: x, y, yaw)

The types are imported from their packages' public modules (STRUCTURED below).

The sink runs at the viewer rate rounded to a whole number of base steps
(30 Hz at dt = 1 ms is every 33 steps: 30.30 Hz), chosen so the scene's
rates still share a short tick pattern.
"""

from __future__ import annotations

import dataclasses

from snakesim.framework.assembly import ComponentSpec, Resolved
from snakesim.framework.rates import MAX_PHASES, lcm, nearest_period
from snakesim.framework.signals import Structured

from snakesim.components.port_roles import CAMERA_FRAME, LIDAR_SCAN, LINK_POSES

from .target import VizTarget

VIEWER_RATE_HZ = 30.0
#: output roles drawn as sensor data (components/port_roles.py)
SENSOR_ROLES = (LIDAR_SCAN, CAMERA_FRAME)


@dataclasses.dataclass
class Attached:
    name: str
    robot: str | None = None
    terrain: str | None = None
    contacts: str | None = None
    attraction: str | None = None
    tethers: str | None = None
    series: list[str] = dataclasses.field(default_factory=list)
    sensors: list[str] = dataclasses.field(default_factory=list)
    rate: float = VIEWER_RATE_HZ


def structured_inputs() -> dict[str, type]:
    """Sink input -> the structured type whose outputs are wired to it."""
    from snakesim.components.contact import ContactSet
    from snakesim.components.placement import AttractionSet
    from snakesim.components.terrain import Terrain

    return {"terrain": Terrain, "contacts": ContactSet, "attraction": AttractionSet}


def provides_robot(cls) -> bool:
    """Whether a component class provides the robot (a RobotModel resource)."""
    from snakesim.components.multibody.robot_model import RobotModel

    return any(issubclass(prov.kind, RobotModel) for prov in getattr(cls, "provides", {}).values())


def tether_lines(cls, params: dict) -> list[dict]:
    """Tie points and anchors of a ``tethers`` component's ropes ([{link, offset, anchor}]), read
    through its own Params; [] for any other component, or when its params do not validate (the
    build reports those, naming file and key)."""
    from pydantic import ValidationError

    from snakesim.components.tethers import Tethers

    if not (isinstance(cls, type) and issubclass(cls, Tethers)):
        return []
    try:
        ropes = cls.Params(**(params or {})).tethers
    except (ValidationError, TypeError, ValueError):
        return []
    return [{"link": r.link, "offset": list(r.offset), "anchor": list(r.anchor)} for r in ropes]



def viewer_period(dt: float, rates, target_hz: float = VIEWER_RATE_HZ) -> int:
    """Base steps per viewer frame: nearest to 1/(target·dt) whose tick pattern with
    the other components' periods stays within the scheduler's limit."""
    n0 = nearest_period(target_hz, dt)
    periods = [nearest_period(r, dt) for r in rates if r]
    best = None
    for n in sorted(range(max(1, n0 - 4), n0 + 5), key=lambda k: (abs(k - n0), k)):
        if lcm([n, *periods]) <= MAX_PHASES:
            return n
        best = best or n
    return best


def declared_names(classes: dict, ref: str) -> list[str] | None:
    """The element names output ``ref`` ('comp.port') declares as a fixed tuple (planar_pose's pose: x, y, yaw),
    the plot's legend; None where they depend on the built component (per-link names) or none are given."""
    comp, _, port = ref.partition(".")
    out = getattr(classes.get(comp), "outputs", {}).get(port)
    names = getattr(getattr(out, "signal", None), "names", None)
    return list(names) if isinstance(names, tuple) else None


def attach_viewer(resolved: Resolved, target: VizTarget, registry=None, name: str = "viz",
                  params: dict | None = None) -> Attached:
    """Add a ``rerun_viewer`` component to ``resolved`` and wire it (in place)."""
    from snakesim.framework.registry import default_registry

    registry = registry or default_registry()
    base, k = name, 1
    while name in resolved.components:
        name, k = f"{base}_{k}", k + 1
    found = Attached(name)
    sink = {"target": str(target)}
    uses = {}
    conns = []
    kinds = structured_inputs()
    classes = {}
    for comp, spec, cls in registry.classes_in(resolved):
        classes[comp] = cls
        if found.robot is None and provides_robot(cls):
            found.robot = comp
            uses["robot"] = comp             # explicit: the scene may have several providers
            sink["robot_component"] = comp
            poses = [p for p, out in cls.outputs.items() if out.role == LINK_POSES]
            if poses:
                conns.append((f"{comp}.{poses[0]}", f"{name}.link_poses"))
        for port, out in cls.outputs.items():
            if out.role in SENSOR_ROLES:
                found.sensors.append(f"{comp}.{port}")
                conns.append((f"{comp}.{port}", f"{name}.sensor{len(found.sensors) - 1}"))
                continue
            sig = out.signal
            if not (isinstance(sig, Structured) and isinstance(sig.cls, type)):
                continue
            for role, kind in kinds.items():
                if getattr(found, role) is None and issubclass(sig.cls, kind):
                    setattr(found, role, comp)
                    conns.append((f"{comp}.{port}", f"{name}.{role}"))
                    break
        if found.tethers is None:
            lines = tether_lines(cls, spec.params)
            if lines:
                found.tethers = comp
                sink["tether_lines"] = lines
    for i, (ref, _) in enumerate(resolved.record):
        found.series.append(ref)
        conns.append((ref, f"{name}.s{i}"))
    sink["series"] = list(found.series)
    sink["series_names"] = [declared_names(classes, ref) for ref in found.series]
    sink["sensors"] = list(found.sensors)
    sim = resolved.sim
    sink["t_end"] = sim.t0 + sim.duration
    sink.update(params or {})
    period = viewer_period(sim.dt, [s.rate for s in resolved.components.values()])
    found.rate = 1.0 / (period * sim.dt)
    resolved.components[name] = ComponentSpec(type="rerun_viewer", params=sink, rate=found.rate, uses=uses)
    resolved.connections.extend((s, d, "--viz") for s, d in conns)
    resolved.where[name] = "--viz"
    return found
