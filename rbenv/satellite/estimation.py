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
unchanged (only the rows with one are computed; no loop over satellites).

:class:`MEKF` holds its state component-major ((4, N), (3, N), (6, 6, N)) and runs on the 3 × 3
blocks of Φ and H; :class:`ScalarMEKF` is the same filter for one satellite on Python floats
(the single env's, where NumPy's per-call overhead would dominate); the two agree to round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rbenv.core import validation as check
from rbenv.satellite import sensors as sn
from rbenv.satellite.sensors import qconj, qlog, qmul, rotate_inverse, skew

__all__ = ["MEKF", "Estimator", "ScalarMEKF", "monte_carlo", "process_noise",
           "transition_matrix"]

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


def _matmul_cm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for matrices stacked on the last axis, (i, k, N) @ (k, j, N) -> (i, j, N):
    NumPy's batched matmul over small matrices costs about 10× this einsum."""
    return np.einsum("ikn,kjn->ijn", a, b)


def _matmul_t_cm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ bᵀ, (i, k, N) @ (j, k, N)ᵀ -> (i, j, N)."""
    return np.einsum("ikn,jkn->ijn", a, b)


def _inverse3_cm(a: np.ndarray) -> np.ndarray:
    """Inverses of (3, 3, N) matrices by the adjugate (NumPy's batched solve costs more)."""
    c = np.empty_like(a)
    c[0, 0] = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c[0, 1] = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    c[0, 2] = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    c[1, 0] = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c[1, 1] = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    c[1, 2] = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    c[2, 0] = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    c[2, 1] = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    c[2, 2] = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    c /= a[0, 0] * c[0, 0] + a[0, 1] * c[1, 0] + a[0, 2] * c[2, 0]
    return c


def _qmul_cm(a, b) -> np.ndarray:
    """Hamilton product of quaternions stacked on the first axis, (4, N) (or 4 rows, each
    (N,) or a float)."""
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    out = np.empty((4, *np.broadcast(a0, b0).shape))
    out[0] = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    out[1] = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    out[2] = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    out[3] = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    return out


def _qconj_cm(q) -> tuple:
    return (q[0], -q[1], -q[2], -q[3])


def _normalized_cm(q: np.ndarray) -> np.ndarray:
    q /= np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return q


def _phi_coefficients(x: np.ndarray, y: np.ndarray, z: np.ndarray, dt: float):
    """(c1, c2, c3, |ω̂|²), each (N,), for ω̂ = (x, y, z): exp(−[ω̂×]dt) = I − c1 K + c2 K² and
    J = ∫₀^dt exp(−[ω̂×]s) ds = I dt − c2 K + c3 K², K = [ω̂×] (series below |ω̂|dt = 1e-3)."""
    w2 = x * x + y * y + z * z
    w = np.sqrt(w2)
    a = w * dt
    a2 = a * a
    small = a < 1e-3
    if small.all():  # every row on the series (a satellite at rest): no sine or cosine
        return (dt - a2 * (dt / 6.0), dt * dt / 2.0 - a2 * (dt * dt / 24.0),
                dt ** 3 / 6.0 - a2 * (dt ** 3 / 120.0), w2)
    ws = np.where(small, 1.0, w)
    ws2 = ws * ws
    c1 = np.sin(a) / ws
    c3 = (dt - c1) / ws2
    c2 = (1.0 - np.cos(a)) / ws2
    if small.any():
        c1 = np.where(small, dt - a2 * (dt / 6.0), c1)
        c2 = np.where(small, dt * dt / 2.0 - a2 * (dt * dt / 24.0), c2)
        c3 = np.where(small, dt ** 3 / 6.0 - a2 * (dt ** 3 / 120.0), c3)
    return c1, c2, c3, w2


def _phi_rows_cm(omega_hat: np.ndarray, dt: float) -> np.ndarray:
    """Φ's first block row [A, −J] (3, 6, N) (its second is [0, I]) for ω̂ (3, N), entry by
    entry: A = I − c1 K + c2 K², J = I dt − c2 K + c3 K², K² = ω̂ω̂ᵀ − |ω̂|² I."""
    x, y, z = omega_hat
    c1, c2, c3, w2 = _phi_coefficients(x, y, z, dt)
    da, dj = 1.0 - c2 * w2, c3 * w2 - dt  # the diagonals: 1 − c2|ω̂|² and −(dt − c3|ω̂|²)
    g = np.empty((3, 6, x.shape[0]))
    comps = (x, y, z)
    for off, c, diag in ((0, c2, da), (3, -c3, dj)):  # c ω̂ω̂ᵀ plus the diagonal
        cw = (c * x, c * y, c * z)
        for i in range(3):
            for j in range(3):
                np.multiply(cw[i], comps[j], out=g[i, off + j])
            g[i, off + i] += diag
    # −c1 K in A, +c2 K in −J; K = [[0, −z, y], [z, 0, −x], [−y, x, 0]]
    for off, c in ((0, c1), (3, -c2)):
        kx, ky, kz = c * x, c * y, c * z
        g[0, off + 1] += kz
        g[0, off + 2] -= ky
        g[1, off + 0] -= kz
        g[1, off + 2] += kx
        g[2, off + 0] += ky
        g[2, off + 1] -= kx
    return g


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
    phi = np.zeros((n, 6, 6))
    phi[:, :3] = _phi_rows_cm(np.ascontiguousarray(omega_hat.T), dt).transpose(2, 0, 1)
    phi[:, 3:, 3:] = np.eye(3)
    return phi


class MEKF:
    """The filter's state for N satellites: ``q`` (N, 4), ``bias`` (N, 3, rad/s), ``P``
    (N, 6, 6); gyro noise σ_v (rad/√s) and σ_u (rad/s/√s) set its process noise.

    The state is held component-major, q (4, N), bias (3, N), P (6, 6, N) (``q``, ``bias``
    and ``P`` are (N, ...) views of them, writes go through): each component is a contiguous
    row, and the products run on the 3 × 3 blocks of Φ = [[A, −J], [0, I]] and H = [M 0] as
    einsums over the last axis, which cost a tenth of NumPy's batched matmul on (N, 6, 6)."""

    def __init__(self, q: np.ndarray, bias: np.ndarray, P: np.ndarray, sigma_v: float,
                 sigma_u: float, noise_scale: float = 1.0):
        self.q = q
        self.bias = bias
        self.P = P
        self.sigma_v, self.sigma_u, self.noise_scale = sigma_v, sigma_u, noise_scale
        self._q_dt = None  # (dt, Q) of the last propagation: Q is constant per dt

    @property
    def q(self) -> np.ndarray:
        """The attitude estimate (N, 4): a view of the (4, N) store."""
        return self._q.T

    @q.setter
    def q(self, value) -> None:
        self._q = np.array(np.asarray(value, dtype=float).T, order="C")

    @property
    def bias(self) -> np.ndarray:
        """The bias estimate (N, 3, rad/s): a view of the (3, N) store."""
        return self._b.T

    @bias.setter
    def bias(self, value) -> None:
        self._b = np.array(np.asarray(value, dtype=float).T, order="C")

    @property
    def P(self) -> np.ndarray:
        """The covariance (N, 6, 6): a view of the (6, 6, N) store (writes go through)."""
        return self._P.transpose(2, 0, 1)

    @P.setter
    def P(self, value) -> None:
        self._P = np.ascontiguousarray(np.asarray(value, dtype=float).transpose(1, 2, 0))

    def covariance_copy(self) -> np.ndarray:
        """A copy of P, (N, 6, 6), laid out (6, 6, N) in memory (a transposing copy costs
        ten times a plain one at N = 1024)."""
        return self._P.copy().transpose(2, 0, 1)

    def covariance_diagonal(self) -> np.ndarray:
        """P's diagonal, (6, N)."""
        return self._P[np.arange(6), np.arange(6)]

    def _noise(self, dt: float) -> tuple:
        """(q11, q12, q22): Q = [[q11 I, q12 I], [q12 I, q22 I]] for dt (cached)."""
        if self._q_dt is None or self._q_dt[0] != dt:
            q = self.noise_scale * process_noise(self.sigma_v, self.sigma_u, dt)
            self._q_dt = (dt, float(q[0, 0]), float(q[0, 3]), float(q[3, 3]))
        return self._q_dt[1:]

    def propagate(self, dtheta_m: np.ndarray, dt: float) -> None:
        """Advance over dt s with the gyro increment Δθ_m (N, 3, rad): P ← ΦPΦᵀ + Q by
        blocks, G = [A, −J]: P₁₁ ← G P Gᵀ, P₁₂ ← (G P)₂, P₂₂ unchanged (then + Q)."""
        step = dtheta_m.T - self._b * dt  # (3, N)
        g = _phi_rows_cm(step / dt, dt)
        self._q = _normalized_cm(_qmul_cm(self._q, sn.qexp_cm(step)))
        P = self._P
        gp = _matmul_cm(g, P)  # (3, 6, N)
        p11 = _matmul_t_cm(gp, g)
        P[:3, :3] = 0.5 * (p11 + p11.transpose(1, 0, 2))
        P[:3, 3:] = gp[:, 3:]
        P[3:, :3] = gp[:, 3:].transpose(1, 0, 2)
        q11, q12, q22 = self._noise(dt)  # Q's blocks are multiples of I
        for i in range(3):
            P[i, i] += q11
            P[i, i + 3] += q12
            P[i + 3, i] += q12
            P[i + 3, i + 3] += q22

    def _update(self, residual: np.ndarray, M: np.ndarray | None, R: np.ndarray,
                valid: np.ndarray) -> None:
        """One 3-D measurement update for the rows where ``valid`` (N,) bool; residual (N, 3),
        H = [M 0] with M (N, 3, 3) or None for the identity (the measurements see the
        attitude error only), R (3, 3) or (N, 3, 3). K = P Hᵀ S⁻¹ and P ← P − K S Kᵀ =
        P − K (P Hᵀ)ᵀ (symmetrized), S = M P₁₁ Mᵀ + R.

        Under a quarter of the rows valid: only those are computed (gathered and scattered
        back); else all, and the valid rows' results kept (a scatter costs about what the
        rows it saves do)."""
        if not np.any(valid):
            return
        n_all = valid.shape[0]
        rows = np.flatnonzero(valid)
        if 4 * len(rows) >= n_all:
            rows, merge = None, not len(rows) == n_all
        else:
            merge = False
        # np.take keeps the last axis contiguous (a fancy index on it would put it outermost
        # in memory, and the einsums would run five times slower)
        P = self._P if rows is None else np.take(self._P, rows, axis=2)
        residual = residual.T  # (3, N)
        if rows is not None:
            residual = np.take(residual, rows, axis=1)
            M = None if M is None else M[rows]
            R = R[rows] if R.ndim == 3 else R
        R = R[:, :, None] if R.ndim == 2 else np.ascontiguousarray(R.transpose(1, 2, 0))
        if M is None:
            pht = P[:, :3]  # (6, 3, n)
            S = pht[:3] + R
        else:
            m = np.ascontiguousarray(M.transpose(1, 2, 0))
            pht = _matmul_t_cm(P[:, :3], m)
            S = _matmul_cm(m, pht[:3]) + R
        K = _matmul_cm(pht, _inverse3_cm(0.5 * (S + S.transpose(1, 0, 2))))
        x = np.einsum("ikn,kn->in", K, np.ascontiguousarray(residual))  # (6, n)
        newP = P - _matmul_t_cm(K, pht)
        newP = 0.5 * (newP + newP.transpose(1, 0, 2))
        q = _normalized_cm(_qmul_cm(self._q if rows is None else np.take(self._q, rows, axis=1),
                                    sn.qexp_cm(x[:3])))
        if rows is not None:
            self._P[:, :, rows] = newP
            self._q[:, rows] = q
            self._b[:, rows] += x[3:]
        elif merge:  # the rows without a measurement keep their state exactly
            self._P = np.where(valid, newP, self._P)
            self._q = np.where(valid, q, self._q)
            self._b = np.where(valid, self._b + x[3:], self._b)
        else:
            self._P, self._q = newP, q
            self._b = self._b + x[3:]

    def update_attitude(self, q_m: np.ndarray, R: np.ndarray, valid: np.ndarray) -> None:
        """A star-tracker fix q_m (N, 4) with noise covariance R (3, 3, rad², body axes)."""
        if not np.any(valid):
            return
        self._update(sn.qlog_cm(_qmul_cm(_qconj_cm(self._q), q_m.T)).T, None, R, valid)

    def update_vector(self, y_B: np.ndarray, r_N: np.ndarray, R: np.ndarray,
                      valid: np.ndarray, unit: bool = False) -> None:
        """A body vector y_B (N, 3) of the inertial vector r_N (N, 3), noise covariance R
        ((3, 3) or (N, 3, 3), same unit squared).

        unit: y_B and r_N are unit vectors, R singular along y_B: the residual and R are
        projected off the predicted direction b̂, which H = [b̂×] cannot see, and R is given
        the variance trace(R) there, so that direction carries no information."""
        if not np.any(valid):
            return
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


# --------------------------------------------------------------------------- one satellite
# 3 × 3 blocks as tuples of 3 row tuples of floats, for the filter of one satellite.


def _mm(a, b):
    """a @ b."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return ((a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21,
             a00 * b02 + a01 * b12 + a02 * b22),
            (a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21,
             a10 * b02 + a11 * b12 + a12 * b22),
            (a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21,
             a20 * b02 + a21 * b12 + a22 * b22))


def _mmt(a, b):
    """a @ bᵀ."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return ((a00 * b00 + a01 * b01 + a02 * b02, a00 * b10 + a01 * b11 + a02 * b12,
             a00 * b20 + a01 * b21 + a02 * b22),
            (a10 * b00 + a11 * b01 + a12 * b02, a10 * b10 + a11 * b11 + a12 * b12,
             a10 * b20 + a11 * b21 + a12 * b22),
            (a20 * b00 + a21 * b01 + a22 * b02, a20 * b10 + a21 * b11 + a22 * b12,
             a20 * b20 + a21 * b21 + a22 * b22))


