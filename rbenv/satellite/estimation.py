"""The multiplicative extended Kalman filter (MEKF), batched over N satellites in NumPy.

Lefferts, Markley & Shuster (JGCD 1982); Markley & Crassidis, "Fundamentals of Spacecraft
Attitude Determination and Control" (2014), ch. 6. The state is the attitude estimate q̂ (N, 4,
scalar-first, body to inertial) and the gyro-bias estimate b̂ (N, 3, rad/s); the filter's
error state is ``x = (δθ, Δb)`` with ``δq = q̂⁻¹ ⊗ q = exp(δθ)`` (body axes, rad) and
``Δb = b − b̂`` (rad/s), its covariance P (N, 6, 6).

Propagation with the gyro increment Δθ_m over dt (rbenv.satellite.sensors.gyro_increment):
``q̂ ← q̂ ⊗ exp(Δθ_m − b̂ dt)``, ``P ← Φ P Φᵀ + Q`` with ``Φ = [[exp(−[ω̂×]dt), −J], [0, I]]``,
J = ∫₀^dt exp(−[ω̂×]s) ds (closed form), and the gyro's process noise (Markley & Crassidis
§6.2)::

    Q = [[(σ_v² dt + σ_u² dt³/3) I, −σ_u² dt²/2 I], [−σ_u² dt²/2 I, σ_u² dt I]].

Updates (K = P Hᵀ S⁻¹, P ← P − K S Kᵀ symmetrized, then ``q̂ ← q̂ ⊗ exp(δθ̂)``,
``b̂ ← b̂ + Δb̂``): a star-tracker quaternion (residual ``log(q̂⁻¹ ⊗ q_m)``, H = [I 0]) and
body vectors of known inertial direction (magnetometer field, fitted Sun direction: residual
``y − A(q̂)ᵀ r``, H = [[A(q̂)ᵀ r ×] 0]). Rows without a measurement this step are left
unchanged (a mask, no loop over satellites).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rbenv.core import validation as check
from rbenv.satellite import sensors as sn
from rbenv.satellite.sensors import qconj, qexp, qlog, qmul, rotate_inverse, skew

__all__ = ["MEKF", "Estimator", "monte_carlo", "process_noise", "transition_matrix"]

_DEG = math.pi / 180.0


@dataclass(frozen=True)
class Estimator:
    """``[estimator]``: the MEKF in the loop (needs ``[sensors] attitude = "estimator"``).

    initial_attitude_sigma_deg: 1σ per axis of the first estimate's error (drawn per episode,
    the filter starts with this covariance); the bias prior is the gyro's
    ``gyro_bias_sigma_dps``. process_noise_scale: factor on Q (1: the gyro's own model)."""

    initial_attitude_sigma_deg: float = 1.0
    process_noise_scale: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "initial_attitude_sigma_deg", check.number(
            "estimator.initial_attitude_sigma_deg", self.initial_attitude_sigma_deg, low=0.0,
            low_open=True, high=60.0))
        object.__setattr__(self, "process_noise_scale", check.number(
            "estimator.process_noise_scale", self.process_noise_scale, low=1.0, high=1e6))


def _inverse3(a: np.ndarray) -> np.ndarray:
    """Inverses of (N, 3, 3) matrices by the adjugate (NumPy's batched solve costs more)."""
    c00 = a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1]
    c01 = a[:, 0, 2] * a[:, 2, 1] - a[:, 0, 1] * a[:, 2, 2]
    c02 = a[:, 0, 1] * a[:, 1, 2] - a[:, 0, 2] * a[:, 1, 1]
    c10 = a[:, 1, 2] * a[:, 2, 0] - a[:, 1, 0] * a[:, 2, 2]
    c11 = a[:, 0, 0] * a[:, 2, 2] - a[:, 0, 2] * a[:, 2, 0]
    c12 = a[:, 0, 2] * a[:, 1, 0] - a[:, 0, 0] * a[:, 1, 2]
    c20 = a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0]
    c21 = a[:, 0, 1] * a[:, 2, 0] - a[:, 0, 0] * a[:, 2, 1]
    c22 = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    det = a[:, 0, 0] * c00 + a[:, 0, 1] * c10 + a[:, 0, 2] * c20
    adj = np.stack((np.stack((c00, c01, c02), -1), np.stack((c10, c11, c12), -1),
                    np.stack((c20, c21, c22), -1)), -2)
    return adj / det[:, None, None]


def process_noise(sigma_v: float, sigma_u: float, dt: float) -> np.ndarray:
    """The 6 × 6 discrete process noise Q of the gyro (σ_v rad/√s, σ_u rad/s/√s, dt s)."""
    q = np.zeros((6, 6))
    eye = np.eye(3)
    q[:3, :3] = (sigma_v ** 2 * dt + sigma_u ** 2 * dt ** 3 / 3.0) * eye
    q[:3, 3:] = q[3:, :3] = -0.5 * sigma_u ** 2 * dt ** 2 * eye
    q[3:, 3:] = sigma_u ** 2 * dt * eye
    return q


