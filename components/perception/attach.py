"""Head sensors on any robot scene: what ``snakesim run --lidar PRESET --stereo WxH`` adds.

Finds, by what the classes declare (never by names): the component providing the robot
(``Provides(RobotModel)``) and its LINK_POSES output, and the first Terrain output. Adds
one ``sensor_scene`` (``sensors``) wired to both, then

    --lidar PRESET    ``lidar``: the preset (beam_patterns.PRESETS) at 10 Hz (``--lidar-rate``) on the robot's
                      ``lidar`` link (the EELS heads' lidar frame)
    --stereo WxH      ``stereo``: a 90° pinhole pair, 6.75 cm baseline, W×H pixels, at 5 Hz (``--stereo-rate``),
                      on the ``camera_left`` link (optical: looking along the link's x)

A robot without those links is a clear error at build (the mount names the link and lists
the robot's). Mount rotations are the link's: a scene that rolls the robot (the default
scene lies on its side) rolls the sensors with it; give rpy in the scene's YAML to level
them (assemblies/perception-obstacle-course.yaml does).
"""

from __future__ import annotations

from snakesim.framework.assembly import ComponentSpec, Resolved
from snakesim.framework.errors import ConfigError
from snakesim.framework.signals import Structured

from .beam_patterns import PRESETS

LIDAR_RATE, CAMERA_RATE = 10.0, 5.0
SCENE, LIDAR, STEREO = "sensors", "lidar", "stereo"


def _robot_and_terrain(resolved: Resolved, registry):
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.port_roles import LINK_POSES
    from snakesim.components.terrain import Terrain

    robot = poses = terrain = None
    for comp, _, cls in registry.classes_in(resolved):
        if robot is None and any(issubclass(p.kind, RobotModel) for p in getattr(cls, "provides", {}).values()):
            out = [p for p, o in cls.outputs.items() if o.role == LINK_POSES]
            if out:
                robot, poses = comp, f"{comp}.{out[0]}"
        if terrain is None:
            for port, o in cls.outputs.items():
                sig = o.signal
                if isinstance(sig, Structured) and isinstance(sig.cls, type) and issubclass(sig.cls, Terrain):
                    terrain = f"{comp}.{port}"
                    break
    if robot is None:
        raise ConfigError("head sensors need a robot: no component provides one (a multibody)", "--lidar/--stereo")
    return robot, poses, terrain


def _scene(resolved: Resolved, registry) -> str:
    """The sensor_scene component's name (added and wired once)."""
    from snakesim.framework.registry import default_registry

    if SCENE in resolved.components and resolved.components[SCENE].type == "sensor_scene":
        return SCENE
    if SCENE in resolved.components:
        raise ConfigError(f"the scene already has a component named '{SCENE}'", "--lidar/--stereo")
    robot, poses, terrain = _robot_and_terrain(resolved, registry or default_registry())
    # raster: the stereo pair's pinhole images rasterised (.raster), the lidar cast by Embree as before
    resolved.components[SCENE] = ComponentSpec(type="sensor_scene", uses={"robot": robot},
                                               params={"ray_caster": "raster"})
    resolved.connections.append((poses, f"{SCENE}.link_poses", "--lidar/--stereo"))
    if terrain is not None:
        resolved.connections.append((terrain, f"{SCENE}.terrain", "--lidar/--stereo"))
    resolved.where[SCENE] = "--lidar/--stereo"
    return SCENE


def _add(resolved: Resolved, name: str, spec: ComponentSpec, scene: str, option: str) -> None:
    if name in resolved.components:
        raise ConfigError(f"the scene already has a component named '{name}'", option)
    robot = resolved.components[scene].uses["robot"]
    resolved.components[name] = spec.model_copy(update={"uses": {"robot": robot}})
    resolved.connections.append((f"{scene}.world", f"{name}.world", option))
    resolved.where[name] = option


