"""Forward-difference Jacobians measured in one batch, rounded as one evaluation at a time (issue 30: the
shaft placement's refinement, components/placement/shaft_brace.py).

A least-squares fit whose residuals come from a terrain query spends its time in the queries' overhead when
scipy's default '2-point' Jacobian asks for the n + 1 residual vectors one at a time. Here the n steps are
taken exactly as scipy takes them (relative step √ε·max(1, |x|), signed as x, a step past a bound taken the
other way or cut to the bound), but evaluated in one call of a batched residual, rows of X (m, n) -> rows
(m, r). Results are bit-for-bit scipy's when the batched residual rounds each row as a single evaluation
does: the products below are numpy matmuls of the same operand shapes as a single evaluation's (a BLAS
product's rounding depends on them; an einsum's differs in the last bit), which matters because a fit that
stops on a flat valley (max_nfev, xtol) amplifies 1e-16 in a Jacobian into micrometres of pose.
"""

from __future__ import annotations

import numpy as np

#: scipy's relative step of a 2-point difference (scipy.optimize._numdiff: EPS ** 0.5)
REL_STEP = np.finfo(float).eps ** 0.5


def forward_steps(x, lb, ub) -> np.ndarray:
    """Each coordinate's step h (n,): √ε·max(1, |x|) signed as x (+ at 0); one past a bound goes the other
    way if it fits there, else it is cut to the farther bound."""
    h = REL_STEP * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    past = (x + h < lb) | (x + h > ub)
    fits = np.abs(h) <= np.maximum(x - lb, ub - x)
    h[past & fits] *= -1
    return np.where(fits, h, np.where(ub - x >= x - lb, ub - x, -(x - lb)))


def forward_differences(residuals, x, f0, lb, ub) -> np.ndarray:
    """J (r, n) of ``residuals`` at x, whose residual vector there is f0 (r,): (f(x + h_i e_i) − f0) / h_i
    with the n rows x + h_i e_i measured in one call ``residuals(X)`` -> (n, r)."""
    h = forward_steps(x, lb, ub)
    X = np.tile(x, (len(x), 1))
    X[np.arange(len(x)), np.arange(len(x))] += h
    return ((residuals(X) - f0) / ((x + h) - x)[:, None]).T


def row_dot(u, v) -> np.ndarray:
    """u·v over the last axis, rounded as numpy's 1-D ``u @ v`` (so sqrt(row_dot(u, u)) as ``norm(u)``)."""
    return np.matmul(u[..., None, :], v[..., None])[..., 0, 0]


def padded_groups(group, points, n_groups: int):
    """``points`` (k, 3) of groups ``group`` (k,) laid out per group, zero-padded to the largest:
    (n_groups, width, 3), and each point's flat place there (k,) (group · width + rank in its group, the
    points' order kept). A group's (width, 3) block times its 3×3 rounds its rows as the group's own
    (k_g, 3) block would."""
    group = np.asarray(group, int)
    order = np.argsort(group, kind="stable")
    first = np.searchsorted(group[order], np.arange(n_groups))
    rank = np.empty(len(group), int)
    rank[order] = np.arange(len(group)) - first[group[order]]
    width = int(rank.max(initial=0)) + 1
    padded = np.zeros((n_groups, width, 3))
    padded[group, rank] = points
    return padded, group * width + rank
