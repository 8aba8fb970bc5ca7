"""Registers snakesim's built-in components through the public hook.

Third-party packages do exactly this in their own module, named by an entry
point in the ``snakesim`` group (see docs/plugins.md).
"""

from snakesim.framework import hookimpl

# Component classes and the command-line hooks load on first use: `snakesim --help` lists the commands
# without importing a physics module (bench/cli_startup.py).


def builtin_components() -> tuple:
    from .contact.point_contact import PointContact
    from .contact.hull import HullContact
    from .control.screw_drive import ScrewDrive
    from .contact.screw_sdf import ScrewSdfContact
    from .contact.body_contact import BodyContact
    from .control import CsvTrajectory, HelicalGait, JointPid, JointSetpoints, JointSpringDamper, Schedule, SerpenoidGait
    from .examples.mass_spring import PointMass, SpringDamper
    from .examples.pendulum import Pendulum, ViscousDamper
    from .monitors import MobilityMonitor
    from .monitors.vertical_mobility import VerticalMobilityEvaluation
    from .monitors.traverse import TraverseEvaluation
    from .monitors.terrain_clearance import TerrainClearance
    from .monitors.joint_limits import JointLimits
    from .control.brace_climb import BraceClimb
    from .monitors.planar_pose import PlanarPose
    from .control.screw_schedule import ScrewSchedule
    from .multibody import Multibody
    from .perception import PERCEPTION
    from .placement import PLACEMENT
    from .terrain import TerrainSource
    from .signals.blocks import Gain, Sum, ZeroOrderHold
    from .signals.sources import Constant, Sine, Step
    from .sensors import ForceTorqueSensors, Imu
    from .sensors.fts_wall_loads import FtsWallLoads
    from .sensors.odometry import Odometry
    from .sensors.terrain_map import TerrainMap
    from .tethers import Tethers, WrenchSum
    from .viz import RerunSink
    from .ros2 import Ros2Commands, Ros2Publisher, Ros2SensorBridge, Ros2SimControl, Ros2TetherCommands
    from .ros2.mcap_recorder import Ros2McapRecorder
    from .ros2.sensor_mcap import Ros2SensorMcap
    from .ros2.gait_commands import Ros2GaitCommands
    from .ros2.brace_commands import Ros2BraceCommands
    from .ros2.odometry_attach import Ros2Odometry, Ros2OdometryMcap
    from .ros2.terrain_map_attach import Ros2TerrainMap, Ros2TerrainMapMcap
    from .sensors.terrain_map_files import TerrainMapFiles
    from .thermal import THERMAL
    from .terramechanics import TERRAMECHANICS

    return (Constant, Step, Sine, Gain, Sum, ZeroOrderHold, Pendulum, ViscousDamper, PointMass, SpringDamper,
            PointContact, HullContact, TerrainSource, Multibody, ScrewSdfContact, BodyContact, ScrewDrive,
            JointPid, JointSpringDamper, JointSetpoints, SerpenoidGait, HelicalGait, CsvTrajectory, Schedule, ForceTorqueSensors, FtsWallLoads,
            Imu, Odometry, TerrainMap, Tethers, WrenchSum, MobilityMonitor, VerticalMobilityEvaluation, TraverseEvaluation, TerrainClearance, JointLimits, BraceClimb, RerunSink, PlanarPose, ScrewSchedule, Ros2Publisher,
            Ros2Commands, Ros2SensorBridge, Ros2SimControl, Ros2McapRecorder, Ros2SensorMcap, Ros2TetherCommands,
            Ros2GaitCommands, Ros2BraceCommands, Ros2Odometry, Ros2OdometryMcap, Ros2TerrainMap, Ros2TerrainMapMcap,
            TerrainMapFiles, *TERRAMECHANICS, *PLACEMENT, *PERCEPTION, *THERMAL)


def __getattr__(name):
    if name == "BUILTIN":           # the tuple this module used to hold; kept for code that reads it
        return builtin_components()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@hookimpl
