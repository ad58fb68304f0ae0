"""Behaviour cloning (rbenv.agents.training.clone): the discounted returns against their closed
form, and a tiny innocube-3u run cloned from the slew law acts like the law afterwards."""

import json

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies.evaluate import make_policy
from rbenv.agents.policies.load import load_policy
from rbenv.agents.training.clone import _expert, clone, discounted_returns
from rbenv.core.errors import InvalidParameterError

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


def _lifted_env(n=1):
    return gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=n, scene="innocube-3u",
                        vectorization_mode="vector_entry_point",
                        action_mode="acceleration_lifted")


def test_expert_kwargs_set_the_experts_fields():
    env = _lifted_env(4)
    obs = env.reset(seed=3)[0]
    plain = make_policy("innocube-slew", env)
    tuned = _expert("innocube-slew", env, {"rate_gain": 1.2, "position_gain": 0.5})
    assert (tuned.rate_gain, tuned.position_gain) == (1.2, 0.5)
    # The rate loop's gain scales the command wherever the clamp does not bind.
    a, b = plain.predict(obs)[0], tuned.predict(obs)[0]
    assert not np.allclose(a, b)
    assert _expert("innocube-slew", env, None).rate_gain == plain.rate_gain


@pytest.mark.parametrize(("name", "kwargs", "words"), [
    ("innocube-slew", {"rate_gian": 1.0}, ["rate_gian", "rate_gain"]),
    ("zero", {"rate_gain": 1.0}, ["'zero'", "innocube-slew"]),
    ("innocube-slew", [1.0], ["expert_kwargs must be a dict", "[1.0]"]),
])
def test_bad_expert_kwargs_are_named(name, kwargs, words):
    with pytest.raises(InvalidParameterError) as err:
        _expert(name, _lifted_env(), kwargs)
    assert all(w in str(err.value) for w in words), str(err.value)


@pytest.mark.slow  # trains a tiny run, then clones into it with a DAgger round
def test_dagger_rounds_add_the_clones_own_states(tmp_path):
    out = tmp_path / "run"
    kwargs = {"action_mode": "acceleration_lifted"}
    assert cli_main(["train", "--timesteps", "128", "--n-envs", "8", "--out", str(out),
                     "--scene", "innocube-3u", "--hyperparams", json.dumps(SMALL),
                     "--checkpoint-every", "128", "--eval-every", "100000",
                     "--env-kwargs", json.dumps(kwargs), "--no-report", "--no-progress"]) == 0
    fields = {"rate_gain": 1.2, "position_gain": 0.5}
    record = clone(out, "innocube-slew", rollouts_per_env=1, epochs=20, batch=256, lr=3e-3,
                   expert_kwargs=fields, dagger=2, dagger_epochs=10)
    assert record["samples"] == 3 * 8 * 160 and len(record["action_mse_per_round"]) == 3
    assert record["expert_kwargs"] == fields and record["dagger"] == 2
    saved = json.loads((out / "clone.json").read_text())
    assert saved["action_mse_per_round"][-1] == record["action_mse"]
    with pytest.raises(InvalidParameterError, match="dagger must be an integer >= 0, got -1"):
        clone(out, "innocube-slew", dagger=-1)
