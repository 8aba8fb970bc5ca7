"""Passive joint spring-dampers, all DOF joints in one vectorised component.

    tau_i = −k_i · (q_i − q0_i) − c_i · v_i      (q − q0 wrapped to (−π, π] on continuous joints)

k (N·m/rad), c (N·m·s/rad) and q0 (rad) by joint name or glob pattern;
joints no key matches get 0 (free). Add to a PID's torque with a ``sum``
block (n = nj) when both drive the multibody.

in   q[nj] rad, v[nj] rad/s    from multibody.joint_q / joint_v
out  tau[nj] N·m               (feedthrough)
uses robot: RobotModel (the multibody's): joint names and which are continuous
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape
from snakesim.framework import Component, Input, Output, Params, Uses

from .joint_selection import finite_or_raise, per_joint, wrap_angle


class SpringDamperParams(Params):
    stiffness: dict[str, float] = Field(default_factory=dict, description="N·m/rad by joint name or pattern")
    damping: dict[str, float] = Field(default_factory=dict, description="N·m·s/rad by joint name or pattern")
    rest: dict[str, float] = Field(default_factory=dict, description="rest angle q0, rad, by joint name or pattern")



class JointSpringDamper(Component[SpringDamperParams]):
    type_name = "joint_spring_damper"
    robot = Uses(RobotModel)

    q = Input(shape=joint_shape, unit="rad")
    v = Input(shape=joint_shape, unit="rad/s")
    tau = Output(shape=joint_shape, unit="N*m", feedthrough=True, names=joint_names)

    def setup(self):
        p, names = self.p, self.robot.joints
        for what in ("stiffness", "damping", "rest"):
            finite_or_raise(getattr(p, what), f"{self.name}: {what}")
        self._k = np.array(per_joint(names, p.stiffness, f"{self.name}: stiffness", 0.0), dtype=float)
        self._c = np.array(per_joint(names, p.damping, f"{self.name}: damping", 0.0), dtype=float)
        self._q0 = np.array(per_joint(names, p.rest, f"{self.name}: rest", 0.0), dtype=float)
        if (self._k < 0).any() or (self._c < 0).any():
            raise ValueError(f"{self.name}: stiffness and damping must be >= 0")
        self._wrap = self.robot.continuous_mask()

    def output(self, t, x, u, y):
        dq = u.q - self._q0
        if self._wrap.any():
            dq = np.where(self._wrap, wrap_angle(dq), dq)
        np.multiply(-self._k, dq, out=y.tau)
        y.tau -= self._c * u.v