def _ab_cd(a, b, c, d):
    """a @ b − c @ d."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = c
    (d00, d01, d02), (d10, d11, d12), (d20, d21, d22) = d
    return ((a00 * b00 + a01 * b10 + a02 * b20 - (c00 * d00 + c01 * d10 + c02 * d20),
             a00 * b01 + a01 * b11 + a02 * b21 - (c00 * d01 + c01 * d11 + c02 * d21),
             a00 * b02 + a01 * b12 + a02 * b22 - (c00 * d02 + c01 * d12 + c02 * d22)),
            (a10 * b00 + a11 * b10 + a12 * b20 - (c10 * d00 + c11 * d10 + c12 * d20),
             a10 * b01 + a11 * b11 + a12 * b21 - (c10 * d01 + c11 * d11 + c12 * d21),
             a10 * b02 + a11 * b12 + a12 * b22 - (c10 * d02 + c11 * d12 + c12 * d22)),
            (a20 * b00 + a21 * b10 + a22 * b20 - (c20 * d00 + c21 * d10 + c22 * d20),
             a20 * b01 + a21 * b11 + a22 * b21 - (c20 * d01 + c21 * d11 + c22 * d21),
             a20 * b02 + a21 * b12 + a22 * b22 - (c20 * d02 + c21 * d12 + c22 * d22)))


def _sym_abt_cdt(a, b, c, d, s):
    """½(X + Xᵀ) + s I with X = a @ bᵀ − c @ dᵀ (only X's upper triangle is formed)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = c
    (d00, d01, d02), (d10, d11, d12), (d20, d21, d22) = d
    x00 = a00 * b00 + a01 * b01 + a02 * b02 - (c00 * d00 + c01 * d01 + c02 * d02)
    x11 = a10 * b10 + a11 * b11 + a12 * b12 - (c10 * d10 + c11 * d11 + c12 * d12)
    x22 = a20 * b20 + a21 * b21 + a22 * b22 - (c20 * d20 + c21 * d21 + c22 * d22)
    x01 = 0.5 * (a00 * b10 + a01 * b11 + a02 * b12 - (c00 * d10 + c01 * d11 + c02 * d12)
                 + (a10 * b00 + a11 * b01 + a12 * b02 - (c10 * d00 + c11 * d01 + c12 * d02)))
    x02 = 0.5 * (a00 * b20 + a01 * b21 + a02 * b22 - (c00 * d20 + c01 * d21 + c02 * d22)
                 + (a20 * b00 + a21 * b01 + a22 * b02 - (c20 * d00 + c21 * d01 + c22 * d02)))
    x12 = 0.5 * (a10 * b20 + a11 * b21 + a12 * b22 - (c10 * d20 + c11 * d21 + c12 * d22)
                 + (a20 * b10 + a21 * b11 + a22 * b12 - (c20 * d10 + c21 * d11 + c22 * d12)))
    return ((x00 + s, x01, x02), (x01, x11 + s, x12), (x02, x12, x22 + s))


def _add_diag(a, s):
    """a + s I."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    return ((a00 + s, a01, a02), (a10, a11 + s, a12), (a20, a21, a22 + s))


def _a_bct(a, b, c):
    """a − b @ cᵀ."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = c
    return ((a00 - (b00 * c00 + b01 * c01 + b02 * c02), a01 - (b00 * c10 + b01 * c11 + b02 * c12),
             a02 - (b00 * c20 + b01 * c21 + b02 * c22)),
            (a10 - (b10 * c00 + b11 * c01 + b12 * c02), a11 - (b10 * c10 + b11 * c11 + b12 * c12),
             a12 - (b10 * c20 + b11 * c21 + b12 * c22)),
            (a20 - (b20 * c00 + b21 * c01 + b22 * c02), a21 - (b20 * c10 + b21 * c11 + b22 * c12),
             a22 - (b20 * c20 + b21 * c21 + b22 * c22)))


def _t(a):
    """aᵀ."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    return ((a00, a10, a20), (a01, a11, a21), (a02, a12, a22))


def _add(a, b):
    """a + b."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return ((a00 + b00, a01 + b01, a02 + b02), (a10 + b10, a11 + b11, a12 + b12),
            (a20 + b20, a21 + b21, a22 + b22))


