"""Adds a ROS 2 publisher to a resolved scene: what ``snakesim run --ros2`` does before the build.

Found by what the classes declare, never by component or port names:

    robot     the first component that provides the RobotModel (the publisher uses that robot);
              its outputs of roles LINK_POSES, JOINT_POSITIONS, JOINT_VELOCITIES are wired in
    efforts   the first output of role JOINT_EFFORTS (the torques commanded to the robot: a PID)
    imu       an ``imu`` component (class Imu): its IMU_* outputs, its link as frame_id and its noise
              as covariances
    fts       a ``force_torque_sensors`` component (class ForceTorqueSensors): its SENSOR_WRENCHES
              output and its cuts (one WrenchStamped topic per sensor)

``--ros2-domain N`` and ``--ros2-interface IF`` imply ``--ros2`` and set the publisher's params (and the
command source's).

The command source (``ros2_commands``, :func:`attach_commands`), added with the publisher when the scene
has a robot:

    gravity   the robot provider's ``gravity`` input (multibody, "scale" mode), when the scene leaves it
              unconnected
    pid       the first ``joint_pid`` (class JointPid): ``commands.setpoint -> pid.setpoint`` and
              ``commands.rate -> pid.rate_ref`` where the scene leaves them unconnected; the PID's modes
              (kind_gains/gains ``mode``) are copied so set-points mean what the PID reads
    q         the robot's JOINT_POSITIONS output (set-points start by holding the joints where they are)

The simulation control gate (``ros2_sim_control``, :func:`attach_sim_control`), always added with the
publisher: /sim/pause, /sim/step, /sim/reset (topics and services); when the robot provider is a
multibody (class Multibody) its name is the gate's ``robot_state`` and the gate uses its robot, so
/sim/set_pose and /sim/set_joint_positions are accepted; its ``world_frame`` is the publisher's.

The sensor bridge (``ros2_sensor_bridge``, :func:`attach_sensor_bridge`), added when the scene has
perception sensors: every output of port role LIDAR_SCAN or CAMERA_FRAME, one topic base each
(/comp, or /comp/port when the component has several such ports: a stereo pair's left and right),
at the fastest of those sensors' rates. When the run records to MCAP (``--ros2-mcap``), the bridge
is mirrored into the recording (``ros2_sensor_mcap``), whenever it is added.

The tether command source (``ros2_tether_commands``, :func:`attach_tether_commands`), added when the
scene has a ``tethers`` component (class Tethers) whose ``attached`` input it leaves unconnected:
``ros2_tether_commands.attached -> tethers.attached`` (/tethers/attached).

The parameter command sources (:mod:`.parameter_commands`), each added for the first component of its
kind that leaves one of its inputs unconnected, wired input by input of the same name:
``ros2_gait_commands`` (/gait/parameters) for a serpenoid_gait or helical_gait,
``ros2_brace_commands`` (/brace/parameters) for a brace_climb (target_force, climb_speed).

The rule when the scene already drives the PID's set-points (a schedule, a gait, joint_setpoints): plain
``--ros2`` leaves the scene's connection alone and does not accept joint commands (the source does
not subscribe to them, and says so once on the ``snakesim.ros2`` logger); ``--ros2-commands`` hands the
set-points to ROS 2: the scene's connections into ``pid.setpoint`` and ``pid.rate_ref`` are removed
and the command source's wired instead (each replaced connection is logged). Never both: the two
sources never fight over one input.
"""

from __future__ import annotations

import logging

from snakesim.framework.assembly import ComponentSpec, Resolved

from .odometry_attach import attach_odometry
from snakesim.framework.rates import nearest_period

from snakesim.components.port_roles import (IMU_ANGULAR_RATE, IMU_ORIENTATION, IMU_SPECIFIC_FORCE, JOINT_EFFORTS,
                                            JOINT_POSITIONS, JOINT_VELOCITIES, LINK_POSES, SENSOR_WRENCHES)

from .publisher import DEFAULT_RATES

log = logging.getLogger("snakesim.ros2")
COMMANDS = "ros2_commands"
SIM_CONTROL = "ros2_sim_control"
TETHER_COMMANDS = "ros2_tether_commands"
COMMANDS_RATE = 100.0          # Hz, how often the command topics are polled (rounded to whole base steps)
#: publisher params the command source shares
SHARED = ("domain_id", "interface", "node_graph", "ros_distro")

