"""Sensor models: force-torque sensors (paper 2.2.4) and the IMU."""

from .fts import ForceTorqueSensors
from .imu import Imu

__all__ = ["ForceTorqueSensors", "Imu"]
