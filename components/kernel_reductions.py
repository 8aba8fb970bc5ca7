"""NumPy reductions in numba, bit for bit: ``np_sum`` (``a.sum()``, NumPy's pairwise summation),
``least_distance`` (``distance[:counts[4]].min()`` with NumPy's NaN rule) and ``same_bits`` (two
arrays' bytes equal), so a kernel reduces its own arrays without a NumPy call per evaluation and
gives the very answers NumPy would.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _block_sum(a, lo, n):
    """NumPy's pairwise_sum for n <= 128: a plain loop below 8, else 8 partial sums."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def np_sum(a):
    """``a.sum()`` of a contiguous float64 vector, bit for bit: NumPy's pairwise summation (blocks of
    up to 128 summed by _block_sum, longer runs halved at a multiple of 8 and the halves added).
    NumPy recurses; numba's disk cache cannot load a self-recursive function, so the same tree is
    walked with an explicit stack (post-order: a node adds its two halves once both are summed).
    tests/contact/test_sdf_kernels.py checks it against NumPy."""
    lo_s = np.empty(128, np.int64)         # 2 frames per halving level: room for 2**63 elements
    n_s = np.empty(128, np.int64)
    done = np.empty(128, np.bool_)
    vals = np.empty(128)
    top, nv = 0, 0
    lo_s[0], n_s[0], done[0] = 0, a.size, False
    while top >= 0:
        lo, n = lo_s[top], n_s[top]
        if n <= 128:
            vals[nv] = _block_sum(a, lo, n)
            nv += 1
            top -= 1
        elif done[top]:
            vals[nv - 2] = vals[nv - 2] + vals[nv - 1]
            nv -= 1
            top -= 1
        else:
            n2 = n // 2 - (n // 2) % 8
            done[top] = True
            lo_s[top + 1], n_s[top + 1], done[top + 1] = lo + n2, n - n2, False      # right half, summed second
            lo_s[top + 2], n_s[top + 2], done[top + 2] = lo, n2, False               # left half, summed first
            top += 2
    return 0.0 + vals[0]       # the reduction starts from the identity: -0.0 sums to 0.0


@njit(cache=True)
def least_distance(distance, counts):
    """``distance[:counts[4]].min()`` as NumPy gives it (NaN if one is NaN), +inf over no rows: the max_depth
    watch on the last evaluation's m rows without a NumPy reduction per evaluation."""
    out = math.inf
    for i in range(counts[4]):
        x = distance[i]
        if x != x:
            return x
        if x < out:
            out = x
    return out


@njit(cache=True)
def same_bits(a, b):
    """True if float64 arrays a and b of one size hold the same values bit for bit (NaNs and signed zeros
    included), as ``a.tobytes() == b.tobytes()`` for contiguous ones."""
    x, y = a.ravel().view(np.uint64), b.ravel().view(np.uint64)
    for i in range(x.size):
        if x[i] != y[i]:
            return False
    return True
