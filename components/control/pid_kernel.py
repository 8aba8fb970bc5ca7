"""numba kernel of the joint PID law (pid.py): every joint in one call, no temporaries.

The law is the module docstring of :mod:`.pid`, joint by joint; ``pid_law``
fills per joint

    tau    the saturated output
    err    e (position error wrapped to (−π, π] on continuous joints)
    dint   the integral's rate: e, or 0 while clamped (anti-windup)
    zrate  continuous form: ż = (r − z)/tf (position) or (e − z)/tf (velocity), times 1/tf = 0 if tf = 0
           discrete form:   the next filter state z_{k+1}

so ``output``, ``derivative`` and ``update`` each read what they need.
x is the state: [I, z] (continuous) or [I, z, started] (discrete).
"""

from __future__ import annotations

import math

from numba import njit

from ..kernel_args import record

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def pid_law(pos, wrap, kp, ki, kd, tf, tmax, inv_tf, a, T, discrete, clamp, setpoint, rate_ref, tau_ff, q, v, x,
            tau, err, dint, zrate):
    n = kp.size
    first = discrete and x[2 * n] == 0.0
    for i in range(n):
        r = rate_ref[i] - v[i]
        if pos[i]:
            e = setpoint[i] - q[i]
            if wrap[i]:
                e = math.pi - (math.pi - e) % TWO_PI
        else:
            e = setpoint[i] - v[i]
        z = x[n + i]
        if discrete:
            if first:                       # the filter starts at its input: no derivative kick
                z = r if pos[i] else e
            d = (1.0 - a[i]) * z + a[i] * r if pos[i] else (e - z) / (tf[i] + T)
        elif pos[i]:
            d = z if tf[i] > 0 else r
        else:
            d = (e - z) * inv_tf[i]
        raw = kp[i] * e + ki[i] * x[i] + kd[i] * d + tau_ff[i]
        out = raw
        if raw > tmax[i]:
            out = tmax[i]
        elif raw < -tmax[i]:
            out = -tmax[i]
        tau[i] = out
        err[i] = e
        dint[i] = 0.0 if (clamp and raw != out and e * raw > 0) else e
        if discrete:
            zrate[i] = d if pos[i] else z + T * d
        else:
            zrate[i] = ((r - z) if pos[i] else (e - z)) * inv_tf[i]


# -- on argument records (kernel_args.py) ------------------------------------------------------------
#   gains  Gains   the component's constants (per joint: mode, wrap, gains, filter, limits)
#   run    PidRun  this run's input views, state view x, and where the law writes tau, err, dint, zrate

Gains = record("Gains", ("pos", "wrap", "kp", "ki", "kd", "tf", "tmax", "inv_tf", "a", "T", "discrete", "clamp"))
PidRun = record("PidRun", ("setpoint", "rate_ref", "tau_ff", "q", "v", "x", "tau", "err", "dint", "zrate"))


@njit(cache=True)
def pid_step(gains, run):
    g, r = gains, run
    pid_law(g.pos, g.wrap, g.kp, g.ki, g.kd, g.tf, g.tmax, g.inv_tf, g.a, g.T, g.discrete, g.clamp, r.setpoint,
            r.rate_ref, r.tau_ff, r.q, r.v, r.x, r.tau, r.err, r.dint, r.zrate)
