"""benchmarks/time_to_solve.py --quick: trains the shipped PPO of Reorient-v1 for a few
rollouts, evaluates it on held-out episodes outside the training clock, and writes the JSON
(into tmp_path, never the committed results)."""

from __future__ import annotations

import json

import pytest

from benchmarks import common, time_to_solve

pytest.importorskip("stable_baselines3")


@pytest.fixture
def results(tmp_path, monkeypatch, request):
    import torch

    threads = torch.get_num_threads()
    request.addfinalizer(lambda: torch.set_num_threads(threads))
    monkeypatch.setattr(common, "RESULTS", tmp_path)
    monkeypatch.setattr(time_to_solve, "RESULTS", tmp_path)
    return tmp_path


@pytest.mark.slow  # a few seconds on an idle machine
def test_quick_run_writes_curve_and_table(results):
    time_to_solve.main(["--quick"])
    data = json.loads((results / "time_to_solve_quick.json").read_text())
    (run,) = data["runs"]
    assert run["path"] == "sb3-v1-fast" and run["seed"] == 0
    # Evaluations every 4096 samples up to the 8192-sample budget, the clocks only counting
    # training: wall and CPU time grow with the samples.
    assert [p["samples"] for p in run["curve"]] == [4096, 8192]
    first, last = run["curve"]
    assert 0 < first["train_s"] < last["train_s"] and 0 < first["cpu_s"] < last["cpu_s"]
    # 8k samples do not solve the task: the miss is recorded with its best rate.
    assert not run["solved"] and run["time_to_solve_s"] is None
    assert run["best_success"] == max(p["success"] for p in run["curve"]) < 0.99
    (row,) = data["table"]
    assert row["path"] == "sb3-v1-fast" and row["seeds"] == 1 and row["solved"] == 0
    assert len(run["load_before"]) == 3
    assert (results / "time_to_solve_quick.png").is_file()


def test_paths_name_known_engines_and_settings():
    for path in time_to_solve.PATHS.values():
        assert path.engine in time_to_solve.RUNNERS
        assert path.budget is None or path.budget >= path.eval_every > 0
    # The fast path names Reorient-v1's fast recipe (600k steps), whatever the id ships now.
    from rbenv.agents.settings.shipped import REORIENT_V1_PPO

    fast = time_to_solve.PATHS["sb3-v1-fast"]
    assert (fast.n_envs, fast.budget, fast.eval_every) == (256, 600_000, 50_000)
    assert fast.hyperparams == {k: v for k, v in REORIENT_V1_PPO.items()
                                if k not in ("n_envs", "n_timesteps")}


@pytest.mark.slow  # a few seconds on an idle machine, plus JAX's compilation
def test_quick_off_policy_run_through_sbx(results):
    pytest.importorskip("sbx", reason="sbx-rl is not installed (the sbx extra)")
    name = "sbx-td3-256e-b1024-g16-64"
    time_to_solve.main(["--quick", "--paths", name])
    (run,) = json.loads((results / "time_to_solve_quick.json").read_text())["runs"]
    assert run["path"] == name
    assert [p["samples"] for p in run["curve"]] == [1024, 2048]
    assert 0 < run["curve"][0]["cpu_s"] < run["curve"][1]["cpu_s"]
    assert not run["solved"] and run["best_success"] < 0.99


@pytest.mark.slow  # a few seconds on an idle machine
def test_quick_run_through_skrl(results):
    pytest.importorskip("skrl", reason="skrl is not installed (in no extra)")
    name = "skrl-b4096-e3-lr2e-3"
    time_to_solve.main(["--quick", "--paths", name])
    (run,) = json.loads((results / "time_to_solve_quick.json").read_text())["runs"]
    assert run["path"] == name
    # 64 envs x 16-step rollouts, an evaluation every 4096 samples: whole rollouts of skrl's
    # loop, the CPU clock counting training only.
    assert [p["samples"] for p in run["curve"]] == [4096, 8192]
    assert 0 < run["curve"][0]["cpu_s"] < run["curve"][1]["cpu_s"]
    assert not run["solved"] and run["best_success"] < 0.99


def test_the_measured_torchrl_path_is_what_the_registry_ships():
    from rbenv.agents import settings
    from rbenv.agents.training.config import torchrl_fields

    shipped = torchrl_fields(settings.get("rbenv/SatelliteReorient-v1").recipe("ppo", "torchrl"))
    path = time_to_solve.PATHS["torchrl-g0.98-std-0.5-1.2M"]
    assert path.budget == shipped["timesteps"]
    assert path.hyperparams == {k: shipped[k] for k in path.hyperparams}
