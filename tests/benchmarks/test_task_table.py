"""benchmarks/task_table.py: the verdict's rule on made-up figures, and --quick on one id (a
tiny PPO through ``rbenv train``, 10 episodes) into tmp_path, its JSON checked against the
schema and its verdict recomputed from its own numbers."""

from __future__ import annotations

import json

import pytest

from benchmarks import task_table


def fig(success, time, cost):
    return {"success_rate": success, "time": time, "cost": cost, "final_error_deg": 0.5}


def test_the_best_baseline_is_the_most_successful_then_the_fastest_then_the_cheapest():
    assert task_table.best_baseline({"a": fig(0.9, 10.0, 1.0), "b": fig(1.0, 30.0, 2.0)}) == "b"
    assert task_table.best_baseline({"a": fig(1.0, 20.0, 1.0), "b": fig(1.0, 19.0, 2.0)}) == "b"
    assert task_table.best_baseline({"a": fig(1.0, 20.0, 1.0), "b": fig(1.0, 20.0, 2.0)}) == "a"
    # A baseline without a settle time (no success) ranks below a measured one.
    assert task_table.best_baseline({"a": fig(0.0, None, 0.1), "b": fig(0.0, 50.0, 9.0)}) == "b"


@pytest.mark.parametrize(("policy", "expected"), [
    (fig(1.0, 20.0, 1.0), True),    # faster and cheaper
    (fig(1.0, 25.0, 1.0), True),    # as fast, cheaper
    (fig(1.0, 20.0, 1.5), True),    # faster, as cheap
    (fig(1.0, 25.0, 1.5), False),   # equal on both: not better on either
    (fig(1.0, 20.0, 1.6), False),   # faster but dearer
    (fig(0.99, 10.0, 0.5), False),  # less successful
    (fig(1.0, None, 0.5), False),   # no settle time measured
])
def test_the_verdict_needs_success_one_better_measure_and_none_worse(policy, expected):
    base = fig(1.0, 25.0, 1.5)
    assert task_table.beats(policy, base) is expected
    v = task_table.verdict([{**policy, "seed": 0}], {"pd": base}, "pd")
    assert v["pass"] is expected and v["per_seed"] == [expected]
    assert (v["text"] == "passes") is expected


def test_without_a_time_measure_cost_alone_decides():
    base = fig(1.0, None, 0.85)
    assert task_table.beats(fig(1.0, None, 0.80), base)
    assert not task_table.beats(fig(1.0, None, 0.90), base)


def test_a_row_passes_only_when_every_seed_does():
    base = {"pd": fig(1.0, 25.0, 1.5)}
    runs = [{**fig(1.0, 20.0, 1.0), "seed": 0}, {**fig(1.0, 30.0, 1.0), "seed": 1}]
    v = task_table.verdict(runs, base, "pd")
    assert v == {"pass": False, "per_seed": [True, False],
                 "text": "fails against pd (seed 1: time 30 > 25)"}


def test_default_scenes_are_the_tasks_own():
    from rbenv.envs import registry

    assert registry.get("rbenv/SatelliteDesaturate-v0").scene == "cubesat-6u-rw"
    assert registry.get("rbenv/SatelliteTrack-v1").scene == "cubesat-12u"
    assert task_table.slug("rbenv/SatelliteTrack-v1", "cubesat-12u") == "track-v1-cubesat-12u"


