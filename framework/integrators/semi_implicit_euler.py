"""Semi-implicit Euler, order 1.

For second-order states [q, v] (q̇ = v in the tangent space):
    v⁺ = v + h·a(q, v),   q⁺ = q ⊕ h·v⁺
It is symplectic, and so keeps a shadow energy, only for a separable
Hamiltonian in canonical coordinates (constant mass, forces of position
alone: a spring-mass chain, a pendulum). A multibody's mass matrix depends on
q and its Coriolis terms on v, and it steps velocities, not momenta: there
the method is not symplectic, and energy drifts: +0.27 %/s at 1 ms on
``robot-zero-g`` (EELS 1.0, 10 modules, free in zero gravity, bend rates
0.3 rad/s; RK4 keeps it to 2e-13 /s), measured with ``snakesim run
robot-zero-g --integrator semi_implicit_euler --out DIR`` from robot.energy. First-order states take an explicit Euler step. Since q̇ = v, the
position increment h·v⁺ = h·v + h²·a, so the step is explicit Euler plus h²·a
on the position rows: one derivative evaluation per step.
"""

from __future__ import annotations

import numpy as np

from .base import FixedStep


class SemiImplicitEuler(FixedStep):
    name = "semi_implicit_euler"
    order = 1
    description = "symplectic Euler: v then q; one evaluation per step"

    def _alloc(self, nx, ndx):
        sys = self.sys
        self.dxh = np.zeros(ndx)
        self.pairs = sys.second_order_pairs()
        # views into dxh, made once: the position rows and a scratch of their size; the velocity rows
        # of the plan's DX, which is k1 at every base step
        self._pos_views = [(self.dxh[pos], vel, np.zeros(pos.stop - pos.start)) for pos, vel in self.pairs]
        self._dx, self._dx_views = sys.DX, [(d, sys.DX[vel], tmp) for d, vel, tmp in self._pos_views]
        self._integrate = sys.bind_integrate(sys.X, self.dxh, sys.X)

    def step(self, t, h, k1):
        np.multiply(k1, h, out=self.dxh)
        hh = h * h
        if k1 is self._dx:
            for dpos, kvel, tmp in self._dx_views:
                np.multiply(kvel, hh, out=tmp)
                dpos += tmp
        else:
            for dpos, vel, tmp in self._pos_views:
                np.multiply(k1[vel], hh, out=tmp)
                dpos += tmp
        self._integrate()
