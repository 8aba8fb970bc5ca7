"""Adds a viewer sink to a resolved scene: what ``snakesim run --viz TARGET`` does before the build.

Components are found by what their class declares, not by name:

    robot     the first component with a ``link_poses`` output (the multibody):
              its link_poses are wired in and its robot source keys copied, so the
              sink draws the same URDF
    terrain   the first structured output of a Terrain type
    attraction the first structured output of placement_settle's AttractionSet type
              (checked first: it too has ``points`` and ``forces``)
    contacts  the first other structured output whose type has ``points`` and
              ``forces`` fields (ContactSet, any contact back end)
    tethers   the first structured output with ``strips`` or ``points`` (and no
              ``forces``) on a component or port whose name says "tether"; else a
              component whose params list ``tethers: [{link, offset, anchor}]``
              (the tethers component): drawn as straight ropes from the link poses
    series    every recorded signal ('comp.port'), one plot each

The sink runs at the viewer rate rounded to a whole number of base steps
(30 Hz at dt = 1 ms is every 33 steps: 30.30 Hz), chosen so the scene's
rates still share a short tick pattern.
"""

from __future__ import annotations

import dataclasses
import math

from snakesim.framework.assembly import ComponentSpec, Resolved
from snakesim.framework.signals import Structured

from .target import VizTarget

VIEWER_RATE_HZ = 30.0
MAX_PHASES = 4096        # the scheduler's limit on distinct tick patterns (framework/plan.py)
ROBOT_KEYS = ("urdf", "design", "modules", "head", "robot")


@dataclasses.dataclass
class Attached:
    name: str
    robot: str | None = None
    terrain: str | None = None
    contacts: str | None = None
    attraction: str | None = None
    tethers: str | None = None
    series: list[str] = dataclasses.field(default_factory=list)
    rate: float = VIEWER_RATE_HZ


def _fields(cls) -> set[str]:
    if dataclasses.is_dataclass(cls):
        return {f.name for f in dataclasses.fields(cls)}
    return set(getattr(cls, "__annotations__", {})) | {n for n in dir(cls) if not n.startswith("_")}


def _classes(resolved: Resolved, registry):
    for name, spec in resolved.components.items():
        try:
            yield name, spec, registry.component(spec.type)
        except Exception:            # unknown type: the build reports it, naming file and key
            continue


def _tether_lines(params: dict) -> list[dict]:
    """Tie points and anchors of a tethers component's ropes (params.tethers: [{link, offset, anchor}])."""
    ropes = params.get("tethers")
    if not isinstance(ropes, list):
        return []
    out = [{"link": r["link"], "offset": list(r.get("offset", (0.0, 0.0, 0.0))), "anchor": list(r["anchor"])}
           for r in ropes if isinstance(r, dict) and "link" in r and "anchor" in r]
    return out if len(out) == len(ropes) else []


def viewer_period(dt: float, rates, target_hz: float = VIEWER_RATE_HZ) -> int:
    """Base steps per viewer frame: nearest to 1/(target·dt) whose tick pattern with
    the other components' periods stays within the scheduler's limit."""
    n0 = max(1, round(1.0 / (target_hz * dt)))
    periods = [max(1, round(1.0 / (r * dt))) for r in rates if r]
    best = None
    for n in sorted(range(max(1, n0 - 4), n0 + 5), key=lambda k: (abs(k - n0), k)):
        lcm = n
        for p in periods:
            lcm = lcm * p // math.gcd(lcm, p)
        if lcm <= MAX_PHASES:
            return n
        best = best or n
    return best


def attach_viewer(resolved: Resolved, target: VizTarget, registry=None, name: str = "viz",
                  params: dict | None = None) -> Attached:
    """Add a ``rerun_viewer`` component to ``resolved`` and wire it (in place)."""
    from snakesim.components.placement.settle import AttractionSet
    from snakesim.components.terrain import Terrain
    from snakesim.framework.registry import default_registry

    registry = registry or default_registry()
    base, k = name, 1
    while name in resolved.components:
        name, k = f"{base}_{k}", k + 1
    found = Attached(name)
    sink = {"target": str(target)}
    conns = []
    for comp, spec, cls in _classes(resolved, registry):
        for port, out in cls.outputs.items():
            sig = out.signal
            if found.robot is None and port == "link_poses" and not isinstance(sig, Structured):
                found.robot = comp
                sink["robot_component"] = comp
                sink.update({key: spec.params[key] for key in ROBOT_KEYS if key in spec.params})
                conns.append((f"{comp}.link_poses", f"{name}.link_poses"))
            if not isinstance(sig, Structured):
                continue
            fields = _fields(sig.cls)
            if found.terrain is None and isinstance(sig.cls, type) and issubclass(sig.cls, Terrain):
                found.terrain = comp
                conns.append((f"{comp}.{port}", f"{name}.terrain"))
            elif isinstance(sig.cls, type) and issubclass(sig.cls, AttractionSet):
                if found.attraction is None:           # never taken for contacts, even when a second one
                    found.attraction = comp
                    conns.append((f"{comp}.{port}", f"{name}.attraction"))
            elif found.contacts is None and {"points", "forces"} <= fields:
                found.contacts = comp
                conns.append((f"{comp}.{port}", f"{name}.contacts"))
            elif (found.tethers is None and ("strips" in fields or "points" in fields)
                  and "tether" in f"{spec.type} {comp} {port}".lower()):
                found.tethers = comp
                conns.append((f"{comp}.{port}", f"{name}.tethers"))
        if found.tethers is None and _tether_lines(spec.params):
            found.tethers = comp
            sink["tether_lines"] = _tether_lines(spec.params)
    for i, (ref, _) in enumerate(resolved.record):
        found.series.append(ref)
        conns.append((ref, f"{name}.s{i}"))
    sink["series"] = list(found.series)
    sim = resolved.sim
    sink["t_end"] = sim.t0 + sim.duration
    sink.update(params or {})
    period = viewer_period(sim.dt, [s.rate for s in resolved.components.values()])
    found.rate = 1.0 / (period * sim.dt)
    resolved.components[name] = ComponentSpec(type="rerun_viewer", params=sink, rate=found.rate)
    resolved.connections.extend((s, d, "--viz") for s, d in conns)
    resolved.where[name] = "--viz"
    return found
