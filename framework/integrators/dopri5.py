"""Adaptive Dormand-Prince 5(4) with error control (rtol, atol).

Within each base step it takes as many sub-steps as the error estimate
needs; the step size carries over between base steps. The error norm is the
RMS of err_i / (atol + rtol·max(|x_i|, |x⁺_i|)) over Euclidean states (atol
alone on manifold coordinates). Hairer, Nørsett & Wanner, Solving ODEs I,
II.4 and II.5 (coefficients, PI-free step control with safety 0.9).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ..errors import SnakesimError
from .base import Integrator, IntegratorParams

C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1])
A = [
    [],
    [1 / 5],
    [3 / 40, 9 / 40],
    [44 / 45, -56 / 15, 32 / 9],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
]
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0])
E = B - np.array([5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40])


class Dopri5Params(IntegratorParams):
    rtol: float = Field(1e-6, gt=0)
    atol: float = Field(1e-8, gt=0)
    h_init: float | None = Field(None, gt=0, description="first trial step, s (default: the base step)")
    h_min: float = Field(1e-12, gt=0, description="below this the run stops as too stiff, s")
    max_substeps: int = Field(100000, gt=0, description="per base step")


class Dopri5(Integrator):
    name = "dopri5"
    order = 5
    description = "adaptive Dormand-Prince 5(4), error-controlled (rtol, atol)"
    Params = Dopri5Params

    def _alloc(self, nx, ndx):
        self.k = np.zeros((7, ndx))
        self.x0 = np.zeros(nx)
        self.xs = np.zeros(nx)
        self.x5 = np.zeros(nx)
        self.dx = np.zeros(ndx)
        self.err = np.zeros(ndx)
        self.h = self.p.h_init
        self.e = self.sys.n_euclid_x
        self.stats.update(rejected=0)

    def advance(self, t0, t1, k1):
        sys, k = self.sys, self.k
        h = self.h or (t1 - t0)
        t = t0
        np.copyto(k[0], k1)
        n = 0
        while t < t1 - 1e-15 * max(1.0, abs(t1)):
            h = min(h, t1 - t)
            np.copyto(self.x0, sys.X)
            for s in range(1, 7):
                self.dx[:] = 0.0
                for j, a in enumerate(A[s]):
                    if a:
                        self.dx += a * k[j]
                self.dx *= h
                sys.integrate(self.x0, self.dx, self.xs)
                np.copyto(k[s], sys.f(t + C[s] * h, self.xs))
                sys.dexp_inv(self.x0, self.dx, k[s])  # RKMK chart correction (manifold states)
            self.stats["f_evals"] += 6
            # 5th-order solution is the last stage's point (FSAL): xs = x0 ⊕ h·Σ b k
            np.dot(E, k, out=self.err)
            self.err *= h
            e = self.e
            scale = self.p.atol + self.p.rtol * np.maximum(np.abs(self.x0[:e]), np.abs(self.xs[:e]))
            ratio = np.concatenate((self.err[:e] / scale, self.err[e:] / self.p.atol)) if e < self.err.size \
                else self.err / scale
            err = float(np.sqrt(np.mean(ratio * ratio))) if ratio.size else 0.0
            n += 1
            if err <= 1.0 or h <= self.p.h_min:
                if err > 1.0:
                    raise SnakesimError(f"dopri5: step size fell to h_min = {self.p.h_min:g} s at t = {t:.9g} s "
                                        f"with error ratio {err:.3g}; the system is too stiff for an explicit "
                                        f"method: try the 'rosenbrock2' integrator or loosen rtol/atol")
                t += h
                np.copyto(sys.X, self.xs)
                np.copyto(k[0], k[6])
                self.stats["steps"] += 1
                fac = 5.0 if err == 0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
            else:
                self.stats["rejected"] += 1
                np.copyto(sys.X, self.x0)
                fac = max(0.2, 0.9 * err ** -0.2)
            h *= fac
            if n > self.p.max_substeps:
                raise SnakesimError(f"dopri5: more than {self.p.max_substeps} sub-steps in one base step at t = {t:.9g} s")
        self.h = h
