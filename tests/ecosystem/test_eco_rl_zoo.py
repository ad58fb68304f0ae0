"""RL Baselines3 Zoo with the hyperparameters rbenv ships (``--conf-file rbenv.hyperparams.ppo``).

A tiny budget (one PPO rollout of 64 envs x 64 steps) through the zoo's real command line:
``rl_zoo3.train`` must pick up rbenv's settings, not its ``default:`` entry, and ``rl_zoo3.enjoy``
must load and run what it saved.
"""

from __future__ import annotations

import os
import subprocess
import sys

import gymnasium as gym
import pytest

import rbenv
from rbenv.hyperparams import ppo

ZOO_STEPS = 4096  # exactly one rollout of the shipped settings: 64 envs x n_steps 64


def test_every_registered_id_has_zoo_settings():
    ours = sorted(env_id for env_id in gym.registry if env_id.startswith("rbenv/"))
    assert rbenv.ENV_ID in ours
    missing = [env_id for env_id in ours if env_id not in ppo.hyperparams]
    assert not missing, f"add {missing} to rbenv/hyperparams/ppo.py"


def test_zoo_settings_are_rbenv_trains_ppo_defaults():
    """One set of PPO settings: the zoo file and ``rbenv train`` both read the registry entry,
    which points at rbenv.hyperparams.tuned.PPO."""
    pytest.importorskip("stable_baselines3", reason="stable-baselines3 is not installed "
                        "(train extra)")
    from agents.train import ZOO_ONLY, TrainConfig
    from rbenv.hyperparams import tuned

    for env_id, settings in ppo.hyperparams.items():
        assert rbenv.registry.get(env_id).hyperparams["ppo"] is tuned.PPO
        assert settings == tuned.PPO, env_id
        cfg = TrainConfig(env_id=env_id).resolve()
        assert cfg.hyperparams == {k: v for k, v in settings.items() if k not in ZOO_ONLY}
        assert cfg.n_envs == settings["n_envs"]
        assert cfg.timesteps == settings["n_timesteps"]
        assert settings["normalize"] is True  # rbenv train wraps the env in VecNormalize


def _zoo(module: str, *args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_zoo_trains_and_enjoys_with_the_shipped_file(tmp_path):
    pytest.importorskip("rl_zoo3", reason="rl_zoo3 is not installed (ecosystem extra)")
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with rl_zoo3")
    common = ["--algo", "ppo", "--env", rbenv.ENV_ID, "--gym-packages", "rbenv",
              "--device", "cpu", "-f", str(tmp_path / "logs")]
    train = _zoo("rl_zoo3.train", *common, "--conf-file", "rbenv.hyperparams.ppo",
                 "-n", str(ZOO_STEPS), "--num-threads", "1", "--seed", "0",
                 "--eval-freq", str(ZOO_STEPS), "--eval-episodes", "2", cwd=tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    assert "Using 'default' hyperparameters" not in train.stdout
    run = tmp_path / "logs" / "ppo" / "rbenv-SatelliteReorient-v0_1"
    name = "rbenv-SatelliteReorient-v0"
    assert (run / f"{name}.zip").exists()
    assert (run / name / "vecnormalize.pkl").exists()
    with open(run / name / "config.yml") as f:
        saved = dict(yaml.load(f, Loader=yaml.UnsafeLoader))
    assert saved["n_envs"] == 64 and saved["n_steps"] == 64 and saved["batch_size"] == 1024
    assert len(list(run.glob("*.monitor.csv"))) == 64
    header = (run / "0.monitor.csv").read_text().splitlines()[1]
    assert header.split(",") == ["r", "l", "t", "is_success"]

    enjoy = _zoo("rl_zoo3.enjoy", *common, "--exp-id", "1", "-n", "200", "--no-render",
                 cwd=tmp_path)
    assert enjoy.returncode == 0, enjoy.stderr[-3000:]