@pytest.mark.slow  # an 8192-step PPO training in a subprocess and 10-episode evaluations
def test_quick_run_writes_the_row_and_merges_the_folder(tmp_path):
    pytest.importorskip("stable_baselines3")
    other = {"env_id": "rbenv/SatelliteReorient-v2", "scene": "cubesat-12u",
             "command": "python -m rbenv train", "episodes": 500, "seed": 1_000_000,
             "time_measure": task_table.SETTLE, "cost_measure": task_table.PROPELLANT,
             "policy": {"algo": "ppo", "runs": [{**fig(1.0, 20.0, 1.2), "seed": 0}]},
             "baselines": {"pd": fig(1.0, 37.8, 1.36)}, "best_baseline": "pd",
             "verdict": {"pass": True, "per_seed": [True], "text": "passes"}}
    (tmp_path / "reorient.json").write_text(json.dumps({"rows": [other]}))
    env_id = "rbenv/SatelliteDetumble-v1"
    task_table.main(["--quick", "--ids", env_id, "--out", str(tmp_path),
                     "--runs", str(tmp_path / "runs")])
    data = json.loads((tmp_path / "detumble.json").read_text())
    assert data["benchmark"] == "task_table/detumble"
    (row,) = data["rows"]
    assert row["env_id"] == env_id and row["scene"] == "cubesat-12u"
    assert row["episodes"] == task_table.QUICK_EPISODES and row["seed"] == 1_000_000
    assert row["command"] == f"python -m benchmarks.task_table --ids {env_id}"
    assert row["time_measure"] == task_table.SETTLE
    assert row["cost_measure"] == task_table.PROPELLANT
    (run,) = row["policy"]["runs"]
    assert run["seed"] == 0 and run["timesteps"] >= task_table.QUICK_TIMESTEPS
    assert run["training_cpu_s"] > 0
    assert (tmp_path / "runs" / "detumble-v1-cubesat-12u-seed0" / "training.json").is_file()
    # Detumble's baselines on a thruster scene: rate damping (B-dot needs magnetorquers).
    assert set(row["baselines"]) == {"pd"}
    pd = row["baselines"]["pd"]
    assert pd["success_rate"] == 1.0 and pd["time"] > 0 and pd["cost"] > 0
    # The verdict follows from the numbers: recomputed here from the rule in words.
    ok = (run["success_rate"] >= pd["success_rate"]
          and run["time"] is not None and run["cost"] is not None
          and ((run["time"] < pd["time"] and run["cost"] <= pd["cost"])
               or (run["cost"] < pd["cost"] and run["time"] <= pd["time"])))
    assert row["best_baseline"] == "pd"
    assert row["verdict"]["pass"] is ok and row["verdict"]["per_seed"] == [ok]
    # The table holds every JSON's rows of the folder, its own and the other file's.
    table = (tmp_path / "table.md").read_text().splitlines()
    assert len(table) == 4
    assert "SatelliteDetumble-v1" in table[2] and "SatelliteReorient-v2" in table[3]
    assert ("passes" in table[2]) is ok and "passes" in table[3]
    # A second run reuses the finished training and keeps the other file's row.
    task_table.main(["--quick", "--ids", env_id, "--out", str(tmp_path),
                     "--runs", str(tmp_path / "runs")])
    again = json.loads((tmp_path / "detumble.json").read_text())["rows"][0]
    assert again["policy"]["runs"][0]["training_cpu_s"] == run["training_cpu_s"]
    assert again["policy"]["runs"][0]["success_rate"] == run["success_rate"]


def test_table_only_merges_every_json_of_the_folder_without_training(tmp_path):
    def row(env_id, runs, ok):
        return {"env_id": env_id, "scene": "cubesat-12u", "command": f"cmd {env_id}",
                "episodes": 500, "seed": 1_000_000, "time_measure": task_table.SETTLE,
                "cost_measure": task_table.PROPELLANT,
                "policy": {"algo": "ppo", "runs": runs}, "baselines": {"pd": fig(1.0, 2.0, 0.67)},
                "best_baseline": "pd",
                "verdict": {"pass": ok, "per_seed": [ok] * len(runs), "text": "x"}}
    runs = [{**fig(1.0, 1.5, 0.41), "seed": 0}, {**fig(1.0, 2.0, 0.45), "seed": 1}]
    (tmp_path / "a.json").write_text(json.dumps({"rows": [row("rbenv/B-v0", runs, True)]}))
    (tmp_path / "b.json").write_text(json.dumps({"rows": [row("rbenv/A-v1", runs[:1], False)]}))
    task_table.main(["--table-only", "--out", str(tmp_path), "--runs", str(tmp_path / "runs")])
    lines = (tmp_path / "table.md").read_text().splitlines()
    assert not (tmp_path / "runs").exists()
    assert lines[2].startswith("| A-v1 |") and "**fails** (0/1 seeds pass)" in lines[2]
    assert lines[3].startswith("| B-v0 |") and "| passes |" in lines[3]
    # The policy's figures are ranges over its seeds.
    assert "| 100.0 % (0,1) | 1.5–2.0 | 0.41–0.45 |" in lines[3]
