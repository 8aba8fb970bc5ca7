"""Classic fourth-order Runge-Kutta, four evaluations per step.

On manifold states each stage derivative is mapped back to the chart at the
step's start (RKMK, Munthe-Kaas 1998), so the order stays 4 on SE(3).
"""

from __future__ import annotations

import numpy as np

from .base import FixedStep


class RK4(FixedStep):
    name = "rk4"
    order = 4
    description = "classic Runge-Kutta 4; four evaluations per step"

    def _alloc(self, nx, ndx):
        self.x0 = np.zeros(nx)
        self.xs = np.zeros(nx)
        self.k = np.zeros((4, ndx))
        self.tmp = np.zeros(ndx)
        self._to_stage = self.sys.bind_integrate(self.x0, self.tmp, self.xs)
        self._to_end = self.sys.bind_integrate(self.x0, self.tmp, self.sys.X)

    def step(self, t, h, k1):
        sys, k, tmp = self.sys, self.k, self.tmp
        np.copyto(self.x0, sys.X)
        np.copyto(k[0], k1)
        for i, (c, a) in enumerate(((0.5, 0.5), (0.5, 0.5), (1.0, 1.0)), start=1):
            np.multiply(k[i - 1], a * h, out=tmp)
            self._to_stage()                         # xs = x0 ⊕ tmp
            np.copyto(k[i], sys.f(t + c * h, self.xs))
            sys.dexp_inv(self.x0, tmp, k[i])  # Munthe-Kaas: keeps order 4 on SE(3)
        self.stats["f_evals"] += 3
        np.add(k[0], k[3], out=tmp)
        tmp += 2.0 * k[1]
        tmp += 2.0 * k[2]
        tmp *= h / 6.0
        self._to_end()                               # X = x0 ⊕ tmp
