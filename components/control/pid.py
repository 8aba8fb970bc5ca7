"""PID joint controllers for every DOF joint of a robot, in one vectorised component (paper 2.2.5).

Like the hardware's joint controllers: each joint runs in position or
velocity mode (or off), with its own gains, a torque limit, anti-windup and a
first-order-filtered derivative. Per joint i (all vector operations)::

    position mode:  e = setpoint − q        (wrapped to (−π, π] on continuous joints)
                    r = rate_ref − v        the error rate, from the measured joint rate
                    d = r filtered by 1/(tf·s + 1)
    velocity mode:  e = setpoint − v
                    d = s/(tf·s + 1) · e    filtered derivative of the error
    u   = kp·e + ki·I + kd·d + tau_ff       I = ∫ e dt
    tau = clip(u, −tau_max, tau_max)

Anti-windup is **clamping** (conditional integration): I stops integrating
while the output is saturated and the error drives it further into the
limit (e·u > 0); ``anti_windup: none`` integrates always.

Two forms, chosen by the assembly:
- no ``rate``: continuous time, state [I, z] (nj each), z the filter state
  (ż = (r − z)/tf in position mode, ż = (e − z)/tf in velocity mode).
- ``rate`` (Hz): discrete, hardware-like; sample period T = 1/rate, outputs
  computed at each tick and held (zero-order hold), backward-Euler filter
  a = T/(tf + T)::
      position: d_k = (1 − a)·z_k + a·r_k,         z_{k+1} = d_k
      velocity: d_k = (e_k − z_k)/(tf + T),       z_{k+1} = z_k + T·d_k
                (tf = 0: the backward difference (e_k − e_{k−1})/T)
      I_{k+1} = I_k + T·e_k   (unless clamped)
  The first tick starts the filter at its input (no derivative kick).

Gains: ``gains`` by joint name or glob pattern, each field falling back to
``kind_gains`` for the joint's kind (bend, twist, screw, other), then to the
built-in defaults :data:`DEFAULT_GAINS` (bend/twist position, screws
velocity). tau_max falls back to the URDF effort limit (``torque_limit:
urdf``) or to none.

in   setpoint[nj]  rad (position joints) or rad/s (velocity joints), DOF joints in URDF order
     rate_ref[nj]  rad/s, rate reference of position joints (default 0)
     tau_ff[nj]    N·m feedforward, added before saturation (default 0)
     q[nj] rad, v[nj] rad/s   from multibody.joint_q / joint_v
out  tau[nj]   N·m    (feedthrough from all inputs)
     error[nj] rad or rad/s, e above
uses robot: RobotModel (the multibody's): joint names, kinds, continuity and effort limits
"""

from __future__ import annotations

import math

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from snakesim.components.multibody.robot_model import JOINT_KINDS, RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape
from snakesim.framework import Component, ContinuousState, Input, Output, Params, Uses
from snakesim.components.port_roles import JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES

from .joint_selection import per_joint
from ..kernel_args import bind
from .pid_kernel import Gains, PidRun, pid_step

Mode = Literal["position", "velocity", "off"]

#: Built-in gains per joint kind. Bend/twist actuators hold angles; screws run at commanded speeds.
DEFAULT_GAINS = {
    "bend": {"mode": "position", "kp": 200.0, "ki": 0.0, "kd": 20.0, "tf": 0.005},
    "twist": {"mode": "position", "kp": 100.0, "ki": 0.0, "kd": 10.0, "tf": 0.005},
    "screw": {"mode": "velocity", "kp": 5.0, "ki": 20.0, "kd": 0.0, "tf": 0.0},
    "other": {"mode": "position", "kp": 10.0, "ki": 0.0, "kd": 1.0, "tf": 0.0},
}


