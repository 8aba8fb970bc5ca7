"""Joint control (paper 2.2.5): PID controllers, spring-dampers, gait sources, schedules, and the
screw speed drive (a velocity servo on every screw DOF, a PD lock on the rest) contact scenes use."""

from .gaits import JointSetpoints, SerpenoidGait
from .helical_gait import HelicalGait
from .pid import DEFAULT_GAINS, JointGains, JointPid
from .schedule import Schedule
from .screw_drive import ScrewDrive, ScrewDriveParams
from .spring_damper import JointSpringDamper
from .trajectory import CsvTrajectory

__all__ = ["DEFAULT_GAINS", "CsvTrajectory", "HelicalGait", "JointGains", "JointPid", "JointSetpoints", "JointSpringDamper",
           "Schedule", "ScrewDrive", "ScrewDriveParams", "SerpenoidGait"]
