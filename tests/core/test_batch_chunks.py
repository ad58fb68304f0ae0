"""Large batches step chunk by chunk (cache-sized NumPy passes) with bit-identical results."""

import numpy as np
import pytest
from rbenv.core import INTEGRATORS, RigidBody, quaternion
from rbenv.core.integrators import BATCH_CHUNK


@pytest.mark.parametrize("name", [n for n, it in INTEGRATORS.items() if it.element_wise])
def test_chunked_batch_equals_one_kernel_call_bit_for_bit(name):
    rng = np.random.default_rng(5)
    n = 2 * BATCH_CHUNK + 123                 # chunked: two full chunks and a remainder
    c = quaternion.to_matrix(quaternion.random(rng))
    body = RigidBody(mass=1.0, inertia=c @ np.diag([2.0, 3.0, 4.5]) @ c.T)
    q = tuple(quaternion.random(rng, (n,)).T.copy())
    w = tuple(rng.normal(0.0, 1.0, (3, n)))
    tau_B = tuple(rng.normal(0.0, 0.3, (3, n)))
    tau_W = (0.1, -0.2, 0.05)                  # floats broadcast against the chunks
    it = INTEGRATORS[name]
    assert it.advance_batch is not it.advance
    q_a, w_a = it.advance_batch(body, q, w, 0.05, tau_B, tau_W)
    q_k, w_k = it.advance(body, q, w, 0.05, tau_B, tau_W)
    for a, b in zip(q_a + w_a, q_k + w_k, strict=True):
        assert a.shape == (n,)
        np.testing.assert_array_equal(a, b)


def test_midpoint_is_not_chunked():
    # Its Newton iteration decides convergence over the whole batch.
    assert INTEGRATORS["midpoint"].advance_batch is INTEGRATORS["midpoint"].advance


def test_one_body_and_small_batches_call_the_kernel_directly():
    body = RigidBody(mass=1.0, inertia=np.diag([5.0, 10.0, 13.0]))
    q, w = (1.0, 0.0, 0.0, 0.0), (0.1, 0.2, 0.3)
    it = INTEGRATORS["rk4"]
    assert it.advance_batch(body, q, w, 0.1) == it.advance(body, q, w, 0.1)
