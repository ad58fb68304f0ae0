"""SB3 adapter: the VecEnv contract SB3's algorithms rely on, and PPO/SAC training through it."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from rbenv.agents.training.sb3_vec_env import SB3VecEnv
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

import rbenv


def native(n=4, **kwargs):
    return gym.make_vec(rbenv.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)


def test_requires_same_step_autoreset():
    venv = gym.make_vec(rbenv.ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="SAME_STEP"):
        SB3VecEnv(venv)


def test_spaces_reset_and_step_types():
    env = SB3VecEnv(native(4))
    assert isinstance(env, VecEnv)
    assert env.observation_space.shape == (15,) and env.action_space.shape == (12,)
    obs = env.reset()
    assert obs.shape == (4, 15) and obs.dtype == np.float32
    obs, rewards, dones, infos = env.step(np.zeros((4, 12), np.float32))
    assert obs.shape == (4, 15) and rewards.dtype == np.float32 and dones.dtype == bool
    assert isinstance(infos, list) and len(infos) == 4 and all(isinstance(i, dict) for i in infos)


def test_seed_makes_reset_reproducible_and_matches_native_seeding():
    env = SB3VecEnv(native(3))
    env.seed(7)
    a = env.reset()
    env.seed(7)
    b = env.reset()
    direct, _ = native(3).reset(seed=[7, 8, 9])
    assert np.array_equal(a, b)
    assert np.array_equal(a, direct)


def test_timeout_gives_terminal_observation_and_truncation_flag():
    env = SB3VecEnv(native(3, max_episode_steps=3))
    env.reset()
    for _ in range(2):
        _, _, dones, infos = env.step(np.zeros((3, 12), np.float32))
        assert not dones.any() and all("terminal_observation" not in i for i in infos)
    obs, _, dones, infos = env.step(np.zeros((3, 12), np.float32))
    assert dones.all()
    for i, info in enumerate(infos):
        assert info["TimeLimit.truncated"] is True
        assert info["terminal_observation"].shape == (15,)
        assert not np.array_equal(info["terminal_observation"], obs[i])  # obs is the reset obs
        assert "is_success" in info and info["is_success"] is False


def test_termination_is_not_a_timeout():
    # Start just below the rate limit and torque the spin up: loss of control terminates.
    venv = native(2, action_mode="torque")
    env = SB3VecEnv(venv)
    limit = venv.unwrapped.config.scene.episode.rate_limit
    env.set_options({"omega_B": np.tile([0.0, 0.0, 0.999 * limit], (2, 1))})
    env.reset()
    for _ in range(20):
        _, _, dones, infos = env.step(np.tile([0.0, 0.0, 1.0], (2, 1)).astype(np.float32))
        if dones.any():
            break
    i = int(np.flatnonzero(dones)[0])
    assert infos[i]["TimeLimit.truncated"] is False
    assert infos[i]["is_success"] is False


def test_monitor_and_evaluate_policy_read_episodes():
    env = VecMonitor(SB3VecEnv(native(4, max_episode_steps=5)), info_keywords=("is_success",))
    model = PPO("MlpPolicy", env, n_steps=8, batch_size=32, seed=0, device="cpu")
    rewards, lengths = evaluate_policy(model, env, n_eval_episodes=4, return_episode_rewards=True)
    assert len(rewards) == 4 and all(n == 5 for n in lengths)


@pytest.mark.slow
@pytest.mark.parametrize("algo", [PPO, SAC])
def test_algorithms_train_through_the_adapter(algo, tmp_path):
    env = VecNormalize(VecMonitor(SB3VecEnv(native(8))))
    kwargs = {"n_steps": 64, "batch_size": 256} if algo is PPO else {
        "learning_starts": 200, "batch_size": 64, "buffer_size": 5000}
    model = algo("MlpPolicy", env, seed=0, device="cpu", **kwargs)
    model.learn(3000)
    assert model.num_timesteps >= 3000
    assert len(model.ep_info_buffer) > 0  # episodes completed and were monitored
    model.save(tmp_path / "m.zip")
    assert (tmp_path / "m.zip").exists()
