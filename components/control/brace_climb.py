"""A reference brace-and-climb controller for vertical mobility (paper 4.3): a baseline to beat.

The body is braced across a shaft (two walls, a tube) by one *amplitude* A that scales a
fixed bend/twist pattern (default every bend joint +1: a C whose ends press one wall and middle the
other; a helix in a tube widens by untwisting: twist joints −1) and a feed-forward torque pattern; A is regulated on the measured wall loads; the screws
are braked until ``climb_start``, turn at the climb speeds until ``climb_stop`` (ramped over
``spin_up`` both ways) and are braked again, while the brace is kept all along::

    load      L = mean (or min, ``regulate``) of the ``loads`` input over the screws (``load_screws``; N):
              contact.screw_normal_force (ground truth), or what the robot measures: fts_wall_loads.loads
              (each segment's wall load from the FTS array; walls-body-brace-climb.yaml)
    brace     A_{k+1} = clip(A_k + T·clip(gain·(F* − L)/F*, −max_rate, max_rate), A_min, A_max)
              at every sample of period T (``rate``), in every phase: the brace is held while climbing
              (A_min < 0 lets the loop relieve a squeeze that builds up while the screws roll)
    lost      a screw whose load falls below lost_fraction·F* counts as out of contact; L then uses
              the min (recovery: the amplitude rises until every screw is back on a wall)
    set-points  bend/twist j: base_j + A·pattern_j (rad) (twist joints: + twist);
                screw j: ω_j = r(t)·S·climb_sign_j (rad/s, the PID's velocity mode; its integral
                brakes the screws at ω_j = 0), S the commanded speed ω* reached at ``speed_slew``
                (rad/s² per sample; default the drive ramp's slope |ω*|/spin_up: a step change of speed
                mid-climb unloads the brace while the screws' loops catch up), with the drive ramp
                r(t) = clip((t − climb_start)/spin_up, 0, 1) − clip((t − climb_stop)/spin_up, 0, 1)
                (spin_up = 0: steps)
    feed-forward  tau_ff[j] = A·torque_pattern_j + g_j (N·m): a pre-load in proportion to the amplitude
                (e.g. a placement's latched pre-load torques for A = 1 at the target load)
    limit guard   (``limit_margin`` m_l set, ``joint_q`` wired) g_j = −k_l (q_j − (q_hi − m_l))⁺ + k_l ((q_lo + m_l) − q_j)⁺
                on bend and twist joints (k_l ``limit_stiffness``, q_lo/q_hi the URDF limits), sampled at the
                rate: a soft stop that keeps a compliant brace inside its joints' range when the walls widen
                (moulin-brace-down.yaml); off (g = 0) by default

How a braced screw robot climbs (walls-brace-climb.yaml, walls-brace-climb-down.yaml). A turning screw
pressed on a wall slides in its surface direction ê_φ = â × ê_c (â its axis, ê_c towards the wall):
its friction there is ≈ μF_n (eq. 6), far above the thread's axial thrust, and reacts the screw's
torque. Between two parallel walls with a planar brace (every â in the plane normal to the walls),
ê_φ is horizontal: turning screws on the two walls make a yaw couple that nothing opposes (a
compressed brace is unstable in yaw; only static friction held it), so the robot rolls like a log
about the vertical at ω r / (gap/2) and loses the brace in ~0.1 s, whatever the thread anisotropy.
Tilting the brace plane by β about the wall normal turns every ê_φ on a wall into the same direction
(−cos β, 0, sin β) (opposite on the other wall): with the screws on the two walls turning in opposite
senses (``climb_signs``) every contact rolls the same way, and the whole robot translates like a
wheeled vehicle at ω r along the brace plane's normal, climbing at ω r sin β with no yaw couple. The
weight is carried by static (creep) friction; nothing slides. Stiff screw speed loops and twists keep
every contact rolling at one speed and direction (a mismatch winds the brace up or down; ``regulate:
min`` with A_min < 0 absorbs what remains). In a tube the log roll is harmless: a braced C's screws
turning the same way only orbit it about the axis (at ω r / R), neither lifting nor lowering it; a
screw descent there needs every screw axis leaned out of the plane through the axis by the same angle
α about its own wall normal (the C twisted into a one-turn chordal helix, which a tilted planar C
cannot give): screws turning the same way then roll the robot down a helix, orbiting, at ≈ ω r sin α
(tube-brace-descend.yaml: leans 5-11°, the robot sinks between its slowest and fastest screw's rolling
speed).

Friction descent (``descent_speed`` v* > 0; off by default). A brace in a plane through a tube's axis
cannot screw down (its screws only orbit it), but it can slide down like a climber in a chimney: inside
the window [``descend_start``, ``descend_stop``) (or while the optional ``descent_speed`` input, m/s, is
finite and > 0) the amplitude follows the measured descent speed instead of the load, with a
velocity-form PI::

    descent   v_d = −v_z of link ``descent_link`` (the ``link_velocities`` input: the root's vertical
              velocity, a stand-in for the robot's own odometry), e_k = v_d,k − v*
              A_{k+1} = clip(A_k + k_p (e_k − e_{k−1}) + T k_i e_k, A_min, A_max)   (``descent_kp``, ``descent_ki``)

Sliding, the wall friction is kinetic, μ ΣF_n(A), so the robot's descent obeys m v̇_d = m g − μ ΣF_n(A) with
ΣF_n ∝ A (the pre-load torques scale with A): v̇_d = −c (A − A_eq), c = μ ΣF_n(1)/m. With the PI the loop is
second order, s² + c k_p s + c k_i: ω_n = √(c k_i), ζ = k_p √c / (2 √k_i). While stuck (v_d = 0) the
integral relaxes the brace at k_i v* until it slips. Outside the window (v* = 0) the load law above
holds again once the slide has stopped: the PI (with v* = 0) acts until v_d < ``stopped_speed``. The
window's command is ramped up and down over ``descent_ramp`` (drive_ramp's trapezoid; the input is taken as
it comes): in tube-body-brace-descend, squeezing a 5 cm/s slide to rest at the full rate (max_rate, no ramp)
blew the 10 ms run up within 0.4 s (a screw 41 mm deep), the ramped PI stops it smoothly. e_{k−1} is kept
during the hold as v_d − 0, so entering the descent relaxes A at once by k_p v*.

``target`` (F*) and ``speed`` (ω*) are parameters, overridable at run time through the optional
``target_force`` and ``climb_speed`` inputs (wire a ROS 2 command or a schedule; NaN or
unconnected: the parameter). Descend with a negative speed.

in   loads[ns]        N, per screw wall load (feedthrough-free: sampled at the rate)
     target_force[1]  N (optional), climb_speed[1] rad/s (optional)
     joint_q[nj]      rad (optional; the limit guard's), the multibody's DOF joint order
     link_velocities[nl, 6]  (optional; the friction descent's) the multibody's (vx, vy, vz, wx, wy, wz)
     descent_speed[1]    m/s (optional): commanded descent speed (0: grip; NaN/unconnected: the window)
out  setpoint[nj]     rad (bend, twist) or rad/s (screws), the multibody's DOF joint order
     tau_ff[nj]       N·m, to the PID's feed-forward
     amplitude[1]     rad, A;  phase[1]: 0 brace/hold, 1 driving (ramps included), 2 braked after
                      climb_stop;  load[1]: L, N
uses robot: RobotModel (the multibody's): joint names and kinds
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape
from snakesim.framework import Component, Input, Output, Params, Uses

from .joint_selection import finite_or_raise, per_joint
from .setpoint_ports import command_input

A, PHASE, LOAD, SPEED, E_PREV, REGRIP, NX = 0, 1, 2, 3, 4, 5, 6     # then nj limit-guard torques


def drive_ramp(t: float, start: float, stop: float, spin_up: float) -> float:
    """r(t) of the docstring: 0 before ``start``, 1 between the ramps, 0 again ``spin_up`` after ``stop``."""
    if spin_up <= 0:
        return float(start <= t < stop)
    up = min(max((t - start) / spin_up, 0.0), 1.0)
    down = min(max((t - stop) / spin_up, 0.0), 1.0) if stop < float("inf") else 0.0
    return max(up - down, 0.0)


class BraceClimbParams(Params):
    target: float = Field(100.0, gt=0, description="N, wall load per screw the brace regulates to")
    regulate: Literal["mean", "min"] = Field("mean", description="which screw load the amplitude follows")
    gain: float = Field(0.5, gt=0, description="rad/s per unit relative load error")
    max_rate: float = Field(0.5, gt=0, description="rad/s, largest amplitude change")
    amplitude0: float = Field(0.0, description="rad, the starting amplitude")
    amplitude_min: float = Field(0.0, description="rad")
    amplitude_max: float = Field(1.2, description="rad, a brace never bends further")
    pattern: dict[str, float] = Field(default_factory=lambda: {"bend_*": 1.0},
                                      description="rad per unit amplitude, by bend/twist joint name/pattern (unnamed: 0)")
    base: list[float] = Field(default_factory=list, description="rad, set-points at A = 0, every DOF joint "
                              "in URDF order (empty: 0; screws ignored)")
    torque_pattern: dict[str, float] = Field(default_factory=dict,
                                             description="N·m per unit amplitude, by joint name/pattern")
    twist: float = Field(0.0, description="rad, every twist joint")
    load_screws: list[int] = Field(default_factory=list, description="indices into ``loads`` of the screws the brace "
                                   "presses on a wall (empty: all; e.g. [0, 3] for a strut whose middle is free)")
    lost_fraction: float = Field(0.2, ge=0, lt=1, description="a screw below this share of the target is off the wall")
    climb_start: float = Field(float("inf"), description="s, screws start turning")
    speed: float = Field(0.0, description="rad/s, climb speed (negative: descend)")
    climb_stop: float = Field(float("inf"), description="s, screws ramp down and brake again")
    spin_up: float = Field(0.0, ge=0, description="s, the screws' speed ramps linearly over this time (up and down)")
    climb_signs: dict[str, float] = Field(default_factory=lambda: {"screw_*": 1.0},
                                          description="per screw joint/pattern factor on the speed")
    speed_slew: float | None = Field(None, gt=0, description="rad/s², how fast a commanded climb_speed is reached "
                                     "(None: |speed|/spin_up, the drive ramp's own slope; a step if spin_up is 0)")
    limit_margin: float | None = Field(None, ge=0, description="rad: the limit guard acts this far inside each "
                                       "bend/twist joint's URDF limits (None: off; needs joint_q wired)")
    limit_stiffness: float = Field(500.0, gt=0, description="N·m/rad, the limit guard's spring")
    descent_speed: float = Field(0.0, ge=0, description="m/s, the friction descent's commanded speed v* (0: off)")
    descend_start: float = Field(float("inf"), description="s, the friction descent starts (the brace relaxes)")
    descend_stop: float = Field(float("inf"), description="s, the friction descent stops (the brace re-grips)")
    descent_kp: float = Field(0.5, ge=0, description="rad per m/s, the descent PI's proportional gain")
    descent_ki: float = Field(2.0, gt=0, description="rad/s per m/s, the descent PI's integral gain")
    stopped_speed: float = Field(0.002, gt=0, description="m/s: re-gripping, the PI (v* = 0) acts until the "
                                 "descent speed falls below this, then the load law resumes")
    descent_ramp: float = Field(0.0, ge=0, description="s, the commanded descent speed ramps up and down over this")
    descent_link: str = Field("tail", description="the link whose vertical velocity is the measured descent speed")


class BraceClimb(Component[BraceClimbParams]):
    type_name = "brace_climb"
    robot = Uses(RobotModel)

    loads = Input(shape=None, unit="N")
    target_force = command_input("N")
    climb_speed = command_input("rad/s")
    joint_q = Input(shape=joint_shape, unit="rad", default=np.nan)
    link_velocities = Input(shape=None, unit=None, default=np.nan)
    descent_speed = command_input("m/s")
    setpoint = Output(shape=joint_shape, unit=None, feedthrough=(), names=joint_names)
    tau_ff = Output(shape=joint_shape, unit="N*m", feedthrough=(), names=joint_names)
    amplitude = Output(shape=(1,), unit="rad", feedthrough=())
    phase = Output(shape=(1,), unit="1", feedthrough=())
    load = Output(shape=(1,), unit="N", feedthrough=())

    def setup(self):
        p, names = self.p, list(self.robot.joints)
        if self.rate is None:
            raise ValueError(f"{self.name}: brace_climb is a sampled controller: give it `rate: HZ`")
        if any(i < 0 for i in p.load_screws) or len(set(p.load_screws)) != len(p.load_screws):
            raise ValueError(f"{self.name}: load_screws must be distinct indices >= 0 into loads, got {p.load_screws}")
        if p.climb_stop < float("inf") and not p.climb_start < p.climb_stop:
            raise ValueError(f"{self.name}: need climb_start < climb_stop, got {p.climb_start} and {p.climb_stop}")
        if not p.amplitude_min <= p.amplitude0 <= p.amplitude_max:
            raise ValueError(f"{self.name}: need amplitude_min <= amplitude0 <= amplitude_max")
        finite_or_raise(p.pattern, f"{self.name}: pattern")
        finite_or_raise(p.climb_signs, f"{self.name}: climb_signs")
        kinds = np.array(self.robot.joint_kinds)
        self._bend, self._twist, self._screw = kinds == "bend", kinds == "twist", kinds == "screw"
        shaped = self._bend | self._twist   # a helix brace widens by untwisting (radius κ/(κ² + τ²))
        self._pattern = np.array(per_joint(names, p.pattern, f"{self.name}: pattern", 0.0), float) * shaped
        nj = self.robot.nj
        if p.base and len(p.base) != nj:
            raise ValueError(f"{self.name}: base has {len(p.base)} values, the robot has {nj} DOF joints")
        self._base = (np.array(p.base, float) if p.base else np.zeros(nj)) * ~self._screw
        finite_or_raise(p.torque_pattern, f"{self.name}: torque_pattern")
        self._tau = np.array(per_joint(names, p.torque_pattern, f"{self.name}: torque_pattern", 0.0), float)
        self._signs = np.array(per_joint(names, p.climb_signs, f"{self.name}: climb_signs", 0.0), float) * self._screw
        ramp = abs(p.speed) / p.spin_up if p.spin_up > 0 and p.speed != 0 else float("inf")
        self._slew = p.speed_slew if p.speed_slew is not None else ramp
        lo, hi = self.robot.position_limits()
        self._guard_lo, self._guard_hi = np.asarray(lo, float), np.asarray(hi, float)
        if p.descend_stop < float("inf") and not p.descend_start < p.descend_stop:
            raise ValueError(f"{self.name}: need descend_start < descend_stop, got {p.descend_start} and {p.descend_stop}")
        if p.descent_link not in self.robot.link_row:
            raise ValueError(f"{self.name}: descent_link '{p.descent_link}' is not a link of {self.robot.label}; "
                             f"links: {', '.join(self.robot.links)}")
        self._vz = 6 * self.robot.link_row[p.descent_link] + 2     # vz of that link's row, flattened

    def discrete_state(self):
        x = np.zeros(NX + self.robot.nj)
        x[A] = self.p.amplitude0
        x[SPEED] = self.p.speed
        return x

    def output(self, t, x, u, y):
        y.setpoint[:] = self._base + x[A] * self._pattern + self.p.twist * self._twist
        y.tau_ff[:] = x[A] * self._tau + x[NX:]
        if x[PHASE] == 1.0:
            p = self.p
            r = drive_ramp(t, p.climb_start, p.climb_stop, p.spin_up) if p.spin_up > 0 else 1.0  # steps: the phase
            y.setpoint[self._screw] = r * x[SPEED] * self._signs[self._screw]
        y.amplitude[0], y.phase[0], y.load[0] = x[A], x[PHASE], x[LOAD]

    def update(self, t, xd, u):
        p, T = self.p, 1.0 / self.rate
        F = float(u.target_force[0])
        F = F if F == F and F > 0 else p.target
        loads = np.asarray(u.loads, float).ravel()
        if p.load_screws:
            if max(p.load_screws) >= loads.size:
                raise ValueError(f"{self.name}: load_screws {p.load_screws} index past the {loads.size} loads wired in")
            loads = loads[p.load_screws]
        lost = bool((loads < p.lost_fraction * F).any())
        L = float(loads.min() if (p.regulate == "min" or lost) else loads.mean()) if loads.size else 0.0
        v_cmd = self._descent_command(t, u)
        if v_cmd is None:       # the load law (the default: no descent configured)
            rate = min(max(p.gain * (F - L) / F, -p.max_rate), p.max_rate)
            xd[A] = min(max(xd[A] + T * rate, p.amplitude_min), p.amplitude_max)
        else:
            v = np.asarray(u.link_velocities, float).ravel()
            if v.size <= self._vz or not np.isfinite(v[self._vz]):
                raise ValueError(f"{self.name}: the friction descent (descent_speed > 0) needs the multibody's "
                                 f"link_velocities wired to {self.name}.link_velocities")
            e = -float(v[self._vz]) - v_cmd
            if v_cmd > 0 or (xd[REGRIP] and e > p.stopped_speed):   # descend, or stop a slide: PI on the speed
                dA = p.descent_kp * (e - xd[E_PREV]) + T * p.descent_ki * e
                xd[A] = min(max(xd[A] + dA, p.amplitude_min), p.amplitude_max)
                xd[REGRIP] = 1.0
            else:               # grip: the load law
                xd[REGRIP] = 0.0
                rate = min(max(p.gain * (F - L) / F, -p.max_rate), p.max_rate)
                xd[A] = min(max(xd[A] + T * rate, p.amplitude_min), p.amplitude_max)
            xd[E_PREV] = e
        xd[LOAD] = L
        s = float(u.climb_speed[0])
        s = s if s == s else p.speed
        if self._slew * T == float("inf"):
            xd[SPEED] = s
        else:       # a commanded speed is reached at the ramp's slope: a step would unload the brace
            xd[SPEED] += min(max(s - xd[SPEED], -self._slew * T), self._slew * T)
        end = p.climb_stop + p.spin_up
        xd[PHASE] = 0.0 if t < p.climb_start else (1.0 if t < end else 2.0)
        if p.limit_margin is not None:
            q = np.asarray(u.joint_q, float).ravel()
            if not np.isfinite(q).all():
                raise ValueError(f"{self.name}: limit_margin is set: wire the multibody's joint_q to {self.name}.joint_q")
            over = (np.maximum(q - (self._guard_hi - p.limit_margin), 0.0)
                    + np.minimum(q - (self._guard_lo + p.limit_margin), 0.0))
            xd[NX:] = -p.limit_stiffness * over * (self._bend | self._twist)

    def _descent_command(self, t, u) -> float | None:
        """v* (m/s) now: the input if finite, else descent_speed inside the window, else 0; None: no descent mode."""
        p = self.p
        c = float(u.descent_speed[0])
        if c == c:
            if c < 0:
                raise ValueError(f"{self.name}: descent_speed input = {c:g} m/s: a descent speed is >= 0 "
                                 "(0 grips; NaN hands back to the descent_speed param's window)")
            return c
        if p.descent_speed <= 0:
            return None
        return p.descent_speed * drive_ramp(t, p.descend_start, p.descend_stop, p.descent_ramp)
