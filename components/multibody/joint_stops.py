"""Joint stops: a one-sided spring-damper at each limited joint's URDF position limits.

The multibody integrates joint angles freely; a controller or a placement that asks for more than the
hardware bends gets it. With ``joint_stops: {enabled: true}`` every DOF joint whose URDF ``<limit
lower upper>`` is finite (revolute; continuous joints have none) gets an end stop: the penalty
(compliant) joint-limit model of Drake's MultibodyPlant and of MuJoCo's soft limit constraints
(a spring-damper acting only past the limit; MuJoCo ``solref`` sets it by a time constant and a
damping ratio, Drake by a penetration allowance), with the damper clamped so the stop pushes and
never pulls (the Hunt-Crossley remedy for the linear damper's tensile force on release). Per side,
s = +1 at the upper limit and −1 at the lower one::

    δ = s (q − q_lim)                      (rad, > 0 past the limit)
    τ_stop = −s max(0, k δ + c s q̇)        (N·m, while δ > 0; 0 otherwise)

so past the upper limit τ = −(k δ + c q̇) ≤ 0 and past the lower one τ = k δ − c q̇ ≥ 0. A static load
τ presses the joint to δ = τ / k. With c = 0 the stop is conservative (potential ½ k δ²).

Defaults, from what the URDF knows: k = effort limit / ``penetration`` (at the actuator's full torque
the joint goes ``penetration`` past its limit: 0.02 rad, 1.1°) and c = 2 ζ sqrt(k I), I the joint's
apparent inertia with armature at the initial state (``Multibody.joint_inertia()``), ζ =
``damping_ratio`` (1: critically damped, no bounce). ``stiffness`` and ``damping`` override by joint
name or glob pattern. Joints without an effort limit need an explicit stiffness.

Jacobian (framework/linearization.py): while a stop pushes, ∂τ/∂q = −k and ∂τ/∂q̇ = −c on the joint's
diagonal (zero when it is clamped or clear), added to the multibody's torque slopes
(components/multibody/linearization.py) so ``rosenbrock_w`` treats the stop implicitly;
``stiffness_hint`` gives its mode sqrt(k / I) and c / I for explicit integrators' step check.
A stop met inside a step would be integrated explicitly (a stop at ω h = 15 then throws the joint
off at hundreds of rad/s), so J also carries a stop the joint may reach within ``lookahead_steps``
steps, T = lookahead_steps · dt, from its rate and acceleration (MuJoCo's limit ``margin`` in
spirit)::

    δ + T max(s q̇, 0) + T² max(s q̈, 0) > 0

A W-method keeps its order with any matrix in place of J (rosenbrock_w docstring); the price is
accuracy inside that band: a joint pushed by τ approaches at about τ / (γ h k) there, so crossing
it takes about γ (ω h)² steps, ω = sqrt(k / I): a few steps where the stop is resolved (EELS 1.5's
bends at the defaults: k = 4000 N·m/rad on 0.16 kg·m², ω = 157 rad/s, ω h = 1.6 at 10 ms: 4 steps),
seconds where it is not (k = 5e5 N·m/rad on 0.2 kg·m² at 10 ms).

The stops' torque is added to the multibody's generalised force before its forward dynamics; it is not
in the ``tau`` input nor in the ``energy`` output (its potential ½ k δ² is the caller's to add).
"""

from __future__ import annotations

import fnmatch
import math

import numpy as np
from numba import njit
from pydantic import Field

from snakesim.framework import Params

from .model import match_values
from .urdf import MultibodyModelError


