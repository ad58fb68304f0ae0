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
    # The default setting's run is the main job's command, the other names its weight.
    assert "--env-kwargs" in data["learned"][0]["train_command"]
    assert "--env-kwargs" not in data["learned"][1]["train_command"]
    # The PD is fully successful on any 20 episodes; its numbers are rbenv evaluate's.
    pd = data["scripted"]["pd"]
    assert pd["success_rate"] == 1.0 and 20 < pd["settle_median_s"] < 60
    assert data["bounds"]["settle_median_s"] == 14.5
    assert (tmp_path / "trade_quick.png").is_file()


def test_the_default_setting_is_the_env_default():
    from rbenv.tasks.reorient import ReorientV2Weights

    assert trade.DEFAULT_FUEL == ReorientV2Weights().fuel
    assert trade.train_command(trade.DEFAULT_FUEL, 0, "out", None)[:1] == ["train"]
