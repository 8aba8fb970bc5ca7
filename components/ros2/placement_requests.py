"""Robot placement requests from ROS 2, validated into writes of the multibody's state.

Pure functions of the message, the robot and sim time: each returns the
``(index, values)`` a :class:`~snakesim.framework.state_edit.StateEdit` writes into
the robot provider's continuous state (:mod:`snakesim.components.multibody.state_write`),
or raises :class:`.rejections.Rejected` naming the topic, field and value.

    /sim/set_pose               geometry_msgs/PoseStamped  the root link (the URDF root: the tail of
                                snakesim's designs, its /tf frame) at pose.position (m) and
                                pose.orientation (unit quaternion, normalised here), both in
                                header.frame_id, which must be the world frame; every velocity (the
                                base's and the joints') set to zero: the robot is placed at rest;
                                joint angles unchanged
    /sim/set_joint_positions    sensor_msgs/JointState     name[i] to position[i] (rad) for DOF joints by
                                URDF name, their rates to zero; velocity and effort must be empty
                                (a placement sets no motion)

Rejected: a frame other than the world frame (an empty one too), a stamped header older than sim time
by more than ``max_age`` (stale), a non-finite position or orientation component, an orientation of
norm 0, an empty or unknown or repeated joint name, a position list whose length is not that of the
names, a non-finite angle or one with |angle| > ``max_abs_position``, a non-empty velocity or effort.
"""

from __future__ import annotations

import math

import numpy as np

from snakesim.components.multibody import state_write

from .rejections import Rejected, check_stamp

POSE_TOPIC = "/sim/set_pose"
JOINTS_TOPIC = "/sim/set_joint_positions"


def pose_write(msg, robot, t: float, world_frame: str, max_age: float) -> tuple[np.ndarray, np.ndarray]:
    """/sim/set_pose: the root link's pose and every velocity zero."""
    fid = msg.header.frame_id
    if fid != world_frame:
        raise Rejected(f"{POSE_TOPIC}: header.frame_id = '{fid}' is not the world frame '{world_frame}' "
                       "(poses are placed in the world frame only)")
    check_stamp(POSE_TOPIC, msg.header, t, max_age)
    p, o = msg.pose.position, msg.pose.orientation
    try:
        idx, values = state_write.base_pose(robot, (p.x, p.y, p.z), (o.x, o.y, o.z, o.w))
    except ValueError as e:
        raise Rejected(f"{POSE_TOPIC}: pose.{e}") from None
    rest_idx, rest = state_write.at_rest(robot)
    return np.concatenate([idx, rest_idx]), np.concatenate([values, rest])


def joint_positions_write(msg, robot, t: float, max_age: float, max_abs_position: float):
    """/sim/set_joint_positions: the named joints' angles, their rates zero."""
    topic = JOINTS_TOPIC
    check_stamp(topic, msg.header, t, max_age)
    names, pos = list(msg.name), list(msg.position)
    if not names:
        raise Rejected(f"{topic}: name is empty")
    if len(pos) != len(names):
        raise Rejected(f"{topic}: position has {len(pos)} values for {len(names)} name (expected {len(names)})")
    for field in ("velocity", "effort"):
        if len(getattr(msg, field)):
            raise Rejected(f"{topic}: {field} must be empty (a placement sets angles only, at rest)")
    seen = {}
    for k, (n, v) in enumerate(zip(names, pos)):
        if n not in robot.dof_of:
            raise Rejected(f"{topic}: name[{k}] = '{n}' is not a joint of the robot (joints: {', '.join(robot.joints)})")
        if n in seen:
            raise Rejected(f"{topic}: name[{k}] = '{n}' appears twice")
        if not math.isfinite(v):
            raise Rejected(f"{topic}: position[{k}] ({n}) = {v} is not finite")
        if abs(v) > max_abs_position:
            raise Rejected(f"{topic}: position[{k}] ({n}) = {v:g} is out of range (|value| <= {max_abs_position:g})")
        seen[n] = float(v)
    return state_write.joint_positions(robot, seen)
