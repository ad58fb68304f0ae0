"""rbenv train --engine torchrl: the batched TorchRL adapter passes check_env_specs, partial
resets through "_reset" reach the torch env, the saved SB3 policy acts as the trained actor,
and a run has the run folder of the other engines: checkpoints, resume (from the newest usable
checkpoint), the periodic evaluation and --stop-success, the report (smoke runs: success rates
are not asserted; the full run's is in docs/torch.md)."""

from __future__ import annotations

import json
import shutil

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("torchrl", reason="torchrl is not installed (ecosystem extra)")
import torch
from rbenv.agents import cli
from rbenv.agents.policies import load_policy
from rbenv.agents.policies.sb3 import expected_throttle
from rbenv.agents.training.config import TORCHRL_HYPERPARAMS, TorchRLRunConfig
from rbenv.agents.training.engine import run as engine_run
from rbenv.agents.training.torchrl import (
    Learner,
    RbenvTorchRLEnv,
    TorchRLConfig,
    TorchRLSession,
    save_policy,
)
from tensordict import TensorDict
from torchrl.envs.utils import check_env_specs

import rbenv


def test_the_adapter_passes_check_env_specs():
    check_env_specs(RbenvTorchRLEnv(num_envs=4, seed=1))


def test_partial_reset_restarts_only_the_masked_sub_envs():
    env = RbenvTorchRLEnv(num_envs=3, seed=2, max_episode_steps=2)
    td = env.reset()
    first = td["observation"].clone()
    for _ in range(2):
        td = env.step(td.set("action", torch.zeros(3, 12)))["next"]
    assert td["truncated"].all()
    mask = torch.tensor([[True], [False], [True]])
    out = env.reset(td.set("_reset", mask))
    # Reset rows start their second episode; the other keeps its current observation.
    assert not torch.equal(out["observation"][0], first[0])
    assert torch.equal(out["observation"][1], td["observation"][1])


