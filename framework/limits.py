"""Sizes checked before anything is allocated: a bad duration, step or resolution is an error naming
the estimate, the limit and what would fit, never a MemoryError, a swapping machine or an overflow.

``memory_limit_bytes()`` is half the machine's physical memory, or ``SNAKESIM_MEMORY_LIMIT`` (bytes,
e.g. ``8e9``) when set. One allocation may take at most that much.
"""

from __future__ import annotations

import os

from .errors import ConfigError

#: most base steps in one run: t = t0 + k·dt stays exact in float64 far beyond it, and at ~1 µs a step
#: it is already 11 days of wall time
MAX_STEPS = 10**12


def memory_limit_bytes() -> float:
    env = os.environ.get("SNAKESIM_MEMORY_LIMIT")
    if env:
        try:
            v = float(env)
        except ValueError:
            raise ConfigError(f"SNAKESIM_MEMORY_LIMIT must be a number of bytes, got {env!r}") from None
        if not v > 0:
            raise ConfigError(f"SNAKESIM_MEMORY_LIMIT must be > 0 bytes, got {env!r}")
        return v
    try:
        return 0.5 * os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):     # not POSIX: a conservative 8 GB
        return 8e9


def fmt_bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def step_count(duration: float, dt: float) -> int:
    """round(duration / dt), refused beyond :data:`MAX_STEPS` (and when it overflows) naming both values."""
    ratio = duration / dt
    if not ratio <= MAX_STEPS:      # also inf and nan
        raise ConfigError(f"duration {duration:g} s at dt = {dt:g} s is {ratio:.3g} steps; at most {MAX_STEPS:.0e} "
                          f"steps are allowed (a larger dt, at least {duration / MAX_STEPS:.3g} s, or a shorter "
                          f"duration)", None, "sim.dt")
    return int(round(ratio))
