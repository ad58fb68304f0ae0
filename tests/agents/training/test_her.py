"""rbenv.agents.training.her: the features extractor and replay buffer that let SB3's HER learn
the goal form of Reorient-v1, checked against the env itself; and the module docstring's recipe
trains."""

from __future__ import annotations

import pytest

pytest.importorskip("stable_baselines3")

from rbenv.envs.goal import GOAL_ID

PLAIN_ID, SCENE = "rbenv/SatelliteReorient-v1", "cubesat-12u"


def test_goal_error_features_are_the_v1_error_observation():
    """--features goal-error: from the goals, v1's rot6_err and attitude_fine of the same
    state, step by step (so HER's substituted goals get their own error)."""
    import gymnasium as gym
    import numpy as np
    import torch

    goal = gym.make(GOAL_ID, scene=SCENE)
    plain = gym.make(PLAIN_ID, scene=SCENE)
    from rbenv.agents.training.her import GoalErrorFeatures

    features = GoalErrorFeatures(goal.observation_space, goal.unwrapped.task.success_angle)
    obs, _ = goal.reset(seed=7)
    v1, _ = plain.reset(seed=7)
    rng = np.random.default_rng(7)
    for _ in range(30):
        batch = {k: torch.as_tensor(v[None]) for k, v in obs.items()}
        got = features(batch)[0].numpy()
        assert got.shape == (12 + 9,)
        np.testing.assert_array_equal(got[:12], obs["observation"])
        np.testing.assert_allclose(got[12:], v1[:9], atol=2e-5)
        action = rng.uniform(-1, 1, goal.action_space.shape).astype(np.float32)
        obs, _, term, trunc, _ = goal.step(action)
        v1, _, term_v1, _, _ = plain.step(action)
        assert term == term_v1
        if term or trunc:
            break


def test_reached_buffer_ends_relabelled_transitions_whose_goal_is_reached():
    """A satellite at rest far from its target: the real episode goes on (SB3's buffer: every
    done 0), but goals relabelled from its own attitude are reached after the hold, so the
    relabelled transitions from then on are terminal."""
    import gymnasium as gym
    import numpy as np
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: gym.make(GOAL_ID, scene=SCENE)])
    raw = gym.make(GOAL_ID, scene=SCENE)
    hold = raw.unwrapped.hold
    from rbenv.agents.training.her import ReachedHerReplayBuffer

    buffer = ReachedHerReplayBuffer(40, raw.observation_space, raw.action_space, env=venv,
                                    n_sampled_goal=4, goal_selection_strategy="future",
                                    copy_info_dict=True)
    obs, _ = raw.reset(seed=0, options={"q": [1.0, 0, 0, 0], "q_target": [0.0, 1.0, 0, 0],
                                        "omega_B": np.zeros(3)})
    off = -np.ones(raw.action_space.shape, np.float32)
    steps = 3 * hold
    for k in range(steps):
        nxt, reward, term, _, info = raw.step(off)
        assert not term
        last = k == steps - 1
        info = {**info, "TimeLimit.truncated": last}  # the episode cut short here
        buffer.add({key: v[None] for key, v in obs.items()},
                   {key: v[None] for key, v in nxt.items()}, off[None], np.array([reward]),
                   np.array([last]), [info])
        obs = nxt
    data = buffer.sample(500)
    n_virtual = int(buffer.her_ratio * 500)
    real, virtual = data.dones[:500 - n_virtual], data.dones[500 - n_virtual:]
    assert real.sum() == 0  # the timeout is not a termination
    assert 0 < virtual.mean() < 1  # reached after the hold, not before


@pytest.mark.slow
def test_the_documented_recipe_trains_and_relabels_with_the_buffer(request):
    """The module docstring's model, shrunk (2 envs, small nets, 300 steps): it trains, its
    buffer is the reached one, and its features are observation + 9."""
    import math

    import torch
    from rbenv.agents.training.her import GoalErrorFeatures, ReachedHerReplayBuffer
    from stable_baselines3 import SAC
    from stable_baselines3.common.env_util import make_vec_env

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    request.addfinalizer(lambda: torch.set_num_threads(threads))
    env = make_vec_env(GOAL_ID, n_envs=2, seed=0,
                       env_kwargs={"action_mode": "torque", "allocator": "pinv"})
    angle = env.get_attr("task", [0])[0].success_angle
    model = SAC("MultiInputPolicy", env, replay_buffer_class=ReachedHerReplayBuffer,
                replay_buffer_kwargs={"goal_selection_strategy": "future",
                                      "n_sampled_goal": 4, "copy_info_dict": True},
                policy_kwargs={"net_arch": [16, 16],
                               "features_extractor_class": GoalErrorFeatures,
                               "features_extractor_kwargs": {"success_angle": angle}},
                learning_starts=200, batch_size=32, seed=0, device="cpu")
    model.learn(300)
    assert isinstance(model.replay_buffer, ReachedHerReplayBuffer)
    assert model.actor.features_extractor.features_dim == 12 + 9
    assert model.num_timesteps == 300 and model._n_updates > 0
    assert math.isfinite(float(model.logger.name_to_value["train/critic_loss"]))


def test_the_buffer_refuses_to_run_without_the_step_infos():
    import gymnasium as gym
    from rbenv.agents.training.her import GoalErrorFeatures, ReachedHerReplayBuffer
    from stable_baselines3.common.vec_env import DummyVecEnv

    raw = gym.make(GOAL_ID)
    venv = DummyVecEnv([lambda: gym.make(GOAL_ID)])
    with pytest.raises(ValueError, match="copy_info_dict must be True"):
        ReachedHerReplayBuffer(40, raw.observation_space, raw.action_space, env=venv)
    with pytest.raises(ValueError, match="success_angle must be > 0"):
        GoalErrorFeatures(raw.observation_space, 0.0)


def test_rbenv_train_refuses_the_goal_form_and_says_how_to_train_it(tmp_path):
    from rbenv.agents.cli import main
    from rbenv.core.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match=r"rbenv\.agents\.training\.her") as e:
        main(["train", "--algo", "sac", "--env-id", GOAL_ID, "--out", str(tmp_path / "run")])
    assert GOAL_ID in str(e.value)
    assert not (tmp_path / "run").exists()
