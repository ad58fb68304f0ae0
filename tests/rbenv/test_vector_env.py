"""The native vector env: make_vec contract, equality with single envs, autoreset, seeding."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space
from rbenv.core import quaternion

import rbenv
from rbenv.tasks.reorient import ReorientWeights

ID = "rbenv/SatelliteReorient-v0"  # this file checks the first release's vector env
KEYS = ("attitude_error_deg", "rate_dps", "fuel_kg", "impulse_Ns", "time_s", "is_success",
        *(f"reward_{t}" for t in ReorientWeights.Terms._fields))


def make_vec(n=4, **kwargs):
    return gym.make_vec(ID, num_envs=n, **kwargs)


def spin_up_actions(n, steps, seed=0, thrusters=12):
    """Random throttles biased to two thrusters, so that some sub-envs lose control (reset)."""
    a = np.random.default_rng(seed).uniform(-1, 1, (steps, n, thrusters)).astype(np.float32)
    a[:, :, -2:] += 0.6
    return a


def test_make_vec_returns_native_env_with_batched_spaces():
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # e.g. missing autoreset_mode metadata
        envs = make_vec(3)
    assert isinstance(envs, rbenv.SatelliteReorientVectorEnv)
    assert envs.observation_space == batch_space(envs.single_observation_space, 3)
    assert envs.action_space == batch_space(envs.single_action_space, 3)
    assert envs.single_observation_space.dtype == np.float32
    assert envs.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert envs.unwrapped.spec.id == ID
    obs, info = envs.reset(seed=0)
    assert obs.shape == (3, 7) and obs.dtype == np.float32
    obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert reward.shape == (3,) and reward.dtype == np.float64
    assert terminated.dtype == np.bool_ and truncated.dtype == np.bool_
    for key in KEYS:
        assert info[key].shape == (3,) and info["_" + key].all()


def test_options_and_autoreset_mode_per_instance():
    same = make_vec(2, autoreset_mode=AutoresetMode.SAME_STEP, scene="microsat-100kg",
                    action_mode="torque")
    nxt = make_vec(2)
    assert same.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert nxt.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert rbenv.SatelliteReorientVectorEnv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert same.single_action_space.shape == (3,)
    assert make_vec(2, autoreset_mode="SameStep").metadata["autoreset_mode"] is \
        AutoresetMode.SAME_STEP
    assert make_vec(2, autoreset_mode=AutoresetMode.DISABLED).autoreset_mode is \
        AutoresetMode.DISABLED
    assert nxt.autoreset_mode is AutoresetMode.NEXT_STEP  # an attribute, as Gymnasium's envs
    with pytest.raises(ValueError, match="autoreset_mode"):
        make_vec(2, autoreset_mode="Sometimes")


def test_sync_vectorization_of_the_single_env_also_works():
    envs = make_vec(2, vectorization_mode="sync")
    assert isinstance(envs, gym.vector.SyncVectorEnv)
    envs.reset(seed=0)
    envs.step(envs.action_space.sample())


@pytest.mark.parametrize("scene", ["cubesat-12u", "microsat-100kg"])
def test_matches_single_envs_to_1e12_through_autoresets(scene, lockstep):
    """Sub-env i seeded s + i equals a single env seeded s + i, episode after episode.

    microsat-100kg has sensor noise, drawn from the batch generator in the vector env: there
    the states are compared (not the observations) from identical starts given through reset
    options, until a sub-env's first reset (the single env's stream also fed its noise).
    """
    n, steps, seed = 6, 260, 11
    noisy = scene != "cubesat-12u"
    venv = make_vec(n, scene=scene)
    singles = [gym.make(ID, scene=scene) for _ in range(n)]
    options = None
    if noisy:
        rng = np.random.default_rng(3)
        options = {"q": quaternion.random(rng, (n,)), "q_target": quaternion.random(rng, (n,)),
                   "omega_B": rng.uniform(-0.01, 0.01, (n, 3))}
    obs, _ = venv.reset(seed=seed, options=options)
    for i, env in enumerate(singles):
        opts = None if options is None else {k: v[i] for k, v in options.items()}
        o, _ = env.reset(seed=seed + i, options=opts)
        if not noisy:
            np.testing.assert_array_equal(o, obs[i])
    actions = spin_up_actions(n, steps, seed=5, thrusters=venv.single_action_space.shape[0])
    prev_done = np.zeros(n, dtype=bool)
    reset_once = np.zeros(n, dtype=bool)
    resets = 0
    step_alongside, assert_sub_env_matches = lockstep
    for t in range(steps):
        vec_out, singles_out = step_alongside(venv, singles, actions[t], prev_done)
        obs, _, terminated, truncated, info = vec_out
        resets += int(prev_done.sum())
        for i in range(n):
            o, inf = singles_out[i][0], singles_out[i][4]
            reset_once[i] |= prev_done[i]
            if noisy and reset_once[i]:
                continue
            assert_sub_env_matches(singles[i], singles_out[i], venv, vec_out, i)
            if not noisy:
                np.testing.assert_allclose(o, obs[i], rtol=0, atol=1e-6)  # float32
            for key in KEYS:
                assert abs(float(inf[key]) - float(info[key][i])) <= 1e-9 * max(
                    1.0, abs(float(inf[key])))
        prev_done = terminated | truncated
    assert resets >= 3  # the comparison went through autoresets


def test_next_step_autoreset_semantics():
    envs = make_vec(2)
    envs.reset(seed=0)
    limit = envs.unwrapped.scene.episode.rate_limit
    envs.reset(seed=0, options={"omega_B": np.array([[0, 0, 0.99 * limit], [0, 0, 0.0]])})
    a = -np.ones((2, 12), np.float32)
    a[0, 10:12] = 1.0
    obs1, _, term1, _, info1 = envs.step(a)
    assert term1.tolist() == [True, False] and not info1["is_success"][0]
    assert abs(obs1[0, 6]) == 1.0  # terminal observation: rate clipped at the limit
    obs2, r2, term2, trunc2, info2 = envs.step(a)
    assert r2[0] == 0.0 and not term2[0] and not trunc2[0]
    assert info2["time_s"][0] == 0.0 and info2["fuel_kg"][0] == 0.0
    assert info2["time_s"][1] == 1.0
    assert np.abs(obs2[0, 4:]).max() < 1.0  # a fresh episode


def test_same_step_autoreset_semantics_and_final_info():
    nxt = make_vec(3)
    same = make_vec(3, autoreset_mode=AutoresetMode.SAME_STEP)
    nxt.reset(seed=4)
    same.reset(seed=4)
    actions = spin_up_actions(3, 200, seed=9)
    finals = 0
    for t in range(200):  # identical until the first episode ends
        o_n, r_n, te_n, tr_n, i_n = nxt.step(actions[t])
        o_s, r_s, te_s, _, i_s = same.step(actions[t])
        np.testing.assert_array_equal(r_n, r_s)
        np.testing.assert_array_equal(te_n, te_s)
        done = te_n | tr_n
        if done.any():
            assert i_s["_final_obs"].tolist() == done.tolist()
            assert i_s["_final_info"].tolist() == done.tolist()
            for i in np.flatnonzero(done):
                finals += 1
                np.testing.assert_array_equal(i_s["final_obs"][i], o_n[i])  # terminal obs
                assert i_s["final_info"]["_attitude_error_deg"][i]
                assert i_s["final_info"]["attitude_error_deg"][i] == \
                    i_n["attitude_error_deg"][i]
                assert i_s["time_s"][i] == 0.0  # returned info is the reset info
                assert not np.array_equal(o_s[i], o_n[i])  # returned obs is the reset obs
            for i in np.flatnonzero(~done):
                assert i_s["final_obs"][i] is None
                np.testing.assert_array_equal(o_s[i], o_n[i])
            break
        assert "final_obs" not in i_s
        np.testing.assert_array_equal(o_s, o_n)
    assert finals >= 1


def test_seeding_is_reproducible_and_per_sub_env():
    a = make_vec(3)
    b = make_vec(3)
    o1, _ = a.reset(seed=42)
    o2, _ = b.reset(seed=42)
    np.testing.assert_array_equal(o1, o2)
    assert not np.array_equal(o1[0], o1[1])
    np.testing.assert_array_equal(make_vec(3).reset(seed=[42, 43, 44])[0], o1)
    single = gym.make(ID).reset(seed=43)[0]
    np.testing.assert_array_equal(single, o1[1])
    o3, _ = a.reset()  # unseeded: continues the streams
    assert not np.array_equal(o3, o1)


def test_noisy_scene_is_reproducible():
    def run(seed):
        envs = make_vec(3, scene="boom-sat")
        out = [envs.reset(seed=seed)[0]]
        for act in spin_up_actions(3, 20):
            out.append(envs.step(act)[0])
        return np.array(out)

    np.testing.assert_array_equal(run(1), run(1))


def test_nan_and_clipping_in_the_vector_env():
    envs = make_vec(2)
    envs.reset(seed=0)
    a = np.zeros((2, 12), np.float32)
    a[1, 3] = np.nan
    with pytest.raises(ValueError, match=r"NaN at index \(1, 3\)"):
        envs.step(a)
    e1, e2 = make_vec(2), make_vec(2)
    e1.reset(seed=1)
    e2.reset(seed=1)
    big = np.full((2, 12), 5.0, np.float32)
    np.testing.assert_array_equal(e1.step(big)[0], e2.step(np.ones((2, 12)))[0])


def test_vector_env_pickles_and_runs_in_async_workers():
    envs = make_vec(2)
    envs.reset(seed=0)
    clone = pickle.loads(pickle.dumps(envs))
    a = np.full((2, 12), 0.2, np.float32)
    np.testing.assert_array_equal(envs.step(a)[0], clone.step(a)[0])

    async_envs = gym.make_vec(ID, num_envs=2, vectorization_mode="async")
    try:
        obs, _ = async_envs.reset(seed=3)
        ref = make_vec(2).reset(seed=3)[0]
        np.testing.assert_array_equal(obs, ref)
        obs, reward, *_ = async_envs.step(np.zeros((2, 12), np.float32))
        assert obs.shape == (2, 7) and np.isfinite(reward).all()
    finally:
        async_envs.close()


def test_curriculum_setter_applies_to_resets():
    envs = make_vec(8)
    envs.unwrapped.set_initial_ranges(max_initial_angle_deg=5.0, max_initial_rate=0.0)
    _, info = envs.reset(seed=0)
    assert info["attitude_error_deg"].max() <= 5.0 + 1e-9 and info["rate_dps"].max() == 0.0