def transition_matrix(omega_hat: np.ndarray, dt: float) -> np.ndarray:
    """Φ (N, 6, 6) for the estimated rate ω̂ (N, 3, rad/s) held over dt."""
    n = omega_hat.shape[0]
    k = skew(omega_hat)
    k2 = k @ k
    w = np.linalg.norm(omega_hat, axis=-1)[:, None, None]
    a = w * dt
    small = a < 1e-3
    ws = np.where(small, 1.0, w)
    # exp(−K dt) = I − sin(a)/w K + (1 − cos a)/w² K²
    c1 = np.where(small, dt - a * a * dt / 6.0, np.sin(a) / ws)
    c2 = np.where(small, dt * dt / 2.0 - a * a * dt * dt / 24.0, (1.0 - np.cos(a)) / ws ** 2)
    # J = ∫ exp(−K s) ds = I dt − (1 − cos a)/w² K + (dt − sin(a)/w)/w² K²
    c3 = np.where(small, dt ** 3 / 6.0 - a * a * dt ** 3 / 120.0,
                  (dt - np.sin(a) / ws) / ws ** 2)
    eye = np.eye(3)
    phi = np.zeros((n, 6, 6))
    phi[:, :3, :3] = eye - c1 * k + c2 * k2
    phi[:, :3, 3:] = -(eye * dt - c2 * k + c3 * k2)
    phi[:, 3:, 3:] = eye
    return phi


