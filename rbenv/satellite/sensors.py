"""Attitude sensors for the estimator, batched over N satellites in NumPy: their scene tables
and error models.

Every model takes (N, ...) arrays and a :class:`numpy.random.Generator`; quaternions are
scalar-first, body to inertial (as the state). The tables (``[star_tracker]``, ``[magnetometer]``,
``[sun_sensors]``) are opt-in; the gyro is ``[sensors]`` (:class:`rbenv.satellite.scene.Sensors`)
with ``attitude = "estimator"``. Each default quotes a typical CubeSat-class value (the ranges of
docs/estimation.md, "typical") or is marked an assumption there.

* Gyro (:func:`gyro_increment`): an integrating rate gyro that outputs the attitude increment
  over a control step (coning-compensated) plus the integrated bias and the angle random walk::

      Δθ_m = Δθ + ∫ b dt + σ_v W_v(dt),    b(t) = b_k + σ_u W_u(t),

  with σ_v the angle random walk (rad/√s) and σ_u the rate random walk (rad/s/√s); the pair
  (W_u(dt), ∫W_u) is drawn exactly (covariance [[dt, dt²/2], [dt²/2, dt³/3]]), so the Allan
  variance of Δθ_m/τ is σ_v²/τ + σ_u² τ/3 exactly (slopes −½ and +½).
* Star tracker (:func:`star_tracker`): ``q_m = q ⊗ exp(v)`` with v in body axes, 1σ
  ``sigma_cross_arcsec`` across the boresight and ``sigma_about_arcsec`` about it; no fix when
  the Sun is within ``sun_exclusion_deg`` of the boresight, the Earth's limb within
  ``earth_exclusion_deg``, the body rate above ``max_rate_dps``, or a dropout (probability per
  fix) happens.
* Magnetometer (:func:`magnetometer`): ``B_m = Aᵀ B_N + b + σ n`` (T), b a per-episode bias.
* Coarse sun sensors (:func:`sun_sensors`): one photocell per face normal n_i, output
  ``max(0, n_i·ŝ_B)`` inside the field of view (zero beyond ``fov_deg`` off the normal and in
  eclipse) plus σ noise (fraction of full scale); :func:`sun_vector_fit` fits ŝ_B by least
  squares over the lit cells (Basilisk's ``cssWlsEst`` does the same).

The functions ending in 1 (:func:`gyro_increment1`, :func:`star_tracker1`,
:func:`magnetometer1`, and the quaternion helpers) are the same models for one satellite on
Python floats, for the single env; each takes the same numbers from the generator as its
batched twin at N = 1.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError

__all__ = [
    "Magnetometer",
    "StarTracker",
    "SunSensors",
    "gyro_increment",
    "gyro_increment1",
    "gyro_increment_of",
    "magnetometer",
    "magnetometer1",
    "qconj",
    "qexp",
    "qexp_cm",
    "qlog",
    "qlog_cm",
    "qmul",
    "rotate",
    "rotate_inverse",
    "star_tracker",
    "star_tracker1",
    "star_tracker_draws",
    "sun_sensors",
    "sun_vector_fit",
]

ARCSEC = math.pi / (180.0 * 3600.0)
_DEG = math.pi / 180.0


# --------------------------------------------------------------------------- quaternions (N, 4)


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) scalar-first quaternions."""
    a0, a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    b0, b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    out[..., 1] = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    out[..., 2] = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    out[..., 3] = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of (..., 3) vectors (np.cross's result, without its axis handling)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def qconj(q: np.ndarray) -> np.ndarray:
    """The conjugate (the inverse of a unit quaternion)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def qexp_cm(v: np.ndarray) -> np.ndarray:
    """The unit quaternions (4, ...) of rotation vectors v (3, ..., rad), components first (the
    MEKF's layout: each component a contiguous row)."""
    angle = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    half = 0.5 * angle
    out = np.empty((4, *angle.shape))
    out[0] = np.cos(half)
    # sin(a/2)/a, with its series below 1e-4 rad (relative error < 1e-17)
    small = angle < 1e-4
    if small.any():
        ratio = np.where(small, 0.5 - angle * angle / 48.0,
                         np.sin(half) / np.where(small, 1.0, angle))
    else:
        ratio = np.sin(half) / angle
    np.multiply(ratio, v, out=out[1:])
    return out


def qexp(v: np.ndarray) -> np.ndarray:
    """The unit quaternion of the rotation vector v (..., 3), rad (:func:`qexp_cm`)."""
    return np.moveaxis(qexp_cm(np.moveaxis(v, -1, 0)), 0, -1)


def qlog_cm(q: np.ndarray) -> np.ndarray:
    """The rotation vectors (3, ..., rad, |·| ≤ π) of unit quaternions q (4, ...), components
    first (sign taken positive)."""
    w, u = q[0], q[1:]
    neg = w < 0.0
    if neg.any():
        w, u = np.where(neg, -w, w), np.where(neg, -u, u)
    s = np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    small = s < 1e-8
    if small.any():
        k = np.where(small, 2.0 / np.maximum(w, 1e-300),
                     2.0 * np.arctan2(s, w) / np.where(small, 1.0, s))
    else:
        k = 2.0 * np.arctan2(s, w) / s
    return k * u


def qlog(q: np.ndarray) -> np.ndarray:
    """The rotation vector (..., 3, rad, |·| ≤ π) of a unit quaternion (sign taken positive;
    :func:`qlog_cm`)."""
    return np.moveaxis(qlog_cm(np.moveaxis(q, -1, 0)), 0, -1)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A(q) v: a body vector v (..., 3) in inertial axes."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * cross(u, v)
    return v + w * t + cross(u, t)


def rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A(q)ᵀ v: an inertial vector v (..., 3) in body axes."""
    return rotate(qconj(q), v)


def skew(v: np.ndarray) -> np.ndarray:
    """[v×] (..., 3, 3)."""
    out = np.zeros((*v.shape, 3))
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -w, y, -x
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = w, -y, x
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --------------------------------------------------------------------------- tables


def _num(path, value, **rule) -> float:
    return check.number(path, value, **rule)


def _vector3(path, value) -> tuple:
    arr = np.asarray(value, dtype=float) if not isinstance(value, str) else None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)) or \
            np.linalg.norm(arr) < 1e-9:
        raise InvalidParameterError(f"{path} must be a nonzero finite [x, y, z], got {value!r}")
    return tuple(float(x) for x in arr / np.linalg.norm(arr))


@dataclass(frozen=True)
class StarTracker:
    """``[star_tracker]``: one camera head. Noise 1σ across the boresight and about it (arcsec),
    fix rate (Hz; the filter takes the newest fix at each control step, so rates above
    1/control_dt act as 1/control_dt), Sun and Earth-limb exclusion half-angles (deg), the
    largest body rate with a fix (deg/s), and the probability that a fix drops out."""

    boresight_B: tuple = (0.0, 0.0, 1.0)
    sigma_cross_arcsec: float = 10.0
    sigma_about_arcsec: float = 70.0
    rate_hz: float = 1.0
    sun_exclusion_deg: float = 40.0
    earth_exclusion_deg: float = 25.0
    max_rate_dps: float = 3.0
    dropout_probability: float = 0.0

    def __post_init__(self):
        p = "star_tracker"
        object.__setattr__(self, "boresight_B", _vector3(f"{p}.boresight_B", self.boresight_B))
        for name in ("sigma_cross_arcsec", "sigma_about_arcsec"):
            object.__setattr__(self, name, _num(f"{p}.{name}", getattr(self, name), low=0.0,
                                                low_open=True, high=3600.0))
        object.__setattr__(self, "rate_hz", _num(f"{p}.rate_hz", self.rate_hz, low=0.0,
                                                 low_open=True, high=1000.0))
        for name in ("sun_exclusion_deg", "earth_exclusion_deg"):
            object.__setattr__(self, name, _num(f"{p}.{name}", getattr(self, name), low=0.0,
                                                high=90.0))
        object.__setattr__(self, "max_rate_dps", _num(f"{p}.max_rate_dps", self.max_rate_dps,
                                                      low=0.0, low_open=True))
        object.__setattr__(self, "dropout_probability", _num(
            f"{p}.dropout_probability", self.dropout_probability, low=0.0, high=1.0))

    def noise_cov_B(self) -> np.ndarray:
        """(3, 3) covariance of v (rad²), body axes."""
        b = np.array(self.boresight_B)
        cross = (self.sigma_cross_arcsec * ARCSEC) ** 2
        about = (self.sigma_about_arcsec * ARCSEC) ** 2
        return cross * np.eye(3) + (about - cross) * np.outer(b, b)

    def period_steps(self, control_dt: float) -> int:
        """Control steps between fixes (≥ 1)."""
        return max(1, round(1.0 / (self.rate_hz * control_dt)))


@dataclass(frozen=True)
class Magnetometer:
    """``[magnetometer]``: white noise (nT, 1σ per axis) and a bias drawn per episode (nT, 1σ
    per axis, held all episode; the filter does not estimate it and counts it as noise)."""

    noise_nT: float = 100.0
    bias_nT: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "noise_nT", _num("magnetometer.noise_nT", self.noise_nT,
                                                  low=0.0, low_open=True, high=1e5))
        object.__setattr__(self, "bias_nT", _num("magnetometer.bias_nT", self.bias_nT,
                                                 low=0.0, high=1e5))


@dataclass(frozen=True)
class SunSensors:
    """``[sun_sensors]``: coarse sun sensors (photocells), one per face normal (body axes), a
    field-of-view half-angle off the normal (deg) and white noise (fraction of the full-scale
    output, 1σ)."""

    normals_B: tuple = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
                        (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))
    fov_deg: float = 80.0
    noise: float = 0.02

    def __post_init__(self):
        normals = self.normals_B
        if isinstance(normals, str) or not hasattr(normals, "__len__") or \
                not 3 <= len(normals) <= 32:
            raise InvalidParameterError(
                f"sun_sensors.normals_B must be a list of 3 to 32 [x, y, z], got {normals!r}")
        object.__setattr__(self, "normals_B", tuple(
            _vector3(f"sun_sensors.normals_B[{i}]", n) for i, n in enumerate(normals)))
        object.__setattr__(self, "fov_deg", _num("sun_sensors.fov_deg", self.fov_deg, low=0.0,
                                                 low_open=True, high=90.0))
        object.__setattr__(self, "noise", _num("sun_sensors.noise", self.noise, low=0.0,
                                               low_open=True, high=1.0))


# --------------------------------------------------------------------------- models


def gyro_increment(dtheta: np.ndarray, bias: np.ndarray, sigma_v: float, sigma_u: float,
                   dt: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``(Δθ_m, b_next)``: the gyro's measured increment (N, 3, rad) over ``dt`` s for the true
    increment ``dtheta`` (N, 3, rad) and the bias ``bias`` (N, 3, rad/s) at the interval's
    start; sigma_v: angle random walk, rad/√s; sigma_u: rate random walk, rad/s/√s."""
    return gyro_increment_of(dtheta, bias, rng.standard_normal((3, *dtheta.shape)), sigma_v,
                             sigma_u, dt)


def gyro_increment_of(dtheta, bias, n, sigma_v: float, sigma_u: float, dt: float) -> tuple:
    """:func:`gyro_increment` from its standard normals ``n`` (3, N, 3): the angle random walk,
    then the pair (W_u(dt), ∫W_u). Arithmetic alone, so NumPy arrays and torch tensors (the
    torch env's estimator, :mod:`rbenv.envs.torch_estimated`) run the one formula."""
    w_end = math.sqrt(dt) * n[1]  # W_u(dt) and ∫W_u, jointly Gaussian (exact Cholesky)
    w_int = 0.5 * dt * w_end + math.sqrt(dt ** 3 / 12.0) * n[2]
    measured = dtheta + bias * dt + sigma_u * w_int + sigma_v * math.sqrt(dt) * n[0]
    return measured, bias + sigma_u * w_end


@functools.lru_cache(maxsize=64)
def _cholesky_T(params: StarTracker) -> np.ndarray:
    """The transposed Cholesky factor of the star tracker's noise covariance (read-only)."""
    out = np.linalg.cholesky(params.noise_cov_B()).T
    out.flags.writeable = False
    return out


def star_tracker_draws(n: int, rng: np.random.Generator) -> None:
    """Take from ``rng`` what :func:`star_tracker` (or :func:`star_tracker1`) takes for n
    satellites, without computing a fix (a step between fixes)."""
    rng.standard_normal((n, 3))
    rng.random(n)


def star_tracker(params: StarTracker, q_BN: np.ndarray, omega_B: np.ndarray,
                 sun_N: np.ndarray | None, nadir_N: np.ndarray | None, earth_radius_rad: float,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``(q_m, valid)``: the measured attitude (N, 4) and whether there is a fix (N,) bool.

    sun_N, nadir_N: unit vectors (N, 3) from the satellite to the Sun and to the Earth's centre,
    or None (no orbit: no exclusion); earth_radius_rad: the Earth's angular radius seen from
    the orbit."""
    n = q_BN.shape[0]
    v = rng.standard_normal((n, 3)) @ _cholesky_T(params)
    drop = rng.random(n) < params.dropout_probability
    q_m = qmul(q_BN, qexp(v))
    bore_N = rotate(q_BN, np.broadcast_to(np.array(params.boresight_B), (n, 3)))
    valid = ~drop & (np.linalg.norm(omega_B, axis=-1) <= params.max_rate_dps * _DEG)
    if sun_N is not None:
        valid &= np.sum(bore_N * sun_N, -1) < math.cos(params.sun_exclusion_deg * _DEG)
    if nadir_N is not None:
        limit = min(math.pi, earth_radius_rad + params.earth_exclusion_deg * _DEG)
        valid &= np.sum(bore_N * nadir_N, -1) < math.cos(limit)
    return q_m, valid


def magnetometer(params: Magnetometer, q_BN: np.ndarray, field_N_T: np.ndarray,
                 bias_T: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The measured field (N, 3, T, body axes): ``A(q)ᵀ B_N + bias + σ n``."""
    noise = params.noise_nT * 1e-9 * rng.standard_normal(field_N_T.shape)
    return rotate_inverse(q_BN, field_N_T) + bias_T + noise


def sun_sensors(params: SunSensors, q_BN: np.ndarray, sun_N: np.ndarray, lit: np.ndarray,
                rng: np.random.Generator) -> np.ndarray:
    """Cell outputs (N, M, fraction of full scale): ``cos`` of the Sun's angle off each normal
    inside the field of view and in sunlight (lit: (N,) 1.0 or 0.0), else 0; plus noise on
    the cells that see the Sun."""
    normals = np.array(params.normals_B)
    cos = rotate_inverse(q_BN, sun_N) @ normals.T
    seen = (cos >= math.cos(params.fov_deg * _DEG)) & (cos > 0.0) & (lit[:, None] > 0.5)
    out = cos + params.noise * rng.standard_normal(cos.shape)
    return np.where(seen, out, 0.0)


def sun_vector_fit(params: SunSensors, output: np.ndarray,
                   threshold: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s_B, cov, valid)``: the least-squares Sun direction (N, 3, unit) from the cells whose
    output exceeds ``threshold``, its covariance (N, 3, 3) as a unit vector (σ²(HᵀH)⁻¹
    projected off s_B), and whether it is determined (N,) (three lit cells spanning 3-D)."""
    normals = np.array(params.normals_B)
    use = output > threshold  # (N, M)
    h = normals[None] * use[..., None]  # rows of the lit cells, zero elsewhere
    hth = np.einsum("nmi,nmj->nij", h, h)
    det = np.linalg.det(hth)
    valid = det > 1e-6
    hth = np.where(valid[:, None, None], hth, np.eye(3))
    s = np.linalg.solve(hth, np.einsum("nmi,nm->ni", h, output * use)[..., None])[..., 0]
    norm = np.linalg.norm(s, axis=-1, keepdims=True)
    valid &= norm[:, 0] > 0.3
    s_hat = s / np.maximum(norm, 1e-12)
    proj = np.eye(3) - s_hat[..., :, None] * s_hat[..., None, :]
    scale = params.noise ** 2 / np.maximum(norm, 1e-12)[..., None] ** 2
    cov = scale * proj @ np.linalg.inv(hth) @ proj
    return s_hat, cov, valid


# --------------------------------------------------------------------------- one satellite
# The same models for one satellite on Python floats (tuples of components), for the single
# env, where a NumPy call's overhead (about a microsecond) costs more than the arithmetic.
# Each draws the same numbers from the generator as its batched twin at N = 1, in the same
# order, so the two agree to round-off.


def qexp1(v: tuple) -> tuple:
    """:func:`qexp` of one rotation vector (3 floats, rad): 4 floats."""
    angle = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    half = 0.5 * angle
    ratio = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(half) / angle
    return (math.cos(half), ratio * v[0], ratio * v[1], ratio * v[2])


def qlog1(q: tuple) -> tuple:
    """:func:`qlog` of one unit quaternion (4 floats): 3 floats, rad."""
    w, x, y, z = q
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 / max(w, 1e-300) if s < 1e-8 else 2.0 * math.atan2(s, w) / s
    return (k * x, k * y, k * z)


def qmul1(a: tuple, b: tuple) -> tuple:
    """:func:`qmul` of two quaternions (4 floats each)."""
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


def qconj1(q: tuple) -> tuple:
    """The conjugate of one quaternion."""
    return (q[0], -q[1], -q[2], -q[3])


def rotate1(q: tuple, v: tuple) -> tuple:
    """:func:`rotate` of one vector: A(q) v."""
    w, u0, u1, u2 = q
    v0, v1, v2 = v
    t0, t1, t2 = 2.0 * (u1 * v2 - u2 * v1), 2.0 * (u2 * v0 - u0 * v2), 2.0 * (u0 * v1 - u1 * v0)
    return (v0 + w * t0 + (u1 * t2 - u2 * t1), v1 + w * t1 + (u2 * t0 - u0 * t2),
            v2 + w * t2 + (u0 * t1 - u1 * t0))


def rotate_inverse1(q: tuple, v: tuple) -> tuple:
    """:func:`rotate_inverse` of one vector: A(q)ᵀ v."""
    return rotate1(qconj1(q), v)


def gyro_increment1(dtheta: tuple, bias: tuple, sigma_v: float, sigma_u: float, dt: float,
                    rng: np.random.Generator) -> tuple[tuple, tuple]:
    """:func:`gyro_increment` for one satellite (3-tuples of floats)."""
    v0, v1, v2, e0, e1, e2, i0, i1, i2 = rng.standard_normal(9).tolist()
    sq, sq3, sv, h = math.sqrt(dt), math.sqrt(dt ** 3 / 12.0), sigma_v * math.sqrt(dt), 0.5 * dt
    e0, e1, e2 = sq * e0, sq * e1, sq * e2  # W_u(dt)
    b0, b1, b2 = bias
    return ((dtheta[0] + b0 * dt + sigma_u * (h * e0 + sq3 * i0) + sv * v0,
             dtheta[1] + b1 * dt + sigma_u * (h * e1 + sq3 * i1) + sv * v1,
             dtheta[2] + b2 * dt + sigma_u * (h * e2 + sq3 * i2) + sv * v2),
            (b0 + sigma_u * e0, b1 + sigma_u * e1, b2 + sigma_u * e2))


def star_tracker1(params: StarTracker, chol_T: tuple, q_BN: tuple, omega_B: tuple,
                  sun_N: tuple | None, nadir_N: tuple | None, earth_radius_rad: float,
                  rng: np.random.Generator) -> tuple[tuple, bool]:
    """:func:`star_tracker` for one satellite; chol_T: the transposed Cholesky factor of
    ``params.noise_cov_B()`` as 3 rows of floats (constant: the caller holds it)."""
    n0, n1, n2 = rng.standard_normal(3).tolist()
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = chol_T
    v = (n0 * c00 + n1 * c10 + n2 * c20, n0 * c01 + n1 * c11 + n2 * c21,
         n0 * c02 + n1 * c12 + n2 * c22)
    drop = rng.random() < params.dropout_probability
    q_m = qmul1(q_BN, qexp1(v))
    bore = rotate1(q_BN, params.boresight_B)
    w0, w1, w2 = omega_B
    valid = not drop and math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) <= params.max_rate_dps * _DEG
    if valid and sun_N is not None:
        valid = bore[0] * sun_N[0] + bore[1] * sun_N[1] + bore[2] * sun_N[2] < \
            math.cos(params.sun_exclusion_deg * _DEG)
    if valid and nadir_N is not None:
        limit = min(math.pi, earth_radius_rad + params.earth_exclusion_deg * _DEG)
        valid = bore[0] * nadir_N[0] + bore[1] * nadir_N[1] + bore[2] * nadir_N[2] < \
            math.cos(limit)
    return q_m, valid


def magnetometer1(params: Magnetometer, q_BN: tuple, field_N_T: tuple, bias_T: tuple,
                  rng: np.random.Generator) -> tuple:
    """:func:`magnetometer` for one satellite (T, body axes)."""
    noise = rng.standard_normal(3).tolist()
    b = rotate_inverse1(q_BN, field_N_T)
    s = params.noise_nT * 1e-9
    return tuple(b[i] + bias_T[i] + s * noise[i] for i in range(3))
