"""Policies on the estimate: the MEKF in the loop of an env whose scene has ``[estimator]``.

:class:`EstimatorLoop` runs beside the plant for N satellites (the single env: N = 1): after
each step it reads the true attitude and rate, draws the sensors' measurements
(rbenv.satellite.sensors: the gyro's increment over the step, then a star-tracker fix, the
magnetometer, the coarse sun sensors where the scene has them), propagates and updates the
filter (rbenv.satellite.estimation.MEKF), and builds the observation from the estimate: the
task's own components with the estimated attitude and the gyro rate less the estimated bias,
then the actuators' own (the rods' magnetometer reads the ``[magnetometer]``'s measurement,
else the field model through the estimate, never the true body field), then
``estimate_sigma`` (6): the filter's 1σ of the attitude error per body axis and of the bias,
each as ``clip((log10 σ − c) / 3, −1, 1)`` with c = −3 (rad) and −5 (rad/s). Reward,
success and termination stay the task's, on the true state. Its draws come from its own
generator (seeded from the episode's seed), so the plant's draws are those of the same scene
without it. The single env runs it all on Python floats (ScalarMEKF and the sensors' float
twins, the same draws in the same order), the vector env on component-major arrays, the torch
env on tensors (:mod:`rbenv.envs.torch_estimated`, the vector env's draws).

``info`` gains, every step: ``q_true``, ``q_est`` (scalar-first, body to inertial),
``gyro_bias``, ``gyro_bias_est`` (rad/s, body axes), ``estimate_cov`` (6 × 6: the attitude error
``δq = q_est⁻¹ ⊗ q_true`` as a rotation vector, body axes, rad; then the bias, rad/s),
``estimated_attitude_error_deg`` (the error to the target the estimate shows, where the task has
a target) and ``star_tracker_fix`` (whether a fix was taken this step, where the scene has one).
Single env: shapes (4,), (3,), (6, 6); vector env: a leading (N,).
"""

from __future__ import annotations

import math

import numpy as np

from rbenv.satellite import sensors as sn
from rbenv.satellite.disturbances import parse_epoch, sun_direction_N
from rbenv.satellite.estimation import MEKF, ScalarMEKF, _blocks, _qconj_cm, _qmul_cm
from rbenv.tasks.base import _DEG

__all__ = ["SIGMA_FEATURES", "EstimatorLoop"]

SIGMA_FEATURES = 6
_RAD_DEG = math.pi / 180.0
_DEFAULT_EPOCH = "2025-03-20T12:00:00"  # [orbit.srp]'s default epoch, for the Sun's direction


def _rows(components) -> np.ndarray:
    """(N, k) float array of a state's components (floats or (N,) arrays)."""
    return np.stack([np.atleast_1d(np.asarray(c, dtype=float)) for c in components], -1)


def _feature(variance: float, floor: float, c: float) -> float:
    """One estimate_sigma feature from a variance: clip((log10 max(σ, floor) + c) / 3, −1, 1)."""
    sigma = math.sqrt(variance) if variance > 0.0 else 0.0
    x = (math.log10(sigma if sigma > floor else floor) + c) / 3.0
    return -1.0 if x < -1.0 else 1.0 if x > 1.0 else x


