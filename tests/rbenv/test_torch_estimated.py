"""The MEKF in the loop of the torch env (rbenv.envs.torch_estimated) against the NumPy envs.

Same seed, same actions: the torch env (CPU, float64) draws the sensors' noise from the NumPy
env's stream, so every step of every episode agrees with the NumPy vector env's to round-off,
across autoresets and partial resets: the observation (torch's float64 rounded to float32
equals NumPy's float32 within 1e-9), q_est and the bias estimate within 1e-9 (1e-12 rad/s),
estimate_cov within 1e-12 of each matrix's largest entry (5e-11 on InnoCube, see COV_RTOL),
the truth's keys, reward and flags within 1e-12. Scenes: docs/estimation/cubesat-12u-star.toml
(gyro and star tracker) and docs/innocube/innocube-3u-mekf.toml (gyro, magnetometer, coarse
sun sensors), several tasks. Every task the torch env runs takes the estimator; the single
torch env equals the single NumPy env and passes Gymnasium's and SB3's checkers; float32 runs;
on a GPU (where there is one) the CUDA env equals the CPU one."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite import sensors as sn

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")

DOCS = Path(__file__).resolve().parents[2] / "docs"
STAR = str(DOCS / "estimation" / "cubesat-12u-star.toml")
INNOCUBE = str(DOCS / "innocube" / "innocube-3u-mekf.toml")
N = 6
EPISODE = 9  # steps: autoresets within the run
STEPS = 30
# estimate_cov's tolerance, relative to each matrix's largest entry: with the magnetometer and
# sun sensors (InnoCube, a 5° prior) an update shrinks P₁₁ by a factor of hundreds, and
# P − K (P Hᵀ)ᵀ then carries the round-off of the larger prior: up to 1.3e-11 measured.
COV_RTOL = {STAR: 1e-12, INNOCUBE: 5e-11}
KEYS = ("q_est", "gyro_bias_est", "estimate_cov", "q_true", "gyro_bias")


def _close_estimate(got: dict, want: dict, where: str, cov_rtol: float = 1e-12) -> None:
    """The estimator's keys of a torch info (tensors) against a NumPy info (arrays);
    estimate_cov within ``cov_rtol`` of each matrix's largest entry."""
    def t(key):
        value = got[key]
        return value.cpu().numpy() if isinstance(value, torch.Tensor) else np.asarray(value)

    np.testing.assert_allclose(t("q_est"), want["q_est"], rtol=0, atol=1e-9, err_msg=where)
    np.testing.assert_allclose(t("gyro_bias_est"), want["gyro_bias_est"], rtol=0, atol=1e-12,
                               err_msg=where)
    np.testing.assert_allclose(t("q_true"), want["q_true"], rtol=0, atol=1e-12, err_msg=where)
    np.testing.assert_allclose(t("gyro_bias"), want["gyro_bias"], rtol=0, atol=1e-15,
                               err_msg=where)
    cov, ref = t("estimate_cov"), np.asarray(want["estimate_cov"])
    scale = np.abs(ref).max(axis=(-2, -1), keepdims=True)  # each matrix's own size
    assert np.all(np.abs(cov - ref) <= cov_rtol * scale), \
        f"{where}: estimate_cov differs by {np.max(np.abs(cov - ref) / scale):.2e} relative"
    if "star_tracker_fix" in want:
        assert np.array_equal(t("star_tracker_fix"), want["star_tracker_fix"]), where
    if "estimated_attitude_error_deg" in want:
        np.testing.assert_allclose(t("estimated_attitude_error_deg"),
                                   want["estimated_attitude_error_deg"], rtol=0, atol=1e-7,
                                   err_msg=where)


def _pair(env_id, scene, autoreset, **kw):
    kwargs = {"scene": scene, "max_episode_steps": EPISODE, "autoreset_mode": autoreset, **kw}
    ne = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", **kwargs)
    te = gym.make_vec(env_id, num_envs=N, backend="torch", **kwargs)
    return ne, te


