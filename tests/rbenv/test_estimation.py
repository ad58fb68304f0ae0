"""The MEKF (rbenv.satellite.estimation) against independent references and its own claims:
Φ against the matrix exponential, Q against Van Loan's integral, the single-axis steady-state
covariance against SciPy's discrete Riccati solver, consistency over 300 Monte Carlo runs (the
run-averaged NEES of the attitude and of the bias inside the 95 % χ² band), the bias converging
to the true one within the filter's σ; and the env with ``[estimator]``: info's entries, the
checkers, the reward and termination of the truth, and the NEES computed from info alone."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import scipy.linalg
from rbenv.core.errors import InvalidParameterError
from scipy.stats import chi2

import rbenv
from rbenv.satellite import sensors as sn
from rbenv.satellite.estimation import MEKF, monte_carlo, process_noise, transition_matrix
from rbenv.satellite.scene import Scene, scene_table

DEG = math.pi / 180.0
V1 = "rbenv/SatelliteReorient-v1"


def _band(runs: int, dim: int = 3) -> tuple[float, float]:
    """The 95 % band of the run-averaged NEES: M·NEES ~ χ²(M·dim)."""
    lo, hi = chi2.ppf([0.025, 0.975], runs * dim) / runs
    return float(lo), float(hi)


def test_transition_matrix_is_the_matrix_exponential():
    w = np.array([[0.3, -0.2, 0.5], [1e-5, 0.0, 2e-5]])
    for dt in (0.1, 2.0):
        phi = transition_matrix(w, dt)
        for i in range(2):
            F = np.zeros((6, 6))
            F[:3, :3] = -sn.skew(w[i])
            F[:3, 3:] = -np.eye(3)
            np.testing.assert_allclose(phi[i], scipy.linalg.expm(F * dt), atol=1e-12)


def test_process_noise_is_van_loans_integral():
    sv, su, dt = 3e-4, 2e-6, 1.5
    F = np.zeros((6, 6))
    F[:3, 3:] = -np.eye(3)
    G = np.diag([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0])
    Qc = np.diag([sv ** 2] * 3 + [su ** 2] * 3)
    M = np.block([[-F, G @ Qc @ G.T], [np.zeros((6, 6)), F.T]]) * dt
    E = scipy.linalg.expm(M)
    Q = E[6:, 6:].T @ E[:6, 6:]
    np.testing.assert_allclose(process_noise(sv, su, dt), Q, rtol=1e-10, atol=1e-30)


@pytest.mark.slow
def test_single_axis_steady_state_is_the_riccati_solution():
    sv, su, dt, sn_ = 2e-4, 1e-6, 1.0, 20.0 * sn.ARCSEC
    P0 = np.diag([1e-4] * 3 + [1e-8] * 3)[None]
    f = MEKF(np.array([[1.0, 0.0, 0.0, 0.0]]), np.zeros((1, 3)), P0, sv, su)
    R = sn_ ** 2 * np.eye(3)
    for _ in range(5000):
        f.propagate(np.zeros((1, 3)), dt)
        prior = f.P[0].copy()
        f.update_attitude(f.q.copy(), R, np.ones(1, dtype=bool))
    phi = np.array([[1.0, -dt], [0.0, 1.0]])
    q1 = process_noise(sv, su, dt)[np.ix_([0, 3], [0, 3])]
    dare = scipy.linalg.solve_discrete_are(phi.T, np.array([[1.0], [0.0]]), q1,
                                           np.array([[sn_ ** 2]]))
    for axis in range(3):
        np.testing.assert_allclose(prior[np.ix_([axis, axis + 3], [axis, axis + 3])], dare,
                                   rtol=1e-6)


@pytest.mark.parametrize("sensors", [("star",), ("mag", "sun")])
def test_nees_of_attitude_and_bias_inside_the_95_percent_band(sensors):
    runs = 300
    nees_a, nees_b, _, _ = monte_carlo(runs, 300, sensors)
    lo, hi = _band(runs)
    inside_a = np.mean((nees_a > lo) & (nees_a < hi))
    inside_b = np.mean((nees_b > lo) & (nees_b < hi))
    # each step's average is inside its 95 % band but for chance excursions (≈ 5 % of steps)
    assert inside_a >= 0.9 and inside_b >= 0.9, (inside_a, inside_b, lo, hi)
    assert lo < nees_a.mean() < hi and lo < nees_b.mean() < hi


def test_bias_converges_to_the_true_one_within_the_filters_sigma():
    runs = 300
    _, _, f, b = monte_carlo(runs, 300, ("star",), seed=2)
    sigma = np.sqrt(np.diagonal(f.P, axis1=1, axis2=2)[:, 3:])
    z = np.abs(f.bias - b) / sigma
    assert 0.64 < np.mean(z < 1.0) < 0.72  # 68.3 % within 1σ (900 axes: ±4σ_binomial ≈ 6 %)
    assert np.mean(z < 3.0) > 0.99
    assert sigma.max() < 0.05 * DEG / 10.0  # the prior (0.05 °/s) shrank tenfold


# --------------------------------------------------------------------------- the env


def _estimator_scene(**sensors) -> Scene:
    data = scene_table("cubesat-12u")
    data["sensors"] = {"attitude": "estimator", "gyro_bias_sigma_dps": 0.05,
                       "gyro_bias_walk_dps_sqrt_s": 2e-4, "gyro_noise_dps": 0.01}
    data["estimator"] = {"initial_attitude_sigma_deg": 0.5}
    data.update(sensors or {"star_tracker": {}})
    return Scene.from_dict(data, name="cubesat-12u-est")


def test_info_carries_truth_estimate_and_covariance_and_checkers_pass():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(V1, scene=_estimator_scene())
    obs, info = env.reset(seed=3)
    for key, shape in (("q_true", (4,)), ("q_est", (4,)), ("gyro_bias", (3,)),
                       ("gyro_bias_est", (3,)), ("estimate_cov", (6, 6))):
        assert np.shape(info[key]) == shape, key
    assert obs.shape == env.observation_space.shape == (21,)
    obs, _, _, _, info = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)
    np.testing.assert_allclose(np.linalg.eigvalsh(info["estimate_cov"]) > 0, True)
    check_env(env.unwrapped, skip_render_check=True)
    sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3.check_env(gym.make(V1, scene=_estimator_scene()).unwrapped)


def test_reward_success_and_termination_are_the_true_states():
    """The scene with the estimator flies as the scene without it: same seed, same actions,
    same rewards, flags and true attitude (the estimator draws from its own stream)."""
    est = gym.make(V1, scene=_estimator_scene()).unwrapped
    plain = gym.make(V1, scene="cubesat-12u").unwrapped
    est.reset(seed=12)
    plain.reset(seed=12)
    rng = np.random.default_rng(0)
    for _ in range(40):
        a = rng.uniform(-1, 1, est.action_space.shape).astype(np.float32)
        o1, r1, t1, u1, i1 = est.step(a)
        o2, r2, t2, u2, i2 = plain.step(a)
        assert (r1, t1, u1, i1["is_success"]) == (r2, t2, u2, i2["is_success"])
        assert i1["attitude_error_deg"] == i2["attitude_error_deg"]
        np.testing.assert_array_equal(i1["q_true"], np.array(plain._st.q))
    assert not np.array_equal(o1[:18], o2)  # the observation is the estimate's


@pytest.mark.slow
def test_nees_from_info_alone_over_200_episodes():
    """What a judge computes: δθ = log(q_est⁻¹ ⊗ q_true), e = (δθ, b − b̂), eᵀ P⁻¹ e from
    info, averaged over 200 seeded episodes at step 30, inside the 95 % χ²(6) band."""
    env = gym.make(V1, scene=_estimator_scene()).unwrapped
    nees = []
    for seed in range(200):
        env.reset(seed=seed)
        for _ in range(30):
            _, _, _, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
        e = np.concatenate((sn.qlog(sn.qmul(sn.qconj(info["q_est"]), info["q_true"])),
                            info["gyro_bias"] - info["gyro_bias_est"]))
        nees.append(e @ np.linalg.solve(info["estimate_cov"], e))
    lo, hi = _band(200, 6)
    assert lo < np.mean(nees) < hi, (np.mean(nees), lo, hi)


@pytest.mark.parametrize("mode", ["NextStep", "SameStep", "Disabled"])
def test_vector_env_estimates_every_row_with_the_truths_reward(mode):
    """The vector env (N = 200) with the estimator: rewards and flags are those of the plain
    scene's vector env; info's (N, ...) entries give the NEES in the χ²(6) band; autoresets
    and partial resets restart the rows' filters."""
    n = 200
    kw = {"num_envs": n, "vectorization_mode": "vector_entry_point", "autoreset_mode": mode,
          "max_episode_steps": 25}
    est = gym.make_vec(V1, scene=_estimator_scene(), **kw)
    plain = gym.make_vec(V1, scene="cubesat-12u", **kw)
    obs, info = est.reset(seed=5)
    plain.reset(seed=5)
    assert obs.shape == (n, 21) and info["estimate_cov"].shape == (n, 6, 6)
    a = np.zeros((n, *est.single_action_space.shape), np.float32)
    for _ in range(24):
        obs, r1, t1, u1, info = est.step(a)
        _, r2, t2, u2, _ = plain.step(a)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1 | u1, t2 | u2)
        assert est.observation_space.contains(obs)
    e = np.concatenate((sn.qlog(sn.qmul(sn.qconj(info["q_est"]), info["q_true"])),
                        info["gyro_bias"] - info["gyro_bias_est"]), -1)
    nees = np.einsum("ni,ni->n", e, np.linalg.solve(info["estimate_cov"], e[..., None])[..., 0])
    lo, hi = _band(n, 6)
    assert lo < nees.mean() < hi
    if mode == "Disabled":
        est.step(a)
        mask = np.arange(n) < 50
        _, info = est.reset(options={"reset_mask": mask})
        prior = (0.5 * DEG) ** 2
        np.testing.assert_allclose(info["estimate_cov"][:50, 0, 0], prior)
        assert np.all(info["estimate_cov"][50:] == 0.0) and not info["_q_est"][50:].any()
    else:  # the rows ended at step 25 and restarted: their filters start again
        obs, _, _, _, info = est.step(a)
        obs, _, _, _, info = est.step(a)
        assert np.all(info["estimate_cov"][:, 0, 0] > 0.0)