@pytest.mark.slow
def test_quick_cli_writes_a_run_folder_that_loads_as_a_policy(tmp_path):
    out = tmp_path / "run"
    assert cli.main(["train", "--engine", "torchrl", "--device", "cpu", "--quick",
                     "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["engine"] == "torchrl" and config["timesteps"] == 16_384
    assert config["report_episodes"] == 50
    assert set(config["hyperparams"]) == set(TORCHRL_HYPERPARAMS)
    summary = json.loads((out / "training.json").read_text())
    assert summary["timesteps"] == 16_384 and summary["device"] == "cpu"
    hp = config["hyperparams"]
    batch = hp["n_envs"] * hp["n_steps"]
    assert summary["gradient_updates"] == \
        16_384 // batch * hp["n_epochs"] * -(-batch // hp["batch_size"])
    report = (out / "report.md").read_text()
    assert "ppo (TorchRL)" in report and "| pd |" in report
    policy = load_policy(out)
    assert policy.predict(policy.make_env().reset(seed=0)[0])[0].shape == (12,)
    assert not list(out.rglob("*.pkl")) and not list(out.rglob("*.zip"))
    if shutil.which("cc"):  # export verifies the C policy against the run's predict
        assert cli.main(["export", str(out), "--format", "c", "--out", str(tmp_path / "c")]) == 0
        record = json.loads((tmp_path / "c" / "export.json").read_text())
        assert record["output_stage"] == "mean_throttle" and record["timesteps"] == 16_384
        assert record["check"]["max_error_of_range"]["c"] < record["check"]["tolerance"]


def _learner(**over) -> Learner:
    cfg = TorchRLConfig(num_envs=8, rollout=16, minibatch=64, epochs=2, hidden=16,
                        timesteps=256, **over)
    return Learner(cfg)


def test_the_saved_policy_acts_values_and_normalises_as_the_trained_modules(tmp_path):
    learner = _learner()
    for _ in learner.batches(256):  # two updates: weights and statistics away from their start
        pass
    save_policy(learner, tmp_path / "policy.pt", tmp_path / "obs_stats.npz", 256)
    policy = load_policy(tmp_path / "policy.pt", action="mode")
    obs = np.stack([gym.make(rbenv.ENV_ID).reset(seed=s)[0] for s in range(5)])
    x = torch.as_tensor(obs, dtype=torch.float32)
    with torch.no_grad():
        loc, scale = learner.actor.module[0].module(x)
        value = learner.critic(TensorDict({"observation": x}, [5]))["state_value"]
    action, _ = policy.predict(obs)
    np.testing.assert_allclose(action, np.clip(loc.numpy(), -1, 1), atol=1e-5)  # SB3's clip
    space = gym.make(rbenv.ENV_ID).action_space
    assert policy.model.action_space == space and policy.model.observation_space.dtype == \
        np.float32
    sb3 = policy.model.policy
    with torch.no_grad():
        ours = sb3.predict_values(torch.as_tensor(policy.normalize(obs)))
    np.testing.assert_allclose(ours.numpy(), value.numpy(), atol=1e-5)
    np.testing.assert_allclose(sb3.log_std.exp().detach().numpy(), scale[0].numpy(), rtol=1e-6)
    throttle = load_policy(tmp_path / "policy.pt").predict(obs)[0]  # auto: the mean throttle
    np.testing.assert_allclose(throttle, expected_throttle(loc.numpy(), scale.numpy()),
                               atol=1e-5)


@pytest.mark.slow
def test_resume_restores_the_learner_and_goes_on_counting(tmp_path):
    out = tmp_path / "run"
    args = ["train", "--engine", "torchrl", "--out", str(out), "--hyperparams", json.dumps(
        {"n_envs": 8, "n_steps": 16, "batch_size": 64, "n_epochs": 2,
         "policy_kwargs": {"net_arch": [16, 16]}}),
            "--checkpoint-every", "128", "--eval-every", "256", "--eval-episodes", "4",
            "--no-report", "--no-progress"]
    assert cli.main([*args, "--timesteps", "256"]) == 0
    state = torch.load(out / "checkpoints" / "policy_256.torchrl.pt", weights_only=True)
    assert state["samples"] == 256 and state["updates"] == 2 * 2 * 2
    assert (out / "checkpoints" / "policy_128.torchrl.pt").is_file()
    assert cli.main([*args, "--timesteps", "512", "--resume"]) == 0
    summary = json.loads((out / "training.json").read_text())
    assert summary["resumed_from"] == 256 and summary["timesteps"] == 512
    assert summary["gradient_updates"] == 2 * state["updates"]
    adam = torch.load(out / "checkpoints" / "policy_512.torchrl.pt", weights_only=True)
    steps = {float(s["step"]) for s in adam["optimizer"]["state"].values()}
    assert steps == {16.0}  # Adam's moments went on from the checkpoint's 8 steps
    counts = [v for k, v in adam["actor"].items() if k.endswith("count")]
    assert [float(c) for c in counts] == [pytest.approx(512, abs=1e-3)]  # the normaliser too
    with np.load(out / "eval" / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [256, 512]
        assert log["successes"].shape == (2, 4)


def test_resume_skips_a_corrupt_newest_checkpoint(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["train", "--engine", "torchrl", "--out", str(out), "--hyperparams", json.dumps(
        {"n_envs": 8, "n_steps": 16, "batch_size": 128, "n_epochs": 1,
         "policy_kwargs": {"net_arch": [8, 8]}}),
            "--checkpoint-every", "128", "--no-report", "--no-progress"]
    assert cli.main([*args, "--timesteps", "256"]) == 0
    (out / "checkpoints" / "policy_256.torchrl.pt").write_bytes(b"not a checkpoint")
    assert cli.main([*args, "--timesteps", "384", "--resume"]) == 0
    printed = capsys.readouterr().out
    assert "checkpoint at 256 timesteps is unusable" in printed
    assert "from 128 timesteps" in printed
    assert json.loads((out / "training.json").read_text())["resumed_from"] == 128


def test_stop_success_ends_the_run_on_the_policy_it_evaluated(tmp_path, monkeypatch):
    import rbenv.agents.training.torchrl as trl

    def all_succeed(actor, cfg, env_kwargs, episodes, seed):
        assert seed == 3 + trl.VALIDATION_SEED_OFFSET  # the validation episodes, not the report's
        return {"results": [0.0] * episodes, "ep_lengths": [1] * episodes,
                "successes": [True] * episodes}

    monkeypatch.setattr(trl, "evaluate_episodes", all_succeed)
    out = tmp_path / "run"
    cfg = TorchRLRunConfig(out=str(out), seed=3, timesteps=1024, eval_every=256, eval_episodes=5,
                           stop_success=1.0, hyperparams={"n_envs": 8, "n_steps": 16,
                                                          "batch_size": 128, "n_epochs": 1})
    engine_run(cfg, trl.TorchRLSession(progress=False), report=False)
    summary = json.loads((out / "training.json").read_text())
    assert summary["timesteps"] == 256
    assert summary["stopped_at_success"] == {"timesteps": 256, "success_rate": 1.0,
                                             "episodes": 5}
    assert json.loads((out / "policy.json").read_text())["num_timesteps"] == 256


def test_cli_refuses_device_without_torchrl():
    with pytest.raises(ValueError, match="belongs to --engine torchrl, not to --engine sb3"):
        cli.main(["train", "--device", "cuda", "--timesteps", "10"])


@pytest.mark.slow
def test_bench_env_speed_torch_quick_writes_json_and_png(tmp_path):
    """CI's form of ``rbenv bench env_speed --backend torch``: eager torch against NumPy at
    two sizes, memory, float32's cost, training throughput; JSON and PNG written."""
    assert cli.main(["bench", "env_speed", "--backend", "torch", "--device", "cpu", "--quick",
                     "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "torch_env_speed_cpu_quick.json").read_text())
    assert (tmp_path / "torch_env_speed_cpu_quick.png").is_file()
    cases = {r["case"] for r in data["speed"]}
    assert {"torch eager off N=4096", "numpy off N=4096", "torch eager reset-heavy N=1024"} \
        <= cases
    assert all(r["env_steps_per_s"] > 0 for r in data["speed"])
    assert data["memory"]["bytes_per_sub_env"] > 0
    assert 0 < data["float32_accuracy"]["obs_gap_max"] < 1e-3
    assert data["training"]["samples"] >= 16_384


@pytest.mark.slow
def test_checkpoints_and_evaluations_leave_the_training_as_it_is(tmp_path):
    """A run's weights do not depend on how often it is checkpointed or evaluated (saving the
    SB3 policy draws SB3's initial weights, outside the run's random numbers)."""
    hyperparams = {"n_envs": 8, "n_steps": 16, "batch_size": 64, "n_epochs": 2,
                   "policy_kwargs": {"net_arch": [16, 16]}}
    finals = []
    for every in (128, 10**9):
        out = tmp_path / f"every{every}"
        cfg = TorchRLRunConfig(out=str(out), timesteps=512, hyperparams=hyperparams,
                               checkpoint_every=every, eval_every=every, eval_episodes=4,
                               stop_success=0.0)
        engine_run(cfg, TorchRLSession(progress=False), report=False)
        finals.append(torch.load(out / "checkpoints" / "policy_512.torchrl.pt",
                                 weights_only=True)["actor"])
    assert finals[0].keys() == finals[1].keys()
    assert all(torch.equal(finals[0][k], finals[1][k]) for k in finals[0])


@pytest.mark.parametrize("device", ["gpu", "cuda:99", "mps"])
def test_a_device_this_machine_lacks_is_named_before_anything_is_written(device, tmp_path,
                                                                         capsys):
    if device == "mps" and torch.backends.mps.is_available():
        pytest.skip("this machine has mps")
    assert cli.console(["train", "--engine", "torchrl", "--device", device, "--out",
                        str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rbenv train: error: device") and repr(device) in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "run").exists()
