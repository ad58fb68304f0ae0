"""The goal-conditioned form rbenv/SatelliteReorientGoal-v1 (rbenv/envs/goal.py): HER's interface,
both checkers, compute_reward equal to the env's reward, and v1's episodes."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import rbenv
from rbenv.envs.goal import GOAL_ID


def _episode(env, seed, steps=60):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(steps):
        obs, reward, term, trunc, info = env.step(
            rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        rows.append((obs, reward, info))
        if term or trunc:
            break
    return rows


def test_both_checkers_pass_with_warnings_as_errors():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(GOAL_ID, render_mode="rgb_array").unwrapped)
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(gym.make(GOAL_ID).unwrapped, warn=True)


def test_compute_reward_vectorised_equals_the_env_reward_also_for_other_goals():
    env = gym.make(GOAL_ID)
    rows = _episode(env, seed=4)
    achieved = np.array([o["achieved_goal"] for o, _, _ in rows])
    desired = np.array([o["desired_goal"] for o, _, _ in rows])
    infos = np.array([i for _, _, i in rows])  # SB3's HerReplayBuffer passes an array of dicts
    u = env.unwrapped
    np.testing.assert_array_equal(u.compute_reward(achieved, desired, infos),
                                  [r for _, r, _ in rows])
    # HER's relabelling: goals taken from later achieved attitudes, batch == one by one.
    future = achieved[::-1]
    batch = u.compute_reward(achieved, future, infos)
    one = [u.compute_reward(a, d, i) for a, d, i in zip(achieved, future, infos, strict=True)]
    np.testing.assert_array_equal(batch, one)
    assert not np.array_equal(batch, u.compute_reward(achieved, desired, infos))


def test_goal_form_runs_v1_episodes_with_v1_reward():
    goal, plain = gym.make(GOAL_ID), gym.make("rbenv/SatelliteReorient-v1")
    a = _episode(goal, seed=9)
    b = _episode(plain, seed=9)
    assert len(a) == len(b)
    for (_, r_goal, i_goal), (_, r_v1, i_v1) in zip(a, b, strict=True):
        assert i_goal["attitude_error_deg"] == i_v1["attitude_error_deg"]
        assert r_goal == pytest.approx(r_v1, abs=1e-6)


def test_reaching_the_goal_pays_success_once_and_the_observation_ignores_the_goal():
    env = gym.make(GOAL_ID)
    u = env.unwrapped
    q = np.array([0.5, 0.5, 0.5, 0.5])
    obs, _ = env.reset(seed=0, options={"q": q, "q_target": q, "omega_B": np.zeros(3)})
    other, _ = gym.make(GOAL_ID).reset(seed=0, options={"q": q, "omega_B": np.zeros(3)})
    np.testing.assert_array_equal(obs["observation"], other["observation"])
    assert not np.array_equal(obs["desired_goal"], other["desired_goal"])
    off = -np.ones(env.action_space.shape, np.float32)
    paid = []
    for _ in range(u.hold + 1):
        obs, reward, term, _, info = env.step(off)
        paid.append(info["reward_fuel"] == 0.0 and reward)
        if term:
            break
    assert info["is_success"] and len(paid) == u.hold
    assert paid[-1] > u.task.weights.success - 1.0 > max(paid[:-1])


@pytest.mark.slow
def test_her_sac_learns_on_it_for_a_few_steps(request):
    sb3 = pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3.common.env_util import make_vec_env

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # small networks: one thread (as rbenv train)
    request.addfinalizer(lambda: torch.set_num_threads(threads))

    venv = make_vec_env(GOAL_ID, n_envs=1, seed=0)
    model = sb3.SAC("MultiInputPolicy", venv, replay_buffer_class=sb3.HerReplayBuffer,
                    replay_buffer_kwargs={"n_sampled_goal": 4, "copy_info_dict": True,
                                          "goal_selection_strategy": "future"},
                    learning_starts=160, batch_size=32, policy_kwargs={"net_arch": [32, 32]},
                    seed=0, device="cpu")
    model.learn(240)
    assert model.replay_buffer.size() > 0 and model.num_timesteps == 240
    assert math.isfinite(float(model.logger.name_to_value.get("train/critic_loss", 0.0)))
    assert rbenv.envs.goal.GOAL_ID == GOAL_ID
    with pytest.raises(ValueError, match="copy_info_dict"):
        venv.env_method("compute_reward", np.zeros((2, 6)), np.zeros((2, 6)), [{}, {}],
                        indices=[0])


def test_goal_reached_is_the_success_of_the_goal_given():
    env = gym.make(GOAL_ID)
    u = env.unwrapped
    q = np.array([0.5, 0.5, 0.5, 0.5])
    env.reset(seed=0, options={"q": q, "q_target": q, "omega_B": np.zeros(3)})
    off = -np.ones(env.action_space.shape, np.float32)
    rows = []
    for _ in range(u.hold + 1):
        obs, _, term, _, info = env.step(off)
        rows.append((obs, info))
        if term:
            break
    achieved = np.array([o["achieved_goal"] for o, _ in rows])
    infos = [i for _, i in rows]
    reached = u.goal_reached(achieved, np.array([o["desired_goal"] for o, _ in rows]), infos)
    assert reached.tolist() == [i["is_success"] for i in infos] == [False] * (u.hold - 1) + [True]
    assert u.goal_reached(achieved[-1], rows[-1][0]["desired_goal"], infos[-1])
    # Another goal (30° away) is not reached by the same steps.
    far = gym.make(GOAL_ID).reset(seed=0, options={"q_target": [math.cos(0.26), math.sin(0.26),
                                                              0.0, 0.0]})[0]["desired_goal"]
    assert not u.goal_reached(achieved, np.repeat(far[None], len(rows), 0), infos).any()