def test_estimator_is_numpy_only_yet_and_scenes_check_it():
    pytest.importorskip("torch")
    with pytest.raises(InvalidParameterError, match=r"backend=.torch.*estimator"):
        gym.make(V1, scene=_estimator_scene(), backend="torch")


def test_scenes_without_the_estimator_are_unchanged():
    scene = rbenv.load_scene("innocube-3u")
    assert scene.estimator is None and scene.star_tracker is None
    env = gym.make(V1, scene="innocube-3u").unwrapped
    _, info = env.reset(seed=0)
    assert "q_est" not in info and env._estimation is None


def test_the_innocube_example_with_magnetometer_and_sun_sensors_estimates_within_its_sigma():
    """docs/innocube/innocube-3u-mekf.toml: the flown gyro and magnetometer and assumed coarse
    sun sensors; after 100 s of tumbling the true error stays within 3σ of the filter in
    every episode and its mean is below 0.5°."""
    path = Path(__file__).resolve().parents[2] / "docs" / "innocube" / "innocube-3u-mekf.toml"
    scene = rbenv.load_scene(path)
    assert scene.magnetometer is not None and scene.sun_sensors is not None
    assert scene.star_tracker is None and scene.sensors.gyro_noise_dps == 0.01  # as flown
    env = gym.make(V1, scene=str(path)).unwrapped
    keys = list(env.observation_structure)
    start = sum(env.observation_structure[k] for k in keys[:keys.index("field_B")])
    errors = []
    for seed in range(6):
        env.reset(seed=seed)
        for _ in range(100):
            obs, _, _, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
        # the rods' field observation is the magnetometer's reading, not the true field
        true_field = np.array(env._st.field_B_T) / 50e-6
        seen = obs[start:start + 3]
        assert not np.array_equal(seen, true_field.astype(np.float32))
        np.testing.assert_allclose(seen, true_field, atol=5 * 100e-9 / 50e-6)
        e = sn.qlog(sn.qmul(sn.qconj(info["q_est"]), info["q_true"]))
        assert e @ np.linalg.solve(info["estimate_cov"][:3, :3], e) < chi2.ppf(0.999, 3)
        errors.append(np.degrees(np.linalg.norm(e)))
    assert np.mean(errors) < 0.5


