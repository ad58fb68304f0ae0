"""RL Baselines3 Zoo's modules (``--conf-file rbenv.agents.zoo.<algo>``): each a view of the
training settings, and the env package never imports them (nor anything of agents)."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest
from rbenv.agents import settings
from rbenv.agents.zoo import zoo_table

import rbenv

ALGOS = ("ppo", "sac", "td3", "tqc", "crossq")


@pytest.mark.parametrize("algo", ALGOS)
def test_each_module_is_the_settings_table_of_its_algorithm(algo):
    table = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams
    source = settings.zoo_hyperparams(algo)
    assert set(rbenv.ENV_IDS) <= set(table) == set(source)
    for env_id, entry in table.items():
        # the zoo hands policy_kwargs to SB3 as they are: an activation goes as its class
        plain = {k: v for k, v in entry.get("policy_kwargs", {}).items() if k != "activation_fn"}
        want = source[env_id].get("policy_kwargs", {})
        assert plain == {k: v for k, v in want.items() if k != "activation_fn"}, env_id
        assert ("activation_fn" in entry.get("policy_kwargs", {})) == ("activation_fn" in want)
        assert {k: v for k, v in entry.items() if k != "policy_kwargs"} == {
            k: v for k, v in source[env_id].items() if k != "policy_kwargs"}, env_id


def test_an_activation_named_in_the_settings_reaches_the_zoo_as_a_class(monkeypatch):
    torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")
    from rbenv.agents.policies.activations import ACTIVATIONS

    env_id = rbenv.ENV_ID
    entry = settings.get(env_id)
    named = {env_id: {**entry.recipe("ppo"), "policy_kwargs": {"activation_fn": "tanh"}}}
    monkeypatch.setattr("rbenv.agents.zoo.zoo_hyperparams", lambda algo: named)
    built = zoo_table("ppo")[env_id]["policy_kwargs"]["activation_fn"]
    assert built is ACTIVATIONS["tanh"] and issubclass(built, torch.nn.Module)


def test_the_env_package_imports_nothing_of_agents():
    code = ("import sys, gymnasium as gym, rbenv\n"
            "env = gym.make(rbenv.ENV_ID); env.reset(seed=0); env.step(env.action_space.sample())\n"
            "envs = gym.make_vec(rbenv.ENV_ID, num_envs=2); envs.reset(seed=0)\n"
            "print(sorted(m for m in sys.modules if m.startswith('rbenv.agents')))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", done.stdout
