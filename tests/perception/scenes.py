"""Sensor test scenes: a robot whose link poses the test sets, on a terrain given inline.

``world_at(terrain, poses)`` runs the real ``sensor_scene`` component (Harness) and
returns its SensorWorld; ``lidar_pose`` puts the ``lidar`` link (and every other link)
at one pose so beams start where the test says.
"""

from __future__ import annotations

import numpy as np

from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.perception import SensorScene
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.0")
USES = {"robot": ROBOT}
F32 = float(np.finfo(np.float32).eps)


def terrain(spec: dict):
    return load_terrain(spec)


def all_links_at(position, quat_xyzw=(0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, :3] = position
    poses[:, 3:] = quat_xyzw
    return poses


def initial_link_poses() -> np.ndarray:
    """The robot's link poses at its initial state (straight, tail at the origin), from the multibody."""
    h = Harness(Multibody, {"design": "eels-1.0"})
    return np.array(h.outputs()["link_poses"])


def world_at(terrain_obj, poses, **params):
    """The sensor_scene's world; the robot is visible only where a test says so (``all_links_at``
    stacks every link at one point)."""
    params.setdefault("robot_visible", False)
    h = Harness(SensorScene, params, uses=USES)
    if terrain_obj is not None:
        h.inputs.terrain = terrain_obj
    h.inputs.link_poses = poses
    return h.outputs()["world"]
