"""One body on FLOAT computes what one row of a NUMPY batch computes, to the bit.

The single env and the vector env share every formula; they can still part in the last bit
where a function or a product is evaluated differently for a float than for an array
(issue 19). These tests pin the two places where that happened on real CPUs.
"""

from __future__ import annotations

import numpy as np
import pytest
from rbenv.core.backend import FLOAT, NUMPY, matmul

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


def test_matmul_is_the_product():
    a, b = RNG.normal(size=(1, 5)), RNG.normal(size=(5, 3))
    np.testing.assert_allclose(matmul(a, b), a @ b, rtol=1e-14)
    np.testing.assert_allclose(matmul(b.T, a.T), b.T @ a.T, rtol=1e-14)
    assert matmul(np.zeros((0, 5)), b).shape == (0, 3)