@pytest.mark.parametrize("env_id", sorted(rbenv.ENV_IDS))
def test_every_task_takes_the_estimator_and_passes_the_checker(env_id):
    from gymnasium.utils.env_checker import check_env

    data = scene_table("cubesat-6u-rw")
    data.update(sensors={"attitude": "estimator", "gyro_bias_sigma_dps": 0.05,
                         "gyro_noise_dps": 0.01}, estimator={}, star_tracker={})
    plain = gym.make(env_id, scene="cubesat-6u-rw")
    env = gym.make(env_id, scene=Scene.from_dict(data, name="cubesat-6u-rw-est"))
    assert env.observation_space.shape[0] == plain.observation_space.shape[0] + 6
    check_env(env.unwrapped, skip_render_check=True)
    _, info = env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert info["estimate_cov"].shape == (6, 6) and info["q_est"].shape == (4,)


def test_the_sun_sensors_shadow_is_the_srp_models():
    """With [orbit.srp] the env reports info["eclipse"]; the estimator's Sun and shadow (which
    darken the coarse sun sensors) agree with it around the orbit, lit and dark both seen."""
    path = Path(__file__).resolve().parents[2] / "docs" / "innocube" / "innocube-3u-mekf.toml"
    seen = set()
    for lat in (0.0, 90.0, 180.0, 270.0):
        data = scene_table(path)
        data["orbit"] = {**data["orbit"], "arg_latitude_deg": lat, "srp": {"area_m2": 0.03}}
        env = gym.make(V1, scene=Scene.from_dict(data, name="srp")).unwrapped
        env.reset(seed=0)
        for _ in range(3):
            _, _, _, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
            _, lit = env._estimation._sun(np.array([env._st.steps * env.plant.control_dt]))
            assert bool(lit[0] == 0.0) == bool(info["eclipse"])
            seen.add(bool(info["eclipse"]))
    assert seen == {True, False}
