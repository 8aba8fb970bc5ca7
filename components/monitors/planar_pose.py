"""Planar pose of one link: x, y and heading (yaw) of its body axis, as a motion-capture rig sees it.

Paper 4.2 measured the free tail's "two-dimensional pose (XY position and yaw angle)" with
VICON. For link j with origin o and axes R (world)::

    x, y = o_x, o_y                               m, world
    yaw  = atan2(â_y, â_x),  â = R·axis            rad in (−π, π]: heading of the body axis
                                                   projected on the ground plane (x-y)

The heading is taken from the body axis (default x: tail to head), not from the link's full
rotation, so a robot lying rolled on its side (a crescent bent in the ground plane) reads the
same yaw as one lying upright.

in   link_poses[nl, 7], link_rotations[nl, 3, 3]   from the multibody
out  pose[3]  [x m, y m, yaw rad]   (feedthrough)
uses robot: RobotModel (the multibody's): the link row
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses

Vec3 = tuple[float, float, float]


class PlanarPoseParams(Params):
    link: str = Field("tail", description="link whose pose is reported")
    axis: Vec3 = Field((1.0, 0.0, 0.0), description="body axis in the link frame")


class PlanarPose(Component[PlanarPoseParams]):
    type_name = "planar_pose"
    robot = Uses(RobotModel)
    link_poses = Input(shape=link_shape(7), unit=None)
    link_rotations = Input(shape=link_shape(3, 3), unit="1")
    pose = Output(shape=(3,), unit=None, feedthrough=True, names=("x", "y", "yaw"))

    def setup(self):
        links = self.robot.links
        if self.p.link not in links:
            raise ValueError(f"{self.name}: link '{self.p.link}' is not a link of the robot; links: {', '.join(links)}")
        a = np.asarray(self.p.axis, dtype=float)
        if not np.linalg.norm(a) > 0:
            raise ValueError(f"{self.name}: axis must be non-zero, got {self.p.axis}")
        self._i = self.robot.link_index(self.p.link)
        self._axis = a / np.linalg.norm(a)

    def output(self, t, x, u, y):
        a = u.link_rotations[self._i] @ self._axis
        y.pose[0] = u.link_poses[self._i, 0]
        y.pose[1] = u.link_poses[self._i, 1]
        y.pose[2] = np.arctan2(a[1], a[0])
