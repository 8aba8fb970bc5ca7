"""BLAS/OpenMP threads: one by default for runs, set before numpy loads.

The dense algebra snakesim does per step is small (an nv × nv LU: 306 × 306 at 100 EELS
modules, ~19 MFlop), where a multithreaded OpenBLAS spends more on waking and
synchronising its threads than on the work, and on a loaded machine far more: measured
on a shared 2-core machine, that LU took 64 ms with OpenBLAS's default threads against
2 ms with one. A run is one sequential loop, so one thread is the right default.

The libraries read their thread counts when they load, so this must run before numpy
(or scipy, Pinocchio, numba) is imported: the ``snakesim`` entry point
(:func:`snakesim.framework.cli.main`) calls :func:`pin_blas_threads` first thing, and
the benchmarks set the same variables at their top.

``SNAKESIM_BLAS_THREADS`` overrides: a number (``SNAKESIM_BLAS_THREADS=4``), or ``auto``
to leave every library at its own default. A variable the user set explicitly
(``OPENBLAS_NUM_THREADS=2 snakesim run``) is never overridden.
"""

from __future__ import annotations

import os
import sys

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
             "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
OVERRIDE = "SNAKESIM_BLAS_THREADS"


def pin_blas_threads(environ=None) -> str | None:
    """Set the BLAS/OpenMP thread variables (unless already set) to ``SNAKESIM_BLAS_THREADS`` or 1.

    Returns the count set ("1"), or None when ``SNAKESIM_BLAS_THREADS=auto``. Has no
    effect on a library already loaded (``too_late()`` says whether numpy is)."""
    env = os.environ if environ is None else environ
    want = env.get(OVERRIDE, "1").strip().lower()
    if want in ("auto", "", "default"):
        return None
    if not want.isdigit() or int(want) < 1:
        raise ValueError(f"{OVERRIDE}={env.get(OVERRIDE)!r}: a thread count >= 1, or 'auto'")
    for var in VARIABLES:
        env.setdefault(var, want)
    return want


def too_late() -> bool:
    """True when numpy is already loaded (its BLAS has read its thread count)."""
    return "numpy" in sys.modules
