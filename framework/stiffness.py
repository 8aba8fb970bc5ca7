"""Is the step small enough for the physics? The stiffest mode the build can estimate against the
integrator's stability bound, checked once before the first step.

Components say what they make stiff through the optional ``Component.stiffness_hint(u, readers)``:
(ω in rad/s, what) pairs, e.g. a contact's penalty stiffness over the lightest body it touches,
ω = sqrt(n·k/m) (and its damping rate n·c/m), a PID's gains over the joint's apparent inertia with
armature, ω = sqrt(kp/I) (and kd/I, the filter's 1/tf). ``readers(port)`` lists the components that
read one of its outputs (the PID asks the multibody its tau feeds for ``joint_inertia()``).

An explicit method is stable for an oscillatory mode while ω·h stays inside its stability region on
the imaginary axis (RK4: 2√2 ≈ 2.8; explicit and semi-implicit Euler: 2, the latter's exact bound
for an undamped oscillator); a decaying mode λ needs |λ|·h inside it on the real axis (RK4 ≈ 2.79,
Euler 2), so one bound per method is used for both. Past it the run does not stop: it is warned
(logger ``snakesim.run`` and the summary's ``step_check``) with the largest stable step, because an
estimate (the lightest body, one contact per ring) can be pessimistic; implicit and adaptive methods
(rosenbrock*, dopri5) have no such bound here.
"""

from __future__ import annotations

import logging
import math

logger = logging.getLogger("snakesim.run")

#: ω·h bound of explicit methods on the imaginary axis (name -> bound)
STABILITY_BOUND = {"rk4": 2.0 * math.sqrt(2.0), "semi_implicit_euler": 2.0, "euler": 2.0}


def stability_bound(integrator) -> float | None:
    """The integrator's ω·h bound: its own ``stability_bound`` attribute (a plugin's), else the table."""
    b = getattr(integrator, "stability_bound", None)
    return b if b is not None else STABILITY_BOUND.get(integrator.name)


def step_check(plan, integrator) -> dict | None:
    """None when no component gives a hint; else what the stiffest mode is and whether dt is past the bound
    (then also logged as a warning)."""
    readers_of: dict = {}
    for dst, src in plan.sources.items():
        readers_of.setdefault(src, []).append(plan.components[dst.comp])
    modes = []
    for name, comp in plan.components.items():
        hint = getattr(comp, "stiffness_hint", None)
        if hint is None:
            continue
        u = plan.io[name][1]
        out = hint(u, lambda port, n=name: readers_of.get(_ref(n, port), []))
        modes += [(float(w), f"{name}: {what}") for w, what in (out or ()) if w > 0 and math.isfinite(w)]
    if not modes:
        return None
    w, what = max(modes)
    bound, dt = stability_bound(integrator), plan.dt
    check = {"stiffest_mode_rad_s": w, "mode": what, "omega_dt": w * dt, "integrator": integrator.name}
    if bound is None:
        check["note"] = f"{integrator.name} has no explicit stability bound here"
        return check
    check["stability_bound_omega_dt"] = bound
    check["largest_stable_dt_s"] = bound / w
    check["dt_exceeds_stable_step"] = w * dt > bound
    if w * dt > bound:
        logger.warning("dt = %g s is past %s's stability bound for the stiffest mode the build can estimate "
                       "(%s: omega = %.4g rad/s, omega*dt = %.3g > %.3g): the run may gain energy from nothing "
                       "(a robot that should lie still hops); use dt <= %.3g s or an implicit integrator "
                       "(rosenbrock_w)", dt, integrator.name, what, w, w * dt, bound, bound / w)
    return check


def _ref(comp: str, port: str):
    from .wiring import PortRef

    return PortRef(comp, port)
