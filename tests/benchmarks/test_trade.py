"""benchmarks/trade.py --quick: two settings of Reorient-v2's trade knob trained for a few
rollouts through the documented commands, evaluated beside the scripted baselines, the JSON
and the figure written (into tmp_path, never the committed results)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks import common, trade

pytest.importorskip("stable_baselines3")


@pytest.mark.slow  # two 8192-step trainings and five 20-episode evaluations, in subprocesses
def test_quick_run_writes_the_trade(tmp_path, monkeypatch):
    monkeypatch.setattr(common, "RESULTS", tmp_path)
    monkeypatch.setattr(trade, "RESULTS", tmp_path)
    trade.main(["--quick", "--runs", str(tmp_path / "runs")])
    data = json.loads((tmp_path / "trade_quick.json").read_text())
    assert data["env_id"] == "rbenv/SatelliteReorient-v2" and data["episodes"] == 20
    assert [r["fuel_weight"] for r in data["learned"]] == [1.0, trade.DEFAULT_FUEL]
    for row in data["learned"]:
        assert row["timesteps"] >= 8192 and row["train_cpu_s"] > 0
        assert 0.0 <= row["success_rate"] <= 1.0 and row["fuel_mean_g"] >= 0.0
    # Every run names its recipe (the main job's before 1.8 M steps shipped) and its weight.
    for row, fuel in zip(data["learned"], (1.0, trade.DEFAULT_FUEL), strict=True):
        assert f'"fuel": {fuel}' in row["train_command"]
        assert '"n_epochs": 3' in row["train_command"] and "--policy-action auto" in \
            row["train_command"]
    # The PD is fully successful on any 20 episodes; its numbers are rbenv evaluate's.
    pd = data["scripted"]["pd"]
    assert pd["success_rate"] == 1.0 and 20 < pd["settle_median_s"] < 60
    assert data["bounds"]["settle_median_s"] == 14.5
    assert (tmp_path / "trade_quick.png").is_file()


def test_the_default_setting_is_the_env_default_and_the_recipe_the_old_main_jobs():
    """With the trade's recipe and the env's fuel weight, a run resolves to what the main job
    trained at 1108ccd (8ef0698's resolution, the golden file of the settings tests)."""
    import copy

    from rbenv.agents.training.config import TrainConfig

    from rbenv.tasks.reorient import ReorientV2Weights

    assert trade.DEFAULT_FUEL == ReorientV2Weights().fuel
    assert trade.TRADE_RECIPE["time"] == ReorientV2Weights().time
    r = copy.deepcopy(trade.TRADE_RECIPE)
    cfg = TrainConfig(env_kwargs={"reward_weights": {"time": r["time"], "fuel": 1.5}},
                      hyperparams=r["hyperparams"], timesteps=r["timesteps"],
                      policy_action=r["policy_action"]).resolve()
    golden = json.loads((Path(__file__).parents[1] / "agents" / "settings" / "data" /
                         "resolution_8ef0698.json").read_text())[
        "sb3/ppo/rbenv/SatelliteReorient-v2/cubesat-12u"]
    assert cfg.hyperparams == golden["hyperparams"] and cfg.timesteps == golden["timesteps"]
    assert trade.train_command(trade.DEFAULT_FUEL, 0, "out", None)[:1] == ["train"]
