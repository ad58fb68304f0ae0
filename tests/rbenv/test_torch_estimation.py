"""The torch MEKF (rbenv.satellite.torch_estimation) against the NumPy one: the same
measurements fed to both, float64, agree to 1e-10 (issue 41: "the NumPy and torch backends
agree"); Φ's rows against the matrix exponential; on a GPU where there is one."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from rbenv.satellite import sensors as sn
from rbenv.satellite.estimation import MEKF

torch = pytest.importorskip("torch")
from rbenv.satellite.torch_estimation import TorchMEKF, transition_rows  # noqa: E402

DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


def _fly(device: str, n: int = 64, steps: int = 60, seed: int = 3):
    """Both filters through the same measurements: gyro increments (half the rows turning
    fast, past the series' switch), star-tracker fixes on a random half of the rows, a unit
    vector on others and a field vector on all; returns both filters."""
    rng = np.random.default_rng(seed)
    q = sn.qexp(2.0 * rng.standard_normal((n, 3)))
    a = 1e-3 * rng.standard_normal((n, 6, 6))
    P = a @ np.swapaxes(a, -1, -2) + 1e-9 * np.eye(6)
    b = 1e-4 * rng.standard_normal((n, 3))
    ref = MEKF(q, b, P, 3e-4, 2e-6)
    tf = TorchMEKF(q, b, P, 3e-4, 2e-6, device=device)
    rate = np.where(np.arange(n)[:, None] % 2 == 0, 1e-5, 0.3)
    R_star = sn.StarTracker().noise_cov_B()
    for _ in range(steps):
        d = rate * 0.5 * rng.standard_normal((n, 3))
        ref.propagate(d, 0.5)
        tf.propagate(d, 0.5)
        q_m = sn.qmul(ref.q, sn.qexp(1e-4 * rng.standard_normal((n, 3))))
        valid = rng.random(n) < 0.5
        ref.update_attitude(q_m, R_star, valid)
        tf.update_attitude(q_m, R_star, valid)
        y = sn.qexp(rng.standard_normal((n, 3)))[:, 1:]
        y /= np.linalg.norm(y, axis=-1, keepdims=True)
        r_N = sn.rotate(ref.q, y + 1e-3 * rng.standard_normal((n, 3)))
        r_N /= np.linalg.norm(r_N, axis=-1, keepdims=True)
        cov = 1e-4 * (np.eye(3) - y[:, :, None] * y[:, None, :])
        some = rng.random(n) < 0.3
        ref.update_vector(y, r_N, cov, some, unit=True)
        tf.update_vector(y, r_N, cov, some, unit=True)
        ref.update_vector(3e-5 * y, 3e-5 * r_N, 1e-14 * np.eye(3), np.ones(n, dtype=bool))
        tf.update_vector(3e-5 * y, 3e-5 * r_N, 1e-14 * np.eye(3), np.ones(n, dtype=bool))
    return ref, tf


@pytest.mark.parametrize("device", DEVICES)
def test_torch_and_numpy_filters_agree_to_1e_10(device):
    ref, tf = _fly(device)
    scale = np.abs(ref.P).max()
    assert tf.q.dtype == torch.float64 and tf.q.device.type == device
    np.testing.assert_allclose(tf.q.cpu().numpy(), ref.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(tf.bias.cpu().numpy(), ref.bias, rtol=0, atol=1e-10 * 1e-4)
    np.testing.assert_allclose(tf.P.cpu().numpy(), ref.P, rtol=1e-10, atol=1e-10 * scale)
    # the covariance shrank from its prior (the updates did something) and stays symmetric
    assert np.all(np.diagonal(ref.P, axis1=1, axis2=2)[:, :3] < 1e-6)
    assert torch.equal(tf.P, tf.P.transpose(-1, -2))


def test_torch_transition_rows_are_the_matrix_exponential():
    w = np.array([[0.3, -0.2, 0.5], [1e-5, 0.0, 2e-5]])
    for dt in (0.1, 2.0):
        g = transition_rows(torch.as_tensor(w), dt).numpy()
        for i in range(2):
            F = np.zeros((6, 6))
            F[:3, :3] = -sn.skew(w[i])
            F[:3, 3:] = -np.eye(3)
            np.testing.assert_allclose(g[i], scipy.linalg.expm(F * dt)[:3], atol=1e-12)


def test_rows_without_a_measurement_keep_their_state():
    rng = np.random.default_rng(5)
    n = 4
    q = sn.qexp(rng.standard_normal((n, 3)))
    P = np.tile(np.diag([1e-6] * 3 + [1e-10] * 3), (n, 1, 1))
    tf = TorchMEKF(q, np.zeros((n, 3)), P, 3e-4, 2e-6)
    valid = np.array([True, False, False, True])
    tf.update_attitude(sn.qmul(q, sn.qexp(1e-4 * np.ones((n, 3)))), 1e-8 * np.eye(3), valid)
    assert np.array_equal(tf.P.numpy()[~valid], P[~valid])
    assert np.array_equal(tf.q.numpy()[~valid], q[~valid])
    assert np.all(tf.P.numpy()[valid, 0, 0] < 1e-6)
