"""rbenv train --engine torchrl: the batched TorchRL adapter passes check_env_specs, partial
resets through "_reset" reach the torch env, and the quick CLI form trains end to end (a smoke
run: its success rate is not asserted; the full run's is in docs/torch.md)."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("torchrl", reason="torchrl is not installed (ecosystem extra)")
import torch
from rbenv.agents import cli
from rbenv.agents.training.torchrl import RbenvTorchRLEnv
from torchrl.envs.utils import check_env_specs


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


def test_quick_cli_trains_and_writes_its_record(tmp_path):
    assert cli.main(["train", "--engine", "torchrl", "--device", "cpu", "--quick",
                     "--out", str(tmp_path)]) == 0
    record = json.loads((tmp_path / "torchrl.json").read_text())
    assert record["samples"] >= 16_384 and 0.0 <= record["held_out_success"] <= 1.0
    assert record["config"]["device"] == "cpu"


def test_cli_refuses_device_without_torchrl():
    with pytest.raises(ValueError, match="belongs to --engine torchrl, not to --engine sb3"):
        cli.main(["train", "--device", "cuda", "--timesteps", "10"])


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
