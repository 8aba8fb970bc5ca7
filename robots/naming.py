"""Systematic link and joint names of generated EELS robots.

dm_control style: a role followed by the module index as two zero-padded
digits (``module_03``, ``bend_03``, ``screw_front_03``). Modules are numbered
from the tail, starting at 00. Links and joints never share a name, so every
name is unambiguous in Pinocchio's frame list.
"""

from __future__ import annotations

TAIL = "tail"
HEAD = "head"  # perception head link
HEAD_JOINT = "head_joint"
HEAD_CAP = "head_cap"
HEAD_CAP_JOINT = "head_cap_joint"
HEAD_SENSOR_FRAMES = ("imu", "lidar", "camera_left", "camera_right")
CROSS_BAR = "cross_bar"
CROSS_BAR_JOINT = "cross_bar_joint"
AVIONICS_BOX = "avionics_box"
AVIONICS_BOX_JOINT = "avionics_box_joint"


def _indexed(role: str, index: int) -> str:
    if not 0 <= index <= 99:
        raise ValueError(f"module index {index} does not fit two digits (0..99)")
    return f"{role}_{index:02d}"


def module_link(i: int) -> str:
    return _indexed("module", i)


def knuckle_link(i: int) -> str:
    return _indexed("knuckle", i)


def bend_joint(i: int) -> str:
    return _indexed("bend", i)


def twist_joint(i: int) -> str:
    return _indexed("twist", i)


def screw_joint(position: str, i: int) -> str:
    """``position`` is ``"front"`` or ``"rear"``."""
    return _indexed(f"screw_{position}", i)


def screw_link(position: str, i: int) -> str:
    return _indexed(f"screw_{position}_link", i)


def fts_link(i: int) -> str:
    return _indexed("fts", i)


def fts_joint(i: int) -> str:
    return _indexed("fts_joint", i)


def sensor_joint(frame: str) -> str:
    return f"{frame}_joint"
