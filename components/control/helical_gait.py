"""Rolling-helix gait source for pitch-yaw chains (Mini EELS 1.0; paper 4.1: climbing small pipes).

A chain whose bend joints alternate pitch (axis y of the joint frame) and yaw (axis z)
bends in any plane through its axis by splitting each pair's bend between the two
families. Index k = 0, 1, ... counts the joints of each family from the tail:

    α_k(t)     = phase + k·φ + ψ(t)                               rad
    dψ/dt      = d·ω for t >= t_start, else 0                      (ω = 2π f, d = direction = ±1)
    ψ(t)       = d_p ω_p max(0, t − t_start) + δ(t)                 (δ: the state, dδ/dt = dψ/dt − d_p ω_p:
                                                                     0 while nothing is commanded)
    θ_pitch,k  = A sin α_k                                        rad
    θ_yaw,k    = A cos α_k                                        rad
    rates      dθ_pitch,k/dt = d ω A cos α_k,  dθ_yaw,k/dt = −d ω A sin α_k   (0 before t_start)

A (rad) is the bend per pair of joints (the curvature vector's magnitude, its direction α in the
body's cross-section): a chain bending A at every other joint puts those joints on a circle of
radius R with chord 2ℓ = 2R sin(A/2), ℓ the joint spacing (m, the module length):

    κ = 1/R = sin(A/2)/ℓ        ⇔   A = 2 arcsin(ℓ κ)
    τ = φ/(2ℓ)                   (φ, rad per pair: the bending plane turns along the body = torsion)

A curve of constant curvature κ and torsion τ is a helix of radius r_h = κ/(κ² + τ²) and
pitch p = 2π τ/(κ² + τ²) (m per turn), so ``helix: {radius, pitch}`` gives
c = p/2π, κ = r_h/(r_h² + c²), τ = c/(r_h² + c²), then A and φ as above (exact for a planar
ring, pitch 0; otherwise the continuum approximation, within the chain's discreteness).

Rolling: α advancing in time at a fixed shape turns the bending plane *in the body*; where the
shape is held by a wall the body instead rolls about its own axis at ω (rad/s). A shell of
radius r_s rolling on a wall without slip moves at v = ω r_s across its axis: a ring or
low-pitch helix pressed inside a vertical pipe climbs (or descends, d = −1) 2π r_s per rolling
cycle (the gait's expected advance; slip takes from it).

Other joints (not in ``joints``, or neither pitch nor yaw) follow joint_setpoints (hold, setpoints).

World reference (``reference: world``, input ``link_rotations`` wired from the multibody; on a robot,
each module's IMU): open loop, a wall that holds the ring lets it warp out of its plane instead of
rolling (mini-eels-pipe-climb: within 0.3 s). Instead each pair k bends about the world's ``up`` as
measured in the link after its first joint, φ_k = atan2(up·y_k, up·z_k) (a level ring whatever the
body's roll), led towards the rolling phase:

    α_k = φ_k + d·clip(d·wrap(α(t) − φ_0), 0, lead)        (α(t) = phase + ψ(t) as above, d its direction)

The lead (rad) is the rolling torque (≈ kp·A·lead per joint); a body ahead of α(t) holds level and
never rolls back; a body more than π/2 behind rolls on at the full lead. The roll then follows α(t),
so ``frequency`` still sets the speed (2π r_s f on a wall without slip) and a command changes it.
Before t_start: α_k = φ_k (held level).

Commands (optional inputs, shape (1,), e.g. from ros2_gait_commands; NaN or unconnected: the
param; a non-finite or out-of-range value: the param): ``amplitude`` (rad, A), ``frequency`` (Hz),
``phase_step`` (rad, φ), ``direction`` (±1). The rolling phase ψ is integrated (its departure from the params' δ
is the gait's continuous state), so a frequency change moves no joint by a jump.

uses robot: RobotModel (the multibody's): joint names, axes, spacing and limits
in   link_rotations[nl,3,3] (optional: the world reference),
     amplitude[1] rad, frequency[1] Hz, phase_step[1] rad,
     direction[1] (optional commands)
out  setpoint[nj] rad, rate[nj] rad/s   (for joint_pid's setpoint and rate_ref)
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Component, ContinuousState, Input, Params, Uses
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape

from .gaits import JointSetpointsParams, command, command_direction, constant_setpoints
from .joint_selection import match
from .setpoint_ports import command_input, setpoint_outputs


class HelixShape(Params):
    """A helix the chain's backbone should follow: radius and pitch (m per turn, signed: hand)."""

    radius: float = Field(gt=0, description="m, radius of the backbone's helix")
    pitch: float = Field(0.0, description="m per turn (0: a planar ring); the sign gives the hand")


