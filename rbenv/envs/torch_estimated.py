"""The MEKF in the loop of the torch env: :class:`rbenv.envs.estimated.EstimatorLoop` on tensors.

:class:`TorchEstimatorLoop` does for :class:`rbenv.envs.torch_env.TorchVectorEnv` what
:class:`~rbenv.envs.estimated.EstimatorLoop` does for the NumPy vector env, with the same
outputs (the observation of the estimate and its ``estimate_sigma`` features, and ``info``'s
``q_true``, ``q_est``, ``gyro_bias``, ``gyro_bias_est``, ``estimate_cov``,
``estimated_attitude_error_deg``, ``star_tracker_fix``, each with a leading N): the filter is
:class:`rbenv.satellite.torch_estimation.TorchMEKF`, the sensors are the tensor forms of
:mod:`rbenv.satellite.sensors` (the gyro's formula is the NumPy one,
:func:`~rbenv.satellite.sensors.gyro_increment_of`), the Sun, the orbit's direction and its
field are :mod:`rbenv.satellite.disturbances`' and :mod:`rbenv.satellite.orbit`'s through the
env's torch namespace, and the task and actuator observations are the transition's.

**Draws.** The sensors' random numbers come from the NumPy env's generator stream, drawn on
the host in the NumPy loop's order and sizes and copied to the device (one copy a step): with
the same seed an episode equals the NumPy vector env's to round-off
(``tests/rbenv/test_torch_estimated.py``). That costs a host draw and a host-to-device copy
per step, and an autoreset reads the ended rows on the host (their count sets how many
numbers the stream gives them): correctness first, a device-side stream is not done.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from rbenv.envs.estimated import EstimatorLoop
from rbenv.satellite import sensors as sn
from rbenv.satellite import torch_estimation as te
from rbenv.satellite.disturbances import sun_direction_N
from rbenv.tasks.base import _DEG

__all__ = ["TorchEstimatorLoop"]

_RAD_DEG = math.pi / 180.0


def _matrix(comps) -> torch.Tensor:
    """Components ((N,) tensors) as an (N, k) tensor."""
    return torch.stack(tuple(comps), -1)


class TorchEstimatorLoop(EstimatorLoop):
    """Sensors and the MEKF for the torch env's satellites (see the module docstring). ``xp``:
    the env's torch namespace (device and dtype); ``stack``: the env's components -> (N, k)
    tensor; ``single_key``: seed the stream as the single NumPy env does (``gym.make(...,
    backend="torch")``, one satellite) instead of as the vector env."""

    def __init__(self, plant, task, xp, stack, single_key: bool = False):
        super().__init__(plant, task, single=False)
        self.xp, self.stack, self.single_key = xp, stack, single_key
        self.device, self.dtype = xp.device, xp.dtype
        if self.star is not None:
            self.star_R_t = self._t(self.star_R)
            self.star_chol_T = self._t(np.linalg.cholesky(self.star_R).T)
        if self.mag is not None:
            self.mag_R_t = self._t(self.mag_R)

    def _t(self, value, dtype=None) -> torch.Tensor:
        return torch.as_tensor(value, dtype=dtype or self.dtype, device=self.device)

    def _device(self, *arrays: np.ndarray) -> list[torch.Tensor]:
        """Host float64 draws as tensors of the env's dtype on its device, in one copy."""
        flat = np.concatenate([a.ravel() for a in arrays])
        out = torch.from_numpy(flat).to(device=self.device, dtype=self.dtype)
        parts, start = [], 0
        for a in arrays:
            parts.append(out[start:start + a.size].reshape(a.shape))
            start += a.size
        return parts

    def seed_key(self, seed: int, episode: int, n: int) -> tuple:
        """The generator's seed of a full reset: the NumPy vector env's, or the single env's
        (``single_key``)."""
        return (seed, episode, 41) if self.single_key else (seed, episode, n, 41)

    # ------------------------------------------------------------------- environment

    def _time(self, st) -> torch.Tensor:
        """The step's time (N,), s, in float64 (the Sun's and the orbit's arguments)."""
        return st.steps.to(torch.float64) * self.dt

    def _sun_t(self, t: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`EstimatorLoop._sun` on tensors: (ŝ_N (N, 3), lit (N,) 1.0 or 0.0)."""
        s = sun_direction_N(self.epoch_days + t / 86400.0, self.xp)
        radius = self.orbit.radius
        r = tuple(radius * c for c in self.orbit.direction_N(t, self.xp))
        along = r[0] * s[0] + r[1] * s[1] + r[2] * s[2]
        perp = tuple(r[i] - along * s[i] for i in range(3))
        shadow = (along < 0.0) & (perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]
                                  < self.orbit.EARTH_RADIUS ** 2)
        return _matrix(s).to(self.dtype), (~shadow).to(self.dtype)

    # ------------------------------------------------------------------- episodes

    def reset(self, st, seed, rows=None) -> None:
        """Start the filter for new episodes: all satellites (rows None; ``seed`` seeds the
        generator) or the rows of ``rows`` (an index tensor; their truth read from ``st``).
        The draws are the NumPy loop's: bias, attitude error, magnetometer bias."""
        self.field_B = None
        if rows is None:
            self.rng = np.random.default_rng(seed)
        q, w = _matrix(st.q), _matrix(st.omega_B)
        if rows is not None:
            q, w = q[rows], w[rows]
        n = q.shape[0]
        rng, s0 = self.rng, self.params.initial_attitude_sigma_deg * _RAD_DEG
        zb, zq, zm = self._device(rng.standard_normal((n, 3)), rng.standard_normal((n, 3)),
                                  rng.standard_normal((n, 3)))
        bias = self.sigma_b * zb
        q_hat = te.qmul(q, te.qexp(-s0 * zq))
        P = torch.diag(self._t([s0 * s0] * 3 + [max(self.sigma_b, 1e-12) ** 2] * 3))
        P = P.expand(n, 6, 6).clone()
        mag_bias = (0.0 if self.mag is None else self.mag.bias_nT * 1e-9) * zm
        fix = torch.zeros(n, dtype=torch.bool, device=self.device)
        if rows is None:
            self.filter = te.TorchMEKF(q_hat, torch.zeros_like(bias), P, self.sigma_v,
                                       self.sigma_u, self.params.process_noise_scale,
                                       device=self.device, dtype=self.dtype)
            self.bias, self.mag_bias, self.fix = bias, mag_bias, fix
            self.q_prev, self.w_est = q, w + bias
            return
        f = self.filter
        f.q, f.P = f.q.index_copy(0, rows, q_hat), f.P.index_copy(0, rows, P)
        f.bias = f.bias.index_fill(0, rows, 0.0)
        self.bias = self.bias.index_copy(0, rows, bias)
        self.mag_bias = self.mag_bias.index_copy(0, rows, mag_bias)
        self.q_prev = self.q_prev.index_copy(0, rows, q)
        self.w_est = self.w_est.index_copy(0, rows, w + bias)
        self.fix = self.fix.index_fill(0, rows, False)

    def step(self, st) -> None:
        """After a step of the plant: measure the new truth in ``st`` and update the filter
        (the NumPy loop's draws in its order: gyro, star tracker, magnetometer, sun sensors)."""
        f, rng, dt = self.filter, self.rng, self.dt
        self.field_B = None
        q = _matrix(st.q)
        n = q.shape[0]
        host = [rng.standard_normal((3, n, 3))]
        if self.star is not None:
            host += [rng.standard_normal((n, 3)),
                     (rng.random(n) < self.star.dropout_probability).astype(float)]
        if self.mag is not None:
            host.append(rng.standard_normal((n, 3)))
        if self.css is not None:
            host.append(rng.standard_normal((n, len(self.css.normals_B))))
        draws = self._device(*host)
        dtheta = te.qlog(te.qmul(te.qconj(self.q_prev), q))
        measured, self.bias = sn.gyro_increment_of(dtheta, self.bias, draws.pop(0),
                                                   self.sigma_v, self.sigma_u, dt)
        f.propagate(measured, dt)
        self.q_prev = q
        t = self._time(st)
        sun = lit = None
        if self.orbit is not None and (self.css is not None or self.star is not None):
            sun, lit = self._sun_t(t)
        if self.star is not None:
            normals, drop = draws.pop(0), draws.pop(0) > 0.5
            nadir = None if self.orbit is None else \
                -_matrix(self.orbit.direction_N(t, self.xp)).to(self.dtype)
            q_m, valid = te.star_tracker(
                self.star, self.star_chol_T, q, _matrix(st.omega_B), sun, nadir,
                0.0 if self.orbit is None else self.earth_radius_rad, normals, drop)
            valid = valid & (st.steps % self.star_period == 0)
            f.update_attitude(q_m, self.star_R_t, valid)
            self.fix = valid
        if self.mag is not None:
            field_N = _matrix(self.orbit.field_N(t, self.xp)).to(self.dtype)
            y = te.magnetometer(self.mag, q, field_N, self.mag_bias, draws.pop(0))
            f.update_vector(y, field_N, self.mag_R_t,
                            torch.ones(n, dtype=torch.bool, device=self.device))
            self.field_B = y
        if self.css is not None:
            s_B, cov, valid = te.sun_vector_fit(self.css, te.sun_sensors(
                self.css, q, sun, lit, draws.pop(0)))
            f.update_vector(s_B, sun, cov, valid, unit=True)
        self.w_est = measured / dt - f.bias

    # ------------------------------------------------------------------- outputs

    def observe(self, st, xp=None) -> torch.Tensor:
        """The observation (N, k + 6) in the env's dtype: the task's components on the
        estimate, the actuators' own, then estimate_sigma (:mod:`rbenv.envs.estimated`)."""
        f = self.filter
        obs = self.task.observe(st, tuple(f.q.unbind(-1)), tuple(self.w_est.unbind(-1)),
                                self.xp)
        for act, _ in self.plant.observers:
            obs = obs + act.observe(self._field_view(st) if act.scene_table == "magnetorquers"
                                    else st, self.xp, None)
        sigma = torch.sqrt(torch.diagonal(f.P, dim1=-2, dim2=-1))  # (N, 6)
        feats = torch.cat((torch.log10(sigma[:, :3]) + 3.0,
                           torch.log10(torch.clamp(sigma[:, 3:], min=1e-30)) + 5.0), -1)
        feats = torch.clamp(feats / 3.0, -1.0, 1.0)
        return torch.cat((self.stack(obs), feats.to(self.dtype)), -1)

    def _field_view(self, st):
        """What the rods' magnetometer observation reads: this step's [magnetometer]
        measurement, else the field model seen through the estimate (as the NumPy loop)."""
        field = self.field_B
        if field is None:
            field_N = _matrix(self.orbit.field_N(self._time(st), self.xp)).to(self.dtype)
            field = te.rotate_inverse(self.filter.q, field_N)
        view = type("FieldView", (), {})()
        view.field_B_T = tuple(field.unbind(-1))
        return view

    def add_info(self, st, info: dict) -> dict:
        """``info`` with the estimate's entries, (N, ...) tensors (the module docstring)."""
        f = self.filter
        info["q_true"] = _matrix(st.q).to(self.dtype)
        info["q_est"] = f.q
        info["gyro_bias"] = self.bias
        info["gyro_bias_est"] = f.bias
        info["estimate_cov"] = f.P
        if self.star is not None:
            info["star_tracker_fix"] = self.fix
        target = getattr(st, "q_target_conj", None)
        if target is not None:
            e = te.qmul(_matrix(target).to(self.dtype), f.q)  # q_target⁻¹ ⊗ q_est
            s = torch.linalg.vector_norm(e[:, 1:], dim=-1)
            info["estimated_attitude_error_deg"] = 2.0 * torch.atan2(s, e[:, 0].abs()) * _DEG
        return info