@pytest.mark.parametrize(("env_id", "scene", "autoreset"), [
    ("rbenv/SatelliteReorient-v1", STAR, AutoresetMode.SAME_STEP),
    ("rbenv/SatelliteReorient-v1", STAR, AutoresetMode.NEXT_STEP),
    ("rbenv/SatelliteReorient-v2", STAR, AutoresetMode.SAME_STEP),
    ("rbenv/SatelliteDetumble-v1", STAR, AutoresetMode.NEXT_STEP),
    ("rbenv/SatelliteTrack-v1", STAR, AutoresetMode.SAME_STEP),
    ("rbenv/SatelliteReorient-v1", INNOCUBE, AutoresetMode.SAME_STEP),
    ("rbenv/SatelliteDetumble-v1", INNOCUBE, AutoresetMode.NEXT_STEP),
])
def test_torch_estimator_episodes_equal_the_numpy_vector_envs(env_id, scene, autoreset):
    ne, te = _pair(env_id, scene, autoreset)
    assert te.single_observation_space.shape == ne.single_observation_space.shape
    obs_n, info_n = ne.reset(seed=21)
    obs_t, info_t = te.reset(seed=21)
    np.testing.assert_allclose(obs_t.float().numpy(), obs_n, rtol=0, atol=1e-9)
    _close_estimate(info_t, info_n, "reset")
    rng = np.random.default_rng(5)
    ended, fixes = 0, 0
    for i in range(STEPS):
        action = rng.uniform(-1.0, 1.0, ne.action_space.shape)
        obs_n, r_n, term_n, trunc_n, info_n = ne.step(action)
        obs_t, r_t, term_t, trunc_t, info_t = te.step(torch.as_tensor(action))
        where = f"step {i}"
        np.testing.assert_allclose(obs_t.float().numpy(), obs_n, rtol=0, atol=1e-9,
                                   err_msg=where)
        np.testing.assert_allclose(r_t.numpy(), r_n, rtol=0, atol=1e-12, err_msg=where)
        assert term_t.tolist() == term_n.tolist() and trunc_t.tolist() == trunc_n.tolist()
        _close_estimate(info_t, info_n, where, COV_RTOL[scene])
        for key in ("attitude_error_deg", "rate_dps", "time_s"):
            if key in info_n:
                np.testing.assert_allclose(info_t[key].numpy(), info_n[key], rtol=0,
                                           atol=1e-12, err_msg=f"{where} {key}")
        done = term_n | trunc_n
        ended += int(done.sum())
        fixes += int(np.sum(info_n.get("star_tracker_fix", 0)))
        if autoreset is AutoresetMode.SAME_STEP and done.any():
            for j in np.flatnonzero(done):
                np.testing.assert_allclose(info_t["final_obs"][j].float().numpy(),
                                           info_n["final_obs"][j], rtol=0, atol=1e-9)
            got = {k: info_t["final_info"][k][torch.as_tensor(done)] for k in KEYS}
            want = {k: np.stack([info_n["final_info"][k][j] for j in np.flatnonzero(done)])
                    for k in KEYS}
            _close_estimate(got, want, f"{where} final_info", COV_RTOL[scene])
    assert ended >= N, "the run would not cross autoresets"
    if scene == STAR:
        assert fixes > 0


def test_a_partial_reset_restarts_the_rows_filters_as_numpys():
    ne, te = _pair("rbenv/SatelliteReorient-v1", STAR, AutoresetMode.DISABLED)
    ne.reset(seed=4)
    te.reset(seed=4)
    a = np.zeros(ne.action_space.shape)
    for _ in range(3):
        ne.step(a)
        te.step(torch.as_tensor(a))
    mask = np.arange(N) % 2 == 0
    obs_n, info_n = ne.reset(options={"reset_mask": mask})
    obs_t, info_t = te.reset(options={"reset_mask": torch.as_tensor(mask)})
    np.testing.assert_allclose(obs_t.float().numpy(), obs_n, rtol=0, atol=1e-9)
    _close_estimate(info_t, info_n, "partial reset")
    assert info_t["_q_est"].tolist() == mask.tolist()
    for i in range(4):
        obs_n, _, _, _, info_n = ne.step(a)
        obs_t, _, _, _, info_t = te.step(torch.as_tensor(a))
        np.testing.assert_allclose(obs_t.float().numpy(), obs_n, rtol=0, atol=1e-9)
        _close_estimate(info_t, info_n, f"step {i} after the partial reset")


@pytest.mark.parametrize("scene", [STAR, INNOCUBE])
def test_the_torch_single_env_equals_the_numpy_single_env_and_passes_the_checkers(scene):
    from gymnasium.utils.env_checker import check_env

    env = gym.make("rbenv/SatelliteReorient-v1", scene=scene, backend="torch").unwrapped
    ref = gym.make("rbenv/SatelliteReorient-v1", scene=scene).unwrapped
    obs, info = env.reset(seed=8)
    want, want_info = ref.reset(seed=8)
    np.testing.assert_allclose(obs, want, rtol=0, atol=1e-7)
    assert set(info) - {"diverged"} == set(want_info)
    rng = np.random.default_rng(2)
    for i in range(40):
        a = rng.uniform(-1, 1, ref.action_space.shape).astype(np.float32)
        obs, reward, term, trunc, info = env.step(a)
        want, want_reward, want_term, want_trunc, want_info = ref.step(a)
        np.testing.assert_allclose(obs, want, rtol=0, atol=1e-7)
        assert abs(reward - want_reward) <= 1e-12 and (term, trunc) == (want_term, want_trunc)
        assert info["estimate_cov"].shape == (6, 6) and info["q_est"].shape == (4,)
        _close_estimate(info, want_info, f"step {i}", COV_RTOL[scene])
        if term or trunc:
            break
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        check_env(gym.make("rbenv/SatelliteReorient-v1", scene=scene,
                           backend="torch").unwrapped, skip_render_check=True)
        sb3_checker.check_env(gym.make("rbenv/SatelliteReorient-v1", scene=scene,
                                       backend="torch").unwrapped)


