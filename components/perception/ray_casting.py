"""What the perception sensors cast into (the ``RayCaster`` port type) and the back ends that cast.

A ``sensor_scene`` outputs, at each instant, a value that satisfies :class:`RayCaster`; lidars and
cameras take it on their ``world`` input (``Input(type=RayCaster)``) and call only what the protocol
declares. Wiring checks the port type structurally (``issubclass`` of a runtime-checkable protocol),
so a component whose output is another back end's world class wires to the sensors as well.

A back end (:class:`RayCasterBackend`) is registered by name through the plugin hook
``snakesim_register_ray_casters(registry)`` with ``registry.add_ray_caster(backend)``, and chosen by
``sensor_scene``'s parameter ``ray_caster`` (default ``embree``: .ray_caster). It gets the same
triangles every back end gets (.surfaces: ``TerrainSurfaces``, ``RobotSurfaces``) and builds:

    terrain(surfaces, refine_limit)   the terrain's static scene, once per terrain object and run, and
                                      again when its state changes (``state.version``: a deformable kind)
    robot(surfaces)                   the robot links' static scenes (link frames), once per sensor_scene
    world(t, terrain, robot, link_poses)   the RayCaster of one instant (either scene may be None:
                                      no terrain, robot not visible; link_poses (nl, 7) or None)

This module imports nothing heavy: a back end's module is imported where it registers.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Callable, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from .ray_caster import CastBuffers, RayBundle, RayHits

#: the back end ``sensor_scene`` uses unless its ``ray_caster`` parameter names another
DEFAULT_RAY_CASTER = "embree"


@runtime_checkable
class RayCaster(Protocol):
    """The physical scene at one instant, as the sensors cast into it (methods only, so that
    ``issubclass`` checks a class structurally). Arrays are float64; results are
    :class:`~.ray_caster.RayHits` (``distance`` (n,) m, inf on a miss; for the hit rays ``normal``
    (n, 3) unit world facing the ray, ``albedo``, ``color``, ``link`` the link row or −1; ``label``
    (n,) uint16 what each ray hit, .labels, or None where a back end cannot tell)."""

    def link_pose(self, row: int) -> tuple[np.ndarray, np.ndarray]:
        """(R (3, 3), p (3,)) of robot link ``row`` (a ``link_poses`` row) in the world: where a
        sensor mounted on it is."""

    def cast(self, origins, directions, max_range: float, min_range: float = 0.0) -> RayHits:
        """Nearest hit of each world ray (origins, unit directions (n, 3)) within
        [min_range, max_range] m (a camera's shadow rays)."""

    def cast_from(self, R, p, origins, directions, max_range: float, min_range: float = 0.0,
                  bundle: RayBundle | None = None, buffers: CastBuffers | None = None, exact: bool = True,
                  refine_beyond: float = 0.0) -> tuple[RayHits, np.ndarray, np.ndarray]:
        """Rays given in a sensor frame posed at (R, p) in the world (rays start at min_range):
        -> (hits, world origins (n, 3), world directions (n, 3)). ``bundle`` (the same rays binned
        once by the sensor, with its mount; or, from ``RayBundle.for_moved``, the sensor's nominal rays
        when ``origins, directions`` are them moved by its own motion: then the robot, which moves with
        it, may be cast along the nominal ones) and ``buffers`` (the sensor's arrays of n rays, which
        the results may be written into) are hints a back end may ignore. ``exact``: terrain hits
        on faces that approximate a curved analytic surface refined onto it (False: the mesh's
        hits); ``refine_beyond`` m: such a hit nearer than this whose ray is inside the terrain
        there may be left unrefined (it only blocks). A sensor passes ``texture_contrast=c`` (the
        terrain materials' texture contrasts times c) only when c is not 1: a back end may omit it."""


@dataclasses.dataclass(frozen=True, eq=False)
class RayCasterBackend:
    """One ray-casting back end: its ``name`` (the value of ``sensor_scene``'s ``ray_caster``) and
    the three builders of the module docstring."""

    name: str
    terrain: Callable[[Any, float], Any]
    robot: Callable[[Any], Any]
    world: Callable[[float, Any, Any, Any], RayCaster]

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name):
            raise TypeError(f"a ray-casting back end needs a name, not {self.name!r}")
        for part in ("terrain", "robot", "world"):
            if not callable(getattr(self, part)):
                raise TypeError(f"ray-casting back end '{self.name}': {part} is not callable")


def ray_casters(registry=None) -> dict[str, RayCasterBackend]:
    """name -> RayCasterBackend of ``registry`` (default: built-ins plus every installed plugin),
    the built-in back ends first."""
    from snakesim.framework.registry import default_ray_casters

    reg = registry or default_ray_casters()
    return reg.builtins_first(reg.ray_casters, "ray caster")


def ray_caster_backend(name: str, registry=None) -> RayCasterBackend:
    """The registered back end ``name``; a ValueError naming the valid ones if there is none (or two
    plugins registered it)."""
    from snakesim.framework.errors import RegistryError
    from snakesim.framework.registry import default_ray_casters

    if registry is None:
        registry = default_ray_casters()
    try:
        registry._clashed("ray caster", name)
    except RegistryError as e:
        raise ValueError(str(e)) from None
    backends = ray_casters(registry)
    if name not in backends:
        raise ValueError(f"ray_caster = '{name}' is not a registered ray-casting back end; valid: "
                         f"{', '.join(backends) or 'none'}")
    return backends[name]
