"""nav_msgs/Odometry: the odometry component's truth and estimate as ROS 2 messages.

The type is generated like every other message snakesim sends (:func:`.messages.ros_type`, from
rosbags' standard ROS 2 definition: DDS type ``nav_msgs::msg::dds_::Odometry_``, plain XCDR1). A
publish patches a message serialised once (:class:`.template.CdrTemplate`): the stamp and the 86
float64 of the pose (position, orientation x, y, z, w), its 6×6 covariance, the twist and its 6×6
covariance, row-major as nav_msgs orders them::

    header.frame_id   the pose's frame (the world frame: the estimate starts at the true pose)
    child_frame_id    the link: the twist is in its axes (nav_msgs/Odometry's convention)
    pose.covariance   [x, y, z, rot X, rot Y, rot Z]² (m², rad²; zero for the truth: exact)
    twist.covariance  [vx, vy, vz, wx, wy, wz]² ((m/s)², (rad/s)²)

tests/sensors/test_odometry.py decodes the bytes with rosbags' own CDR codec and the standard
nav_msgs/msg/Odometry definition.
"""

from __future__ import annotations

import numpy as np

ODOMETRY = "nav_msgs/msg/Odometry"


def odometry_type():
    """The IdlStruct of nav_msgs/msg/Odometry (cyclonedds and rosbags load on first use)."""
    from .messages import ros_type

    return ros_type(ODOMETRY)


def odometry_message(t: float, frame_id: str, child_frame_id: str, pose, twist, pose_covariance=None,
                     twist_covariance=None):
    """One nav_msgs/Odometry (an IdlStruct) at simulated time ``t``: ``pose`` [x, y, z, qx, qy, qz, qw],
    ``twist`` [vx, vy, vz, wx, wy, wz] in the child frame, covariances 6×6 (default 0)."""
    from . import messages as M

    Odometry = odometry_type()
    PoseWithCovariance, TwistWithCovariance = (M.ros_type("geometry_msgs/msg/PoseWithCovariance"),
                                               M.ros_type("geometry_msgs/msg/TwistWithCovariance"))
    Twist = M.ros_type("geometry_msgs/msg/Twist")
    p = [float(v) for v in np.asarray(pose, dtype=float).reshape(7)]
    w = [float(v) for v in np.asarray(twist, dtype=float).reshape(6)]
    pc = [0.0] * 36 if pose_covariance is None else [float(v) for v in np.asarray(pose_covariance).reshape(36)]
    tc = [0.0] * 36 if twist_covariance is None else [float(v) for v in np.asarray(twist_covariance).reshape(36)]
    return Odometry(
        header=M.Header(stamp=M.time_msg(max(t, 0.0)), frame_id=frame_id), child_frame_id=child_frame_id,
        pose=PoseWithCovariance(pose=M.Pose(position=M.Point(*p[:3]), orientation=M.Quaternion(*p[3:])),
                                covariance=pc),
        twist=TwistWithCovariance(twist=Twist(linear=M.Vector3(*w[:3]), angular=M.Vector3(*w[3:])),
                                  covariance=tc))


class OdometryTemplate:
    """A nav_msgs/Odometry serialised once for a frame pair; :meth:`encode` patches stamp and values in place
    and returns the buffer (CDR with its encapsulation header, padded to 4 bytes as DataWriter.write pads)."""

    def __init__(self, frame_id: str, child_frame_id: str):
        from .template import CdrTemplate

        def set_pose(m, v):
            m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z = (float(a) for a in v[:3])
            o = m.pose.pose.orientation
            o.x, o.y, o.z, o.w = (float(a) for a in v[3:7])

        def set_twist(m, v):
            m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z = (float(a) for a in v[:3])
            m.twist.twist.angular.x, m.twist.twist.angular.y, m.twist.twist.angular.z = (float(a) for a in v[3:6])

        def set_pose_cov(m, v):
            m.pose.covariance = [float(a) for a in v]

        def set_twist_cov(m, v):
            m.twist.covariance = [float(a) for a in v]

        msg = odometry_message(0.0, frame_id, child_frame_id, [0, 0, 0, 0, 0, 0, 1], np.zeros(6))
        self.frame_id, self.child_frame_id = frame_id, child_frame_id
        self.tpl = CdrTemplate.of(msg, {"pose": (set_pose, 7), "twist": (set_twist, 6),
                                        "pose_covariance": (set_pose_cov, 36),
                                        "twist_covariance": (set_twist_cov, 36)},
                                  [lambda m, tm: setattr(m.header, "stamp", tm)])

    def encode(self, t: float, pose, twist, pose_covariance=None, twist_covariance=None) -> bytearray:
        ns = int(round(max(t, 0.0) * 1e9))
        tpl = self.tpl
        tpl.set_stamp(*divmod(ns, 1_000_000_000))
        tpl.set_floats("pose", np.asarray(pose, dtype=float).reshape(7))
        tpl.set_floats("twist", np.asarray(twist, dtype=float).reshape(6))
        tpl.set_floats("pose_covariance", 0.0 if pose_covariance is None
                       else np.asarray(pose_covariance, dtype=float).reshape(36))
        tpl.set_floats("twist_covariance", 0.0 if twist_covariance is None
                       else np.asarray(twist_covariance, dtype=float).reshape(36))
        return tpl.buf
