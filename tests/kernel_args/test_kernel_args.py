"""Kernel argument records and bound kernels (components/kernel_args.py), and np_sum (NumPy's sum, bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from snakesim.components.contact.sdf_kernels import np_sum
from snakesim.components.kernel_args import bind, record

Pair = record("Pair", ("a", "b", "scale", "flag"))


@njit(cache=True)
def axpy(r):
    for i in range(r.a.size):
        r.b[i] += r.scale * r.a[i]
    return r.flag


def test_a_record_holds_the_callers_arrays_and_a_bound_kernel_writes_into_them():
    a, b = np.arange(3.0), np.ones(3)
    a_ro = a.view()
    a_ro.flags.writeable = False                          # input views are read-only: fine for reading
    rec = Pair(a=a_ro, b=b, scale=2.0, flag=True)
    call = bind(axpy, rec)
    assert call() is True
    np.testing.assert_array_equal(b, [1.0, 3.0, 5.0])
    a[:] = 1.0                                            # the record sees the caller's array
    call()
    np.testing.assert_array_equal(b, [3.0, 5.0, 7.0])
    assert axpy(rec) is True                              # the dispatcher takes records too


def test_a_record_wants_every_field_by_name():
    with pytest.raises(TypeError, match="missing fields \\['flag'\\]"):
        Pair(a=np.zeros(1), b=np.zeros(1), scale=1.0)
    with pytest.raises(TypeError, match="unknown fields \\['c'\\]"):
        Pair(a=np.zeros(1), b=np.zeros(1), scale=1.0, flag=False, c=1)


@pytest.mark.parametrize("n", [*range(0, 300), 1000, 2049, 4097, 7000, 8193, 65537, 1_000_003])
def test_np_sum_is_numpys_sum_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for trial in range(4):
        a = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8, n)
        if trial == 1:
            a[rng.random(n) < 0.5] = 0.0
        if trial == 2:
            a = -np.abs(a)
            a[rng.random(n) < 0.5] = -0.0
        if trial == 3:
            a[:] = -0.0
        assert np.float64(np_sum(a)).tobytes() == np.float64(a.sum()).tobytes()