class JointGains(Params):
    """Gains of one joint (or a pattern of joints); unset fields fall back (see module docstring)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    mode: Mode | None = None
    kp: float | None = Field(None, ge=0, description="N·m/rad (position) or N·m·s/rad (velocity)")
    ki: float | None = Field(None, ge=0, description="N·m/(rad·s) or N·m/rad")
    kd: float | None = Field(None, ge=0, description="N·m·s/rad or N·m·s²/rad")
    tf: float | None = Field(None, ge=0, description="derivative filter time constant, s (0: unfiltered)")
    tau_max: float | None = Field(None, gt=0, description="N·m, symmetric torque limit")


class JointPidParams(Params):
    gains: dict[str, JointGains] = Field(default_factory=dict, description="by joint name or glob pattern")
    kind_gains: dict[str, JointGains] = Field(default_factory=dict,
                                              description="per joint kind (bend, twist, screw, other)")
    torque_limit: Literal["urdf", "none"] = Field("urdf", description="default tau_max: URDF effort or none")
    anti_windup: Literal["clamp", "none"] = "clamp"


def _kept_while_same(cache, slot: str, mask: np.ndarray, build):
    """``build(mask)``, kept in ``cache.<slot>`` and returned again while the boolean per-joint ``mask``
    is the same: a Jacobian changes only when a joint saturates or its integral clamps or releases, and
    returning the same object lets the linearization reuse what it composed from it. The mask is
    compared as bytes (a cheap ==)."""
    key = mask.tobytes()
    kept = getattr(cache, slot)
    if kept is None or kept[0] != key:
        kept = (key, build(np.frombuffer(key, dtype=bool)))
        setattr(cache, slot, kept)
    return kept[1]


class JointPid(Component[JointPidParams]):
    type_name = "joint_pid"
    robot = Uses(RobotModel)

    setpoint = Input(shape=joint_shape, unit=None, names=joint_names)
    rate_ref = Input(shape=joint_shape, unit="rad/s", default=0.0)
    tau_ff = Input(shape=joint_shape, unit="N*m", default=0.0)
    q = Input(shape=joint_shape, unit="rad", role=JOINT_POSITIONS)
    v = Input(shape=joint_shape, unit="rad/s", role=JOINT_VELOCITIES)
    tau = Output(shape=joint_shape, unit="N*m", feedthrough=True, names=joint_names, role=JOINT_EFFORTS)
    error = Output(shape=joint_shape, unit=None, feedthrough=True, names=joint_names)

    # -- set-up: one array per gain ---------------------------------------------------
    def setup(self):
        p, robot = self.p, self.robot
        names = list(robot.joints)
        bad = set(p.kind_gains) - set(JOINT_KINDS)
        if bad:
            raise ValueError(f"{self.name}: kind_gains: unknown joint kind(s) {sorted(bad)}; kinds: {', '.join(JOINT_KINDS)}")
        explicit = per_joint(names, p.gains, f"{self.name}: gains")
        effort = robot.effort_limits() if p.torque_limit == "urdf" else np.full(len(names), np.inf)
        rows = []
        for i, kind in enumerate(robot.joint_kinds):
            g = dict(DEFAULT_GAINS[kind], tau_max=float(effort[i]))
            for layer in (p.kind_gains.get(kind), explicit[i]):
                if layer is not None:
                    g.update(layer.model_dump(exclude_none=True))
            rows.append(g)
        self.gains_table = rows
        col = lambda k: np.array([r[k] for r in rows], dtype=float)  # noqa: E731
        self._pos = np.array([r["mode"] == "position" for r in rows])
        self._vel = np.array([r["mode"] == "velocity" for r in rows])
        on = self._pos | self._vel
        self._kp, self._ki, self._kd = col("kp") * on, col("ki") * on, col("kd") * on
        self._tf, self._tmax = col("tf"), col("tau_max")
        self._cont = robot.continuous_mask() & self._pos
        self._clamp = p.anti_windup == "clamp"
        self._nj = len(names)
        self._discrete = self.rate is not None
        if self._discrete:
            T = self._T = 1.0 / self.rate
            self._a = T / (self._tf + T)
            self._inv_tf = np.zeros(self._nj)           # the discrete law has no 1/tf
        else:
            bad = [n for n, v, kd, tf in zip(names, self._vel, self._kd, self._tf) if v and kd > 0 and tf == 0]
            if bad:
                raise ValueError(f"{self.name}: velocity-mode joints {bad} have kd > 0 and tf = 0: the continuous "
                                 "form needs a filter time constant tf > 0 to differentiate the rate error "
                                 "(or give the component a rate for the discrete form)")
            self._inv_tf = np.where(self._tf > 0, 1.0 / np.where(self._tf > 0, self._tf, 1.0), 0.0)
            self._T, self._a = 0.0, np.zeros(self._nj)  # the continuous law has no sample period
        self._gains = Gains(pos=self._pos, wrap=self._cont, kp=self._kp, ki=self._ki, kd=self._kd, tf=self._tf,
                            tmax=self._tmax, inv_tf=self._inv_tf, a=self._a, T=float(self._T),
                            discrete=self._discrete, clamp=self._clamp)

    def stiffness_hint(self, u, readers):
        """Each joint's loop on the apparent inertia of the multibody its tau drives: sqrt(kp/I) and kd/I
        (position mode), kp/I (velocity mode), and the derivative filter's 1/tf."""
        inertia = next((r.joint_inertia() for r in readers("tau") if hasattr(r, "joint_inertia")), None)
        if inertia is None:
            return []
        out = []
        for j, name in enumerate(self.robot.joints):
            kp, kd, I = self._kp[j], self._kd[j], inertia[j]
            if not I > 0:
                continue
            if self._pos[j]:
                out.append((math.sqrt(kp / I), f"joint '{name}' kp = {kp:g} over inertia {I:.3g} (armature included)"))
                out.append((kd / I, f"joint '{name}' kd = {kd:g} over inertia {I:.3g} (armature included)"))
            elif self._vel[j]:
                out.append((kp / I, f"joint '{name}' velocity kp = {kp:g} over inertia {I:.3g} (armature included)"))
            if not self._discrete and self._inv_tf[j] > 0:
                out.append((self._inv_tf[j], f"joint '{name}' derivative filter tf = {self._tf[j]:g} s"))
        return out

    def continuous_state(self):
        if self._discrete:
            return None
        n = self._nj
        return ContinuousState(np.zeros(2 * n), names=tuple(f"{j}.{s}" for s in ("integral", "filter")
                                                           for j in self.robot.joints))

    def discrete_state(self):
        if not self._discrete:
            return None
        return np.zeros(2 * self._nj + 1)       # [I, z, started]

    # -- this run's cache: the law bound to the plan's buffers --------------------------------------
    def make_cache(self, x, u, y):
        """The law's per-joint results (pid_kernel.pid_law) and two bound calls: ``output`` writes tau
        and the error straight into the output buffers, ``law`` into scratch (update() must not
        touch the held outputs)."""
        n = self._nj
        dint, zrate = np.zeros(n), np.zeros(n)
        ins = dict(setpoint=u.setpoint, rate_ref=u.rate_ref, tau_ff=u.tau_ff, q=u.q, v=u.v, x=x, dint=dint,
                   zrate=zrate)
        return _Cache(dint, zrate, bind(pid_step, self._gains, PidRun(tau=y.tau, err=y.error, **ins)),
                      bind(pid_step, self._gains, PidRun(tau=np.zeros(n), err=np.zeros(n), **ins)))

    def output(self, t, x, u, y):
        u.cache.output()

    def derivative(self, t, x, u, dx):
        # output() ran on this (t, x, u) just before (framework contract): reuse its law results
        c = u.cache
        n = self._nj
        dx[:n] = c.dint
        dx[n:] = c.zrate

    def update(self, t, xd, u):
        c = u.cache
        n = self._nj
        c.law()
        xd[:n] += self._T * c.dint
        xd[n:2 * n] = c.zrate
        xd[2 * n] = 1.0

    # -- derivatives for linearly implicit integrators (framework/linearization.py) ------------------
    def port_jacobian(self, port, t, x, u, y):
        """∂tau/∂(q, v, setpoint, rate_ref, tau_ff, I, z) of the continuous law, joint by joint; zero
        on saturated joints. The discrete form's output is held between ticks: no dependence.
        The same object is returned while no joint enters or leaves saturation."""
        if port != "tau":
            return None
        live = np.abs(y.tau) < self._tmax                   # saturated joints pass nothing on
        return _kept_while_same(u.cache, "jac_tau", live, self._tau_jacobian)

    def _tau_jacobian(self, live):
        from snakesim.framework.linearization import Elementwise
        n = self._nj
        rows = np.arange(n)
        if self._discrete:
            return Elementwise(n, ())
        pos, vel = self._pos & live, self._vel & live
        kp, ki, kd, itf = self._kp, self._ki, self._kd, self._inv_tf
        filt = self._tf > 0
        d_e = np.where(pos, kp, np.where(vel, kp + kd * itf, 0.0))      # ∂tau/∂setpoint
        d_v = np.where(vel, -kp - kd * itf, np.where(pos & ~filt, -kd, 0.0))
        d_z = np.where(vel, -kd * itf, np.where(pos & filt, kd, 0.0))
        return Elementwise(n, (
            ("q", rows, rows, np.where(pos, -kp, 0.0)), ("v", rows, rows, d_v),
            ("setpoint", rows, rows, d_e), ("rate_ref", rows, rows, np.where(pos & ~filt, kd, 0.0)),
            ("tau_ff", rows, rows, live.astype(float)),
            ("x", rows, rows, np.where(live, ki, 0.0)), ("x", rows, n + rows, d_z)))

    def state_jacobian(self, t, x, u, y):
        """İ = e (0 while clamped) and ż = (r − z)/tf or (e − z)/tf: rows [I, z], per joint. The same
        object is returned while no integral is clamped or released."""
        if self._discrete:
            return None
        c = u.cache
        held = (c.dint == 0.0) & (y.error != 0.0)                 # clamped integrals do not move
        return _kept_while_same(c, "jac_state", held, self._state_jacobian)

    def _state_jacobian(self, held):
        from snakesim.framework.linearization import Elementwise
        n = self._nj
        rows = np.arange(n)
        pos, vel = self._pos, self._vel
        itf = self._inv_tf
        return Elementwise(2 * n, (
            ("q", rows, rows, np.where(pos & ~held, -1.0, 0.0)),
            ("v", rows, rows, np.where(vel & ~held, -1.0, 0.0)),
            ("setpoint", rows, rows, np.where((pos | vel) & ~held, 1.0, 0.0)),
            ("v", n + rows, rows, -itf),
            ("rate_ref", n + rows, rows, np.where(pos, itf, 0.0)),
            ("setpoint", n + rows, rows, np.where(vel, itf, 0.0)),
            ("x", n + rows, n + rows, -itf)))

    # -- introspection ------------------------------------------------------------------------
    def gains_of(self, joint: str) -> dict:
        """The resolved gains of one joint (mode, kp, ki, kd, tf, tau_max)."""
        i = self.robot.dof_of.get(joint)
        if i is None:
            raise KeyError(f"{self.name}: no DOF joint '{joint}'; joints: {', '.join(self.robot.joints)}")
        return dict(self.gains_table[i])



class _Cache:
    __slots__ = ("dint", "zrate", "output", "law", "jac_tau", "jac_state")

    def __init__(self, dint, zrate, output, law):
        self.dint, self.zrate, self.output, self.law = dint, zrate, output, law
        self.jac_tau = self.jac_state = None       # (mask it was made for, Elementwise): port_jacobian, state_jacobian