class JointStopsParams(Params):
    enabled: bool = Field(False, description="end stops at the URDF position limits of every limited joint")
    penetration: float = Field(0.02, gt=0, description="rad past the limit at the joint's effort limit: the "
                                                       "default stiffness is effort / penetration")
    damping_ratio: float = Field(1.0, ge=0, description="default damping c = 2 ζ sqrt(k I), I the joint's "
                                                        "apparent inertia (armature included)")
    stiffness: dict[str, float] = Field(default_factory=dict, description="N·m/rad by joint name or pattern")
    damping: dict[str, float] = Field(default_factory=dict, description="N·m·s/rad by joint name or pattern")
    lookahead_steps: float = Field(1.0, ge=0, description="the Jacobian carries a stop the joint may reach within "
                                                          "this many steps (a W-method's stage that enters it is "
                                                          "then implicit)")


@njit(cache=True)
def add_torques(q, v, qi, vi, lim, side, k, c, T):
    """T[vi] += the stops' torques at (q, v) (module docstring); one entry per (joint, side)."""
    for n in range(qi.size):
        s = side[n]
        d = s * (q[qi[n]] - lim[n])
        if d > 0.0:
            f = k[n] * d + c[n] * s * v[vi[n]]
            if f > 0.0:
                T[vi[n]] -= s * f


@njit(cache=True)
def add_slopes(q, v, a, qi, vi, lim, side, k, c, T, gq, gv):
    """gq[vi] −= k, gv[vi] −= c for every stop that pushes at (q, v), or that the joint may reach within
    T seconds at its current rate and acceleration a (δ + T max(s q̇, 0) + T² max(s q̈, 0) > 0); True if any."""
    any_on = False
    for n in range(qi.size):
        s = side[n]
        d = s * (q[qi[n]] - lim[n])
        w = s * v[vi[n]]                        # the rate towards the stop
        if d > 0.0:
            on = k[n] * d + c[n] * w > 0.0
        else:
            on = d + T * max(w, 0.0) + T * T * max(s * a[vi[n]], 0.0) > 0.0
        if on:
            gq[vi[n]] -= k[n]
            gv[vi[n]] -= c[n]
            any_on = True
    return any_on


class JointStops:
    """A multibody's stops: per (joint, side) its q and v index, limit, side, k and c (arrays for the
    kernels), and the buffers of the torque slopes handed to the linearisation."""

    def __init__(self, joints, qi, vi, lim, side, k, c, inertia, nv, lookahead):
        self.joints = joints                        # per stop: the joint's name
        self.qi, self.vi, self.lim, self.side, self.k, self.c = qi, vi, lim, side, k, c
        self.inertia = inertia                      # per stop: the joint's apparent inertia, kg·m²
        self._gq, self._gv = np.zeros(nv), np.zeros(nv)
        self.lookahead = lookahead

    def apply(self, q, v, T) -> None:
        """T += the stops' generalised torques at (q, v)."""
        add_torques(q, v, self.qi, self.vi, self.lim, self.side, self.k, self.c, T)

    def slopes(self, q, v, a, dt, gq, gv, dense):
        """(gq, gv, dense) with −k, −c added on the diagonal of each joint whose stop pushes or may be met
        within ``lookahead_steps`` steps of dt (copies; the inputs are the torque input's cached slopes
        and stay untouched); the same objects when none is."""
        np.copyto(self._gq, gq)
        np.copyto(self._gv, gv)
        if not add_slopes(q, v, a, self.qi, self.vi, self.lim, self.side, self.k, self.c, self.lookahead * dt, self._gq,
                          self._gv):
            return gq, gv, dense
        if dense is not None:
            Gq0, Gv0 = dense[0].copy(), dense[1].copy()
            i = np.arange(gq.size)
            Gq0[i, i] += self._gq - gq
            Gv0[i, i] += self._gv - gv
            dense = (Gq0, Gv0)
        return self._gq, self._gv, dense

    def hint(self) -> list[tuple[float, str]]:
        """The stops' modes on each joint's apparent inertia: sqrt(k / I) and c / I (rad/s)."""
        out = []
        for n in range(0, self.k.size, 2):              # both sides of a joint share k, c
            I = self.inertia[n]
            if I > 0:
                name = self.joints[n]
                out.append((math.sqrt(self.k[n] / I), f"joint stop '{name}' k = {self.k[n]:g} N·m/rad over inertia "
                                                      f"{I:.3g} kg·m²"))
                out.append((self.c[n] / I, f"joint stop '{name}' c = {self.c[n]:g} N·m·s/rad over inertia {I:.3g}"))
        return out

    def table(self) -> dict[str, dict[str, float]]:
        """Per joint: lower, upper (rad), k (N·m/rad), c (N·m·s/rad)."""
        out: dict[str, dict[str, float]] = {}
        for n, name in enumerate(self.joints):
            row = out.setdefault(name, {"k": float(self.k[n]), "c": float(self.c[n])})
            row["upper" if self.side[n] > 0 else "lower"] = float(self.lim[n])
        return out


