"""benchmarks/rl/her.py --quick: HER+SAC trains on the goal env, validates, keeps the best
policy, judges it beside the PD on the same held-out episodes, and writes the JSON and
summary.md it promises (into tmp_path, never the committed results)."""

from __future__ import annotations

import json

import pytest

from benchmarks.rl import her

pytest.importorskip("stable_baselines3")


@pytest.fixture
def one_thread(request):
    import torch

    threads = torch.get_num_threads()
    request.addfinalizer(lambda: torch.set_num_threads(threads))


@pytest.mark.slow  # 4 s on an idle machine, over a minute beside two trainings
def test_quick_run_writes_the_json_and_summary(tmp_path, one_thread):
    her.main(["--quick", "--out", str(tmp_path), "--name", "probe"])
    data = json.loads((tmp_path / "probe.json").read_text())
    s, t = data["settings"], data["training"]
    assert s["env_id"] == "rbenv/SatelliteReorientGoal-v1" and s["algo"] == "sac"
    assert s["replay_buffer_class"] == "HerReplayBuffer"
    assert s["her"] == {"goal_selection_strategy": "future", "n_sampled_goal": 4,
                        "copy_info_dict": True}
    assert s["env_kwargs"] == {"action_mode": "torque", "allocator": "pinv"}
    assert s["normalize"] == "observation" and s["threads"] == 1
    assert "use_sde" not in s["model"]["policy_kwargs"]  # the settings given, not SB3's copy
    # The quick budget: 600 env steps (its cap; its clock limit is far), trained after
    # learning_starts.
    assert t["timesteps"] == her.QUICK["timesteps"]
    assert t["gradient_updates"] > 0 and t["steps_per_s"] > 0
    curve = data["curve"]
    assert [p["timesteps"] for p in curve] == [400, 600]
    kept = t["kept"]
    assert kept["timesteps"] in (400, 600) and kept["last"]["timesteps"] == 600
    best = max(curve, key=lambda p: (p["success_rate"], p["mean_return"]))
    assert kept["timesteps"] == best["timesteps"]
    trained, pd = data["held_out"]
    assert trained["policy"] == "sac+her" and pd["policy"] == "pd"
    for r in (trained, pd):
        assert r["episodes"] == her.QUICK["held_out_episodes"] and r["seed"] == 1_000_000
        assert 0.0 <= r["success_rate"] <= 1.0 and r["fuel"]["mean"] > 0
    assert pd["success_rate"] == 1.0  # the PD settles these episodes; 600 steps of SAC do not
    assert data["load_average_during_training"]["samples"] >= 2
    assert len(data["observation_statistics_of_kept_policy"]["std"]) == 12
    assert data["versions"]["stable_baselines3"]
    assert data["command"].startswith("python -m benchmarks.rl.her --quick")
    table = (tmp_path / "summary.md").read_text()
    assert "| probe | sac+HER | flat | copy | 600 |" in table
    assert "| PD, Reorient-v1 (same 6 episodes" in table


def test_unknown_arguments_and_quick_without_out_are_refused(capsys):
    for argv in (["--no-such-option"], ["--quick"], ["--algo", "td3"]):
        with pytest.raises(SystemExit) as e:
            her.main(argv)
        assert e.value.code == 2, argv
    assert "--quick needs --out" in capsys.readouterr().err


def test_run_episodes_meets_the_pd_episodes_seed_for_seed():
    """The goal env's episode 1,000,000 + i is the PD's: zero torque gives v1's errors."""
    import gymnasium as gym
    import numpy as np

    res = her.run_episodes(lambda obs: np.zeros((len(obs["observation"]), 3), np.float32),
                           range(her.HELD_OUT_SEED, her.HELD_OUT_SEED + 2),
                           {"action_mode": "torque", "allocator": "pinv"})
    for i, final in enumerate(res["final_error_deg"]):
        env = gym.make(her.PLAIN_ID, scene=her.SCENE, action_mode="torque", allocator="pinv")
        env.reset(seed=her.HELD_OUT_SEED + i)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(np.zeros(3, np.float32))
            done = term or trunc
        assert final == info["attitude_error_deg"]
    assert res["success"].tolist() == [0.0, 0.0] and np.isnan(res["settle_time_s"]).all()
