"""benchmarks/trade.py --quick: two settings of Reorient-v2's trade knob trained for a few
rollouts through the documented commands, evaluated beside the scripted baselines, the JSON
and the figure written (into tmp_path, never the committed results)."""

from __future__ import annotations

import json

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
    # Every run names its recipe (the main job's) and its weight.
    for row, fuel in zip(data["learned"], (1.0, trade.DEFAULT_FUEL), strict=True):
        assert f'"fuel": {fuel}' in row["train_command"]
        assert '"n_epochs": 5' in row["train_command"] and "--policy-action mode" in \
            row["train_command"]
    # The PD is fully successful on any 20 episodes; its numbers are rbenv evaluate's.
    pd = data["scripted"]["pd"]
    assert pd["success_rate"] == 1.0 and 20 < pd["settle_median_s"] < 60
    assert data["bounds"]["settle_median_s"] == 14.5
    assert (tmp_path / "trade_quick.png").is_file()


def test_the_default_setting_is_the_main_job():
    """At the default fuel weight the trade's command resolves to what ``python -m rbenv
    train`` trains with no arguments: its hyperparameters, budget, reward weights and action."""
    from rbenv.agents.training.config import TrainConfig

    r = trade.TRADE_RECIPE
    cfg = TrainConfig(env_kwargs={"reward_weights": {"time": r["time"],
                                                     "fuel": trade.DEFAULT_FUEL}},
                      hyperparams=r["hyperparams"], timesteps=r["timesteps"],
                      policy_action=r["policy_action"]).resolve()
    main_job = TrainConfig().resolve()
    for field in ("hyperparams", "timesteps", "env_kwargs", "policy_action", "env_id", "scene"):
        assert getattr(cfg, field) == getattr(main_job, field), field
    assert trade.train_command(trade.DEFAULT_FUEL, 0, "out", None)[:1] == ["train"]
