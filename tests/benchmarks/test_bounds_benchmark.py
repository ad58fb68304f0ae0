"""``python -m benchmarks.bounds --quick``: every file written, no episode below a bound."""

from __future__ import annotations

import json

import pytest

from benchmarks import bounds as bench


@pytest.mark.slow  # the --quick benchmark, about a minute
def test_benchmark_quick_smoke(tmp_path):
    data = bench.main(["--quick", "--out", str(tmp_path)])
    for name in ("bounds.json", "bounds.md", "bounds.png"):
        assert (tmp_path / name).stat().st_size > 0
    saved = json.loads((tmp_path / "bounds.json").read_text())
    # The suite's PPO policy is evaluated when its (uncommitted) run folder is present.
    trained = bench.trained_seeds([0]) == [0]
    assert set(saved["policies"]) == {"pd", "bangbang"} | ({"ppo seed 0"} if trained else set())
    assert saved["missing_ppo_seeds"] == ([] if trained else [0])
    assert all(v == 0 for counts in saved["violations"].values() for v in counts.values())
    for r in data["policies"].values():
        assert r["settle_ratio"]["min"] >= 1.0
    (spot,) = data["optimal"]
    assert spot["time_optimal"]["success"]
    assert spot["time_optimal"]["settle_time_s"] >= spot["settle_bound_s"]
    assert "| pd |" in (tmp_path / "bounds.md").read_text()


@pytest.mark.slow  # 20 episodes of each baseline, a few seconds
def test_v1_quick_compares_on_v0_episodes_and_writes_its_own_table(tmp_path):
    empty = tmp_path / "no-suite"  # no trained policy: the baselines alone, PPO reported missing
    data = bench.main(["--v1", "--quick", "--suite", str(empty), "--out", str(tmp_path)])
    saved = json.loads((tmp_path / "bounds.json").read_text())
    assert saved["env_id"] == bench.V1 and saved["missing_ppo_seeds"] == [0]
    assert set(saved["policies"]) == {"pd", "bangbang"} and data["optimal"] == []
    assert all(v == 0 for counts in saved["violations"].values() for v in counts.values())
    assert "Policies of rbenv/SatelliteReorient-v1" in (tmp_path / "bounds.md").read_text()


def test_v1_refuses_episodes_that_differ_from_v0s():
    from rbenv.agents.baselines import bounds as rb

    v0 = rb.episode_starts(3, 7, bench.SCENE)
    bench.check_same_episodes(v0, rb.episode_starts(3, 7, bench.SCENE, env_id=bench.V1),
                              bench.V1)
    other = rb.episode_starts(3, 8, bench.SCENE, env_id=bench.V1)
    with pytest.raises(ValueError, match="starts other episodes"):
        bench.check_same_episodes(v0, other, bench.V1)


@pytest.mark.parametrize("argv, message", [
    (["--run", "a=/x"], "--run needs --v1"),
    (["--v1", "--run", "noequals"], "NAME=RUN_FOLDER"),
    (["--v1", "--run", "pd=/x"], "used twice"),
    (["--v1", "--run", "a=/x", "--run", "a=/y"], "used twice"),
])
def test_bad_run_options_exit_with_a_message(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main(argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_a_run_folder_without_a_policy_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"no policy\.pt"):
        bench.run_policy("sac", tmp_path)
