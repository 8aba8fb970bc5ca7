"""``snakesim run --odometry [LINK]``: an ``odometry`` component (components/sensors/odometry.py) on any robot
scene (``--terrain-map``: terrain_map_cli.py).

Finds, by what the classes declare (never by names), the component providing the robot
(``Provides(RobotModel)``) and its LINK_POSES / LINK_VELOCITIES outputs, and adds ``odometry`` (at
:data:`~.odometry.DEFAULT_RATE`, 50 Hz) on LINK (default: the robot's root link), wired to both and with
its truth and estimate ports recorded (``--out`` keeps them). ``--ros2`` publishes it on /odom/ground_truth
and /odom, ``--ros2-mcap`` records those topics (components/ros2/odometry_attach.py): those options add
sinks and run after this one. A link the robot does not have is a clear error at build, naming the link
and listing the robot's. ``snakesim check`` takes the same option (``for_check``).
"""

from __future__ import annotations

import click

from snakesim.framework import hookimpl

OPTION = "--odometry"
NAME = "odometry"
#: the ports recorded: truth and estimate (the 6x6 covariances are left to a scene's own ``record``)
RECORDED = ("pose", "twist", "estimate_pose", "estimate_twist")
#: the value ``--odometry`` alone gets: the robot's root link
ROOT = ""


def robot_with_link_ports(resolved, registry, option: str = OPTION):
    """(robot component, its LINK_POSES port, its LINK_VELOCITIES port)."""
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.port_roles import LINK_POSES, LINK_VELOCITIES
    from snakesim.framework.errors import ConfigError

    for comp, _spec, cls in registry.classes_in(resolved):
        if not any(issubclass(p.kind, RobotModel) for p in getattr(cls, "provides", {}).values()):
            continue
        poses = [p for p, o in cls.outputs.items() if o.role == LINK_POSES]
        vels = [p for p, o in cls.outputs.items() if o.role == LINK_VELOCITIES]
        if poses and vels:
            return comp, poses[0], vels[0]
    raise ConfigError(f"{option.lstrip('-')} needs a robot: no component provides one with link poses and "
                      "velocities (a multibody)", option)


def attach_odometry_sensor(resolved, link: str | None = None, registry=None) -> str:
    """Add the ``odometry`` component on ``link`` (None or '': the robot's root), wired by port role and its
    truth and estimate ports recorded. Its name."""
    from snakesim.framework.assembly import ComponentSpec
    from snakesim.framework.errors import ConfigError
    from snakesim.framework.registry import default_registry

    from .odometry import DEFAULT_RATE

    if NAME in resolved.components:
        raise ConfigError(f"the scene already has a component named '{NAME}'", OPTION)
    robot, poses, vels = robot_with_link_ports(resolved, registry or default_registry())
    params = {"link": link} if link else {}
    resolved.components[NAME] = ComponentSpec(type="odometry", rate=DEFAULT_RATE, params=params,
                                              uses={"robot": robot})
    resolved.connections.append((f"{robot}.{poses}", f"{NAME}.link_poses", OPTION))
    resolved.connections.append((f"{robot}.{vels}", f"{NAME}.link_velocities", OPTION))
    have = {ref for ref, _ in resolved.record}
    resolved.record.extend((f"{NAME}.{port}", OPTION) for port in RECORDED if f"{NAME}.{port}" not in have)
    resolved.where[NAME] = OPTION
    return NAME


def _odometry(resolved, value):
    if value is None:
        return
    attach_odometry_sensor(resolved, value or None)


# added before the sinks (--ros2, --ros2-mcap wire what they find: not adds_sink); `snakesim check
# --odometry` builds what `run` would
_odometry.for_check = True


@hookimpl(specname="snakesim_run_options")
def sensors_run_options():
    from .terrain_map_cli import terrain_map_options

    return [
        (click.Option([OPTION], is_flag=False, flag_value=ROOT, default=None, metavar="[LINK]",
                      help="Add odometry (50 Hz: the link's true pose and twist, and a dead-reckoning estimate) "
                           "of LINK (default: the robot's root link), recorded; on /odom and /odom/ground_truth "
                           "with --ros2 / --ros2-mcap"), _odometry),
        *terrain_map_options(),
    ]