def build(mb, p: JointStopsParams) -> JointStops | None:
    """The stops of multibody ``mb`` (after its setup: robot, model, joint inertia), or None when off or
    no joint is limited. Errors name the key, the value and what is valid."""
    if not p.enabled:
        if p.stiffness or p.damping:
            raise MultibodyModelError(f"{mb.name}: joint_stops.stiffness / damping are given but joint_stops.enabled "
                                      "is false: set enabled: true or remove them")
        return None
    robot = mb.robot
    lo, hi = robot.position_limits()
    limited = np.isfinite(lo) | np.isfinite(hi)
    names = list(robot.joints)
    for what, spec in (("stiffness", p.stiffness), ("damping", p.damping)):
        bad = {key: val for key, val in spec.items() if not (math.isfinite(val) and val >= 0)
               or (what == "stiffness" and val == 0)}
        if bad:
            valid = "> 0" if what == "stiffness" else ">= 0"
            raise MultibodyModelError(f"{mb.name}: joint_stops.{what}: {bad} must be finite and {valid} "
                                      f"({'N·m/rad' if what == 'stiffness' else 'N·m·s/rad'})")
        match_values(names, spec, f"{mb.name}: joint_stops.{what}")      # a key matching no joint raises, listing them
        unlimited = [key for key in spec if not any(limited[j] for j, n in enumerate(names)
                                                    if n == key or fnmatch.fnmatchcase(n, key))]
        if unlimited:
            raise MultibodyModelError(f"{mb.name}: joint_stops.{what}: {unlimited} name only joints without position "
                                      f"limits (continuous); limited joints: "
                                      f"{', '.join(n for n, m in zip(names, limited) if m) or 'none'}")
    k_user = match_values(names, p.stiffness, "joint_stops.stiffness")
    c_user = match_values(names, p.damping, "joint_stops.damping")
    effort = robot.effort_limits()
    inertia = mb.joint_inertia()
    qi, vi, lim, side, k, c, who, I = [], [], [], [], [], [], [], []
    for j, name in enumerate(names):
        if not limited[j]:
            continue
        kj = k_user.get(name)
        if kj is None:
            if not math.isfinite(effort[j]):
                raise MultibodyModelError(f"{mb.name}: joint_stops: joint '{name}' has no URDF effort limit to derive "
                                          "its stop stiffness from: give joint_stops.stiffness for it")
            kj = effort[j] / p.penetration
        cj = c_user.get(name, 2.0 * p.damping_ratio * math.sqrt(kj * inertia[j]))
        for s, limit in ((1.0, hi[j]), (-1.0, lo[j])):
            qi.append(mb._jq_idx[j]), vi.append(mb._dof_v[j]), lim.append(limit), side.append(s)
            k.append(kj), c.append(cj), who.append(name), I.append(inertia[j])
    if not qi:
        return None
    i64, f64 = (lambda a: np.array(a, dtype=np.int64)), (lambda a: np.array(a, dtype=float))
    return JointStops(who, i64(qi), i64(vi), f64(lim), f64(side), f64(k), f64(c), f64(I), mb._nv,
                      p.lookahead_steps)

