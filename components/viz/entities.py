"""Where things live in a snakesim rerun recording, and which of them are physical.

Entity layout (one recording per run; timeline ``sim`` is simulated time, a
duration in seconds from the run's t0)::

    world/physical/terrain                     Mesh3D, static         the terrain surface (a terrain with state:
                                                                      at the first frame and at each change)
    world/physical/<robot>/<link>              Transform3D per frame  link pose (world)
    world/physical/<robot>/<link>/visual       Mesh3D, static         URDF visual geometry, link frame
    world/physical/tethers                     LineStrips3D           tether polylines (when present)
    world/debug/contacts/points                Points3D               active contact points
    world/debug/contacts/normal_forces         Arrows3D               F_n n, scaled (m per N); the whole
                                                                      force when the contact value has no normals
    world/debug/contacts/friction_forces       Arrows3D               F - F_n n, scaled
    world/debug/attraction                     Arrows3D               placement attraction springs (paper
                                                                      fig. 9, yellow), scaled; empty once latched
    world/debug/frames/<link>                  Transform3D + Arrows3D body frame axes (on request)
    world/sensors/<component>/<port>           Transform3D per sample the sensor frame (lidar frame, camera
                                                                      optical frame), world, at the sample time
    world/sensors/<component>/<port>/points    Points3D per sample    lidar returns, sensor frame, coloured by
                                                                      intensity (no-returns left out)
    world/sensors/<component>/<port>/pinhole   Pinhole, static        camera resolution and K, optical frame
                                                                      (RDF: x right, y down, z forward)
    world/sensors/<component>/<port>/pinhole/image  Image per sample  the camera image, 8-bit grey or RGB
    world/sensors/<component>/<port>/pinhole/depth  DepthImage        depth (z in the optical frame), m
    plots/<component>/<port>                   Scalars                a recorded signal, one series per element
    plots/sim/real_time_factor                 Scalars                simulated s per wall-clock s

Physical vs ornamental (paper 2.2.3). Everything under ``world/physical``
is an object a sensor could see: terrain, robot bodies, tethers. Everything
under ``world/debug`` is ornamental: arrows, frames, labels and markers that
explain the simulation. The viewer shows both; a sensor never sees debug
geometry. Contract for the perception sensors (``components/perception``:
lidar, cameras): a sensor builds its scene from the physical objects only --
the terrain and the link meshes this package logs under ``world/physical``
(``perception/surfaces.py`` builds them from the same terrain mesh and
``robot_geometry.link_meshes``; tethers are left out there on purpose) --
and never ray-casts against, renders or returns anything under
``world/debug``; use :func:`is_physical` when a sensor or exporter walks
entity paths. New ornamental geometry goes under ``world/debug``; new
geometry with mass or optical presence goes under ``world/physical``.

Sensor data (``world/sensors``) is neither: it is what the sensors measured,
drawn where they measured it. It is not physical (a sensor must never see
another sensor's points or images: :func:`is_physical` is False for it) and
not ornamental (it is measurement, not an explanation of the simulation).
Each sample is logged once, at its own sample time (:mod:`.sensor_log`).
"""

from __future__ import annotations

import re

WORLD = "world"
PHYSICAL = f"{WORLD}/physical"
DEBUG = f"{WORLD}/debug"
SENSORS = f"{WORLD}/sensors"
PLOTS = "plots"
TIMELINE = "sim"

TERRAIN = f"{PHYSICAL}/terrain"
TETHERS = f"{PHYSICAL}/tethers"
CONTACT_POINTS = f"{DEBUG}/contacts/points"
CONTACT_NORMAL = f"{DEBUG}/contacts/normal_forces"
CONTACT_FRICTION = f"{DEBUG}/contacts/friction_forces"
ATTRACTION = f"{DEBUG}/attraction"
FRAMES = f"{DEBUG}/frames"
REAL_TIME_FACTOR = f"{PLOTS}/sim/real_time_factor"

_UNSAFE = re.compile(r"[^A-Za-z0-9_\-/]")


def part(name: str) -> str:
    """A name as entity-path text: characters rerun treats specially become '_'
    ('/' is kept: component names of included assemblies nest)."""
    return _UNSAFE.sub("_", name).strip("/") or "_"


def robot_root(component: str) -> str:
    return f"{PHYSICAL}/{part(component)}"


def link_path(component: str, link: str) -> str:
    return f"{robot_root(component)}/{part(link).replace('/', '_')}"


def frame_path(link: str) -> str:
    return f"{FRAMES}/{part(link).replace('/', '_')}"


def sensor_path(output: str) -> str:
    """'lidar.scan' -> 'world/sensors/lidar/scan': the sensor frame's entity (a component name may
    contain '/'); its data lies under it (:data:`SENSOR_POINTS`, :data:`SENSOR_PINHOLE`, ...)."""
    comp, _, port = output.rpartition(".")
    return f"{SENSORS}/{part(comp)}/{part(port)}"


# under sensor_path(output): the lidar's points, the camera's pinhole and the images it projects
SENSOR_POINTS = "points"
SENSOR_PINHOLE = "pinhole"
SENSOR_IMAGE = f"{SENSOR_PINHOLE}/image"
SENSOR_DEPTH = f"{SENSOR_PINHOLE}/depth"


def series_path(signal: str) -> str:
    """'robot.joint_q' -> 'plots/robot/joint_q' (a component name may contain '/')."""
    comp, _, port = signal.rpartition(".")
    return f"{PLOTS}/{part(comp)}/{part(port)}"


def is_physical(entity_path: str) -> bool:
    """True for what a sensor may see (``world/physical/...``), False for
    ornamental geometry (``world/debug/...``), sensor data (``world/sensors/...``),
    plots and anything else."""
    p = entity_path.lstrip("/")
    return p == PHYSICAL or p.startswith(PHYSICAL + "/")
