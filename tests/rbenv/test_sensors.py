"""The estimator's sensor models against closed forms: the gyro's Allan variance (angle random
walk, slope −½; rate random walk, slope +½) and its bias; the star tracker's noise about and
across the boresight, its Sun and Earth exclusions, rate limit and dropouts; the magnetometer's
bias and noise; the coarse sun sensors' cosine response, field of view, eclipse, and the
least-squares fit's covariance. Scene tables: defaults load, bad values are named."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rbenv.core.errors import InvalidParameterError

from rbenv.satellite import sensors as sn
from rbenv.satellite.scene import Scene

DEG = math.pi / 180.0


def _allan(rates: np.ndarray, m: int) -> float:
    """Non-overlapping Allan variance at τ = m samples of (series, samples, axes) rates."""
    k = rates.shape[1] // m
    means = rates[:, :k * m].reshape(rates.shape[0], k, m, -1).mean(axis=2)
    return 0.5 * float(np.mean(np.diff(means, axis=1) ** 2))


def test_gyro_allan_variance_is_arw_over_tau_plus_rrw_tau_over_three():
    rng = np.random.default_rng(7)
    sigma_v, sigma_u, dt, series, length = 1e-3, 1e-4, 1.0, 300, 2048
    bias = np.zeros((series, 3))
    rates = np.empty((series, length, 3))
    for i in range(length):
        m, bias = sn.gyro_increment(np.zeros((series, 3)), bias, sigma_v, sigma_u, dt, rng)
        rates[:, i] = m / dt
    taus = [1, 4, 16, 64, 256, 1024]
    measured = np.array([_allan(rates, t) for t in taus])
    closed = np.array([sigma_v ** 2 / t + sigma_u ** 2 * t / 3.0 for t in taus])
    np.testing.assert_allclose(measured, closed, rtol=0.12)
    # the Allan deviation's slopes: −½ where the angle random walk rules, +½ at long τ
    slope = np.diff(np.log(np.sqrt(measured))) / np.diff(np.log(taus))
    closed_slope = np.diff(np.log(np.sqrt(closed))) / np.diff(np.log(taus))
    np.testing.assert_allclose(slope, closed_slope, atol=0.06)
    assert slope[0] == pytest.approx(-0.5, abs=0.05)
    assert slope[-1] == pytest.approx(0.5, abs=0.08)


def test_gyro_bias_is_the_mean_of_its_output():
    rng = np.random.default_rng(3)
    sigma_v, dt, length = 1e-3, 0.5, 4000
    bias = np.array([[1e-3, -2e-3, 5e-4]])
    total = np.zeros((1, 3))
    w = np.array([[0.01, 0.02, -0.03]])
    for _ in range(length):
        m, bias = sn.gyro_increment(w * dt, bias, sigma_v, 0.0, dt, rng)
        total += m
    mean_error = total / (length * dt) - w
    # the angle random walk's mean over T s has σ = σ_v / √T
    assert np.all(np.abs(mean_error - bias) < 4.0 * sigma_v / math.sqrt(length * dt))


def _star(**kw) -> sn.StarTracker:
    return sn.StarTracker(**kw)


def test_star_tracker_noise_is_its_covariance_about_and_across_the_boresight():
    rng = np.random.default_rng(11)
    st = _star(boresight_B=(1.0, 1.0, 0.0))
    n = 40000
    q = np.broadcast_to(sn.qexp(np.array([0.3, -1.0, 2.0])), (n, 4))
    q_m, valid = sn.star_tracker(st, q, np.zeros((n, 3)), None, None, 0.0, rng)
    assert valid.all()
    v = sn.qlog(sn.qmul(sn.qconj(q), q_m))
    cov = v.T @ v / n
    R = st.noise_cov_B()
    assert np.abs(cov - R).max() < 0.03 * R.max()
    b = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    about = math.sqrt(np.mean((v @ b) ** 2)) / sn.ARCSEC
    cross = math.sqrt(np.mean(v[:, 2] ** 2)) / sn.ARCSEC
    assert about == pytest.approx(70.0, rel=0.02) and cross == pytest.approx(10.0, rel=0.02)


def test_star_tracker_outages_sun_earth_rate_and_dropouts():
    rng = np.random.default_rng(5)
    st = _star(sun_exclusion_deg=40.0, earth_exclusion_deg=25.0, max_rate_dps=2.0)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))  # boresight along inertial +z

    def at(deg, axis=0):
        a = deg * DEG
        v = np.zeros(3)
        v[2], v[axis] = math.cos(a), math.sin(a)
        return v

    sun = np.stack([at(39.0), at(41.0), at(120.0), at(120.0)])
    rho = 20.0  # the Earth's angular radius here, deg
    nadir = np.stack([at(170.0), at(170.0), at(rho + 24.0, 1), at(rho + 26.0, 1)])
    _, valid = sn.star_tracker(st, q, np.zeros((4, 3)), sun, nadir, rho * DEG, rng)
    assert valid.tolist() == [False, True, False, True]
    w = np.array([[0.0, 0.0, 1.9 * DEG], [0.0, 2.1 * DEG, 0.0]])
    _, valid = sn.star_tracker(st, q[:2], w, None, None, 0.0, rng)
    assert valid.tolist() == [True, False]
    n, p = 20000, 0.3
    _, valid = sn.star_tracker(_star(dropout_probability=p), np.tile(q[0], (n, 1)),
                               np.zeros((n, 3)), None, None, 0.0, rng)
    assert abs((1.0 - valid.mean()) - p) < 4.0 * math.sqrt(p * (1 - p) / n)


def test_magnetometer_bias_and_noise():
    rng = np.random.default_rng(2)
    mag = sn.Magnetometer(noise_nT=150.0, bias_nT=300.0)
    n = 20000
    q = sn.qexp(rng.standard_normal((n, 3)))
    field = np.tile([2e-5, -1e-5, 3e-5], (n, 1))
    bias = np.tile([3e-7, -1e-7, 0.0], (n, 1))
    err = sn.magnetometer(mag, q, field, bias, rng) - sn.rotate_inverse(q, field)
    assert np.abs(err.mean(0) - bias[0]).max() < 4.0 * 150e-9 / math.sqrt(n)
    np.testing.assert_allclose(err.std(0), 150e-9, rtol=0.03)


def test_sun_sensors_cosine_field_of_view_and_eclipse():
    rng = np.random.default_rng(4)
    css = sn.SunSensors(fov_deg=60.0, noise=1e-12)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    a = 50.0 * DEG  # the Sun 50° off +x toward +z: +x sees cos 50°, +z sees cos 40°
    sun = np.tile([math.cos(a), 0.0, math.sin(a)], (3, 1))
    out = sn.sun_sensors(css, q, sun, np.array([1.0, 1.0, 0.0]), rng)
    assert out[0, 0] == pytest.approx(math.cos(a), abs=1e-9)
    assert out[0, 4] == pytest.approx(math.sin(a), abs=1e-9)
    assert np.all(out[0, [1, 2, 3, 5]] == 0.0)
    b = 65.0 * DEG  # beyond the 60° field of view of +x: nothing; +z at 25°: cos 25°
    out = sn.sun_sensors(css, q[:1], np.array([[math.cos(b), 0.0, math.sin(b)]]),
                         np.ones(1), rng)
    assert out[0, 0] == 0.0 and out[0, 4] == pytest.approx(math.sin(b), abs=1e-9)
    assert np.all(sn.sun_sensors(css, q, sun, np.zeros(3), rng) == 0.0)  # eclipse


def test_sun_vector_fit_recovers_the_sun_with_its_covariance():
    rng = np.random.default_rng(9)
    css = sn.SunSensors(noise=0.01)
    n = 20000
    s = np.array([0.5, 0.6, 0.62])
    s /= np.linalg.norm(s)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    fit, cov, valid = sn.sun_vector_fit(css, sn.sun_sensors(css, q, np.tile(s, (n, 1)),
                                                            np.ones(n), rng))
    assert valid.all()
    err = fit - s
    assert np.abs(err.mean(0)).max() < 1e-3
    sample = err.T @ err / n
    assert np.abs(sample - cov[0]).max() < 0.05 * np.abs(cov[0]).max()


def test_sensor_tables_load_and_name_bad_values():
    base = {"body": {"shape": "box", "mass": 4.0, "size": [0.1, 0.1, 0.3]},
            "magnetorquers": {"axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "max_dipole": 0.2},
            "orbit": {"model": "circular", "magnetic_field": True},
            "sensors": {"attitude": "estimator", "gyro_noise_dps": 0.01},
            "estimator": {}}
    scene = Scene.from_dict({**base, "star_tracker": {}, "magnetometer": {},
                             "sun_sensors": {}})
    assert scene.star_tracker.sigma_about_arcsec == 70.0 and scene.magnetometer.noise_nT == 100.0
    assert len(scene.sun_sensors.normals_B) == 6
    with pytest.raises(InvalidParameterError, match=r"star_tracker\.sun_exclusion_deg"):
        Scene.from_dict({**base, "star_tracker": {"sun_exclusion_deg": 120.0}})
    with pytest.raises(InvalidParameterError, match=r"magnetometer\.noise_nT"):
        Scene.from_dict({**base, "magnetometer": {"noise_nT": -1.0}})
    with pytest.raises(InvalidParameterError, match="at least one attitude sensor"):
        Scene.from_dict(base)
    with pytest.raises(InvalidParameterError, match="magnetic_field = true"):
        Scene.from_dict({**base, "orbit": {"model": "circular"}, "magnetometer": {}})
    with pytest.raises(InvalidParameterError, match=r"go\s+together"):
        Scene.from_dict({**{k: v for k, v in base.items() if k != "estimator"},
                         "star_tracker": {}})
    with pytest.raises(InvalidParameterError, match=r"sensor_noise\.model = 'gaussian'"):
        Scene.from_dict({**base, "star_tracker": {},
                         "sensor_noise": {"model": "gaussian", "rate": 1e-4}})
    with pytest.raises(InvalidParameterError, match=r"sensors\.delay_steps = 1"):
        Scene.from_dict({**base, "star_tracker": {},
                         "sensors": {**base["sensors"], "delay_steps": 1}})
    with pytest.raises(InvalidParameterError, match=r"sensors\.gyro_noise_dps must be > 0"):
        Scene.from_dict({**base, "star_tracker": {},
                         "sensors": {"attitude": "estimator"}})
    with pytest.raises(InvalidParameterError, match="unknown field"):
        Scene.from_dict({**base, "star_tracker": {"sigma": 1.0}})
