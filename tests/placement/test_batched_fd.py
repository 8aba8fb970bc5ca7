"""batched_fd (components/placement/batched_fd.py): its Jacobian is scipy's own '2-point' one, bit for bit,
so a fit that swaps it in follows the same path; the padded per-group products round as per-group ones."""

from __future__ import annotations

import numpy as np
from scipy.optimize import approx_fprime, least_squares

from snakesim.components.placement.batched_fd import forward_differences, padded_groups, row_dot

LB = np.array([-np.inf, -1.0, 0.2])
UB = np.array([np.inf, 1.0, 0.3])


def residuals(X):
    """Rows of X (m, 3) -> (m, 4): nonlinear, its optimum past the third coordinate's upper bound."""
    x = np.atleast_2d(X)
    return np.stack([np.sin(3 * x[:, 0]) + x[:, 1] ** 2, x[:, 0] * x[:, 2] - 0.5, np.exp(x[:, 1]) - 2.0,
                     10 * (x[:, 2] - 0.5)], axis=1)


def test_jacobian_is_scipys_forward_differences():
    """Where |x| < 1 and x >= 0 scipy's relative step is approx_fprime's absolute √ε: the same columns."""
    x = np.array([0.3, 0.7, 0.25])
    J = forward_differences(residuals, x, residuals(x)[0], np.full(3, -np.inf), np.full(3, np.inf))
    ref = np.array([approx_fprime(x, lambda v, i=i: residuals(v)[0, i]) for i in range(4)])
    assert np.array_equal(J, ref)


def test_a_fit_takes_scipys_path_at_and_near_the_bounds():
    """The optimum presses x₂ onto its upper bound 0.3 (a step there turns back), x₁ starts negative (a
    step against its sign): the fit ends where scipy's own '2-point' fit does, to the bit, in as many
    evaluations."""
    x0 = np.array([0.1, -0.2, 0.3 - 1e-12])
    ref = least_squares(lambda x: residuals(x)[0], x0, bounds=(LB, UB))
    ours = least_squares(lambda x: residuals(x)[0], x0, bounds=(LB, UB),
                         jac=lambda x: forward_differences(residuals, x, residuals(x)[0], LB, UB))
    assert ref.x[2] == UB[2] or abs(ref.x[2] - UB[2]) < 1e-6
    assert np.array_equal(ours.x, ref.x) and ours.nfev == ref.nfev


def test_padded_groups_round_as_each_group_alone():
    rng = np.random.default_rng(0)
    group = rng.integers(0, 4, 50)
    points = rng.normal(size=(50, 3))
    R = np.linalg.qr(rng.normal(size=(4, 3, 3)))[0]
    padded, slot = padded_groups(group, points, 4)
    batched = (padded @ R.swapaxes(-1, -2)).reshape(-1, 3)[slot]
    for g in range(4):
        assert np.array_equal(batched[group == g], points[group == g] @ R[g].T)
    u, v = rng.normal(size=(2, 6, 3))
    assert all(row_dot(u, v)[i] == u[i] @ v[i] for i in range(6))
    assert all(np.sqrt(row_dot(u, u))[i] == np.linalg.norm(u[i]) for i in range(6))
