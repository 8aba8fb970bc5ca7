"""Wall loads estimated from the force-torque sensor array (paper 2.2.4: the FTS array tells a
vertical-mobility controller about its contact with the walls), what a robot can measure in place of
the simulator's contact forces.

The sensors cut the chain into segments: segment 0 is everything before the first sensor (the tail
side), segment k the links between sensor k and sensor k+1, the last one everything beyond the last
sensor. Each sensor reads the wrench its parent side exerts on its child side (``force_torque_sensors``,
convention parent_on_child), force f_k in its own frame R_k. Newton for segment k, static (a brace,
a hold; accelerations neglected — the estimate's error is the segment's m·a)::

    F_k = R_{k+1} f_{k+1} − R_k f_k − m_k g          (N, world; the first term absent for the last segment,
                                                      the second for segment 0)

F_k is everything else that pushes on segment k: its wall contacts (normal load and friction). The
wall load a brace regulates is its part across gravity (``component: across_gravity``, default: the
normal load when the walls are vertical and friction carries the weight along gravity), its part
along a known wall normal n̂ (``along_normal``: |F_k·n̂|, exact for plane walls whatever the friction
does, e.g. a brace turned so that friction also acts across gravity; the autonomy would take n̂ from
its perception), or its whole magnitude (``total``). Sensor rotations R_k come from the link poses (on the robot: joint encoders and
an IMU); masses from the URDF.

in   wrench[ns, 6]       N, N·m, sensor frames (force_torque_sensors.wrench, parent_on_child)
     link_poses[nl, 7]   role link_poses, from the multibody
out  loads[ns + 1]       N, per segment, tail first
     forces[ns + 1, 3]   N, world, per segment
uses robot: RobotModel (the multibody's): the sensors' links, the segments' masses
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.framework import Component, Input, Output, Params, Uses

Vec3 = tuple[float, float, float]


class FtsWallLoadsParams(Params):
    cuts: list[str] = Field(default_factory=lambda: ["fts_joint_*"],
                            description="the sensors' cuts, as given to force_torque_sensors (same order)")
    gravity: Vec3 = Field((0.0, 0.0, -9.81), description="m/s², world")
    component: Literal["across_gravity", "along_normal", "total"] = Field(
        "across_gravity", description="which part of F_k is the load")
    normal: Vec3 | None = Field(None, description="the walls' normal, world (along_normal only; normalised)")


class FtsWallLoads(Component[FtsWallLoadsParams]):
    type_name = "fts_wall_loads"
    robot = Uses(RobotModel)

    wrench = Input(shape=lambda c: (len(c.sensor_links), 6), unit=None)
    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    loads = Output(shape=lambda c: (len(c.sensor_links) + 1,), unit="N", feedthrough=True)
    forces = Output(shape=lambda c: (len(c.sensor_links) + 1, 3), unit="N", feedthrough=True)

    def setup(self):
        robot, tree = self.robot, self.robot.tree
        try:
            _names, links = robot.cuts(self.p.cuts)
        except ValueError as e:
            raise ValueError(f"{self.name}: cuts: {e}") from None
        if not links:
            raise ValueError(f"{self.name}: the cuts {self.p.cuts} name no sensor of {robot.label}")
        beyond = [set(tree.subtree(ln)) for ln in links]
        for k in range(len(links) - 1):
            if links[k + 1] not in beyond[k]:
                raise ValueError(f"{self.name}: sensor links must follow one another along the chain, tail to "
                                 f"head: '{links[k + 1]}' is not beyond '{links[k]}'")
        self.sensor_links = tuple(links)
        mass = {ln.name: ln.mass for ln in tree.links}
        segments = [set(robot.links) - beyond[0]] + [beyond[k] - (beyond[k + 1] if k + 1 < len(links) else set())
                                                     for k in range(len(links))]
        self._weight = np.array([sum(mass[n] for n in seg) for seg in segments])[:, None] * np.array(self.p.gravity)
        self._rows = np.array([robot.link_index(ln) for ln in links], dtype=np.intp)
        g = np.array(self.p.gravity, float)
        self._down = g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else None
        if self.p.component == "across_gravity" and self._down is None:
            raise ValueError(f"{self.name}: component 'across_gravity' needs a non-zero gravity")
        n = np.array(self.p.normal if self.p.normal is not None else (0.0, 0.0, 0.0), float)
        if self.p.component == "along_normal" and not np.linalg.norm(n) > 0:
            raise ValueError(f"{self.name}: component 'along_normal' needs a non-zero `normal`, got {self.p.normal}")
        self._normal = n / np.linalg.norm(n) if np.linalg.norm(n) > 0 else n

    def output(self, t, x, u, y):
        poses = np.asarray(u.link_poses, float)
        R = rotation_matrices(poses[self._rows, 3:])
        f = np.einsum("kij,kj->ki", R, np.asarray(u.wrench, float)[:, :3])     # world, parent on child
        F = y.forces
        F[:] = -self._weight
        F[:-1] += f          # R_{k+1} f_{k+1} on segment k
        F[1:] -= f           # − R_k f_k on segment k
        if self.p.component == "total":
            y.loads[:] = np.linalg.norm(F, axis=1)
        elif self.p.component == "along_normal":
            y.loads[:] = np.abs(F @ self._normal)
        else:
            along = F @ self._down
            y.loads[:] = np.linalg.norm(F - along[:, None] * self._down, axis=1)