class MEKF:
    """The filter's state for N satellites: ``q`` (N, 4), ``bias`` (N, 3, rad/s), ``P``
    (N, 6, 6); gyro noise σ_v (rad/√s) and σ_u (rad/s/√s) set its process noise."""

    def __init__(self, q: np.ndarray, bias: np.ndarray, P: np.ndarray, sigma_v: float,
                 sigma_u: float, noise_scale: float = 1.0):
        self.q = np.array(q, dtype=float)
        self.bias = np.array(bias, dtype=float)
        self.P = np.array(P, dtype=float)
        self.sigma_v, self.sigma_u, self.noise_scale = sigma_v, sigma_u, noise_scale

    def propagate(self, dtheta_m: np.ndarray, dt: float) -> None:
        """Advance over dt s with the gyro increment Δθ_m (N, 3, rad)."""
        step = dtheta_m - self.bias * dt
        phi = transition_matrix(step / dt, dt)
        self.q = qmul(self.q, qexp(step))
        self.q /= np.linalg.norm(self.q, axis=-1, keepdims=True)
        q = self.noise_scale * process_noise(self.sigma_v, self.sigma_u, dt)
        self.P = phi @ self.P @ np.swapaxes(phi, -1, -2) + q
        self.P = 0.5 * (self.P + np.swapaxes(self.P, -1, -2))

    def _update(self, residual: np.ndarray, M: np.ndarray, R: np.ndarray,
                valid: np.ndarray) -> None:
        """One 3-D measurement update for the rows where ``valid`` (N,) bool; residual (N, 3),
        H = [M 0] with M (N, 3, 3) (the measurements see the attitude error only), R (3, 3) or
        (N, 3, 3). K = P Hᵀ S⁻¹ and P ← P − K S Kᵀ (symmetrized), S = M P₁₁ Mᵀ + R."""
        if not np.any(valid):
            return
        P = self.P
        Mt = np.swapaxes(M, -1, -2)
        PHt = P[:, :, :3] @ Mt  # (N, 6, 3)
        S = M @ PHt[:, :3] + R
        K = PHt @ _inverse3(0.5 * (S + np.swapaxes(S, -1, -2)))
        x = (K @ residual[..., None])[..., 0]
        newP = P - K @ np.swapaxes(PHt, -1, -2)  # P − K S Kᵀ = P − K (P Hᵀ)ᵀ
        m = valid[:, None]
        self.P = np.where(valid[:, None, None], 0.5 * (newP + np.swapaxes(newP, -1, -2)), P)
        q = qmul(self.q, qexp(x[:, :3]))
        self.q = np.where(m, q / np.linalg.norm(q, axis=-1, keepdims=True), self.q)
        self.bias = np.where(m, self.bias + x[:, 3:], self.bias)

    def update_attitude(self, q_m: np.ndarray, R: np.ndarray, valid: np.ndarray) -> None:
        """A star-tracker fix q_m (N, 4) with noise covariance R (3, 3, rad², body axes)."""
        residual = qlog(qmul(qconj(self.q), q_m))
        self._update(residual, np.broadcast_to(np.eye(3), (self.q.shape[0], 3, 3)), R, valid)

    def update_vector(self, y_B: np.ndarray, r_N: np.ndarray, R: np.ndarray,
                      valid: np.ndarray, unit: bool = False) -> None:
        """A body vector y_B (N, 3) of the inertial vector r_N (N, 3), noise covariance R
        ((3, 3) or (N, 3, 3), same unit squared).

        unit: y_B and r_N are unit vectors, R singular along y_B: the residual and R are
        projected off the predicted direction b̂, which H = [b̂×] cannot see, and R is given
        the variance trace(R) there, so that direction carries no information."""
        predicted = rotate_inverse(self.q, r_N)
        residual = y_B - predicted
        if unit:
            along = predicted[..., :, None] * predicted[..., None, :]
            proj = np.eye(3) - along
            residual = (proj @ residual[..., None])[..., 0]
            R = proj @ R @ proj + np.trace(R, axis1=-2, axis2=-1)[..., None, None] * along
        self._update(residual, skew(predicted), R, valid)

    def error(self, q_true: np.ndarray, bias_true: np.ndarray) -> np.ndarray:
        """The true error state (N, 6): ``log(q̂⁻¹ ⊗ q)`` then ``b − b̂``."""
        return np.concatenate((qlog(qmul(qconj(self.q), q_true)), bias_true - self.bias), -1)

    def nees(self, q_true: np.ndarray, bias_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(attitude NEES, bias NEES)``, each (N,): eᵀP⁻¹e of the 3-blocks (χ²(3) when
        consistent)."""
        e = self.error(q_true, bias_true)
        out = []
        for sl in (slice(0, 3), slice(3, 6)):
            blk = self.P[:, sl, sl]
            out.append(np.einsum("ni,ni->n", e[:, sl],
                                 np.linalg.solve(blk, e[:, sl, None])[..., 0]))
        return out[0], out[1]


def monte_carlo(runs, steps, sensors, seed=1, dt=1.0):
    """The validation harness: ``runs`` satellites turning at constant rates (0.005 rad/s 1σ
    per axis), a gyro of 0.15 °/√h ARW, 2e-4 °/s/√s RRW and 0.05 °/s bias (1σ), the filter
    started 1° off; ``sensors`` names what updates it: "star" (a default star tracker, a fix
    every 5 steps), "mag" (a constant field, 150 nT noise), "sun" (six coarse sun sensors, the
    Sun fixed). Returns the per-step run-averaged NEES of the attitude and of the bias (each
    (steps,)), the filter and the true bias at the end."""
    rng = np.random.default_rng(seed)
    sv, su, sb, s0 = 0.15 * _DEG / 60.0, 2e-4 * _DEG, 0.05 * _DEG, 1.0 * _DEG
    q = sn.qexp(2.0 * rng.standard_normal((runs, 3)))
    w = 0.005 * rng.standard_normal((runs, 3))
    b = sb * rng.standard_normal((runs, 3))
    P0 = np.zeros((runs, 6, 6))
    P0[:, :3, :3], P0[:, 3:, 3:] = s0 ** 2 * np.eye(3), sb ** 2 * np.eye(3)
    f = MEKF(sn.qmul(q, sn.qexp(-s0 * rng.standard_normal((runs, 3)))), np.zeros((runs, 3)),
             P0, sv, su)
    star, css, mag = sn.StarTracker(), sn.SunSensors(), sn.Magnetometer(noise_nT=150.0)
    sun_N = np.tile(np.array([0.6, 0.0, 0.8]), (runs, 1))
    field_N = np.tile(np.array([1e-5, 2.5e-5, -1e-5]), (runs, 1))
    nees_a, nees_b = [], []
    for k in range(steps):
        dtheta = w * dt
        m, b = sn.gyro_increment(dtheta, b, sv, su, dt, rng)
        q = sn.qmul(q, sn.qexp(dtheta))
        f.propagate(m, dt)
        if "star" in sensors:
            q_m, valid = sn.star_tracker(star, q, w, None, None, 0.0, rng)
            f.update_attitude(q_m, star.noise_cov_B(), valid & (k % 5 == 0))
        if "mag" in sensors:
            y = sn.magnetometer(mag, q, field_N, 0.0, rng)
            f.update_vector(y, field_N, (150e-9) ** 2 * np.eye(3), np.ones(runs, dtype=bool))
        if "sun" in sensors:
            s_B, cov, valid = sn.sun_vector_fit(css, sn.sun_sensors(css, q, sun_N,
                                                                    np.ones(runs), rng))
            f.update_vector(s_B, sun_N, cov, valid, unit=True)
        a, bb = f.nees(q, b)
        nees_a.append(a.mean())
        nees_b.append(bb.mean())
    return np.array(nees_a), np.array(nees_b), f, b