def _rate(rate, default: float, option: str) -> float:
    if rate is None:
        return default
    if not (isinstance(rate, (int, float)) and 0 < rate < float("inf")):
        raise ConfigError(f"{option}: {rate!r} is not a rate; give a positive number of Hz, e.g. 10", option)
    return float(rate)


def attach_lidar(resolved: Resolved, preset: str, registry=None, rate: float | None = None) -> None:
    """Add the head lidar ``preset`` at ``rate`` Hz (default LIDAR_RATE)."""
    rate = _rate(rate, LIDAR_RATE, "--lidar-rate")
    if preset not in PRESETS:
        raise ConfigError(f"--lidar: '{preset}' is not a lidar preset; valid: {', '.join(PRESETS)}", "--lidar")
    scene = _scene(resolved, registry)
    _add(resolved, LIDAR, ComponentSpec(type="lidar", rate=rate, params={"link": "lidar", "preset": preset}),
         scene, "--lidar")


def parse_size(text: str) -> tuple[int, int]:
    """'640x480' -> (640, 480); a ValueError saying what is valid otherwise."""
    parts = str(text).lower().split("x")
    if len(parts) != 2 or not all(p.isdigit() and int(p) > 0 for p in parts):
        raise ValueError(f"'{text}' is not an image size; give WIDTHxHEIGHT in pixels, e.g. 640x480")
    return int(parts[0]), int(parts[1])


def attach_stereo(resolved: Resolved, size: str, registry=None, rate: float | None = None) -> None:
    """Add the head stereo pair of ``size`` ('WxH') at ``rate`` Hz (default CAMERA_RATE)."""
    rate = _rate(rate, CAMERA_RATE, "--stereo-rate")
    try:
        w, h = parse_size(size)
        from .camera import check_camera_size
        check_camera_size(w, h, views=2)        # refused with the estimate before anything is built
    except ValueError as e:
        raise ConfigError(str(e), "--stereo") from None
    scene = _scene(resolved, registry)
    params = {"link": "camera_left", "width": w, "height": h, "baseline": 0.0675,
              "model": {"kind": "pinhole", "fov": 90.0}}
    _add(resolved, STEREO, ComponentSpec(type="stereo_camera", rate=rate, params=params), scene, "--stereo")


#: run options whose sinks take every sensor output (a LIDAR_SCAN or CAMERA_FRAME role): what each does with it
SENSOR_SINK_OPTIONS = {"viz": "drawn by --viz", "ros2": "published on ROS 2 (--ros2)",
                       "ros2_mcap": "published on ROS 2 and recorded to the --ros2-mcap file"}


def _resolution(name: str, spec: ComponentSpec) -> str:
    p = spec.params
    if name == STEREO or "width" in p:
        return f"{p['width']}x{p['height']} px, two views"
    beams = PRESETS[p["preset"]]["beams"]
    n = getattr(beams, "channels", None)
    if n is not None:
        return f"{p['preset']}, {n} channels x {beams.horizontal_samples} beams"
    return f"{p['preset']}, {beams.points} beams"


def sensor_notice(resolved: Resolved, name: str, sinks=()) -> str:
    """One line for a sensor ``--lidar``/``--stereo`` added: its name, resolution, rate and frame (the link
    it is mounted on), and where its data go: the recorded ports of it (``resolved.record``), the run
    options in ``sinks`` that take it (names of SENSOR_SINK_OPTIONS), or that nothing publishes it."""
    spec = resolved.components[name]
    where = [SENSOR_SINK_OPTIONS[s] for s in sinks if s in SENSOR_SINK_OPTIONS]
    recorded = [ref for ref, _ in resolved.record if ref.split(".", 1)[0] == name]
    if recorded:
        where.append("recorded: " + ", ".join(recorded))
    if not where:
        where = ["not published: add --viz or --ros2"]
    return (f"sensor {name} ({spec.type}): {_resolution(name, spec)}, {spec.rate:g} Hz, frame "
            f"'{spec.params['link']}'; " + "; ".join(where))
