"""RL Baselines3 Zoo with the hyperparameters rbenv ships (``--conf-file rbenv.agents.zoo.X``).

A tiny budget (one PPO rollout of 64 envs x 64 steps) through the zoo's real command line:
``rl_zoo3.train`` must pick up rbenv's settings, not its ``default:`` entry, and ``rl_zoo3.enjoy``
must load and run what it saved.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys

import gymnasium as gym
import pytest
from rbenv.agents import settings
from rbenv.agents.zoo import ppo

import rbenv

# Exactly one rollout of the default id's shipped PPO settings (n_envs x n_steps).
_PPO = settings.get(rbenv.ENV_ID).recipe("ppo")
ZOO_STEPS = _PPO["n_envs"] * _PPO["n_steps"]
ZOO_NAME = rbenv.ENV_ID.replace("/", "-")  # the zoo names its run and model files so
ALGOS = ("ppo", "sac", "td3", "tqc", "crossq")
OFF_POLICY_STEPS = 1024  # 32 vector steps of the shipped 32 envs


def test_every_registered_id_has_zoo_settings():
    # The goal-conditioned form (rbenv/envs/goal.py) is trained with SAC/TQC + HER, not from these
    # tables; it has no zoo entry yet.
    ours = sorted(env_id for env_id in gym.registry if env_id.startswith("rbenv/")
                  and env_id != rbenv.envs.goal.GOAL_ID)
    assert rbenv.ENV_ID in ours
    missing = [env_id for env_id in ours if env_id not in ppo.hyperparams]
    assert not missing, f"add {missing} to agents/zoo/ppo.py"


@pytest.mark.parametrize("algo", ALGOS)
def test_every_algorithm_ships_settings_for_every_id(algo):
    table = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams
    assert set(rbenv.ENV_IDS) <= set(table)  # every shipped id (a test may register more)


@pytest.mark.parametrize("algo", ALGOS)
def test_zoo_settings_are_rbenv_trains_defaults(algo):
    """One set of settings: the zoo file says what ``rbenv train --algo ALGO`` does."""
    pytest.importorskip("stable_baselines3", reason="stable-baselines3 is not installed "
                        "(train extra)")
    from rbenv.agents.policies.activations import to_classes
    from rbenv.agents.training.config import ZOO_KEYS, TrainConfig, normalize_kwargs

    table = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams
    for env_id, entry in table.items():
        cfg = TrainConfig(algo=algo, env_id=env_id).resolve()
        # rbenv train names an activation (config.json is JSON); the zoo gets its class.
        built = {**cfg.hyperparams, **({"policy_kwargs": to_classes(
            cfg.hyperparams["policy_kwargs"])} if "policy_kwargs" in cfg.hyperparams else {})}
        assert built == {k: v for k, v in entry.items() if k not in ZOO_KEYS}
        assert cfg.n_envs == entry["n_envs"]
        assert cfg.timesteps == entry["n_timesteps"]
        assert cfg.env_kwargs == entry.get("env_kwargs", {})
        assert cfg.normalize == normalize_kwargs(entry["normalize"])
    if algo == "ppo":  # rbenv train wraps the env in VecNormalize, rewards included
        assert cfg.normalize == {"norm_obs": True, "norm_reward": True}
    else:  # off-policy: observations only (issue 22's recipe), torque actions
        assert cfg.normalize == {"norm_obs": True, "norm_reward": False}
        assert cfg.env_kwargs["action_mode"] == "torque"


def _zoo(module: str, *args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_zoo_trains_and_enjoys_with_the_shipped_file(tmp_path):
    pytest.importorskip("rl_zoo3", reason="rl_zoo3 is not installed (ecosystem extra)")
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with rl_zoo3")
    common = ["--algo", "ppo", "--env", rbenv.ENV_ID, "--gym-packages", "rbenv",
              "--device", "cpu", "-f", str(tmp_path / "logs")]
    train = _zoo("rl_zoo3.train", *common, "--conf-file", "rbenv.agents.zoo.ppo",
                 "-n", str(ZOO_STEPS), "--num-threads", "1", "--seed", "0",
                 "--eval-freq", str(ZOO_STEPS), "--eval-episodes", "2", cwd=tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    assert "Using 'default' hyperparameters" not in train.stdout
    run = tmp_path / "logs" / "ppo" / f"{ZOO_NAME}_1"
    name = ZOO_NAME
    assert (run / f"{name}.zip").exists()
    assert (run / name / "vecnormalize.pkl").exists()
    with open(run / name / "config.yml") as f:
        saved = dict(yaml.load(f, Loader=yaml.UnsafeLoader))
    assert (saved["n_envs"], saved["n_steps"], saved["batch_size"]) == \
        (_PPO["n_envs"], _PPO["n_steps"], _PPO["batch_size"])
    assert len(list(run.glob("*.monitor.csv"))) == _PPO["n_envs"]
    header = (run / "0.monitor.csv").read_text().splitlines()[1]
    assert header.split(",") == ["r", "l", "t", "is_success"]

    enjoy = _zoo("rl_zoo3.enjoy", *common, "--exp-id", "1", "-n", "200", "--no-render",
                 cwd=tmp_path)
    assert enjoy.returncode == 0, enjoy.stderr[-3000:]


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["sac", "td3", "tqc", "crossq"])
def test_zoo_trains_off_policy_with_the_shipped_file(tmp_path, algo):
    """The zoo reads each off-policy module: its env options (torque actions), its n_envs and
    its observation-only normalisation. ``learning_starts`` is lowered so a gradient step runs."""
    pytest.importorskip("rl_zoo3", reason="rl_zoo3 is not installed (ecosystem extra)")
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with rl_zoo3")
    train = _zoo("rl_zoo3.train", "--algo", algo, "--env", rbenv.ENV_ID, "--gym-packages",
                 "rbenv", "--device", "cpu", "-f", str(tmp_path / "logs"), "--conf-file",
                 f"rbenv.agents.zoo.{algo}", "-n", str(OFF_POLICY_STEPS), "--num-threads",
                 "1", "--seed", "0", "--eval-freq", "-1", "-params", "learning_starts:256",
                 "gradient_steps:1", "batch_size:64", "buffer_size:4096", cwd=tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    assert "Using 'default' hyperparameters" not in train.stdout
    run = tmp_path / "logs" / algo / f"{ZOO_NAME}_1"
    assert (run / f"{ZOO_NAME}.zip").exists()
    with open(run / ZOO_NAME / "config.yml") as f:
        saved = dict(yaml.load(f, Loader=yaml.UnsafeLoader))
    assert dict(saved["env_kwargs"])["action_mode"] == "torque"
    from rl_zoo3.utils import ALGOS as ZOO_ALGOS

    model = ZOO_ALGOS[algo].load(run / f"{ZOO_NAME}.zip", device="cpu")
    assert model.action_space.shape == (3,)  # the zoo built the torque env, not 12 throttles
    assert model.num_timesteps == OFF_POLICY_STEPS and model._n_updates > 0
    assert saved["n_envs"] == 32
    normalize = {k: v for k, v in dict(saved["normalize"]).items() if k != "gamma"}
    assert normalize == {"norm_obs": True, "norm_reward": False}  # the zoo adds gamma
