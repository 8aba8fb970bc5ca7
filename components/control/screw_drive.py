"""Screw speed drive: a velocity servo on every screw DOF and a PD lock on every other joint.

A stand-in for the control components (PID per joint) so contact scenes can drive their
screws; it knows which DOFs are screws from the robot description (robot_screws.py).

    screw DOF j:  τ_j = sat(k_v (ω − v_j))             (ω the set speed of the DOF: the front
                                                         screw's; its mimic turns at −ω)
    other DOF j:  τ_j = sat(k_p (0 − q_j) − k_d v_j)    (bend/twist held straight)

sat clips at ±tau_max (no limit when None). A pure velocity servo settles with a speed
error τ_load / k_v; scenes that need the exact speed read joint_v.

uses robot: RobotModel                     (the multibody's)
in   joint_q[nj] rad, joint_v[nj] rad/s   (multibody joint_q, joint_v)
out  tau[nj] N·m                          (feedthrough from both; to multibody.tau)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape

from ..contact.robot_screws import screw_layout


class ScrewDriveParams(Params):
    omega: float = Field(0.0, description="rad/s, set spin rate of every screw DOF")
    kv: float = Field(5.0, ge=0, description="N·m·s/rad, screw velocity gain")
    kp: float = Field(500.0, ge=0, description="N·m/rad, lock stiffness of the other joints")
    kd: float = Field(20.0, ge=0, description="N·m·s/rad, lock damping of the other joints")
    tau_max: float | None = Field(None, gt=0, description="N·m, symmetric torque limit")


class ScrewDrive(Component[ScrewDriveParams]):
    type_name = "screw_drive"
    robot = Uses(RobotModel)
    joint_q = Input(shape=joint_shape, unit="rad", names=joint_names)
    joint_v = Input(shape=joint_shape, unit="rad/s", names=joint_names)
    tau = Output(shape=joint_shape, unit="N*m", feedthrough=True, names=joint_names)

    def setup(self):
        p = self.p
        self.screws = lay = self.robot.derived(screw_layout)
        screw = np.zeros(self.robot.nj, dtype=bool)
        screw[lay.spin_dof] = True
        self._kp = np.where(screw, 0.0, p.kp)
        self._kd = np.where(screw, p.kv, p.kd)
        self._v_ref = np.where(screw, p.omega, 0.0)
        self.screw_dofs = np.flatnonzero(screw)
        self._jac = None

    def port_jacobian(self, port, t, x, u, y):
        """∂tau/∂joint_q = −k_p, ∂tau/∂joint_v = −k_d (k_v on screws); zero where saturated."""
        from snakesim.framework.linearization import Elementwise
        if port != "tau":
            return None
        n = self.robot.nj
        rows = np.arange(n)
        if self.p.tau_max is None:
            if self._jac is None:           # a constant: the same object every time
                self._jac = Elementwise(n, (("joint_q", rows, rows, -self._kp), ("joint_v", rows, rows, -self._kd)))
            return self._jac
        live = (np.abs(y.tau) < self.p.tau_max).astype(float)
        return Elementwise(n, (("joint_q", rows, rows, -self._kp * live), ("joint_v", rows, rows, -self._kd * live)))

    def output(self, t, x, u, y):
        tau = y.tau
        np.subtract(self._v_ref, u.joint_v, out=tau)
        tau *= self._kd                  # k_v (ω − v) on screws, −k_d v elsewhere
        tau -= self._kp * u.joint_q
        if self.p.tau_max is not None:
            np.clip(tau, -self.p.tau_max, self.p.tau_max, out=tau)