def _mean_t(a, b):
    """½(a + bᵀ)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return ((0.5 * (a00 + b00), 0.5 * (a01 + b10), 0.5 * (a02 + b20)),
            (0.5 * (a10 + b01), 0.5 * (a11 + b11), 0.5 * (a12 + b21)),
            (0.5 * (a20 + b02), 0.5 * (a21 + b12), 0.5 * (a22 + b22)))


def _sym(a):
    """½(a + aᵀ)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    x01, x02, x12 = 0.5 * (a01 + a10), 0.5 * (a02 + a20), 0.5 * (a12 + a21)
    return ((a00, x01, x02), (x01, a11, x12), (x02, x12, a22))


def _inv(a):
    """a⁻¹ by the adjugate (as :func:`_inverse3_cm`)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    c00, c01, c02 = a11 * a22 - a12 * a21, a02 * a21 - a01 * a22, a01 * a12 - a02 * a11
    c10, c11, c12 = a12 * a20 - a10 * a22, a00 * a22 - a02 * a20, a02 * a10 - a00 * a12
    c20, c21, c22 = a10 * a21 - a11 * a20, a01 * a20 - a00 * a21, a00 * a11 - a01 * a10
    d = a00 * c00 + a01 * c10 + a02 * c20
    return ((c00 / d, c01 / d, c02 / d), (c10 / d, c11 / d, c12 / d), (c20 / d, c21 / d, c22 / d))


def _mv(a, v):
    """a @ v."""
    return tuple(r[0] * v[0] + r[1] * v[1] + r[2] * v[2] for r in a)


def _skew1(v):
    return ((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0))


def _blocks(m) -> tuple:
    """A 3 × 3 array-like as a block (row tuples of floats)."""
    return tuple(tuple(r) for r in np.asarray(m, dtype=float).tolist())


class ScalarMEKF:
    """:class:`MEKF` for one satellite on Python floats (the single env's filter): the same
    equations, in the same order of blocks, agreeing with it to round-off. ``q`` (4-tuple),
    ``bias`` (3-tuple, rad/s), P as the blocks ``p11``, ``p12``, ``p22`` (P₂₁ = P₁₂ᵀ);
    :attr:`P` gives the (6, 6) array."""

    def __init__(self, q, bias, P, sigma_v: float, sigma_u: float, noise_scale: float = 1.0):
        P = np.asarray(P, dtype=float)
        self.q = tuple(float(c) for c in q)
        self.bias = tuple(float(c) for c in bias)
        self.p11, self.p12, self.p22 = _blocks(P[:3, :3]), _blocks(P[:3, 3:]), _blocks(P[3:, 3:])
        self.sigma_v, self.sigma_u, self.noise_scale = sigma_v, sigma_u, noise_scale
        self._q_dt = None

    @property
    def P(self) -> np.ndarray:
        """The covariance (6, 6), a new array."""
        (a, b, c), (d, e, f), (g, h, i) = self.p11, self.p12, _t(self.p12)
        return np.array((*a, *d, *b, *e, *c, *f, *g, *self.p22[0], *h, *self.p22[1], *i,
                         *self.p22[2])).reshape(6, 6)

    def _noise(self, dt: float):
        if self._q_dt is None or self._q_dt[0] != dt:
            q = self.noise_scale * process_noise(self.sigma_v, self.sigma_u, dt)
            self._q_dt = (dt, float(q[0, 0]), float(q[0, 3]), float(q[3, 3]))  # Q is diagonal
        return self._q_dt[1:]

    def propagate(self, dtheta_m: tuple, dt: float) -> None:
        """:meth:`MEKF.propagate` for Δθ_m (3 floats, rad)."""
        b = self.bias
        step = (dtheta_m[0] - b[0] * dt, dtheta_m[1] - b[1] * dt, dtheta_m[2] - b[2] * dt)
        w = (step[0] / dt, step[1] / dt, step[2] / dt)
        w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        a = math.sqrt(w2) * dt
        if a < 1e-3:
            c1, c2 = dt - a * a * dt / 6.0, dt * dt / 2.0 - a * a * dt * dt / 24.0
            c3 = dt ** 3 / 6.0 - a * a * dt ** 3 / 120.0
        else:
            ws = math.sqrt(w2)
            sin_a = math.sin(a)
            c1, c2, c3 = sin_a / ws, (1.0 - math.cos(a)) / ws ** 2, (dt - sin_a / ws) / ws ** 2
        x, y, z = w
        # K = [ω̂×], K² = ω̂ω̂ᵀ − |ω̂|² I; A = I − c1 K + c2 K², J = I dt − c2 K + c3 K²
        kxx, kyy, kzz = x * x - w2, y * y - w2, z * z - w2
        kxy, kxz, kyz = x * y, x * z, y * z
        A = ((1.0 + c2 * kxx, c2 * kxy + c1 * z, c2 * kxz - c1 * y),
             (c2 * kxy - c1 * z, 1.0 + c2 * kyy, c2 * kyz + c1 * x),
             (c2 * kxz + c1 * y, c2 * kyz - c1 * x, 1.0 + c2 * kzz))
        J = ((c3 * kxx + dt, c3 * kxy + c2 * z, c3 * kxz - c2 * y),
             (c3 * kxy - c2 * z, c3 * kyy + dt, c3 * kyz + c2 * x),
             (c3 * kxz + c2 * y, c3 * kyz - c2 * x, c3 * kzz + dt))
        q = sn.qmul1(self.q, sn.qexp1(step))
        inv = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        self.q = (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)
        p11, p12, p22 = self.p11, self.p12, self.p22
        # G = [A, −J]: G P = [A P₁₁ − J P₂₁, A P₁₂ − J P₂₂]; P₁₁ ← (G P) Gᵀ, P₁₂ ← (G P)₂
        u = _ab_cd(A, p11, J, _t(p12))
        v = _ab_cd(A, p12, J, p22)
        q11, q12, q22 = self._noise(dt)  # Q's blocks are multiples of I
        self.p11 = _sym_abt_cdt(u, A, v, J, q11)
        self.p12 = _add_diag(v, q12)
        self.p22 = _add_diag(p22, q22)

    def _update(self, residual: tuple, M, R) -> None:
        """:meth:`MEKF._update` for one satellite (M None: the identity); residual 3 floats,
        M and R 3 × 3 blocks."""
        p11, p12, p22 = self.p11, self.p12, self.p22
        p21 = _t(p12)
        if M is None:
            h1, h2 = p11, p21  # P Hᵀ = [P₁₁; P₂₁]
            S = _add(p11, R)
        else:
            h1, h2 = _mmt(p11, M), _mmt(p21, M)
            S = _add(_mm(M, h1), R)
        s_inv = _inv(_sym(S))
        k1, k2 = _mm(h1, s_inv), _mm(h2, s_inv)
        x1, x2 = _mv(k1, residual), _mv(k2, residual)
        self.p11 = _sym(_a_bct(p11, k1, h1))
        self.p12 = _mean_t(_a_bct(p12, k1, h2), _a_bct(p21, k2, h1))
        self.p22 = _sym(_a_bct(p22, k2, h2))
        q = sn.qmul1(self.q, sn.qexp1(x1))
        inv = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        self.q = (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)
        b = self.bias
        self.bias = (b[0] + x2[0], b[1] + x2[1], b[2] + x2[2])

    def update_attitude(self, q_m: tuple, R, valid: bool) -> None:
        """:meth:`MEKF.update_attitude` for one fix (4 floats), R a 3 × 3 block."""
        if valid:
            self._update(sn.qlog1(sn.qmul1(sn.qconj1(self.q), q_m)), None, R)

    def update_vector(self, y_B: tuple, r_N: tuple, R, valid: bool, unit: bool = False) -> None:
        """:meth:`MEKF.update_vector` for one body vector (3 floats), R a 3 × 3 block."""
        if not valid:
            return
        p = sn.rotate_inverse1(self.q, r_N)
        residual = (y_B[0] - p[0], y_B[1] - p[1], y_B[2] - p[2])
        if unit:
            along = tuple(tuple(p[i] * p[j] for j in range(3)) for i in range(3))
            proj = tuple(tuple((1.0 if i == j else 0.0) - along[i][j] for j in range(3))
                         for i in range(3))
            residual = _mv(proj, residual)
            tr = R[0][0] + R[1][1] + R[2][2]
            R = _add(_mm(_mm(proj, R), proj), tuple(tuple(tr * c for c in r) for r in along))
        self._update(residual, _skew1(p), R)