def test_float32_runs_the_estimator_close_to_float64():
    kw = {"scene": STAR, "max_episode_steps": 200, "autoreset_mode": AutoresetMode.DISABLED}
    e64 = gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=N, backend="torch", **kw)
    e32 = gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=N, backend="torch",
                       dtype="float32", **kw)
    e64.reset(seed=3)
    obs32, _ = e32.reset(seed=3)
    a = torch.zeros(e64.action_space.shape)
    for _ in range(60):
        _, _, _, _, i64 = e64.step(a)
        obs32, _, _, _, i32 = e32.step(a)
    assert obs32.dtype == torch.float32 and i32["estimate_cov"].dtype == torch.float32
    assert e32.observation_space.contains(obs32.numpy())
    # the float32 filter's estimate error stays within 4σ of its own covariance, and its
    # estimate within 1e-5 rad of the float64 filter's (8e-7 rad measured, N = 64, 150 steps)
    e = sn.qlog(sn.qmul(sn.qconj(i32["q_est"].double().numpy()), i32["q_true"].double().numpy()))
    sigma = np.sqrt(np.diagonal(i32["estimate_cov"].double().numpy(), axis1=1, axis2=2)[:, :3])
    assert np.all(np.abs(e) < 4 * sigma)
    diff = sn.qlog(sn.qmul(sn.qconj(i64["q_est"].numpy()), i32["q_est"].double().numpy()))
    assert np.abs(diff).max() < 1e-5  # rad


@pytest.mark.parametrize("env_id", sorted(set(rbenv.ENV_IDS) - {rbenv.DESATURATE_ID,
                                                               "rbenv/SatelliteDesaturate-v0"}))
def test_every_task_the_torch_env_runs_takes_the_estimator(env_id):
    """The torch env's observation is the NumPy env's (the estimate's, 6 σ features more than
    the plain scene's), and info carries the estimator's keys with a leading N."""
    ne, te = _pair(env_id, STAR, AutoresetMode.NEXT_STEP)
    plain = gym.make_vec(env_id, num_envs=N, backend="torch", scene="cubesat-12u")
    assert te.single_observation_space.shape[0] == plain.single_observation_space.shape[0] + 6
    obs_n, _ = ne.reset(seed=0)
    te.reset(seed=0)
    a = np.zeros(ne.action_space.shape)
    obs_n, _, _, _, info_n = ne.step(a)
    obs_t, _, _, _, info_t = te.step(torch.as_tensor(a))
    np.testing.assert_allclose(obs_t.float().numpy(), obs_n, rtol=0, atol=1e-9)
    assert info_t["estimate_cov"].shape == (N, 6, 6) and info_t["q_est"].shape == (N, 4)
    assert set(info_n) <= set(info_t)
    _close_estimate(info_t, info_n, env_id)


def test_compile_with_the_estimator_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match=r"compile=True.*estimator"):
        gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=2, backend="torch", scene=STAR,
                     compile=True)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")
def test_cuda_estimator_episodes_equal_the_cpu_ones():  # pragma: no cover (needs a GPU)
    kw = {"scene": STAR, "max_episode_steps": EPISODE, "autoreset_mode": AutoresetMode.SAME_STEP}
    cpu = gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=N, backend="torch", **kw)
    gpu = gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=N, backend="torch",
                       device="cuda", **kw)
    cpu.reset(seed=9)
    gpu.reset(seed=9)
    rng = np.random.default_rng(1)
    for _ in range(STEPS):
        a = torch.as_tensor(rng.uniform(-1, 1, cpu.action_space.shape))
        oc, _, _, _, ic = cpu.step(a)
        og, _, _, _, ig = gpu.step(a.cuda())
        assert og.device.type == "cuda"
        np.testing.assert_allclose(og.cpu().numpy(), oc.numpy(), rtol=0, atol=1e-9)
        _close_estimate({k: ig[k] for k in (*KEYS, "star_tracker_fix")},
                        {k: ic[k].numpy() for k in (*KEYS, "star_tracker_fix")}, "cuda")
