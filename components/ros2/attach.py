"""Adds a ROS 2 publisher to a resolved scene: what ``snakesim run --ros2`` does before the build.

Found by what the classes declare, never by component or port names:

    robot     the first component that provides the RobotModel (the publisher uses that robot);
              its outputs of roles LINK_POSES, JOINT_POSITIONS, JOINT_VELOCITIES are wired in
    efforts   the first output of role JOINT_EFFORTS (the torques commanded to the robot: a PID)
    imu       an ``imu`` component (class Imu): its IMU_* outputs, its link as frame_id and its noise
              as covariances
    fts       a ``force_torque_sensors`` component (class ForceTorqueSensors): its SENSOR_WRENCHES
              output and its cuts (one WrenchStamped topic per sensor)

``--ros2-domain N`` and ``--ros2-interface IF`` imply ``--ros2`` and set the publisher's params.
"""

from __future__ import annotations

from snakesim.framework.assembly import ComponentSpec, Resolved
from snakesim.framework.rates import nearest_period

from snakesim.components.port_roles import (IMU_ANGULAR_RATE, IMU_ORIENTATION, IMU_SPECIFIC_FORCE, JOINT_EFFORTS,
                                            JOINT_POSITIONS, JOINT_VELOCITIES, LINK_POSES, SENSOR_WRENCHES)

from .publisher import DEFAULT_RATES

NAME = "ros2"
ROBOT_ROLES = {LINK_POSES: "link_poses", JOINT_POSITIONS: "joint_positions", JOINT_VELOCITIES: "joint_velocities"}
IMU_ROLES = {IMU_ANGULAR_RATE: "imu_angular_rate", IMU_SPECIFIC_FORCE: "imu_specific_force",
             IMU_ORIENTATION: "imu_orientation"}


def _classes(resolved: Resolved, registry):
    for name, spec in resolved.components.items():
        try:
            yield name, spec, registry.component(spec.type)
        except Exception:            # unknown type: the build reports it, naming file and key
            continue


def _params(cls, spec):
    try:
        return cls.Params(**(spec.params or {}))
    except Exception:                # the build reports invalid params, naming file and key
        return None


def attach_ros2(resolved: Resolved, registry=None, params: dict | None = None) -> str:
    """Add (once) a ``ros2_publisher`` to ``resolved``, wired by port role; update its params. Its name."""
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
    name, k = NAME, 1
    while name in resolved.components:
        name, k = f"{NAME}_{k}", k + 1
    sink: dict = {}
    uses: dict = {}
    conns: list[tuple[str, str]] = []
    robot = efforts = imu = fts = None
    for comp, spec, cls in _classes(resolved, registry):
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
