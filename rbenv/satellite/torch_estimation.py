"""The MEKF of :mod:`rbenv.satellite.estimation` on torch tensors, batched over N satellites.

The same equations as :class:`rbenv.satellite.estimation.MEKF` (its module docstring gives
them and their sources), on any device and dtype (float64 by default, where it agrees with the
NumPy filter to round-off: ``tests/rbenv/test_torch_estimation.py``). The state: ``q`` (N, 4,
scalar-first, body to inertial), ``bias`` (N, 3, rad/s), ``P`` (N, 6, 6), the error state
(δθ, Δb) with δq = q̂⁻¹ ⊗ q = exp(δθ) (body axes, rad) and Δb = b − b̂ (rad/s).

Propagation runs on Φ's blocks (Φ = [[A, −J], [0, I]]: P₁₁ ← G P Gᵀ with G = [A, −J],
P₁₂ ← (G P)₂, P₂₂ unchanged, then + Q) and the updates on H = [M 0]. Rows without a
measurement are kept by ``torch.where`` on the whole batch, not by indexing, so a step has no
data-dependent control flow (no host synchronisation on a GPU). The small-angle series are
chosen by ``torch.where`` as well.

The sensors' measurement models of :mod:`rbenv.satellite.sensors` (star tracker, magnetometer,
coarse sun sensors and their least-squares fit) are here on tensors too, each taking its
standard normals (or uniforms) as arguments: the torch env's estimator
(:mod:`rbenv.envs.torch_estimated`) draws them from the NumPy env's generator stream, so both
backends measure the same. They restate the NumPy models' few lines on (N, ·) tensors (NumPy's
write into preallocated arrays); the gyro's formula is shared
(:func:`rbenv.satellite.sensors.gyro_increment_of`).
"""

from __future__ import annotations

import functools
import math

import torch

from rbenv.satellite.estimation import process_noise

__all__ = ["TorchMEKF", "magnetometer", "qconj", "qexp", "qlog", "qmul", "rotate", "rotate_inverse",
           "star_tracker", "sun_sensors", "sun_vector_fit", "transition_rows"]

_DEG = math.pi / 180.0


def qmul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product of (..., 4) scalar-first quaternions."""
    a0, a1, a2, a3 = a.unbind(-1)
    b0, b1, b2, b3 = b.unbind(-1)
    return torch.stack((a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0), -1)


def qconj(q: torch.Tensor) -> torch.Tensor:
    """The conjugate of (..., 4) quaternions (the inverse of a unit quaternion)."""
    return torch.cat((q[..., :1], -q[..., 1:]), -1)


def qexp(v: torch.Tensor) -> torch.Tensor:
    """The unit quaternion of the rotation vector v (..., 3), rad (series below 1e-4 rad)."""
    angle = torch.sqrt((v * v).sum(-1, keepdim=True))
    half = 0.5 * angle
    small = angle < 1e-4
    ratio = torch.where(small, 0.5 - angle * angle / 48.0,
                        torch.sin(half) / torch.where(small, torch.ones_like(angle), angle))
    return torch.cat((torch.cos(half), ratio * v), -1)


def qlog(q: torch.Tensor) -> torch.Tensor:
    """The rotation vector (..., 3, rad, |·| ≤ π) of a unit quaternion (sign taken positive)."""
    q = torch.where(q[..., :1] < 0.0, -q, q)
    w, u = q[..., :1], q[..., 1:]
    s = torch.sqrt((u * u).sum(-1, keepdim=True))
    small = s < 1e-8
    k = torch.where(small, 2.0 / torch.clamp(w, min=1e-300),
                    2.0 * torch.atan2(s, w) / torch.where(small, torch.ones_like(s), s))
    return k * u


def rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """A(q) v: a body vector v (..., 3) in inertial axes."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * torch.linalg.cross(u, v, dim=-1)
    return v + w * t + torch.linalg.cross(u, t, dim=-1)


