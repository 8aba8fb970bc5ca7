"""The ports every joint set-point source declares alike, and the gaits' command inputs.

A set-point source (``joint_setpoints``, ``serpenoid_gait``, ``helical_gait``, ``csv_trajectory``,
``screw_schedule``, ``ros2_commands``) writes what the PID reads::

    setpoint[nj]   rad (position-mode joints) or rad/s (velocity-mode joints): the PID's mode says
    rate[nj]       rad/s, d(setpoint)/dt (the PID's rate_ref; 0 for a held value)

both named by the DOF joints in the multibody's order. A command input (a gait's amplitude, a
brace's target force) is shape (1,) and NaN until something commands it: the component then uses
its own parameter (``gaits.command`` reads it).
"""

from __future__ import annotations

import numpy as np

from snakesim.components.multibody.robot_ports import joint_names, joint_shape
from snakesim.framework import Input, Output


def setpoint_outputs(feedthrough: tuple[str, ...] = ()) -> tuple[Output, Output]:
    """(setpoint, rate): a set-point source's two outputs; ``feedthrough`` the inputs they read in the
    same tick (none for a source driven by time alone). Unpack in the class body, in this order."""
    return (Output(shape=joint_shape, unit=None, feedthrough=feedthrough, names=joint_names),
            Output(shape=joint_shape, unit="rad/s", feedthrough=feedthrough, names=joint_names))


def command_input(unit: str) -> Input:
    """A command input in ``unit``: shape (1,), NaN while not commanded."""
    return Input(shape=(1,), unit=unit, default=np.nan)
