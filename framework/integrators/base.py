"""What every integrator implements: advance the shared state X from t0 to t1.

The system (a compiled :class:`~snakesim.framework.plan.Plan`) provides::

    f(t, X) -> DX        derivative in the tangent space (a shared buffer: copy it)
    integrate(X, dX, out) X ⊕ dX (vector add, or a component's manifold map)
    X, nx, ndx           the working state and its sizes

``advance`` is called once per base step with ``k1`` = f(t0, X) already
evaluated by the simulator's output pass (first-same-as-last).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict


class IntegratorParams(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class Integrator:
    name: ClassVar[str] = ""
    order: ClassVar[int] = 0
    description: ClassVar[str] = ""
    Params: ClassVar[type[BaseModel]] = IntegratorParams

    def __init__(self, params: dict | BaseModel | None = None):
        params = params or {}
        self.p = params if isinstance(params, self.Params) else self.Params(**params)
        self.stats = {"f_evals": 0, "steps": 0}

    def bind(self, system) -> None:
        self.sys = system
        self.stats = {"f_evals": 0, "steps": 0}    # per run: bind starts every run
        self._alloc(system.nx, system.ndx)

    def restart(self) -> None:
        """Forget every memory of past steps (step size, Jacobian, multistep history) after the state was
        changed between two steps (:mod:`snakesim.framework.state_edit`); the run's stats are kept and
        ``restarts`` counts the restarts."""
        stats = self.stats
        self.bind(self.sys)
        stats["restarts"] = stats.get("restarts", 0) + 1
        self.stats = stats

    def _alloc(self, nx: int, ndx: int) -> None:
        """Preallocate work arrays."""

    def advance(self, t0: float, t1: float, k1: np.ndarray) -> None:
        raise NotImplementedError


class FixedStepParams(IntegratorParams):
    substeps: int = 1  # integrator steps per base step (h = dt / substeps)


class FixedStep(Integrator):
    """Base of fixed-step schemes: ``substeps`` equal steps per base step."""

    Params = FixedStepParams

    def substeps_now(self, t0: float) -> int:
        """How many equal steps the base step from ``t0`` is taken in (``substeps``; a method may take more
        where it knows the dynamics are fast: rosenbrock_w's refresh window)."""
        return self.p.substeps

    def advance(self, t0, t1, k1):
        n = self.substeps_now(t0)
        if n == 1:
            self.step(t0, t1 - t0, k1)
            self.stats["steps"] += 1
            return
        h = (t1 - t0) / n
        for s in range(n):
            if s:
                k1 = self.sys.f(t0 + s * h, self.sys.X)
                self.stats["f_evals"] += 1
            self.step(t0 + s * h, h, k1)
            self.stats["steps"] += 1

    def step(self, t, h, k1) -> None:
        raise NotImplementedError
