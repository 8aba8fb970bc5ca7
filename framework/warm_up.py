"""Loading a plan's compiled code before its first timed step.

Numba loads each compiled kernel from its on-disk cache the first time a process calls it, and a bound
call (``kernel_args.bind``, ``linear_solve_kernels.bind``) types its arguments once: in a fresh process
the first evaluations, Jacobian assembly, factorisation and solves of a run cost ~0.2 s of loading, a
third of the default scene's 45 s at its speed. A session therefore takes one throwaway step of its
continuous system when it is built (the build's cost, not the run's): the time-invariant components
made, one derivative, one integrator step from the initial state, then the state put back. Only the
continuous closure is evaluated (plan.f), never a sink, a discrete update, a gate or an edit, so no
output leaves the process and no component's discrete state moves; whatever a component caches from it
is checked against its inputs as on any evaluation. Best effort: an error here is left for the run to
meet and report.

The same goes for connections and files a component would open at its first step (a DDS participant
and its endpoints take ~0.1 s each to open): ``open_before_run`` calls every component's ``before_run``
just before the timed loop of a run (never at build: ``snakesim check`` opens nothing), and
``close_after_run`` every ``after_run`` once the run has ended (an MCAP file complete when ``run``
returns, not when the process exits).
"""

from __future__ import annotations

import logging

import numpy as np

logger = logging.getLogger("snakesim.run")


def warm_up(plan, integrator, t0: float) -> None:
    """One step of ``plan``'s continuous system with ``integrator`` from its initial state, undone."""
    if not plan.nx:
        return
    X0, XD0 = plan.X.copy(), plan.XD.copy()
    flag = plan.stop_flag
    before = {k: getattr(flag, k) for k in type(flag).__slots__}
    try:
        for fn, x, u, y in plan.once:
            fn(t0, x, u, y)
        integrator.bind(plan)
        integrator.advance(t0, t0 + plan.dt, plan.f(t0, plan.X))
    except Exception as e:           # noqa: BLE001 - the run meets the same error and reports it
        logger.debug("warm-up step failed (the run will report it): %s", e)
    finally:
        np.copyto(plan.X, X0)
        np.copyto(plan.XD, XD0)
        for k, v in before.items():  # a stop asked for during the throwaway step is not the run's
            setattr(flag, k, v)


def open_before_run(plan, t0: float) -> None:
    """Every component's :meth:`~.component.Component.before_run` (with its inputs and ``u.cache``)."""
    for name, comp in plan.components.items():
        comp.before_run(t0, plan.io[name][1])


def close_after_run(plan) -> None:
    """Every component's :meth:`~.component.Component.after_run`, each tried even if one fails (the first
    error is raised after all were called)."""
    first = None
    for name, comp in plan.components.items():
        try:
            comp.after_run(plan.io[name][1])
        except Exception as e:      # noqa: BLE001 - the others still close; the first error is the run's
            first = first or e
    if first is not None:
        raise first


#: s the first build takes to compile snakesim's kernels on a 2-core machine (measured: ~50 s)
FIRST_COMPILE_S = 50


def kernels_cached() -> bool:
    """Whether numba's on-disk cache holds compiled kernels of this installation: an index file (``.nbi``)
    in the package's ``__pycache__`` folders, in ``NUMBA_CACHE_DIR``, or in numba's per-user cache (used
    when the package folder is read-only). A cold cache means the next build compiles for about
    :data:`FIRST_COMPILE_S` seconds, before the clock starts (:func:`warm_up`)."""
    import os
    from pathlib import Path

    package = Path(__file__).resolve().parents[1]          # the package's root (framework/ is in it)
    roots = [package / "components", package / "framework"]
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        roots = [Path(env)]
    roots.append(Path.home() / ".cache" / "numba")
    return any(next(r.rglob("*.nbi"), None) is not None for r in roots if r.is_dir())