def rotate_inverse(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """A(q)ᵀ v: an inertial vector v (..., 3) in body axes."""
    return rotate(qconj(q), v)


def _skew(v: torch.Tensor) -> torch.Tensor:
    """[v×] (..., 3, 3)."""
    x, y, z = v.unbind(-1)
    o = torch.zeros_like(x)
    return torch.stack((torch.stack((o, -z, y), -1), torch.stack((z, o, -x), -1),
                        torch.stack((-y, x, o), -1)), -2)


def transition_rows(omega_hat: torch.Tensor, dt: float) -> torch.Tensor:
    """Φ's first block row [A, −J] (N, 3, 6) for the rate ω̂ (N, 3, rad/s) held over dt:
    A = exp(−[ω̂×]dt) = I − c1 K + c2 K², J = ∫₀^dt exp(−[ω̂×]s) ds = I dt − c2 K + c3 K²,
    K = [ω̂×] (closed form; series below |ω̂|dt = 1e-3)."""
    w2 = (omega_hat * omega_hat).sum(-1)
    w = torch.sqrt(w2)
    a = w * dt
    a2 = a * a
    small = a < 1e-3
    ws = torch.where(small, torch.ones_like(w), w)
    ws2 = ws * ws
    c1 = torch.where(small, dt - a2 * (dt / 6.0), torch.sin(a) / ws)
    c2 = torch.where(small, dt * dt / 2.0 - a2 * (dt * dt / 24.0), (1.0 - torch.cos(a)) / ws2)
    c3 = torch.where(small, dt ** 3 / 6.0 - a2 * (dt ** 3 / 120.0),
                     (dt - torch.sin(a) / ws) / ws2)
    k = _skew(omega_hat)
    k2 = k @ k
    eye = torch.eye(3, dtype=omega_hat.dtype, device=omega_hat.device)
    c1, c2, c3 = c1[:, None, None], c2[:, None, None], c3[:, None, None]
    A = eye - c1 * k + c2 * k2
    J = eye * dt - c2 * k + c3 * k2
    return torch.cat((A, -J), -1)


class TorchMEKF:
    """The MEKF for N satellites on torch tensors (see the module docstring): ``q`` (N, 4),
    ``bias`` (N, 3, rad/s), ``P`` (N, 6, 6); gyro noise σ_v (rad/√s) and σ_u (rad/s/√s) set
    its process noise. Arrays or tensors are taken; the state lives on ``device`` in
    ``dtype``."""

    def __init__(self, q, bias, P, sigma_v: float, sigma_u: float, noise_scale: float = 1.0,
                 device=None, dtype: torch.dtype = torch.float64):
        kw = {"dtype": dtype, "device": device}
        self.q = torch.as_tensor(q, **kw).clone()
        self.bias = torch.as_tensor(bias, **kw).clone()
        self.P = torch.as_tensor(P, **kw).clone()
        self.sigma_v, self.sigma_u, self.noise_scale = sigma_v, sigma_u, noise_scale
        self._q_dt = None

    def _tensor(self, x) -> torch.Tensor:
        return torch.as_tensor(x, dtype=self.q.dtype, device=self.q.device)

    def _noise(self, dt: float) -> torch.Tensor:
        if self._q_dt is None or self._q_dt[0] != dt:
            q = self.noise_scale * process_noise(self.sigma_v, self.sigma_u, dt)
            self._q_dt = (dt, self._tensor(q))
        return self._q_dt[1]

    def propagate(self, dtheta_m, dt: float) -> None:
        """Advance over dt s with the gyro increment Δθ_m (N, 3, rad)."""
        step = self._tensor(dtheta_m) - self.bias * dt
        g = transition_rows(step / dt, dt)  # (N, 3, 6)
        q = qmul(self.q, qexp(step))
        self.q = q / torch.linalg.vector_norm(q, dim=-1, keepdim=True)
        P = self.P
        gp = g @ P  # (N, 3, 6)
        p11 = gp @ g.transpose(-1, -2)
        p12 = gp[:, :, 3:]
        top = torch.cat((0.5 * (p11 + p11.transpose(-1, -2)), p12), -1)
        bottom = torch.cat((p12.transpose(-1, -2), P[:, 3:, 3:]), -1)
        self.P = torch.cat((top, bottom), -2) + self._noise(dt)

    def _update(self, residual: torch.Tensor, M: torch.Tensor | None, R: torch.Tensor,
                valid: torch.Tensor) -> None:
        """One 3-D measurement update for the rows where ``valid`` (N,) bool; residual (N, 3),
        H = [M 0] with M (N, 3, 3) or None for the identity, R (3, 3) or (N, 3, 3).
        K = P Hᵀ S⁻¹, P ← P − K (P Hᵀ)ᵀ symmetrized, S = M P₁₁ Mᵀ + R."""
        P = self.P
        if M is None:
            pht = P[:, :, :3]  # (N, 6, 3)
            S = pht[:, :3] + R
        else:
            pht = P[:, :, :3] @ M.transpose(-1, -2)
            S = M @ pht[:, :3] + R
        K = pht @ torch.linalg.inv(0.5 * (S + S.transpose(-1, -2)))
        x = (K @ residual[..., None])[..., 0]
        newP = P - K @ pht.transpose(-1, -2)
        newP = 0.5 * (newP + newP.transpose(-1, -2))
        q = qmul(self.q, qexp(x[:, :3]))
        q = q / torch.linalg.vector_norm(q, dim=-1, keepdim=True)
        m = valid[:, None]
        self.P = torch.where(valid[:, None, None], newP, P)
        self.q = torch.where(m, q, self.q)
        self.bias = torch.where(m, self.bias + x[:, 3:], self.bias)

    def update_attitude(self, q_m, R, valid) -> None:
        """A star-tracker fix q_m (N, 4) with noise covariance R (3, 3, rad², body axes)."""
        residual = qlog(qmul(qconj(self.q), self._tensor(q_m)))
        self._update(residual, None, self._tensor(R),
                     torch.as_tensor(valid, dtype=torch.bool, device=self.q.device))

    def update_vector(self, y_B, r_N, R, valid, unit: bool = False) -> None:
        """A body vector y_B (N, 3) of the inertial vector r_N (N, 3), noise covariance R
        ((3, 3) or (N, 3, 3)); unit: unit vectors, the residual and R projected off the
        predicted direction (as :meth:`rbenv.satellite.estimation.MEKF.update_vector`)."""
        predicted = rotate_inverse(self.q, self._tensor(r_N))
        residual = self._tensor(y_B) - predicted
        R = self._tensor(R)
        if unit:
            along = predicted[..., :, None] * predicted[..., None, :]
            proj = torch.eye(3, dtype=R.dtype, device=R.device) - along
            residual = (proj @ residual[..., None])[..., 0]
            trace = torch.diagonal(R, dim1=-2, dim2=-1).sum(-1)[..., None, None]
            R = proj @ R @ proj + trace * along
        self._update(residual, _skew(predicted), R,
                     torch.as_tensor(valid, dtype=torch.bool, device=self.q.device))

    def error(self, q_true, bias_true) -> torch.Tensor:
        """The true error state (N, 6): ``log(q̂⁻¹ ⊗ q)`` then ``b − b̂``."""
        return torch.cat((qlog(qmul(qconj(self.q), self._tensor(q_true))),
                          self._tensor(bias_true) - self.bias), -1)


# --------------------------------------------------------------------------- sensors on tensors
# rbenv.satellite.sensors' models (their docstrings give the error models), on (N, ·) tensors,
# with the random numbers passed in.


@functools.lru_cache(maxsize=64)
def _constant(values: tuple, dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    """A sensor's fixed vectors (boresight, cell normals) on the device, copied there once."""
    return torch.tensor(values, dtype=dtype, device=device)


def star_tracker(params, chol_T: torch.Tensor, q_BN: torch.Tensor, omega_B: torch.Tensor,
                 sun_N: torch.Tensor | None, nadir_N: torch.Tensor | None,
                 earth_radius_rad: float, normals: torch.Tensor,
                 drop: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`rbenv.satellite.sensors.star_tracker`: ``(q_m (N, 4), valid (N,) bool)`` from
    the standard normals ``normals`` (N, 3) and the dropouts ``drop`` (N,) bool; chol_T: the
    transposed Cholesky factor of ``params.noise_cov_B()`` (3, 3)."""
    q_m = qmul(q_BN, qexp(normals @ chol_T))
    bore = _constant(params.boresight_B, q_BN.dtype, q_BN.device)
    bore_N = rotate(q_BN, bore.expand_as(omega_B))
    valid = ~drop & (torch.linalg.vector_norm(omega_B, dim=-1) <= params.max_rate_dps * _DEG)
    if sun_N is not None:
        valid = valid & ((bore_N * sun_N).sum(-1) < math.cos(params.sun_exclusion_deg * _DEG))
    if nadir_N is not None:
        limit = min(math.pi, earth_radius_rad + params.earth_exclusion_deg * _DEG)
        valid = valid & ((bore_N * nadir_N).sum(-1) < math.cos(limit))
    return q_m, valid


def magnetometer(params, q_BN: torch.Tensor, field_N_T: torch.Tensor, bias_T: torch.Tensor,
                 normals: torch.Tensor) -> torch.Tensor:
    """:func:`rbenv.satellite.sensors.magnetometer` (T, body axes) from the standard normals
    ``normals`` (N, 3)."""
    return rotate_inverse(q_BN, field_N_T) + bias_T + params.noise_nT * 1e-9 * normals


def sun_sensors(params, q_BN: torch.Tensor, sun_N: torch.Tensor, lit: torch.Tensor,
                normals: torch.Tensor) -> torch.Tensor:
    """:func:`rbenv.satellite.sensors.sun_sensors`: cell outputs (N, M) from the standard
    normals ``normals`` (N, M); lit (N,) 1.0 or 0.0."""
    faces = _constant(params.normals_B, q_BN.dtype, q_BN.device)
    cos = rotate_inverse(q_BN, sun_N) @ faces.T
    seen = (cos >= math.cos(params.fov_deg * _DEG)) & (cos > 0.0) & (lit[:, None] > 0.5)
    return torch.where(seen, cos + params.noise * normals, 0.0)


def sun_vector_fit(params, output: torch.Tensor, threshold: float = 0.05) -> tuple:
    """:func:`rbenv.satellite.sensors.sun_vector_fit`: ``(s_B (N, 3), cov (N, 3, 3), valid
    (N,))`` by least squares over the cells above ``threshold``."""
    faces = _constant(params.normals_B, output.dtype, output.device)
    use = output > threshold
    h = faces[None] * use[..., None]
    hth = torch.einsum("nmi,nmj->nij", h, h)
    valid = torch.linalg.det(hth) > 1e-6
    eye = torch.eye(3, dtype=output.dtype, device=output.device)
    hth = torch.where(valid[:, None, None], hth, eye)
    rhs = torch.einsum("nmi,nm->ni", h, output * use)
    s = torch.linalg.solve(hth, rhs[..., None])[..., 0]
    norm = torch.linalg.vector_norm(s, dim=-1, keepdim=True)
    valid = valid & (norm[:, 0] > 0.3)
    norm = torch.clamp(norm, min=1e-12)
    s_hat = s / norm
    proj = eye - s_hat[..., :, None] * s_hat[..., None, :]
    cov = params.noise ** 2 / norm[..., None] ** 2 * proj @ torch.linalg.inv(hth) @ proj
    return s_hat, cov, valid
