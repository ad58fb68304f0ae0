"""The MPC's recorded evaluation (rbenv.agents.policies.recorded): it is what a fresh
evaluation gives on the same episodes, it stands only for exactly those episodes, and the
training report shows it beside the policy, labelled as recorded."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from rbenv.agents.policies import recorded
from rbenv.agents.policies.evaluate import evaluate, format_table
from rbenv.agents.training.config import TrainConfig
from rbenv.agents.training.report import mpc_rows
from rbenv.core.errors import InvalidParameterError

V1, V2 = "rbenv/SatelliteReorient-v1", "rbenv/SatelliteReorient-v2"
PATH = recorded.record_path("mpc", "cubesat-12u")


@pytest.fixture(scope="module")
def data():
    return recorded.read_record(PATH)


def test_the_record_covers_the_default_report_episodes(data):
    defaults = TrainConfig()
    assert (data["seed"], data["episodes"]) == (defaults.report_seed, defaults.report_episodes)
    assert set(data["env_ids"]) == {V1, V2}
    per = data["per_episode"]
    assert np.mean(per["success"]) >= 0.99
    settle = [t for t in per["settle_time_s"] if t is not None]
    assert 10.0 < np.median(settle) < 25.0
    assert 0.8e-3 < np.mean(per["fuel_kg"]) < 1.6e-3


@pytest.mark.parametrize("env_id", [V2, V1])
def test_a_fresh_mpc_evaluation_of_the_first_episodes_equals_the_record(data, env_id):
    pytest.importorskip("highspy", reason="the mpc extra is not installed")
    n = 4
    live = evaluate("mpc", episodes=n, seed=data["seed"], env_id=env_id, record=0)
    per = data["per_episode"]
    np.testing.assert_array_equal(live.success, per["success"][:n])
    np.testing.assert_array_equal(live.settle_time_s, np.array(per["settle_time_s"][:n], float))
    np.testing.assert_allclose(live.fuel_kg, per["fuel_kg"][:n], rtol=1e-9)
    np.testing.assert_allclose(live.final_error_deg, per["final_error_deg"][:n], rtol=1e-9)


def _lookup(**change):
    args = {"policy": "mpc", "env_id": V2, "scene": "cubesat-12u", "env_kwargs": {},
            "episodes": 500, "seed": 1_000_000, **change}
    return recorded.lookup(**args)


@pytest.mark.parametrize("change", [
    {}, {"env_id": V1}, {"env_kwargs": {"reward_weights": {"fuel": 3.0}}}])
def test_the_record_stands_for_exactly_its_episodes(change):
    assert _lookup(**change) is not None


@pytest.mark.parametrize("change", [
    {"scene": "cubesat-12u-dr"}, {"scene": "scenes/my-sat.toml"}, {"episodes": 499},
    {"seed": 0}, {"env_id": "rbenv/SatelliteReorient-v0"},
    {"env_kwargs": {"action_mode": "torque"}},
    {"env_kwargs": {"reward_weights": {}, "max_initial_angle_deg": 30.0}}])
def test_other_episodes_or_options_get_no_record(change):
    assert _lookup(**change) is None


def test_the_recorded_result_summarises_and_bounds_like_a_live_one(data):
    rec = _lookup()
    s = rec.result.summary()
    per = data["per_episode"]
    assert s["policy"] == "mpc (recorded)"
    assert s["success_rate"] == pytest.approx(np.mean(per["success"]))
    assert s["fuel"]["mean"] == pytest.approx(np.mean(per["fuel_kg"]))
    opt = s["optimality"]
    assert opt["defined"] and 1.0 <= opt["settle_ratio"]["median"] < 2.0
    assert "mpc (recorded)" in rec.note and "--report-mpc" in rec.note
    row = [line for line in format_table([rec.result]).splitlines()
           if line.startswith("| mpc (recorded)")]
    assert len(row) == 1 and f"{1000 * s['fuel']['mean']:.2f}" in row[0]


def test_the_report_shows_the_record_or_evaluates_the_mpc_when_asked():
    cfg = SimpleNamespace(report_mpc=False, env_id=V2, scene="cubesat-12u", env_kwargs={},
                          report_episodes=500, report_seed=1_000_000)
    rows, notes = mpc_rows(cfg, {})
    assert [r.policy for r in rows] == ["mpc (recorded)"] and len(notes) == 1
    cfg.report_episodes = 100  # a quick report: no record stands for it
    assert mpc_rows(cfg, {}) == ([], [])
    pytest.importorskip("highspy", reason="the mpc extra is not installed")
    cfg.report_mpc = True
    kwargs = {"episodes": 2, "seed": 1_000_000, "scene": "cubesat-12u", "env_kwargs": {},
              "env_id": V2}
    rows, notes = mpc_rows(cfg, kwargs)
    assert [r.policy for r in rows] == ["mpc"] and notes == [] and rows[0].episodes == 2


def test_report_mpc_on_a_task_without_an_mpc_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match=r"report_mpc=True needs .*Detumble-v1"):
        TrainConfig(env_id="rbenv/SatelliteDetumble-v1", report_mpc=True).resolve()


@pytest.mark.parametrize(("text", "named"), [
    ("{not json", "not readable JSON"),
    (json.dumps({"policy": "mpc"}), "missing ['env_ids'"),
    (json.dumps({"policy": "mpc", "env_ids": [V2], "scene": "x", "seed": 0, "episodes": 2,
                 "command": "c", "recorded": "r",
                 "per_episode": {"success": [True, True], "settle_time_s": [1.0, 2.0],
                                 "fuel_kg": [1.0], "final_error_deg": [0.1, 0.1],
                                 "episode_time_s": [5.0, 5.0]}}),
     "per_episode.fuel_kg must be a list of 2 values (episodes), got list of 1"),
])
def test_a_broken_record_gets_a_named_error(tmp_path, text, named):
    path = tmp_path / "mpc-x.json"
    path.write_text(text)
    with pytest.raises(InvalidParameterError, match=str(path).replace(".", r"\.")) as err:
        recorded.read_record(path)
    assert named in str(err.value)