class HelicalGaitParams(JointSetpointsParams):
    kind: Literal["rolling_helix"] = "rolling_helix"
    joints: str = Field("bend_*", description="pattern of the pitch and yaw joints (split by their URDF axis)")
    amplitude: float | None = Field(None, description="rad, A: bend per pair of joints (or give helix)")
    phase_step: float = Field(0.0, description="rad, φ: phase advance per pair along the body (torsion)")
    helix: HelixShape | None = Field(None, description="backbone helix, replaces amplitude and phase_step")
    frequency: float = Field(0.5, ge=0, description="Hz, rolling frequency f")
    direction: Literal[1, -1] = Field(1, description="+1 or −1: which way it rolls")
    phase: float = Field(0.0, description="rad, α at the tail at t_start")
    t_start: float = Field(0.0, ge=0, description="s, the rolling starts here (the shape is held before)")
    limit_margin: float = Field(0.05, ge=0, description="rad kept below the URDF joint limits")
    reference: Literal["body", "world"] = Field("body", description="body: α_k(t) as above; world: each pair's "
                                                "bend plane about world 'up', led towards α_0(t) (input link_rotations)")
    lead: float = Field(0.3, ge=0, lt=math.pi / 2, description="rad, world reference: the largest lead of the bend "
                                                               "plane on the measured one (the rolling torque)")
    up: tuple[float, float, float] = Field((0.0, 0.0, 1.0), description="world reference: the up direction")

    @model_validator(mode="after")
    def _one_shape(self):
        if (self.amplitude is None) == (self.helix is None):
            raise ValueError("give exactly one of 'amplitude' (rad, with phase_step) or 'helix' "
                             "({radius: m, pitch: m per turn})")
        for name in ("amplitude", "phase_step", "frequency", "phase", "t_start"):
            v = getattr(self, name)
            if v is not None and not math.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v}")
        if self.amplitude is not None and self.amplitude < 0:
            raise ValueError(f"amplitude must be >= 0 rad, got {self.amplitude}")
        return self


def pitch_yaw_families(robot: RobotModel, pattern: str, owner: str):
    """Indices (DOF order) of the pitch (axis ±y) and yaw (axis ±z) joints matching ``pattern``, and their
    mean spacing ℓ (m, distance between consecutive selected joints)."""
    names = robot.joints
    idx = list(match(names, pattern, f"{owner}: joints"))
    by_name = {j.name: j for j in robot.tree.dof_joints()}
    pitch, yaw, other = [], [], []
    for i in idx:
        a = np.abs(by_name[names[i]].axis)
        (pitch if a[1] > 0.99 else yaw if a[2] > 0.99 else other).append(i)
    if other:
        raise ValueError(f"{owner}: joints '{pattern}' include joints that are neither pitch (axis y) nor yaw "
                         f"(axis z): {', '.join(names[i] for i in other)}; narrow the pattern")
    if not pitch or not yaw or abs(len(pitch) - len(yaw)) > 1:
        raise ValueError(f"{owner}: a rolling helix needs alternating pitch and yaw joints; '{pattern}' on "
                         f"{robot.label} gives {len(pitch)} pitch and {len(yaw)} yaw joints")
    spacing = [float(np.linalg.norm(by_name[names[i]].translation)) for i in sorted(idx)[1:]]
    ell = float(np.mean(spacing))
    if not ell > 0:
        raise ValueError(f"{owner}: the selected joints have no spacing along the chain")
    return np.array(pitch), np.array(yaw), ell