def snakesim_add_commands(cli):
    from snakesim.framework.cli import lazy_command

    cli.add_command(lazy_command("replay", "snakesim.components.viz.cli:replay_command",
                                 "Turn a finished `snakesim run --out RUN_DIR` folder into a rerun recording."))
    cli.add_command(lazy_command("fit-friction", "snakesim.components.contact.friction_fit_cli:fit_friction",
                                 "Fit mu and ||e_v|| from screw drag tests; write a materials file."))
    cli.add_command(lazy_command("robot", "snakesim.robots.cli:robot",
                                 "Robot descriptions: write a design's URDF for N modules, with its meshes."))
    cli.add_command(lazy_command("mcap", "snakesim.components.ros2.mcap_cli:mcap",
                                 "MCAP recordings (--ros2-mcap): recover a killed run's file."))
    cli.add_command(lazy_command("terrain", "snakesim.components.terrain.cli:terrain",
                                 "Terrains: write a terrain's signed-distance volume (ground truth for mappers)."))


@hookimpl
def snakesim_run_options():
    # one group, in the order the options always had: the viewer, ROS 2, its recorder, the sensors
    from .perception.cli import perception_run_options
    from .sensors.cli import sensors_run_options
    from .ros2.cli import ros2_run_options
    from .ros2.mcap_cli import ros2_mcap_run_options
    from .viz.cli import viz_run_options

    return [*viz_run_options(), *ros2_run_options(), *ros2_mcap_run_options(), *perception_run_options(),
            *sensors_run_options(), terrain_run_option()]


def terrain_run_option():
    # --terrain is the shorthand --set terrain=... (snakesim_cli_shorthands); given, the robot is also put
    # on the new terrain, or the run refused with the reason (placement/terrain_swap.py): one rule, every kind
    import click

    from .placement.terrain_swap import apply_terrain_option

    return (click.Option(["--terrain", "terrain"], default=None, help="Terrain: a name in terrains/ or a YAML/mesh "
                         "path; the robot is placed on it"), apply_terrain_option)


@hookimpl
def snakesim_register_components(registry):
    for cls in builtin_components():
        registry.add_component(cls)


@hookimpl
def snakesim_register_terrain_kinds(registry):
    # the kinds terrain YAML can name: plane, tube, parallel_walls, u_channel, moulin, dem, obstacles, mesh
    from .terrain.builtin_kinds import builtin_terrain_kinds

    for kind in builtin_terrain_kinds():
        registry.add_terrain_kind(kind)


@hookimpl
def snakesim_register_robot_designs(registry):
    # the designs a multibody's `design:` can name: the EELS family (robots/designs.py)
    from snakesim.robots.registration import builtin_robot_designs

    for design in builtin_robot_designs():
        registry.add_robot_design(design)


@hookimpl
def snakesim_register_ray_casters(registry):
    # the back ends sensor_scene's `ray_caster` can name: embree (perception/ray_caster.py), raster
    # (perception/raster.py: pinhole images rasterised, the rest Embree's)
    from .perception.raster import RASTER
    from .perception.ray_caster import EMBREE

    registry.add_ray_caster(EMBREE)
    registry.add_ray_caster(RASTER)


@hookimpl
def snakesim_cli_shorthands():
    # scene parameters every robot scene declares: swapping the robot or the
    # terrain is then one flag on any scene
    return [
        ("--robot", "robot.name", "Robot design (eels-concept, eels-1.0, eels-1.0-front, eels-1.5, mini-eels-1.0)"),
        ("--modules", "robot.modules", "Number of modules"),
        ("--head", "robot.head", "Perception head / cap on or off (true/false; default: the design's)"),
        ("--urdf", "robot.urdf", "Your URDF, checked against the chosen design's structure"),
        ("--terrain", "terrain", "Terrain: a name in terrains/ or a YAML/mesh path"),
    ]
