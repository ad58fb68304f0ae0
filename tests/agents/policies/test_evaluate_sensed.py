"""Where the policy sees a sensed state (innocube-3u's gyro-integrated attitude, a scene's sensor
noise), rbenv evaluate says so beside its result: success reads the true state, so a policy
that holds its sensed error can "fail" on the true one (issue 44, item 6)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from rbenv.agents import cli
from rbenv.agents.policies.evaluate import SENSED_NOTE, evaluate, format_table

import rbenv
from rbenv.satellite.scene import Sensors

ROOT = Path(__file__).resolve().parents[3]
LIFTED = {"action_mode": "acceleration_lifted"}
PLAIN_KEYS = {"policy", "scene", "seed", "episodes", "success_rate", "settle_time_s", "fuel",
              "energy", "final_error_deg", "optimality"}  # optimality: issue 40


def test_the_gyro_scene_reports_the_sensed_error_beside_the_true_one():
    result = evaluate("innocube-slew", episodes=3, scene="innocube-3u", env_kwargs=LIFTED)
    s = result.summary()
    assert s["observation"]["sensed"] == ("attitude integrated from the gyro, 1 control step "
                                          "late")
    assert s["observation"]["note"] == SENSED_NOTE
    sensed, true = s["final_error_deg"]["sensed_median"], s["final_error_deg"]["median"]
    # The gyro's bias (0.002 deg/s per axis) walks the belief away from the truth over 160 s.
    assert sensed != pytest.approx(true, abs=0.05)
    table = format_table([result])
    assert "final error median, sensed (deg)" in table.splitlines()[0]
    assert f"| {sensed:.3g} |" in table.splitlines()[2]
    note = table.splitlines()[-1]
    assert note.startswith(f"Note: {SENSED_NOTE}") and "'innocube-3u'" in note


def test_a_perfect_gyro_believes_the_true_error():
    """An independent reference: with no bias, noise or delay the integrated attitude is the
    true one, so the sensed error equals the true error (round-off), and the note stays (the
    policy still sees a gyro attitude)."""
    base = rbenv.load_scene("innocube-3u")
    perfect = dataclasses.replace(base, sensors=Sensors(attitude="gyro"))
    result = evaluate("innocube-slew", episodes=3, scene=perfect, env_kwargs=LIFTED)
    np.testing.assert_allclose(result.sensed_final_error_deg, result.final_error_deg,
                               atol=1e-6)
    assert result.observation == "attitude integrated from the gyro"


def test_sensor_noise_is_named_and_the_plain_scene_summary_is_unchanged():
    noisy = evaluate("pd", episodes=2, scene="microsat-100kg")
    assert noisy.observation == "sensor noise"
    assert noisy.summary()["observation"]["sensed"] == "sensor noise"
    assert "sensed_median" not in noisy.summary()["final_error_deg"]  # info does not carry it
    assert format_table([noisy]).splitlines()[-1].startswith(f"Note: {SENSED_NOTE}")
    plain = evaluate("pd", episodes=2)
    assert plain.observation is None and set(plain.summary()) == PLAIN_KEYS
    assert set(plain.summary()["final_error_deg"]) == {"median"}
    assert "Note" not in format_table([plain]) and "sensed" not in format_table([plain])


def test_the_note_names_what_corrects_the_attitude():
    """A gyro-integrated attitude is uncorrected; an estimator scene's note names the MEKF and
    says nothing of a missing estimator."""
    star = evaluate("pd", episodes=2, scene=str(ROOT / "docs/estimation/cubesat-12u-star.toml"))
    note = format_table([star]).splitlines()[-1]
    assert star.observation == "the attitude and rate the MEKF estimates"
    assert note.startswith(f"Note: {SENSED_NOTE}") and "estimator" not in note.split(":", 2)[2]
    gyro = evaluate("innocube-slew", episodes=2, scene="innocube-3u", env_kwargs=LIFTED)
    note = format_table([gyro]).splitlines()[-1]
    assert "attitude integrated from the gyro" in note
    assert note.endswith("; no [estimator] corrects it).")


@pytest.mark.slow
def test_one_note_for_a_report_of_several_policies():
    kwargs = {"episodes": 2, "scene": "innocube-3u", "env_kwargs": LIFTED}
    table = format_table([evaluate("innocube-slew", **kwargs),
                          evaluate("innocube-pd", **kwargs)])
    assert table.count("Note: ") == 1


@pytest.mark.slow
def test_rbenv_evaluate_of_the_shipped_innocube_policy_says_why_it_fails(tmp_path, capsys):
    pytest.importorskip("torch")
    out = tmp_path / "innocube.json"
    assert cli.main(["evaluate", "--policy", str(ROOT / "docs/innocube/policy"), "--episodes",
                     "2", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"Note: {SENSED_NOTE}" in printed and "attitude integrated from the gyro" in printed
    summary = json.loads(out.read_text())
    assert summary["observation"]["note"] == SENSED_NOTE
    assert summary["final_error_deg"]["sensed_median"] < summary["final_error_deg"]["median"]


@pytest.mark.slow
def test_a_run_report_on_the_gyro_scene_carries_the_note(tmp_path):
    """report.md of a run (rbenv train's report) shows the same table, note included."""
    pytest.importorskip("matplotlib")
    import gymnasium as gym
    from rbenv.agents.baselines.controllers import ZeroPolicy
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.report import Trained, write_report

    n_act = gym.make(rbenv.ENV_ID, scene="innocube-3u", **LIFTED).action_space.shape[0]
    cfg = TrainConfig(scene="innocube-3u", env_kwargs=LIFTED, report_episodes=2)
    write_report(tmp_path, cfg, {"timesteps": 0, "wall_time_s": 0.0}, Trained(
        ZeroPolicy(n_act), name="zero (stand-in)", title="t", setup="s", load="l"))
    report = (tmp_path / "report.md").read_text()
    assert f"Note: {SENSED_NOTE}" in report and "final error median, sensed (deg)" in report
    evaluations = json.loads((tmp_path / "evaluation.json").read_text())
    assert all(e["observation"]["note"] == SENSED_NOTE for e in evaluations)


def test_an_estimator_scene_reports_what_the_filter_believes_beside_the_truth():
    """On a scene with [estimator] the policy sees the MEKF's estimate: the summary says so,
    and the sensed error is the estimate's own (info's estimated_attitude_error_deg) at the
    end of each episode, not the true one."""
    scene = str(ROOT / "docs" / "estimation" / "cubesat-12u-star.toml")
    result = evaluate("pd", episodes=4, seed=3, env_id="rbenv/SatelliteReorient-v1",
                      env_kwargs={"scene": scene})
    s = result.summary()
    assert s["observation"]["sensed"] == "the attitude and rate the MEKF estimates"
    believed = result.sensed_final_error_deg
    assert np.isfinite(believed).all()
    # The filter tracks the truth to a fraction of a degree, never exactly.
    assert np.abs(believed - result.final_error_deg).max() < 0.2
    assert (believed != result.final_error_deg).all()