NAME = "ros2"
ROBOT_ROLES = {LINK_POSES: "link_poses", JOINT_POSITIONS: "joint_positions", JOINT_VELOCITIES: "joint_velocities"}
IMU_ROLES = {IMU_ANGULAR_RATE: "imu_angular_rate", IMU_SPECIFIC_FORCE: "imu_specific_force",
             IMU_ORIENTATION: "imu_orientation"}



def _params(cls, spec):
    try:
        return cls.Params(**(spec.params or {}))
    except Exception:                # the build reports invalid params, naming file and key
        return None


def attach_ros2(resolved: Resolved, registry=None, params: dict | None = None) -> str:
    """Add (once) a ``ros2_publisher`` to ``resolved``, wired by port role; update its params. Its name.
    Adds (once) the command source too (:func:`attach_commands`), with the same domain and interface."""
    shared = {k: v for k, v in (params or {}).items() if k in SHARED}
    name = _attach_publisher(resolved, registry, params)
    pub = resolved.components[name].params
    both = {**{k: pub[k] for k in SHARED if k in pub}, **shared}
    attach_commands(resolved, registry, both)
    attach_tether_commands(resolved, registry, both)
    attach_gait_commands(resolved, registry, both)
    attach_brace_commands(resolved, registry, both)
    attach_sensor_bridge(resolved, registry, both)
    attach_odometry(resolved, registry, {**both, "world_frame": pub.get("world_frame", "world")})
    from .terrain_map_attach import attach_terrain_map
    attach_terrain_map(resolved, registry, {**both, "world_frame": pub.get("world_frame", "world")})
    attach_sim_control(resolved, {**both, "world_frame": pub.get("world_frame", "world"),
                                  "clock_rate": {**DEFAULT_RATES, **pub.get("rates", {})}["clock"]}, registry)
    return name


def _multibody(resolved: Resolved, registry) -> str | None:
    """The robot provider when it is a multibody (its state is the robot's [q, v]), else None."""
    from snakesim.components.multibody import Multibody
    from snakesim.components.viz.attach import provides_robot

    for comp, _spec, cls in registry.classes_in(resolved):
        if provides_robot(cls):
            return comp if isinstance(cls, type) and issubclass(cls, Multibody) else None
    return None


def attach_sim_control(resolved: Resolved, params: dict | None = None, registry=None) -> str:
    """Add (once) a ``ros2_sim_control`` gate (/sim/pause, /sim/step, lockstep, /sim/reset; placement when
    the robot is a multibody) at the command source's rate; update its params. Its name."""
    from snakesim.framework.registry import default_registry

    existing = _update_existing(resolved, SIM_CONTROL, params)
    if existing is not None:
        return existing
    name = _free_name(resolved, SIM_CONTROL)
    rate = 1.0 / (nearest_period(COMMANDS_RATE, resolved.sim.dt) * resolved.sim.dt)
    prm, uses = dict(params or {}), {}
    robot = _multibody(resolved, registry or default_registry())
    if robot is not None and "robot_state" not in prm:
        prm["robot_state"], uses["robot"] = robot, robot
    resolved.components[name] = ComponentSpec(type=SIM_CONTROL, params=prm, rate=rate, uses=uses)
    resolved.where[name] = "--ros2"
    return name


