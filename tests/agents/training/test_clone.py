"""Behaviour cloning (rbenv.agents.training.clone): the discounted returns against their closed
form, and a tiny innocube-3u run cloned from the slew law acts like the law afterwards."""

import json

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies.evaluate import make_policy
from rbenv.agents.policies.load import load_policy
from rbenv.agents.training.clone import clone, discounted_returns

SMALL = {"n_steps": 16, "batch_size": 64, "n_epochs": 1}


def test_discounted_returns_stop_at_episode_ends():
    reward = np.ones((4, 2))
    done = np.array([[0, 0], [0, 1], [1, 0], [0, 0]], float)
    g = 0.9
    expected = np.array([[1 + g + g * g, 1 + g], [1 + g, 1.0], [1.0, 1 + g], [1.0, 1.0]])
    np.testing.assert_allclose(discounted_returns(reward, done, g), expected, rtol=1e-15)


@pytest.mark.slow  # trains a tiny run, then clones into it
def test_a_cloned_run_acts_like_its_expert(tmp_path):
    out = tmp_path / "run"
    kwargs = {"action_mode": "acceleration_lifted"}
    assert cli_main(["train", "--timesteps", "128", "--n-envs", "8", "--out", str(out),
                     "--scene", "innocube-3u", "--hyperparams", json.dumps(SMALL),
                     "--checkpoint-every", "128", "--eval-every", "100000",
                     "--env-kwargs", json.dumps(kwargs), "--no-report", "--no-progress"]) == 0
    env = gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=8, scene="innocube-3u",
                       vectorization_mode="vector_entry_point", **kwargs)
    expert = make_policy("innocube-slew", env)
    obs, seen = env.reset(seed=5)[0], []
    for _ in range(40):  # states along the expert's own slews
        seen.append(obs)
        obs = env.step(expert.predict(obs)[0])[0]
    obs = np.concatenate(seen)
    target = expert.predict(obs)[0]

    def error():
        return np.mean((load_policy(str(out)).predict(obs, deterministic=True)[0] - target) ** 2)

    before = error()
    record = clone(out, "innocube-slew", rollouts_per_env=1, epochs=20, batch=256, lr=3e-3)
    assert record["samples"] == 8 * 160 and record["checkpoint_steps"] == 128
    assert json.loads((out / "clone.json").read_text())["expert"] == "innocube-slew"
    assert error() < 0.5 * before, (before, error())
