"""Where a sensor sits: a frame fixed to a robot link.

    R_ws = R_wl · R_ls,   p_ws = p_wl + R_wl · xyz

R_wl, p_wl the link's pose (the multibody's ``link_poses`` row), R_ls = R_z(yaw) R_y(pitch)
R_x(roll) from ``rpy`` (URDF convention), ``xyz`` m in the link frame. A lidar's frame is
REP-103 (x forward, y left, z up). A camera's frame is the optical frame (z forward, x
right, y down, as ROS's ``*_optical_frame``); with ``optical: true`` (default) the mount
frame is taken as body-convention (x forward) and turned to optical by R_bo below, so
``link: camera_left`` with no rpy looks along the link's x axis.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from snakesim.components.control.joint_selection import match
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import rpy_matrix

Vec3 = tuple[float, float, float]

#: body (x forward, y left, z up) -> optical (z forward, x right, y down): columns are the
#: optical axes in body coordinates (REP-103's camera_optical_frame, rpy = (−π/2, 0, −π/2))
BODY_TO_OPTICAL = np.array([[0.0, 0.0, 1.0],
                            [-1.0, 0.0, 0.0],
                            [0.0, -1.0, 0.0]])


class SensorMount(BaseModel):
    """A sensor's frame on a robot link."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
    link: str = Field(..., description="robot link (URDF name) the sensor is fixed to")
    xyz: Vec3 = Field((0.0, 0.0, 0.0), description="m, sensor origin in the link frame")
    rpy: Vec3 = Field((0.0, 0.0, 0.0), description="rad, sensor axes in the link frame (URDF roll-pitch-yaw)")


def mount_on(robot: RobotModel, mount: SensorMount, owner: str, optical: bool = False):
    """(link row, R_ls (3, 3), p_ls (3,)) of ``mount`` on ``robot``; a ValueError naming the
    link and listing the robot's links when it does not exist."""
    if mount.link not in robot.links:
        match(robot.links, mount.link, f"{owner}: link")       # raises, listing close names
        raise ValueError(f"{owner}: link must name one link of robot '{robot.label}', not a pattern: "
                         f"'{mount.link}'")
    values = np.r_[mount.xyz, mount.rpy]
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{owner}: xyz and rpy must be finite, got xyz={list(mount.xyz)}, rpy={list(mount.rpy)}")
    R = rpy_matrix(list(mount.rpy))
    if optical:
        R = R @ BODY_TO_OPTICAL
    return robot.link_index(mount.link), R, np.array(mount.xyz, dtype=float)


def rigid_links(robot: RobotModel, row: int) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """The links fixed to link ``row`` (its rigid group: joined by fixed joints, the URDF's
    ``rigid_root``), each as (row, R, p): its frame in link ``row``'s frame. A sensor's rays never move
    against them (``RayBundle``'s ``rigid``)."""
    tree = robot.tree
    name = robot.links[row]
    root = tree.rigid_root(name)
    R_rm, p_rm = tree.placement_in(root, name)
    out = []
    for other, k in robot.link_row.items():
        if k != row and tree.rigid_root(other) == root:
            R_ro, p_ro = tree.placement_in(root, other)
            out.append((int(k), R_rm.T @ R_ro, R_rm.T @ (p_ro - p_rm)))
    return sorted(out, key=lambda e: e[0])


def quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix, w ≥ 0 (Shepperd's method: the largest of
    w², x², y², z² picks the stable branch). Called per sample: written out, not scipy's (~0.5 ms)."""
    m = R
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    i = int(np.argmax((tr, m[0, 0], m[1, 1], m[2, 2])))
    if i == 0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif i == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif i == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    q = np.array(q)
    return q if q[3] >= 0 else -q
