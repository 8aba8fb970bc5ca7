"""Linearly implicit Rosenbrock W-methods on the components' own Jacobian (stiff contact, PIDs).

A W-method keeps its order for *any* matrix in place of the Jacobian; only its stability depends
on it. So J need only carry the stiff terms, and here it is what the components declare
(:mod:`snakesim.framework.linearization`: the contact's spring-damper and regularised-friction
slopes through the contact points' Jacobians, the PID gains, the mass matrix), assembled
analytically in one pass, never by finite differences; what no component declares is integrated
explicitly, at the explicit method's stability limit. A robot at rest is a fixed point of every
method here at any step: f(x*) = 0 gives zero stage slopes.

``method``:

``ros2`` (default) Verwer, Spee, Blom & Hundsdorfer, SIAM J. Sci. Comput. 20 (1999): 2 stages,
    order 2 for any W, L-stable, not stiffly accurate::

        W k1 = f(x),  W k2 = f(x ⊕ h k1) − 2 k1,  x₊ = x ⊕ h (3/2 k1 + 1/2 k2),  W = I − γhJ, γ = 1 + 1/√2

    Robust where the friction regularisation makes the problem both very stiff and strongly
    nonlinear (held robots: the walls hold, the default scene's stop phase creep at the
    converged rate at 10 ms; bench/held_cases.py). While driving its tail error grows ∝ h
    (the contact's onset is not smooth): 5.3 mm over the 45 s traverse at 5 ms, 20 mm at 10 ms.
    ``jacobian_every: 3`` at 5 ms keeps 6.6 mm / 0.003 rad there (11 mm at 5) and the held cases
    within 0.2 % of their converged creep, for ~25 % less time per step (bench/tradeoff.py).
``ros34pw2`` Rang & Angermann, BIT 45 (2005): 4 stages, order 3 for any W, L-stable and stiffly
    accurate (the last stage is the solution), built so that index-1 DAEs keep order 3. More
    accurate while driving (7.1 mm over the 45 s traverse at 10 ms), but its internal stages
    overshoot the friction's narrow linear range on held robots: the stop phase creeps 2.5x
    too fast at 10 ms and the walls hold slides even at 2 ms.
    Transformed (U) form, Hairer & Wanner II, sec. IV.7::

        (1/(γh) I − J) U_i = f(x ⊕ Σ_j a_ij U_j) + Σ_j (c_ij / h) U_j,     x₊ = x ⊕ Σ m_i U_i

    with a = AΓ⁻¹, c = diag(1/γ) − Γ⁻¹, m = bᵀΓ⁻¹ from the method's (α, γ, b).

Stage slopes evaluated at x ⊕ u are mapped back to the chart at x (``dexp_inv``, Munthe-Kaas)
as in the explicit methods. Cost per step: ``stages`` evaluations of f (the first is the
simulator's) and as many structured solves; per Jacobian refresh (``jacobian_every`` steps) one
assembly and one factorisation per multibody: O(links) on its link tree (the articulated-body
elimination of components/multibody/articulated_solve_kernels.py; 100 EELS 1.0 modules, nv = 306:
~0.06 ms against 4.7 ms for the dense LU it replaced), a dense (nv × nv) LU where the tree
elimination does not apply (framework/linearization.py).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from ..linearization import Linearization
from .base import FixedStep, FixedStepParams


def _transformed(gamma: float, alpha: np.ndarray, gam: np.ndarray, b: np.ndarray):
    """(γ, a, c, m) of the U form from the k form's α (strictly lower), γ_ij (lower, off the diagonal)
    and b."""
    G = gam + gamma * np.eye(len(b))
    Gi = np.linalg.inv(G)
    a = alpha @ Gi
    c = np.diag(np.full(len(b), 1.0 / gamma)) - Gi
    m = b @ Gi
    return gamma, np.tril(a, -1), np.tril(c, -1), m


_G = 4.3586652150845900e-01
ROS34PW2 = _transformed(
    _G,
    np.array([[0, 0, 0, 0],
              [8.7173304301691801e-01, 0, 0, 0],
              [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0],
              [0, 0, 1.0, 0]]),
    np.array([[0, 0, 0, 0],
              [-8.7173304301691801e-01, 0, 0, 0],
              [-9.0338057013044082e-01, 5.4180672388095326e-02, 0, 0],
              [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, 0]]),
    np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G]))
_ALPHA = np.array([0.0, 8.7173304301691801e-01, 8.4457060015369423e-01 - 1.1299064236484185e-01, 1.0])  # stage times
GAMMA_ROS2 = 1.0 + 1.0 / np.sqrt(2.0)


class RosenbrockWParams(FixedStepParams):
    method: Literal["ros2", "ros34pw2"] = Field("ros2", description="the W-method: ros2 (robust on held robots) "
                                                                   "or ros34pw2 (more accurate while driving)")
    jacobian_every: int = Field(1, ge=1, description="steps between Jacobian assemblies (the LU is refreshed with it)")


class RosenbrockW(FixedStep):
    name = "rosenbrock_w"
    order = 2
    description = "linearly implicit Rosenbrock W-method (ROS2, or ROS34PW2) on the components' analytic Jacobians"
    Params = RosenbrockWParams

    def _alloc(self, nx, ndx):
        sys = self.sys
        self.lin = Linearization(sys)
        self.lin.gamma_hint = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]
        self.x0 = np.zeros(nx)
        self.xs = np.zeros(nx)
        self.f1 = np.zeros(ndx)
        self.U = np.zeros((4, ndx))
        self.dx = np.zeros(ndx)
        self.h_lu = None
        self.age = 0
        self.stats.update(jacobians=0)
        self._to_stage = sys.bind_integrate(self.x0, self.dx, self.xs)
        self._to_end = sys.bind_integrate(self.x0, self.dx, sys.X)
        self.gamma = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]

    def step(self, t, h, k1):
        sys, lin = self.sys, self.lin
        np.copyto(self.x0, sys.X)
        if self.h_lu is None or self.age >= self.p.jacobian_every:
            lin.assemble(t)                 # the plan was just evaluated at (t, x0): k1 is f there
            self.stats["jacobians"] += 1
            self.age = 0
            self.h_lu = None
        if h != self.h_lu:
            lin.factor(self.gamma * h)
            self.h_lu = h
        self.age += 1
        if self.p.method == "ros2":
            self._ros2(t, h, k1)
        else:
            self._ros34pw2(t, h, k1)

    def _stage_slope(self, t, u=None):
        """f at x0 ⊕ u, in the chart at x0, into self.f1 (u None: already in self.dx)."""
        sys = self.sys
        if u is not None:
            np.copyto(self.dx, u)
        self._to_stage()
        np.copyto(self.f1, sys.f(t, self.xs))
        sys.dexp_inv(self.x0, self.dx, self.f1)
        self.stats["f_evals"] += 1
        return self.f1

    def _ros34pw2(self, t, h, k1):
        gamma, a, c, m = ROS34PW2
        lin, U, gh = self.lin, self.U, gamma * h
        rhs = np.empty_like(self.f1)
        for i in range(4):
            if i == 0:
                np.multiply(k1, gh, out=rhs)
            else:
                u = a[i, 0] * U[0]
                for j in range(1, i):
                    u += a[i, j] * U[j]
                f = self._stage_slope(t + h * _ALPHA[i], u)
                np.multiply(f, gh, out=rhs)
                for j in range(i):
                    rhs += (gamma * c[i, j]) * U[j]
            lin.solve(rhs, U[i])
        np.multiply(U[0], m[0], out=self.dx)
        for i in range(1, 4):
            self.dx += m[i] * U[i]
        self._to_end()

    def _ros2(self, t, h, k1):
        lin = self.lin
        ka, kb = self.U[0], self.U[1]
        lin.solve(k1, ka)
        np.multiply(ka, h, out=self.dx)             # the stage's offset h k1, straight into dx
        f = self._stage_slope(t + h)
        f -= 2.0 * ka
        lin.solve(f, kb)
        np.multiply(ka, 1.5 * h, out=self.dx)
        self.dx += (0.5 * h) * kb
        self._to_end()

