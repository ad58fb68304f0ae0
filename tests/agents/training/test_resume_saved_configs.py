"""Run folders written by main at 8ef0698, before the recipes, resume: their config.json
(data/config_<engine>_8ef0698.json, written by that commit's resolve()) reads back as the same
run; a TorchRL run's hyperparams, saved in TorchRL's names, are read in RL Zoo's."""

from __future__ import annotations

import json
import shutil
from dataclasses import asdict
from pathlib import Path

import pytest
from rbenv.agents.policies.runfolder import RunFolderError
from rbenv.agents.training.config import TorchRLRunConfig, TrainConfig, resumed_config

DATA = Path(__file__).parent / "data"


def _run(tmp_path: Path, name: str) -> tuple[Path, dict]:
    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(DATA / name, run / "config.json")
    return run, json.loads((DATA / name).read_text())


def test_an_sb3_run_of_main_resumes_with_its_own_settings(tmp_path):
    run, saved = _run(tmp_path, "config_sb3_8ef0698.json")
    cfg = resumed_config(TrainConfig, run, {"timesteps": 700_000})
    got = asdict(cfg)
    assert got["timesteps"] == 700_000 and got["out"] == str(run)
    for name, value in saved.items():
        if name not in ("versions", "timesteps", "out"):
            assert json.loads(json.dumps(got[name])) == value, name


def test_a_run_resumes_with_its_own_env_options_after_the_recipe_changed(tmp_path):
    """A Reorient-v1 run started when its cubesat-12u recipe had no reward weights (recipe env
    options taken, none then) resumes on the env it trained on, not the recipe's weights of
    today; a run that has them keeps them."""
    cfg = TrainConfig(env_id="rbenv/SatelliteReorient-v1", out=str(tmp_path)).resolve()
    today = cfg.env_kwargs
    assert cfg.recipe_env_kwargs and today["reward_weights"]["fuel"] == 2.0
    for saved in ({}, today, {"reward_weights": {"fuel": 1.5}}):
        (tmp_path / "config.json").write_text(json.dumps({**asdict(cfg), "env_kwargs": saved}))
        assert resumed_config(TrainConfig, tmp_path).env_kwargs == saved


def test_a_torchrl_run_of_main_resumes_with_its_hyperparams_in_zoo_names(tmp_path):
    pytest.importorskip("torch", reason="the torch env needs torch (ecosystem extra)")
    run, saved = _run(tmp_path, "config_torchrl_8ef0698.json")
    old = saved["hyperparams"]
    assert "rollout" in old and "hidden" in old  # TorchRL's names, as main saved them
    cfg = resumed_config(TorchRLRunConfig, run)
    assert cfg.hyperparams == {"n_envs": old["num_envs"], "n_steps": old["rollout"],
                               "batch_size": old["minibatch"], "n_epochs": old["epochs"],
                               "learning_rate": old["lr"], "gamma": old["gamma"],
                               "gae_lambda": old["lmbda"], "clip_range": old["clip"],
                               "policy_kwargs": {"net_arch": [old["hidden"]] * 2,
                                                 "log_std_init": old["log_std_init"]},
                               "compile": old["compile"]}
    learner = asdict(cfg.learner("cpu"))
    assert {k: learner[k] for k in old} == old  # the same learner as the run trained with
    assert old["gamma"] == 0.97  # the run's own, not the recipe's 0.98
    for name in ("timesteps", "eval_every", "eval_episodes", "stop_success", "seed", "scene"):
        assert getattr(cfg, name) == saved[name], name


def test_a_saved_torchrl_config_with_an_unknown_learner_name_is_named(tmp_path):
    run, saved = _run(tmp_path, "config_torchrl_8ef0698.json")
    saved["hyperparams"]["rollouts"] = 3
    (run / "config.json").write_text(json.dumps(saved))
    with pytest.raises(RunFolderError, match=r"config.json.*\['rollouts'\]"):
        resumed_config(TorchRLRunConfig, run)


def test_a_torchrl_run_of_main_on_a_wheel_scene_resumes_without_the_recipes_env_options(tmp_path):
    """Main's TorchRL runs trained without the recipe's env options (the failure weight on
    cubesat-6u-rw): resumed, they keep training in the env they were trained in, while a new
    run on that scene takes them."""
    pytest.importorskip("torch", reason="the torch env needs torch (ecosystem extra)")
    run, saved = _run(tmp_path, "config_torchrl_8ef0698.json")
    saved.update(env_id="rbenv/SatelliteReorient-v0", scene="cubesat-6u-rw", env_kwargs={})
    (run / "config.json").write_text(json.dumps(saved))
    resumed = resumed_config(TorchRLRunConfig, run)
    assert resumed.env_kwargs == {} and resumed.recipe_env_kwargs is False
    new = TorchRLRunConfig(env_id="rbenv/SatelliteReorient-v0", scene="cubesat-6u-rw").resolve()
    assert new.env_kwargs == {"reward_weights": {"failure": 200.0}}
    assert new.recipe_env_kwargs is True
