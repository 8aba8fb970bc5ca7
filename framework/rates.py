"""Rates and periods: one rule for turning a rate in Hz into a whole number of base steps.

Every multi-rate decision (a discrete component's ticks, the recorder's rows,
a sink's frames, output groups sampled at their readers' ticks) goes through
:func:`period_of`, and the number of distinct tick patterns the plan keeps is
bounded by :data:`MAX_PHASES`.
"""

from __future__ import annotations

import math

from .errors import BuildError

#: most distinct tick patterns (the least common multiple of all periods) a plan keeps
MAX_PHASES = 4096


def period_of(rate: float | None, dt: float, what: str) -> int:
    """Base steps between ticks of ``rate`` Hz (1 for None: every step); an error unless whole.
    ``what`` names the rate in the error, e.g. ``"pid: rate"`` or ``"sim.record_rate"``."""
    if rate is None:
        return 1
    steps = 1.0 / (rate * dt)
    n = round(steps)
    if n < 1 or abs(steps - n) > 1e-6 * max(1.0, steps):
        raise BuildError(f"{what} {rate:g} Hz is not an integer number of base steps "
                         f"(dt = {dt:g} s gives {steps:.4g} steps per tick); valid rates are "
                         f"{1 / dt:g}/k Hz for integer k >= 1, e.g. {1 / (dt * max(1, n)):g} Hz")
    return n


def nearest_period(rate: float, dt: float) -> int:
    """The whole number of base steps closest to ``rate`` Hz, at least 1 (for a sink that may round)."""
    return max(1, round(1.0 / (rate * dt)))


def lcm(periods) -> int:
    n = 1
    for p in periods:
        n = n * p // math.gcd(n, p)
    return n


def phase_count(periods) -> int:
    """Distinct tick patterns of these periods; an error naming them past :data:`MAX_PHASES`."""
    n = lcm(periods)
    if n > MAX_PHASES:
        raise BuildError(f"the component rates need {n} distinct tick patterns (> {MAX_PHASES}); choose rates "
                         f"whose periods in base steps share factors (periods: {sorted(set(periods))})")
    return n
