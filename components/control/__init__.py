"""Joint control (paper 2.2.5): PID controllers, spring-dampers, gait sources, schedules."""

from .gaits import JointSetpoints, SerpenoidGait
from .pid import DEFAULT_GAINS, JointGains, JointPid
from .schedule import Schedule
from .spring_damper import JointSpringDamper
from .trajectory import CsvTrajectory

__all__ = ["DEFAULT_GAINS", "CsvTrajectory", "JointGains", "JointPid", "JointSetpoints", "JointSpringDamper",
           "Schedule", "SerpenoidGait"]