class EstimatorLoop:
    """Sensors and the MEKF for the plant's satellites (see the module docstring)."""

    def __init__(self, plant, task, single: bool):
        scene = plant.scene
        gyro = scene.sensors
        self.plant, self.task, self.single = plant, task, single
        self.dt = dt = plant.control_dt
        self.sigma_v = gyro.gyro_noise_dps * _RAD_DEG * math.sqrt(dt)  # rad/√s
        self.sigma_u = gyro.gyro_bias_walk_dps_sqrt_s * _RAD_DEG  # rad/s/√s
        self.sigma_b = gyro.gyro_bias_sigma_dps * _RAD_DEG  # rad/s
        self.params = scene.estimator
        self.star, self.mag, self.css = scene.star_tracker, scene.magnetometer, scene.sun_sensors
        self.orbit = scene.orbit if scene.orbit.enabled else None
        self.star_R = None if self.star is None else self.star.noise_cov_B()
        self.star_period = 1 if self.star is None else self.star.period_steps(dt)
        if self.orbit is not None:
            srp = self.orbit.srp
            self.epoch_days = srp.epoch_days if srp is not None else \
                parse_epoch("epoch", _DEFAULT_EPOCH)
            self.earth_radius_rad = math.asin(self.orbit.EARTH_RADIUS / self.orbit.radius)
        if self.mag is not None:  # white noise plus the unestimated bias, counted as noise
            self.mag_R = ((self.mag.noise_nT ** 2 + self.mag.bias_nT ** 2) * 1e-18) * np.eye(3)
        if single:  # the filter of one satellite runs on Python floats (ScalarMEKF)
            self.star_R1 = None if self.star is None else _blocks(self.star_R)
            self.star_chol_T = None if self.star is None else \
                _blocks(np.linalg.cholesky(self.star_R).T)
            self.mag_R1 = None if self.mag is None else _blocks(self.mag_R)
        self.rng = np.random.default_rng(0)
        self.filter = None
        self.field_B = None  # the magnetometer's measurement this step (N, 3), T, or None

    # ------------------------------------------------------------------- environment

    def _sun(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ŝ_N (N, 3), lit (N,)): the Sun's direction and 1.0 outside the cylindrical
        shadow (as rbenv.satellite.disturbances.sun_and_shadow)."""
        s = _rows(sun_direction_N(self.epoch_days + t / 86400.0, np))
        r = self.orbit.radius * _rows(self.orbit.direction_N(t, np))
        along = np.sum(r * s, -1)
        perp = r - along[:, None] * s
        shadow = (along < 0.0) & (np.sum(perp * perp, -1) < self.orbit.EARTH_RADIUS ** 2)
        return np.broadcast_to(s, r.shape), 1.0 - shadow

    def _sun1(self, t: float) -> tuple[tuple, float]:
        """:meth:`_sun` for one satellite: (ŝ_N, 3 floats; lit, 1.0 or 0.0)."""
        s = sun_direction_N(self.epoch_days + t / 86400.0, math)
        radius = self.orbit.radius
        r = tuple(radius * c for c in self.orbit.direction_N(t, math))
        along = r[0] * s[0] + r[1] * s[1] + r[2] * s[2]
        perp = (r[0] - along * s[0], r[1] - along * s[1], r[2] - along * s[2])
        shadow = along < 0.0 and \
            perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2] < self.orbit.EARTH_RADIUS ** 2
        return s, 1.0 - shadow

    # ------------------------------------------------------------------- episodes

    def reset(self, st, seed, rows=None) -> None:
        """Start the filter for new episodes: all satellites (rows None; ``seed`` seeds the
        generator) or the rows being reset (their truth read from ``st``)."""
        self.field_B = None  # a reset row has no measurement yet: the estimate's field
        if self.single:
            self._reset1(st, seed)
            return
        if rows is None:
            self.rng = np.random.default_rng(seed)
        q = _rows(st.q) if rows is None else _rows(st.q)[rows]
        n = q.shape[0]
        rng, s0 = self.rng, self.params.initial_attitude_sigma_deg * _RAD_DEG
        bias = self.sigma_b * rng.standard_normal((n, 3))
        q_hat = sn.qmul(q, sn.qexp(-s0 * rng.standard_normal((n, 3))))
        P = np.zeros((n, 6, 6))
        P[:, :3, :3] = s0 * s0 * np.eye(3)
        P[:, 3:, 3:] = max(self.sigma_b, 1e-12) ** 2 * np.eye(3)
        mag_bias = (0.0 if self.mag is None else self.mag.bias_nT * 1e-9) * \
            rng.standard_normal((n, 3))
        w = _rows(st.omega_B) if rows is None else _rows(st.omega_B)[rows]
        fix = np.zeros(n, dtype=bool)
        if rows is None:  # q_prev and w_est: (N, ·) views of component-major stores
            self.filter = MEKF(q_hat, np.zeros((n, 3)), P, self.sigma_v, self.sigma_u,
                               self.params.process_noise_scale)
            self.bias, self.mag_bias, self.fix = bias, mag_bias, fix
            self.q_prev, self.w_est = np.array(q.T).T, np.array((w + bias).T).T
            return
        f = self.filter
        f.q[rows], f.bias[rows], f.P[rows] = q_hat, 0.0, P
        self.bias[rows], self.mag_bias[rows], self.q_prev[rows] = bias, mag_bias, q
        self.w_est[rows], self.fix[rows] = w + bias, fix

    def _reset1(self, st, seed) -> None:
        """:meth:`reset` of the single env: the same draws, on Python floats."""
        rng = self.rng = np.random.default_rng(seed)
        s0, sb = self.params.initial_attitude_sigma_deg * _RAD_DEG, self.sigma_b
        q = tuple(st.q)
        bias = tuple(sb * x for x in rng.standard_normal(3).tolist())
        q_hat = sn.qmul1(q, sn.qexp1(tuple(-s0 * x for x in rng.standard_normal(3).tolist())))
        P = np.zeros((6, 6))
        P[:3, :3] = s0 * s0 * np.eye(3)
        P[3:, 3:] = max(sb, 1e-12) ** 2 * np.eye(3)
        mag = 0.0 if self.mag is None else self.mag.bias_nT * 1e-9
        self.mag_bias = tuple(mag * x for x in rng.standard_normal(3).tolist())
        self.filter = ScalarMEKF(q_hat, (0.0, 0.0, 0.0), P, self.sigma_v, self.sigma_u,
                                 self.params.process_noise_scale)
        w = st.omega_B
        self.bias, self.q_prev, self.fix = bias, q, False
        self.w_est = (w[0] + bias[0], w[1] + bias[1], w[2] + bias[2])

    def _step1(self, st) -> None:
        """:meth:`step` of the single env: the same draws and filter, on Python floats."""
        f, rng, dt = self.filter, self.rng, self.dt
        self.field_B = None
        q = tuple(st.q)
        dtheta = sn.qlog1(sn.qmul1(sn.qconj1(self.q_prev), q))
        measured, self.bias = sn.gyro_increment1(dtheta, self.bias, self.sigma_v,
                                                 self.sigma_u, dt, rng)
        f.propagate(measured, dt)
        self.q_prev = q
        t = float(st.steps) * dt
        sun = lit = None
        if self.orbit is not None and (self.css is not None or self.star is not None):
            sun, lit = self._sun1(t)
        if self.star is not None:
            if st.steps % self.star_period == 0:
                nadir = None if self.orbit is None else \
                    tuple(-c for c in self.orbit.direction_N(t, math))
                q_m, valid = sn.star_tracker1(
                    self.star, self.star_chol_T, q, tuple(st.omega_B), sun, nadir,
                    0.0 if self.orbit is None else self.earth_radius_rad, rng)
                f.update_attitude(q_m, self.star_R1, valid)
            else:  # between fixes: the draws alone, to keep the stream
                sn.star_tracker_draws(1, rng)
                valid = False
            self.fix = valid
        if self.mag is not None:
            field_N = tuple(float(c) for c in self.orbit.field_N(t, math))
            y = sn.magnetometer1(self.mag, q, field_N, self.mag_bias, rng)
            f.update_vector(y, field_N, self.mag_R1, True)
            self.field_B = y
        if self.css is not None:  # the least-squares fit on (1, ·) arrays
            s_B, cov, valid = sn.sun_vector_fit(self.css, sn.sun_sensors(
                self.css, np.array([q]), np.array([sun]), np.array([lit]), rng))
            f.update_vector(tuple(s_B[0].tolist()), sun, _blocks(cov[0]), bool(valid[0]),
                            unit=True)
        b = f.bias
        self.w_est = (measured[0] / dt - b[0], measured[1] / dt - b[1], measured[2] / dt - b[2])

    def step(self, st) -> None:
        """After a step of the plant: measure the new truth in ``st`` and update the filter."""
        if self.single:
            self._step1(st)
            return
        f, rng, dt = self.filter, self.rng, self.dt
        self.field_B = None
        q_T = np.stack([np.asarray(c, dtype=float) for c in st.q])  # (4, N)
        q = q_T.T
        n = q.shape[0]
        dtheta = sn.qlog_cm(_qmul_cm(_qconj_cm(self.q_prev.T), q_T)).T
        measured, self.bias = sn.gyro_increment(dtheta, self.bias, self.sigma_v, self.sigma_u,
                                                dt, rng)
        f.propagate(measured, dt)
        self.q_prev = q
        w = _rows(st.omega_B)
        t = np.broadcast_to(np.asarray(st.steps, dtype=float) * dt, (n,))
        sun = lit = None
        if self.orbit is not None and (self.css is not None or self.star is not None):
            sun, lit = self._sun(t)
        if self.star is not None:
            due = np.asarray(st.steps) % self.star_period == 0
            if due.any():
                nadir = None if self.orbit is None else -_rows(self.orbit.direction_N(t, np))
                q_m, valid = sn.star_tracker(
                    self.star, q, w, sun, nadir,
                    0.0 if self.orbit is None else self.earth_radius_rad, rng)
                valid &= due
                f.update_attitude(q_m, self.star_R, valid)
            else:  # between fixes: the draws alone, to keep the stream
                sn.star_tracker_draws(n, rng)
                valid = np.zeros(n, dtype=bool)
            self.fix = valid
        if self.mag is not None:
            field_N = _rows(self.orbit.field_N(t, np))
            y = sn.magnetometer(self.mag, q, field_N, self.mag_bias, rng)
            f.update_vector(y, field_N, self.mag_R, np.ones(n, dtype=bool))
            self.field_B = y
        if self.css is not None:
            s_B, cov, valid = sn.sun_vector_fit(self.css, sn.sun_sensors(self.css, q, sun, lit,
                                                                         rng))
            f.update_vector(s_B, sun, cov, valid, unit=True)
        self.w_est = (measured.T / dt - f.bias.T).T

    # ------------------------------------------------------------------- outputs

    def observe(self, st, xp) -> np.ndarray:
        """The observation: the task's components on the estimate, then estimate_sigma."""
        f = self.filter
        if self.single:
            obs = self.task.observe(st, f.q, self.w_est, xp)
            for act, _ in self.plant.observers:
                obs = obs + act.observe(self._field_view(st) if act.scene_table ==
                                        "magnetorquers" else st, xp, None)
            (a, _, _), (_, b, _), (_, _, c) = f.p11
            (d, _, _), (_, e, _), (_, _, g) = f.p22
            feats = (_feature(a, 1e-300, 3.0), _feature(b, 1e-300, 3.0),
                     _feature(c, 1e-300, 3.0), _feature(d, 1e-30, 5.0),
                     _feature(e, 1e-30, 5.0), _feature(g, 1e-30, 5.0))
            return np.array((*obs, *feats), dtype=np.float32)
        q_hat, w_est = f.q, self.w_est  # (N, ·) views of (·, N) stores: contiguous rows
        q = tuple(q_hat.T)
        w = tuple(w_est.T)
        obs = self.task.observe(st, q, w, xp)
        for act, _ in self.plant.observers:
            obs = obs + act.observe(self._field_view(st) if act.scene_table == "magnetorquers"
                                    else st, xp, None)
        n, k = q_hat.shape[0], len(obs)
        out = np.empty((n, k + SIGMA_FEATURES), dtype=np.float32)
        for j, c in enumerate(obs):
            out[:, j] = c
        diag = f.covariance_diagonal()  # (6, N)
        sigma = np.sqrt(diag)
        feats = np.empty_like(sigma)
        np.log10(sigma[:3], out=feats[:3])
        np.log10(np.maximum(sigma[3:], 1e-30), out=feats[3:])
        feats[:3] += 3.0
        feats[3:] += 5.0
        feats /= 3.0
        np.clip(feats, -1.0, 1.0, out=feats)
        out[:, k:] = feats.T
        return out

    def _field_view(self, st):
        """What the rods' magnetometer observation reads instead of the true body field: the
        [magnetometer]'s measurement this step, else the field model seen through the
        estimate, A(q̂)ᵀ B_N (the true one would leak the true attitude)."""
        field = self.field_B
        if self.single:
            if field is None:
                t = float(st.steps) * self.dt
                field = sn.rotate_inverse1(self.filter.q, self.orbit.field_N(t, math))
            view = type("FieldView", (), {})()
            view.field_B_T = tuple(float(c) for c in field)
            return view
        if field is None:
            n = self.filter.q.shape[0]
            t = np.broadcast_to(np.asarray(st.steps, dtype=float) * self.dt, (n,))
            field = sn.rotate_inverse(self.filter.q, _rows(self.orbit.field_N(t, np)))
        view = type("FieldView", (), {})()
        view.field_B_T = tuple(field[:, i] for i in range(3))
        return view

    def add_info(self, st, info: dict) -> dict:
        """``info`` with the estimate's entries (the module docstring)."""
        f = self.filter
        if self.single:
            info["q_true"] = np.array(st.q, dtype=float)
            info["q_est"] = np.array(f.q)
            info["gyro_bias"] = np.array(self.bias)
            info["gyro_bias_est"] = np.array(f.bias)
            info["estimate_cov"] = f.P
            if self.star is not None:
                info["star_tracker_fix"] = np.bool_(self.fix)
            target = getattr(st, "q_target_conj", None)
            if target is not None:
                e = sn.qmul1(tuple(target), f.q)
                angle = 2.0 * math.atan2(math.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]),
                                         abs(e[0])) * _DEG
                info["estimated_attitude_error_deg"] = angle
            return info
        info["q_true"] = _rows(st.q)
        info["q_est"] = f.q.copy()
        info["gyro_bias"] = self.bias.copy()
        info["gyro_bias_est"] = f.bias.copy()
        info["estimate_cov"] = f.covariance_copy()
        if self.star is not None:
            info["star_tracker_fix"] = self.fix.copy()
        target = getattr(st, "q_target_conj", None)
        if target is not None:
            e = _qmul_cm(target, f.q.T)  # q_target⁻¹ ⊗ q_est, (4, N)
            s = np.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3])
            info["estimated_attitude_error_deg"] = 2.0 * np.arctan2(s, np.abs(e[0])) * _DEG
        return info
