"""Linearly implicit Rosenbrock ROS2 (order 2, L-stable) for stiff contact.

    (I − γhJ) k1 = f(xₙ)
    (I − γhJ) k2 = f(xₙ ⊕ h·k1) − 2·k1
    xₙ₊₁ = xₙ ⊕ h·(3/2·k1 + 1/2·k2),     γ = 1 + 1/√2

Verwer, Spee, Blom & Hundsdorfer, SIAM J. Sci. Comput. 20 (1999). Two
evaluations and one LU factorisation per step: stiff springs (contact
penalties, tethers) no longer limit the step to their natural period. J is
the Jacobian of f in the tangent space, by forward differences (ndx
evaluations), refreshed every ``jacobian_every`` steps.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from pydantic import Field

from .base import FixedStep, FixedStepParams

GAMMA = 1.0 + 1.0 / np.sqrt(2.0)


class Rosenbrock2Params(FixedStepParams):
    jacobian_every: int = Field(1, ge=1, description="steps between Jacobian refreshes")
    fd_eps: float = Field(1e-7, gt=0, description="relative finite-difference perturbation")


class Rosenbrock2(FixedStep):
    name = "rosenbrock2"
    order = 2
    description = "linearly implicit Rosenbrock ROS2 (L-stable) for stiff systems; FD Jacobian"
    Params = Rosenbrock2Params

    def _alloc(self, nx, ndx):
        self.J = np.zeros((ndx, ndx))
        self.x0 = np.zeros(nx)
        self.xs = np.zeros(nx)
        self.f0 = np.zeros(ndx)
        self.f1 = np.zeros(ndx)
        self.k1 = np.zeros(ndx)
        self.k2 = np.zeros(ndx)
        self.dx = np.zeros(ndx)
        self.eye = np.eye(ndx)
        self.lu = None
        self.h_lu = None
        self.age = 0
        self.stats.update(jacobians=0)

    def _jacobian(self, t, f0):
        sys = self.sys
        e = np.zeros(sys.ndx)
        for j in range(sys.ndx):
            eps = self.p.fd_eps * max(1.0, abs(self.x0[j]) if j < sys.n_euclid_x else 1.0)
            e[j] = eps
            sys.integrate(self.x0, e, self.xs)
            self.J[:, j] = (sys.f(t, self.xs) - f0) / eps
            e[j] = 0.0
        self.stats["f_evals"] += sys.ndx
        self.stats["jacobians"] += 1

    def step(self, t, h, k1):
        sys = self.sys
        np.copyto(self.x0, sys.X)
        np.copyto(self.f0, k1)
        if self.lu is None or self.age >= self.p.jacobian_every or h != self.h_lu:
            if self.lu is None or self.age >= self.p.jacobian_every:
                self._jacobian(t, self.f0)
                self.age = 0
            self.lu = sla.lu_factor(self.eye - (GAMMA * h) * self.J, check_finite=False)
            self.h_lu = h
        self.age += 1
        self.k1[:] = sla.lu_solve(self.lu, self.f0, check_finite=False)
        np.multiply(self.k1, h, out=self.dx)
        sys.integrate(self.x0, self.dx, self.xs)
        np.copyto(self.f1, sys.f(t + h, self.xs))
        sys.dexp_inv(self.x0, self.dx, self.f1)  # chart correction at x0 (manifold states)
        rhs = self.f1 - 2.0 * self.k1
        self.stats["f_evals"] += 1
        self.k2[:] = sla.lu_solve(self.lu, rhs, check_finite=False)
        np.multiply(self.k1, 1.5 * h, out=self.dx)
        self.dx += (0.5 * h) * self.k2
        sys.integrate(self.x0, self.dx, sys.X)
