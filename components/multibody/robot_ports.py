"""Port shapes and element names sized by the robot: one place for what robot-facing components declare.

A component that ``Uses(RobotModel)`` learns its robot at build time, so its ports give callables,
resolved on the built component ``c`` (``framework/signals.py``'s ``resolve_shape``)::

    q = Input(shape=joint_shape, unit="rad", names=joint_names)            # (nj,): tau, joint_q, set-points
    link_poses = Input(shape=link_shape(7), unit=None)                      # (nl, 7): [x, y, z, qx, qy, qz, qw]
    wrenches = Output(shape=link_shape(6), names=link_element_names(SIX))  # (nl, 6), "tail.fx", ...

The order is the :class:`RobotModel`'s: DOF joints in URDF order, links in document order; so every
port declared through these agrees with the multibody's ``tau``/``joint_q`` and ``link_poses`` by
construction. (``joint_shape`` is a shape; ``control.joint_selection.per_joint`` is the different thing
that spreads values given by name or pattern over the joints.)
"""

from __future__ import annotations

from typing import Callable


def joint_shape(c) -> tuple[int]:
    """Shape (nj,): one value per DOF joint of ``c.robot`` (rad, rad/s, N·m: the port says)."""
    return (c.robot.nj,)


def joint_names(c) -> tuple[str, ...]:
    """Element names of a per-joint port: the DOF joint names, in ``tau``/``joint_q`` order."""
    return c.robot.joints


def link_shape(*tail: int) -> Callable[..., tuple[int, ...]]:
    """Shape (nl, *tail): one row per link of ``c.robot`` (``link_shape(7)`` poses, ``link_shape(6)`` twists or
    wrenches, ``link_shape(3, 3)`` rotation matrices)."""

    def shape(c) -> tuple[int, ...]:
        return (c.robot.nl, *tail)

    return shape


def link_element_names(suffixes: tuple[str, ...]) -> Callable[..., tuple[str, ...]]:
    """Element names of a per-link port: ``<link>.<suffix>`` for every link, then every suffix
    (row-major, as the (nl, len(suffixes)) array is laid out)."""

    def names(c) -> tuple[str, ...]:
        return tuple(f"{b}.{s}" for b in c.robot.links for s in suffixes)

    return names
