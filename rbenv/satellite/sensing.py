"""Sensing as flown: an attitude integrated from a biased, noisy gyro, and an observation delay.

The scene's ``[sensors]`` table (:class:`rbenv.satellite.scene.Sensors`) turns it on. The satellite
knows its attitude at the episode's start exactly (a star-tracker fix) and then propagates it with
the gyro's rate ``ω_m = ω + b + σ_n n``; the estimate's error ``δ = q* ⊗ q_est`` (body axes) grows
with the integrated gyro error over each control step::

    δ ← δ ⊗ exp((b + σ_n n)·dt),     b ← b + σ_w √dt n',

with b the bias (drawn per episode, 1σ ``gyro_bias_sigma_dps`` per axis; then a random walk of
σ_w per √s), n and n' standard normals drawn per step. With ``delay_steps = 1`` the policy sees
the measurement of the step before. State fields (the plant's): ``gyro_bias`` (rad/s, 3),
``gyro_drift`` (δ, 4), ``sensed_q``/``sensed_omega_B`` (what the policy sees now) and
``latest_q``/``latest_omega_B`` (the newest measurement, shown a step later when delayed).
"""

from __future__ import annotations

import math

from rbenv.core import kernels as k

__all__ = ["FIELDS", "STEP_NORMALS", "sense", "start"]

_DEG = math.pi / 180.0
FIELDS = {"gyro_bias": "c3", "gyro_drift": "c4", "sensed_q": "c4", "sensed_omega_B": "c3",
          "latest_q": "c4", "latest_omega_B": "c3"}
STEP_NORMALS = 6  # per step: 3 for the rate noise, 3 for the bias walk


def start(sensors, q: tuple, omega_B: tuple, draws) -> dict:
    """Start values of :data:`FIELDS`: the bias drawn from stream "gyro" (three normals), no
    drift, and the first measurement (bias, no noise) both seen and latest."""
    zero = draws.xp.zeros(draws.n)
    if sensors.attitude == "gyro" and sensors.gyro_bias_sigma_dps:
        bias = k.scale(draws.normal("gyro", 3), sensors.gyro_bias_sigma_dps * _DEG)
    else:
        bias = (zero, zero, zero)
    w = k.add(omega_B, bias)
    return {"gyro_bias": bias, "gyro_drift": (zero + 1.0, zero, zero, zero), "sensed_q": q,
            "sensed_omega_B": w, "latest_q": q, "latest_omega_B": w}


def sense(sensors, st, normals, dt: float) -> None:
    """After a control step of ``dt`` s: propagate the drift and the bias with this step's
    ``normals`` (6 components, or None without gyro noise), measure, and set what is seen."""
    if sensors.attitude == "gyro":
        b = st.gyro_bias
        err = b if normals is None else k.add(b, normals[:3], sensors.gyro_noise_dps * _DEG)
        st.gyro_drift = k.qnormalize(k.qmul(st.gyro_drift, k.exp(k.scale(err, dt))))
        q, w = k.qmul(st.q, st.gyro_drift), k.add(st.omega_B, err)
        if normals is not None and sensors.gyro_bias_walk_dps_sqrt_s:
            st.gyro_bias = k.add(b, normals[3:],
                                 sensors.gyro_bias_walk_dps_sqrt_s * _DEG * math.sqrt(dt))
    else:
        q, w = st.q, st.omega_B
    if sensors.delay_steps:
        st.sensed_q, st.sensed_omega_B = st.latest_q, st.latest_omega_B
    else:
        st.sensed_q, st.sensed_omega_B = q, w
    st.latest_q, st.latest_omega_B = q, w
