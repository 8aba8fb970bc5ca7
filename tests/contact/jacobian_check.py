"""The whole plan's analytic Jacobian (framework/linearization.py, dense) next to central differences of
its derivative f on the state manifold, for the contact Jacobian tests."""

from __future__ import annotations

import numpy as np

from snakesim.framework.linearization import Linearization

STEP = 1e-7


def analytic_and_fd_jacobian(plan, t: float):
    """(J, J_fd, q rows, v rows) at the plan's current state and time t (the state is left as found):
    J the assembled declarations, J_fd = (f(X ⊕ h e_j) − f(X ⊖ h e_j)) / 2h column by column; the row
    slices are the multibody's position and velocity tangents."""
    X0 = plan.X.copy()
    plan.f(t, plan.X)
    lin = Linearization(plan)
    lin.assemble(t)
    J = lin.dense()
    n = plan.ndx
    Jfd = np.zeros((n, n))
    xs = np.zeros(plan.nx)
    e = np.zeros(n)
    for j in range(n):
        col = []
        for sign in (1.0, -1.0):
            e[j] = sign * STEP
            plan.integrate(X0, e, xs)
            col.append(plan.f(t, xs).copy())
        e[j] = 0.0
        Jfd[:, j] = (col[0] - col[1]) / (2 * STEP)
    plan.f(t, X0)
    robot = next(sl for sl in plan.slices if sl.second_order)
    nv, q0 = robot.second_order, robot.dx.start
    return J, Jfd, slice(q0, q0 + nv), slice(q0 + nv, q0 + 2 * nv)
