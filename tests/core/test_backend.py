"""One body on FLOAT computes what one row of a NUMPY batch computes, to the bit.

The single env and the vector env share every formula; they can still part in the last bit
where a function or a product is evaluated differently for a float than for an array
(issue 19). These tests pin the two places where that happened on real CPUs.
"""

from __future__ import annotations

import sys
import threading

import numpy as np
import pytest
from rbenv.core.backend import FLOAT, NUMPY, matmul, row_product

RNG = np.random.default_rng(19)
X = RNG.uniform(-4.0, 4.0, 20_000)
Y = RNG.uniform(-4.0, 4.0, 20_000)
POSITIVE = RNG.uniform(0.0, 20.0, 20_000)
SMALL = np.abs(RNG.normal(0.0, 1e-3, 20_000))  # near-goal errors


@pytest.mark.parametrize("name", ["sin", "cos", "tan"])
def test_unary_functions_of_a_float_equal_the_batch_row(name):
    batch = getattr(NUMPY, name)(X)
    single = np.array([getattr(FLOAT, name)(float(x)) for x in X])
    assert np.array_equal(single, batch)
    assert type(getattr(FLOAT, name)(0.5)) is float


def test_log1p_and_power_of_a_float_equal_the_batch_row():
    assert np.array_equal(np.array([FLOAT.log1p(float(x)) for x in POSITIVE]),
                          NUMPY.log1p(POSITIVE))
    assert np.array_equal(np.array([FLOAT.power(float(x), 1.0 / 3.0) for x in POSITIVE]),
                          NUMPY.power(POSITIVE, 1.0 / 3.0))


def test_atan2_of_floats_equals_the_batch_row_also_near_the_goal():
    for y, x in ((Y, X), (SMALL, np.sqrt(1.0 - SMALL**2))):
        single = np.array([FLOAT.atan2(float(a), float(b)) for a, b in zip(y, x, strict=True)])
        assert np.array_equal(single, NUMPY.atan2(y, x))


def test_float_functions_are_right_in_concurrent_threads():
    """FLOAT's functions pass their numbers through scratch arrays: each thread has its own, so
    threads switching every microsecond still get their own values."""
    def run(k, results):
        xs, ys = X[k::4], Y[k::4]
        results[k] = (np.array([FLOAT.sin(x) for x in xs.tolist()]),
                      np.array([FLOAT.atan2(y, x) for y, x in zip(ys.tolist(), xs.tolist(),
                                                                   strict=True)]))

    results = {}
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=run, args=(k, results)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    for k in range(4):
        assert np.array_equal(results[k][0], NUMPY.sin(X[k::4]))
        assert np.array_equal(results[k][1], NUMPY.atan2(Y[k::4], X[k::4]))
    assert type(FLOAT.atan2(0.5, 1.0)) is float and type(FLOAT.power(2.0, 0.5)) is float


@pytest.mark.parametrize("n", [1, 2, 3, 7, 64, 4096])
def test_matmul_rows_do_not_depend_on_how_many_there_are(n):
    """A thruster-sized product (12 throttles → 4 wrench parts): each row of the batch, in
    either orientation, equals the row multiplied alone."""
    M = RNG.normal(size=(12, 4))
    U = RNG.uniform(0.0, 1.0, (n, 12))
    batch_rows = matmul(U, M)
    batch_cols = matmul(M.T, U.T)
    alone = np.array([matmul(u[None, :], M)[0] for u in U])
    assert np.array_equal(batch_rows, alone)
    assert np.array_equal(batch_cols.T, alone)


@pytest.mark.parametrize("thrusters", [1, 8, 12])
@pytest.mark.parametrize("parts", [4, 7])
def test_row_product_equals_the_batch_row(thrusters, parts):
    """The single env's wrench (row_product) equals each row of the batch's, in either
    orientation and at any batch size, to the bit; some throttles are off (exact zeros)."""
    M = np.ascontiguousarray(RNG.normal(size=(thrusters, parts)))
    for n in (1, 5, 4096):
        U = RNG.uniform(0.0, 1.0, (n, thrusters))
        U[RNG.random(U.shape) < 0.3] = 0.0
        alone = np.array([row_product(u, M) for u in U])
        assert np.array_equal(matmul(M.T, U.T).T, alone)
        assert np.array_equal(matmul(U, M), alone)
    single = row_product(U[0], M)
    assert type(single) is list and len(single) == parts and type(single[0]) is float


def test_matmul_is_the_product():
    a, b = RNG.normal(size=(1, 5)), RNG.normal(size=(5, 3))
    np.testing.assert_allclose(matmul(a, b), a @ b, rtol=1e-14)
    np.testing.assert_allclose(matmul(b.T, a.T), b.T @ a.T, rtol=1e-14)
    assert matmul(np.zeros((0, 5)), b).shape == (0, 3)