def helix_amplitude(radius: float, pitch: float, spacing: float) -> tuple[float, float]:
    """(A, φ) in rad for a backbone helix of ``radius`` and ``pitch`` (m) on joints ``spacing`` (m) apart."""
    c = pitch / (2.0 * math.pi)
    d = radius * radius + c * c
    kappa, tau = radius / d, c / d
    if spacing * kappa >= 1.0:
        raise ValueError(f"helix radius {radius:g} m, pitch {pitch:g} m: curvature {kappa:.3g} 1/m is more than "
                         f"joints {spacing:g} m apart can bend (ℓκ = {spacing * kappa:.3g} >= 1)")
    return 2.0 * math.asin(spacing * kappa), 2.0 * spacing * tau


_HELIX_INPUTS = ("link_rotations", "amplitude", "frequency", "phase_step", "direction")


class HelicalGait(Component[HelicalGaitParams]):
    type_name = "helical_gait"
    robot = Uses(RobotModel)
    link_rotations = Input(shape=link_shape(3, 3), unit="1", default=np.nan)
    amplitude = command_input("rad")
    frequency = command_input("Hz")
    phase_step = command_input("rad")
    direction = command_input("1")
    setpoint, rate = setpoint_outputs(_HELIX_INPUTS)

    def setup(self):
        p = self.p
        self._base = constant_setpoints(self.robot, p, self.name)
        self._pitch, self._yaw, self.spacing = pitch_yaw_families(self.robot, p.joints, self.name)
        if p.helix is not None:
            self.amplitude, self.phase_step = helix_amplitude(p.helix.radius, p.helix.pitch, self.spacing)
        else:
            self.amplitude, self.phase_step = float(p.amplitude), float(p.phase_step)
        by_name = {j.name: j for j in self.robot.tree.dof_joints()}
        for i in np.concatenate([self._pitch, self._yaw]):
            j = by_name[self.robot.joints[i]]
            lim = min(abs(j.lower), abs(j.upper)) if j.lower is not None and j.upper is not None else math.inf
            if self.amplitude > lim - p.limit_margin:
                raise ValueError(f"{self.name}: amplitude {self.amplitude:.3f} rad exceeds joint {j.name}'s limit "
                                 f"{lim:.3f} rad less limit_margin {p.limit_margin:g}; use a larger helix radius "
                                 f"(here ℓ = {self.spacing:.3f} m, R = ℓ/sin(A/2))")
        self.curvature = math.sin(self.amplitude / 2.0) / self.spacing        # 1/m, planar-ring relation
        self._limit = min([self._joint_limit(by_name[self.robot.joints[i]])
                           for i in np.concatenate([self._pitch, self._yaw])]) - p.limit_margin
        self._w = 2.0 * math.pi * p.frequency * p.direction
        # world reference: pair k's bend is measured in the frame of the link after its first joint
        n = min(self._pitch.size, self._yaw.size)
        self._pairs = n
        self._first_pitch = bool(self._pitch[0] < self._yaw[0])
        dof = list(self.robot.tree.dof_joints())
        self._ref_rows = np.array([self.robot.link_index(dof[min(self._pitch[k], self._yaw[k])].child)
                                   for k in range(n)])
        up = np.asarray(p.up, dtype=float)
        if not np.linalg.norm(up) > 0:
            raise ValueError(f"{self.name}: up must be a non-zero vector, got {p.up}")
        self._up = up / np.linalg.norm(up)

    @staticmethod
    def _joint_limit(j) -> float:
        return min(abs(j.lower), abs(j.upper)) if j.lower is not None and j.upper is not None else math.inf

    def continuous_state(self):
        return ContinuousState(np.zeros(1), names=("phase_shift",))

    def _omega(self, t, u) -> float:
        """rad/s, dψ/dt: d·2π f from t_start on (commanded or the params'), 0 before."""
        if t < self.p.t_start:
            return 0.0
        return 2.0 * math.pi * command(u.frequency, self.p.frequency, 0.0) * command_direction(u.direction,
                                                                                                self.p.direction)

    def derivative(self, t, x, u, dx):
        dx[0] = self._omega(t, u) - (self._w if t >= self.p.t_start else 0.0)

    def output(self, t, x, u, y):
        a0 = self.p.phase + self._w * max(0.0, t - self.p.t_start) + (x[0] if x is not None else 0.0)
        wdot = self._omega(t, u) if u is not None else (self._w if t >= self.p.t_start else 0.0)
        A = self.amplitude
        a_cmd = command(u.amplitude, A, 0.0) if u is not None else A
        if a_cmd != A and a_cmd <= self._limit:          # a commanded bend past the joints' limits is ignored
            A = a_cmd
        phi = command(u.phase_step, self.phase_step) if u is not None else self.phase_step
        kp = phi * np.arange(self._pitch.size)
        ky = phi * np.arange(self._yaw.size)
        Ap = Ay = A
        ap, ay = a0 + kp, a0 + ky
        if self.p.reference == "world" and u is not None and np.isfinite(u.link_rotations[0, 0, 0]):
            # the bend plane of each pair about world up (a level ring), d·lead ahead: rolls it
            R = u.link_rotations[self._ref_rows]
            phi = np.arctan2(R[:, :, 1] @ self._up, R[:, :, 2] @ self._up)
            # the body's roll (the first pair's) follows α_0(t) by a lead of 0 to `lead` in the rolling
            # direction d: ahead of α_0 (or at it) it holds level, behind it rolls on; never back
            e = math.remainder(a0 - phi[0], 2.0 * math.pi)
            d = 1.0 if wdot >= 0.0 else -1.0
            if wdot != 0.0 and d * e < -0.5 * math.pi:      # far behind, not ahead: a whole turn late
                e += d * 2.0 * math.pi
            alpha = phi + d * min(self.p.lead, max(0.0, d * e))
            n = self._pairs
            ap, ay = np.empty(self._pitch.size), np.empty(self._yaw.size)
            ap[:n], ay[:n] = alpha, alpha
            ap[n:], ay[n:] = alpha[-1], alpha[-1]
        y.setpoint[:] = self._base
        y.setpoint[self._pitch] = Ap * np.sin(ap)
        y.setpoint[self._yaw] = Ay * np.cos(ay)
        y.rate[:] = 0.0
        y.rate[self._pitch] = Ap * wdot * np.cos(ap)
        y.rate[self._yaw] = -Ay * wdot * np.sin(ay)


def ring_centre(robot: RobotModel, amplitude: float, pattern: str = "bend_*") -> tuple[np.ndarray, float]:
    """A planar ring of the rolling helix at α = 0 (yaw joints at ``amplitude``, pitch joints 0; base frame
    identity): the centre (x, y, 0) of the circle through the yaw joints, in the tail's frame, and that circle's
    radius ℓ/sin(A/2). Scenes place the tail at −centre to put the ring on a pipe's axis."""
    _, yaw, ell = pitch_yaw_families(robot, pattern, "ring_centre")
    names = set(robot.joints[i] for i in yaw)
    R, p, pts = np.eye(3), np.zeros(3), []
    for j in robot.tree.dof_joints():                 # a serial chain, tail first
        p = p + R @ j.translation
        R = R @ j.rotation
        if j.name in names:
            pts.append(p.copy())
            c, s = math.cos(amplitude), math.sin(amplitude)
            R = R @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    P = np.array(pts)[:, :2]
    M = np.c_[2.0 * P, np.ones(len(P))]
    sol = np.linalg.lstsq(M, (P * P).sum(1), rcond=None)[0]
    return np.array([sol[0], sol[1], 0.0]), float(np.sqrt(sol[2] + sol[0] ** 2 + sol[1] ** 2))