def attach_tether_commands(resolved: Resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_tether_commands`` source for the first ``tethers`` component whose ``attached``
    input is free, wired into it; update its params. Its name, or None when there is none."""
    from snakesim.components.tethers import Tethers
    from snakesim.framework.registry import default_registry

    existing = _update_existing(resolved, TETHER_COMMANDS, params)
    if existing is not None:
        return existing
    into = {d for _s, d, _w in resolved.connections}
    for comp, spec, cls in (registry or default_registry()).classes_in(resolved):
        if not (isinstance(cls, type) and issubclass(cls, Tethers)) or f"{comp}.attached" in into:
            continue
        prm = _params(cls, spec)
        if prm is None:
            continue
        name = _free_name(resolved, TETHER_COMMANDS)
        rate = 1.0 / (nearest_period(COMMANDS_RATE, resolved.sim.dt) * resolved.sim.dt)
        resolved.components[name] = ComponentSpec(type=TETHER_COMMANDS, rate=rate,
                                                  params={**(params or {}), "tethers": len(prm.tethers)})
        resolved.connections.append((f"{name}.attached", f"{comp}.attached", "--ros2"))
        resolved.where[name] = "--ros2"
        return name
    return None


GAIT_COMMANDS = "ros2_gait_commands"
BRACE_COMMANDS = "ros2_brace_commands"


def attach_gait_commands(resolved: Resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_gait_commands`` source (/gait/parameters, :mod:`.gait_commands`) for the first
    serpenoid_gait or helical_gait with a free command input, wired into each free one of amplitude,
    frequency, wavelength, phase_step, direction; update its params. Its name, or None when there is none."""
    from snakesim.components.control.gaits import SerpenoidGait
    from snakesim.components.control.helical_gait import HelicalGait

    from .gait_commands import Ros2GaitCommands

    return _attach_parameter_commands(resolved, registry, params, Ros2GaitCommands, (SerpenoidGait, HelicalGait))


def attach_brace_commands(resolved: Resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_brace_commands`` source (/brace/parameters, :mod:`.brace_commands`) for the first
    brace_climb with a free ``target_force`` or ``climb_speed`` input, wired into each free one; update its
    params. Its name, or None when there is none."""
    from snakesim.components.control.brace_climb import BraceClimb

    from .brace_commands import Ros2BraceCommands

    return _attach_parameter_commands(resolved, registry, params, Ros2BraceCommands, (BraceClimb,))


def _attach_parameter_commands(resolved: Resolved, registry, params: dict | None, source, targets) -> str | None:
    """Add (once) the ParameterEvent command source class ``source`` for the first component of a class in
    ``targets`` that leaves one of the source's parameters free as an input of the same name, wired into each
    free one; update its params. Its name, or None when there is none."""
    from snakesim.framework.registry import default_registry

    type_name = source.type_name
    existing = _update_existing(resolved, type_name, params)
    if existing is not None:
        return existing
    into = {d for _s, d, _w in resolved.connections}
    for comp, _spec, cls in (registry or default_registry()).classes_in(resolved):
        if not (isinstance(cls, type) and issubclass(cls, targets)):
            continue
        free = [k for k in source.PARAMETERS if k in cls.inputs and f"{comp}.{k}" not in into]
        if not free:
            continue
        name = _free_name(resolved, type_name)
        rate = 1.0 / (nearest_period(COMMANDS_RATE, resolved.sim.dt) * resolved.sim.dt)
        resolved.components[name] = ComponentSpec(type=type_name, rate=rate, params=dict(params or {}))
        resolved.connections.extend((f"{name}.{k}", f"{comp}.{k}", "--ros2") for k in free)
        resolved.where[name] = "--ros2"
        return name
    return None


SENSOR_BRIDGE = "ros2_sensor_bridge"


def attach_sensor_bridge(resolved: Resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_sensor_bridge`` publishing every LIDAR_SCAN and CAMERA_FRAME output (see the
    module docstring); update its params. Its name, or None when the scene has no such output."""
    from snakesim.components.port_roles import CAMERA_FRAME, LIDAR_SCAN
    from snakesim.framework.registry import default_registry

    from .mcap_recorder import sync_sensor_recorder

    existing = _update_existing(resolved, SENSOR_BRIDGE, params)
    if existing is not None:
        sync_sensor_recorder(resolved, existing)          # a --ros2-mcap recording gets what the wire gets
        return existing
    refs, bases, rates = [], [], []
    for comp, spec, cls in (registry or default_registry()).classes_in(resolved):
        ports = [p for p, o in cls.outputs.items() if o.role in (LIDAR_SCAN, CAMERA_FRAME)]
        for port in ports:
            refs.append(f"{comp}.{port}")
            bases.append(f"/{comp}" if len(ports) == 1 else f"/{comp}/{port}")
        if ports and spec.rate:
            rates.append(spec.rate)
    if not refs:
        return None
    name = _free_name(resolved, SENSOR_BRIDGE)
    fastest = max(rates, default=COMMANDS_RATE)
    rate = 1.0 / (nearest_period(fastest, resolved.sim.dt) * resolved.sim.dt)
    from .sensor_frames import sensor_mounts        # where each sensor frame hangs in the tf tree

    mounts, robot = sensor_mounts(resolved, registry or default_registry())
    resolved.components[name] = ComponentSpec(type=SENSOR_BRIDGE, rate=rate, uses={"robot": robot} if robot else {},
                                              params={**(params or {}), "sensors": refs, "bases": bases,
                                                      "mounts": mounts})
    resolved.connections.extend((ref, f"{name}.sensor{i}", "--ros2") for i, ref in enumerate(refs))
    resolved.where[name] = "--ros2"
    sync_sensor_recorder(resolved, name)
    return name


def _attach_publisher(resolved: Resolved, registry=None, params: dict | None = None) -> str:
    from snakesim.components.sensors import ForceTorqueSensors, Imu
    from snakesim.components.viz.attach import provides_robot
    from snakesim.framework.registry import default_registry

    existing = next((n for n, s in resolved.components.items()
                     if s.type == "ros2_publisher" and resolved.where.get(n) == "--ros2"), None)
    if existing is not None:
        spec = resolved.components[existing]
        resolved.components[existing] = ComponentSpec(type=spec.type, params={**spec.params, **(params or {})},
                                                      rate=spec.rate, uses=spec.uses)
        return existing
    registry = registry or default_registry()
    name = _free_name(resolved, NAME)
    sink: dict = {}
    uses: dict = {}
    conns: list[tuple[str, str]] = []
    robot = efforts = imu = fts = None
    for comp, spec, cls in registry.classes_in(resolved):
        outs = cls.outputs
        if robot is None and provides_robot(cls):
            robot = uses["robot"] = comp
            for port, out in outs.items():
                if out.role in ROBOT_ROLES:
                    conns.append((f"{comp}.{port}", f"{name}.{ROBOT_ROLES[out.role]}"))
        if efforts is None:
            port = next((p for p, o in outs.items() if o.role == JOINT_EFFORTS), None)
            if port is not None:
                efforts = comp
                conns.append((f"{comp}.{port}", f"{name}.joint_efforts"))
                sink["effort"] = True
        if imu is None and isinstance(cls, type) and issubclass(cls, Imu):
            prm = _params(cls, spec)
            if prm is not None:
                imu = comp
                conns += [(f"{comp}.{p}", f"{name}.{IMU_ROLES[o.role]}") for p, o in outs.items() if o.role in IMU_ROLES]
                sink.update(imu_frame=prm.link, imu_gyro_noise=prm.gyro_noise, imu_accel_noise=prm.accel_noise)
        if fts is None and isinstance(cls, type) and issubclass(cls, ForceTorqueSensors):
            prm = _params(cls, spec)
            port = next((p for p, o in outs.items() if o.role == SENSOR_WRENCHES), None)
            if prm is not None and port is not None:
                fts = comp
                conns.append((f"{comp}.{port}", f"{name}.sensor_wrenches"))
                sink["wrench_cuts"] = list(prm.cuts)
    sink.update(params or {})
    # the sink ticks at the fastest topic rate, rounded to whole base steps
    rates = {**DEFAULT_RATES, **sink.get("rates", {})}
    fastest = max((r for r in rates.values() if r > 0), default=1.0)
    rate = 1.0 / (nearest_period(fastest, resolved.sim.dt) * resolved.sim.dt)
    resolved.components[name] = ComponentSpec(type="ros2_publisher", params=sink, rate=rate, uses=uses)
    resolved.connections.extend((s, d, "--ros2") for s, d in conns)
    resolved.where[name] = "--ros2"
    return name


def _existing(resolved: Resolved, type_name: str):
    """The name of the ``type_name`` component ``--ros2`` added already, or None."""
    return next((n for n, s in resolved.components.items()
                 if s.type == type_name and resolved.where.get(n) == "--ros2"), None)


def _update_existing(resolved: Resolved, type_name: str, params: dict | None) -> str | None:
    """The ``type_name`` component ``--ros2`` added already, its params updated with ``params`` (an attach
    called again adds nothing twice); None when there is none."""
    existing = _existing(resolved, type_name)
    if existing is not None:
        spec = resolved.components[existing]
        resolved.components[existing] = spec.model_copy(update={"params": {**spec.params, **(params or {})}})
    return existing


def _free_name(resolved: Resolved, base: str) -> str:
    """``base``, or ``base_1``, ``base_2``, ... : the first name no component of the scene has."""
    name, k = base, 1
    while name in resolved.components:
        name, k = f"{base}_{k}", k + 1
    return name


def attach_commands(resolved: Resolved, registry=None, params: dict | None = None,
                    takeover: bool = False) -> str | None:
    """Add (once) a ``ros2_commands`` source wired by declared ports (see the module docstring); update its
    params. ``takeover``: replace the scene's connections into the PID's set-points. Its name, or None
    when the scene has no robot or nothing to wire it to."""
    from snakesim.components.control.pid import JointPid
    from snakesim.components.multibody import Multibody
    from snakesim.components.viz.attach import provides_robot
    from snakesim.framework.registry import default_registry

    registry = registry or default_registry()
    existing = _existing(resolved, COMMANDS)
    if existing is not None and not takeover:
        spec = resolved.components[existing]
        resolved.components[existing] = spec.model_copy(update={"params": {**spec.params, **(params or {})}})
        return existing
    robot = pid = None
    gravity_ok = False
    q_port = None
    pid_params = None
    for comp, spec, cls in registry.classes_in(resolved):
        if robot is None and provides_robot(cls):
            robot = comp
            q_port = next((p for p, o in cls.outputs.items() if o.role == JOINT_POSITIONS), None)
            if isinstance(cls, type) and issubclass(cls, Multibody) and "gravity" in cls.inputs:
                prm = _params(cls, spec)
                gravity_ok = prm is not None and prm.gravity_input == "scale"
        if pid is None and isinstance(cls, type) and issubclass(cls, JointPid):
            pid, pid_params = comp, _params(cls, spec)
    if robot is None:
        return None
    name = existing
    if name is None:
        name = _free_name(resolved, COMMANDS)
    into = {d for s, d, _ in resolved.connections if not s.startswith(f"{name}.")}
    conns: list[tuple[str, str]] = []
    cmd: dict = {}
    if gravity_ok and f"{robot}.gravity" not in into:
        conns.append((f"{name}.gravity", f"{robot}.gravity"))
    cmd["gravity"] = bool(conns)
    joints = False
    if pid is not None:
        targets = {f"{pid}.setpoint": f"{name}.setpoint", f"{pid}.rate_ref": f"{name}.rate"}
        driven = [(s, d, w) for s, d, w in resolved.connections if d in targets]
        if f"{pid}.setpoint" not in into or takeover:
            for c in driven:
                if takeover:
                    log.info("--ros2-commands: %s -> %s (%s) replaced by %s", c[0], c[1], c[2], targets[c[1]])
            resolved.connections[:] = [c for c in resolved.connections if c[1] not in targets]
            conns += [(src, dst) for dst, src in targets.items()]
            joints = True
        else:
            src = next(s for s, d, _ in driven if d == f"{pid}.setpoint")
            log.info("%s: joint commands not accepted: the scene drives %s.setpoint from %s "
                     "(--ros2-commands hands the set-points to ROS 2)", name, pid, src)
        if pid_params is not None:
            cmd["kind_modes"] = {k: g.mode for k, g in pid_params.kind_gains.items() if g.mode is not None}
            cmd["modes"] = {k: g.mode for k, g in pid_params.gains.items() if g.mode is not None}
    cmd["joints"] = joints
    if not conns and existing is None:
        return None                       # nothing to command: not added
    if joints and q_port is not None:
        conns.append((f"{robot}.{q_port}", f"{name}.q"))
    cmd.update(params or {})
    if existing is not None:
        old = resolved.components[existing]
        cmd = {**old.params, **cmd}
        resolved.connections[:] = [c for c in resolved.connections
                                   if not (c[2] == "--ros2" and (c[0].startswith(f"{name}.") or c[1].startswith(f"{name}.")))]
    rate = 1.0 / (nearest_period(COMMANDS_RATE, resolved.sim.dt) * resolved.sim.dt)
    resolved.components[name] = ComponentSpec(type=COMMANDS, params=cmd, rate=rate, uses={"robot": robot})
    resolved.connections.extend((s, d, "--ros2") for s, d in conns)
    resolved.where[name] = "--ros2"
    return name
