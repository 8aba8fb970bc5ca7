"""Registers snakesim's built-in components through the public hook.

Third-party packages do exactly this in their own module, named by an entry
point in the ``snakesim`` group (see docs/plugins.md).
"""

from snakesim.framework import hookimpl

from .contact.friction_fit_cli import snakesim_add_commands  # noqa: F401  (hookimpl: `snakesim fit-friction`)
from .contact.point_contact import PointContact
from .contact.hull import HullContact
from .control.screw_drive import ScrewDrive
from .contact.screw_sdf import ScrewSdfContact
from .control import CsvTrajectory, JointPid, JointSetpoints, JointSpringDamper, Schedule, SerpenoidGait
from .examples.mass_spring import PointMass, SpringDamper
from .examples.pendulum import Pendulum, ViscousDamper
from .monitors import MobilityMonitor
from .monitors.planar_pose import PlanarPose
from .control.screw_schedule import ScrewSchedule
from .multibody import Multibody
from .perception import PERCEPTION
from .perception.cli import perception_run_options  # noqa: F401  (hookimpl: --lidar, --stereo)
from .placement import PLACEMENT
from .terrain import TerrainSource
from .signals.blocks import Gain, Sum, ZeroOrderHold
from .signals.sources import Constant, Sine, Step
from .sensors import ForceTorqueSensors, Imu
from .tethers import Tethers, WrenchSum
from .viz import RerunSink
from .ros2 import Ros2Commands, Ros2Publisher, Ros2SensorBridge, Ros2SimControl, Ros2TetherCommands
from .ros2.cli import ros2_run_options  # noqa: F401  (hookimpl: --ros2)
from .ros2.mcap_cli import ros2_mcap_run_options  # noqa: F401  (hookimpl: --ros2-mcap)
from .ros2.mcap_recorder import Ros2McapRecorder
from .viz.cli import viz_add_commands, viz_run_options  # noqa: F401  (hookimpls: --viz, `snakesim replay`)

BUILTIN = (Constant, Step, Sine, Gain, Sum, ZeroOrderHold, Pendulum, ViscousDamper, PointMass, SpringDamper,
           PointContact, HullContact, TerrainSource, Multibody, ScrewSdfContact, ScrewDrive,
           JointPid, JointSpringDamper, JointSetpoints, SerpenoidGait, CsvTrajectory, Schedule, ForceTorqueSensors,
           Imu, Tethers, WrenchSum, MobilityMonitor, RerunSink, PlanarPose, ScrewSchedule, Ros2Publisher, Ros2Commands, Ros2SensorBridge,
           Ros2SimControl, Ros2McapRecorder, Ros2TetherCommands,
           *PLACEMENT, *PERCEPTION)


@hookimpl
def snakesim_register_components(registry):
    for cls in BUILTIN:
        registry.add_component(cls)


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
