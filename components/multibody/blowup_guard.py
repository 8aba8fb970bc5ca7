"""Blow-up guard: kinetic energy that nothing in the model could have supplied within one step.

Work-energy theorem for the robot (links and rotor armature), over one base step [t0, t1] of length h::

    T(t1) − T(t0) = W_joints + W_external + W_gravity + W_damping,       W_damping ≤ 0

T = ½ vᵀ M v (J): the links' ½ m v_c² + ½ ωᵀ I ω and the rotors' ½ J_a q̇². Each work term is
bounded from what the state and the inputs are at the two ends of the step (the guard sees
nothing in between, and an explicit integrator's stages are not the true path anyway):

    W_gravity  = ½ (g0 + g1) · (Σ m c(t1) − Σ m c(t0))      exact for a constant g: −ΔPE (J)
    W_joints   ≤ h · max over both ends of Σ_j |τ_j q̇_j|     the torque input and the joint stops
    W_external ≤ h · max over both ends of Σ_l |f_l·v_l + τ_l·ω_l|
                                                            the link wrenches (contact, tethers): a contact
                                                            gives back at most the elastic energy it
                                                            stored, which enters through this power

The power bounds hold as written when the power is monotonic over the step (|∫P| ≤ h max|P|); a
resolved trajectory's power varies over a step by a factor of order one, and a contact that returns
its stored energy within one step releases it at a power its end values see only partly. Hence a
step is a blow-up when

    ΔT − W_gravity > factor · h · max(P0, P1) + floor · m_total

``factor`` (default 10) covers the power varying within a step; ``floor`` (J/kg of robot mass, default
0.2: the kinetic energy of 0.63 m/s, or the potential energy of a 2 cm lift, per kilogram) covers what
legitimate integration error leaves in a step where the power bound is near zero (free flight, a
robot at rest: explicit Euler's ½ g² h² is 5e-3 J/kg at 10 ms) and a contact's stored energy that
the step's ends do not show (the default scene's robot, its weight pressing it 0.2 mm into the ice,
stores ½ g δ ≈ 1e-3 J/kg). Measured over every scene in assemblies/ and the contact, control,
multibody, monitor, placement and validation tests (2 s each at the scenes' own integrators, drops
of 5 and 20 cm at RK4 0.2 and 1 ms): no legitimate step left more than 0.015 J/kg unexplained at factor 10 (the
lively free robot at rosenbrock_w's tolerances), 13x below the floor; the default scene at RK4 20 ms
leaves 0.26 J/kg in its 7th step and 0.7 in its 8th, the Mini EELS crawl at RK4 5 ms (10x its
step) 0.28, a fixed-step contact onset that throws the robot 2.5.

What it catches: energy that appears with no power to carry it. A one-sided contact stepped past its
stability bound throws a screw and stops pushing (its power at the step's end is zero) while the
kinetic energy it injected stays; a nonlinear runaway outgrows any end power. What it cannot catch
early: a stiff conservative spring (a joint spring, a PID's gain) stepped past the bound at ω h ≳ 1,
whose energy grows by |R(iωh)|² per step: a correct step would trade the spring's whole energy with
the links as well, and the spring's power at the step's ends (~ω E) allows it. Such a runaway is
stopped once it turns nonlinear (a 1-module robot's bend spring at RK4 ω h = 2·2√2: one step before
its state overflows), or else ends as a non-finite state: a failure either way.

The link named is the one whose own kinetic energy rose the most in the step (joints pass energy
between links, so only the robot's total is bounded; the link says where the runaway is). Runs once
per base step (``Multibody.check``), never in the integrator's stages: one numba kernel over the
links and joints, O(links + joints), no allocation.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field

from snakesim.framework import Params

from ..kernel_args import record
from .joint_stops import add_torques
from .kernels import _ensure_kinematics


class BlowupGuardParams(Params):
    enabled: bool = Field(True, description="stop the run (failure kind blow_up) when a step's kinetic energy "
                                            "gain exceeds what the actuators, contacts and gravity can supply")
    factor: float = Field(10.0, ge=1.0, description="margin on the work bound h · max(end powers): the power "
                                                    "varies within a step")
    floor: float = Field(0.2, gt=0.0, description="J/kg of robot mass: unexplained energy always allowed per "
                                                  "step (integration error, stored contact energy)")


# per run: the stops' arrays (empty without stops) and the previous base step's values
Guard = record("BlowupGuard", ("arm_v", "qi", "vi", "lim", "side", "k", "c", "stop_T", "ke_link", "ke_now",
                               "prev", "args", "out"))
# prev: [T, P, g0, g1, g2, mc0, mc1, mc2, m_total, t] of the previous base tick
# args: [t, restart (1/0), factor, floor J/kg], set before each call
# out:  [ΔT, W_gravity, h·max(P0, P1), excess, ΔT of the named link] (J), h (s) after each call


@njit(cache=True)
def _energies(tree, kin, ports, ke_link):
    """Per-link kinetic energy into ke_link (J); returns (T links + rotors, P = joint + wrench power
    magnitudes (W), Σ m c (kg·m) as three numbers, total mass)."""
    R, p, w, vo = kin.R, kin.p, kin.w, kin.vo
    mass, com, inertia = tree.mass, tree.com, tree.inertia
    W = ports.wrenches
    ke = 0.0
    pw = 0.0
    m_t, s0, s1, s2 = 0.0, 0.0, 0.0, 0.0
    for l in range(mass.shape[0]):
        # the external wrench's power: [f, τ about the link origin] · [v origin, ω], world axes
        pw += abs(W[l, 0] * vo[l, 0] + W[l, 1] * vo[l, 1] + W[l, 2] * vo[l, 2]
                  + W[l, 3] * w[l, 0] + W[l, 4] * w[l, 1] + W[l, 5] * w[l, 2])
        m = mass[l]
        cx = R[l, 0, 0] * com[l, 0] + R[l, 0, 1] * com[l, 1] + R[l, 0, 2] * com[l, 2]
        cy = R[l, 1, 0] * com[l, 0] + R[l, 1, 1] * com[l, 1] + R[l, 1, 2] * com[l, 2]
        cz = R[l, 2, 0] * com[l, 0] + R[l, 2, 1] * com[l, 1] + R[l, 2, 2] * com[l, 2]
        v0 = vo[l, 0] + w[l, 1] * cz - w[l, 2] * cy
        v1 = vo[l, 1] + w[l, 2] * cx - w[l, 0] * cz
        v2 = vo[l, 2] + w[l, 0] * cy - w[l, 1] * cx
        # ω in the link frame, then ½ ωᵀ I ω
        b0 = R[l, 0, 0] * w[l, 0] + R[l, 1, 0] * w[l, 1] + R[l, 2, 0] * w[l, 2]
        b1 = R[l, 0, 1] * w[l, 0] + R[l, 1, 1] * w[l, 1] + R[l, 2, 1] * w[l, 2]
        b2 = R[l, 0, 2] * w[l, 0] + R[l, 1, 2] * w[l, 1] + R[l, 2, 2] * w[l, 2]
        rot = (b0 * (inertia[l, 0, 0] * b0 + inertia[l, 0, 1] * b1 + inertia[l, 0, 2] * b2)
               + b1 * (inertia[l, 1, 0] * b0 + inertia[l, 1, 1] * b1 + inertia[l, 1, 2] * b2)
               + b2 * (inertia[l, 2, 0] * b0 + inertia[l, 2, 1] * b1 + inertia[l, 2, 2] * b2))
        e = 0.5 * m * (v0 * v0 + v1 * v1 + v2 * v2) + 0.5 * rot
        ke_link[l] = e
        ke += e
        m_t += m
        s0 += m * (p[l, 0] + cx)
        s1 += m * (p[l, 1] + cy)
        s2 += m * (p[l, 2] + cz)
    return ke, pw, s0, s1, s2, m_t


@njit(cache=True)
def guard_step(tree, kin, ports, guard):
    """One base step's check at the current state (kin's kinematics, ports' inputs of this tick t).

    Returns the row of the link whose kinetic energy rose the most when the step from the previous
    tick is a blow-up (module docstring), else -1; guard.out holds the step's terms either way. With
    restart set it only records this state (the first tick, after a state edit)."""
    t, restart, factor, floor = guard.args[0], guard.args[1] != 0.0, guard.args[2], guard.args[3]
    _ensure_kinematics(tree, kin)
    v, g = kin.v, kin.g
    ke_now = guard.ke_now
    ke, pw, s0, s1, s2, m_t = _energies(tree, kin, ports, ke_now)
    arm = guard.arm_v
    for i in range(arm.size):
        ke += 0.5 * arm[i] * v[i] * v[i]
    # joint power: the torque input and the joint stops (damping only takes energy out)
    tau, dof = ports.tau, tree.dof_v
    for j in range(dof.size):
        pw += abs(tau[j] * v[dof[j]])
    if guard.qi.size:
        sT = guard.stop_T
        sT[:] = 0.0
        add_torques(kin.q, v, guard.qi, guard.vi, guard.lim, guard.side, guard.k, guard.c, sT)
        for i in range(sT.size):
            pw += abs(sT[i] * v[i])
    prev, out = guard.prev, guard.out
    link = -1
    if restart:
        out[:] = 0.0
    else:
        h = t - prev[9]
        dke = ke - prev[0]
        wg = 0.5 * ((prev[2] + g[0]) * (s0 - prev[5]) + (prev[3] + g[1]) * (s1 - prev[6])
                    + (prev[4] + g[2]) * (s2 - prev[7]))
        work = h * max(prev[1], pw)
        excess = dke - wg - factor * work
        out[0], out[1], out[2], out[3], out[5] = dke, wg, work, excess, h
        if excess > floor * m_t:
            best = -np.inf
            for l in range(ke_now.size):
                d = ke_now[l] - guard.ke_link[l]
                if d > best:
                    best, link = d, l
            out[4] = best
    guard.ke_link[:] = ke_now
    prev[0], prev[1] = ke, pw
    prev[2], prev[3], prev[4] = g[0], g[1], g[2]
    prev[5], prev[6], prev[7], prev[8], prev[9] = s0, s1, s2, m_t, t
    return link


def make_guard(mb, p: BlowupGuardParams):
    """This run's guard record for multibody ``mb`` (its constants: rotor armature, the joint stops), and
    its ``args``, ``out`` and ``prev`` arrays (the record is opaque from Python)."""
    st = mb._stops
    i64, f64 = np.zeros(0, dtype=np.int64), np.zeros(0)
    stops = (st.qi, st.vi, st.lim, st.side, st.k, st.c) if st is not None else (i64, i64, f64, f64, f64, f64)
    nl = mb.robot.nl
    args, out, prev = np.array([0.0, 1.0, p.factor, p.floor]), np.zeros(6), np.zeros(10)
    rec = Guard(arm_v=mb._arm_v, qi=stops[0], vi=stops[1], lim=stops[2], side=stops[3], k=stops[4], c=stops[5],
                stop_T=np.zeros(mb._nv), ke_link=np.zeros(nl), ke_now=np.zeros(nl), prev=prev, args=args, out=out)
    return rec, args, out, prev


def blow_up_reason(robot, link: int, guard_args: np.ndarray, out: np.ndarray, t: float, m_total: float) -> str:
    """The stop's reason: the step, how much energy appeared and from where it could have come, the link."""
    dke, wg, work, excess, dlink, h = (float(x) for x in out)
    t_prev = t - h
    factor, floor = float(guard_args[2]), float(guard_args[3])
    return (f"blow-up in the step from t = {t_prev:.6g} to {t:.6g} s: link '{robot.links[link]}' gained the most "
            f"kinetic energy ({dlink:.4g} J); the robot's rose {dke:.4g} J where gravity supplied {wg:.4g} J and the "
            f"joints and external wrenches at most {factor:g} x {work:.4g} J ({factor:g} x h x their larger end "
            f"power): {excess:.4g} J unexplained, more than the floor {floor * m_total:.3g} J ({floor:g} J/kg)")
