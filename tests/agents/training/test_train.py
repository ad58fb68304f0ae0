"""Training: smoke run, save/load round trip, and resume after a real kill."""

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import torch
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import weights
from rbenv.agents.policies.runfolder import latest_checkpoint
from rbenv.agents.policies.sb3 import SB3Policy
from rbenv.agents.training.config import TrainConfig, shipped_settings
from rbenv.agents.training.sb3 import make_vec_env, train

SMALL = {"n_steps": 32, "batch_size": 128, "n_epochs": 2}


def small_config(out, **kw):
    base = dict(timesteps=2048, n_envs=8, out=str(out), hyperparams=SMALL,
                checkpoint_every=1024, eval_every=1024, eval_episodes=4, report_episodes=8)
    return TrainConfig(**{**base, **kw})


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    train(small_config(out), progress_bar=False, report=True)
    return out


@pytest.mark.slow
def test_run_directory_has_everything(run_dir):
    for name in ("config.json", "policy.pt", "policy.json", "obs_stats.npz", "training.json",
                 "report.md",
                 "episode.png", "evaluation.json", "eval/evaluations.npz"):
        assert (run_dir / name).exists(), name
    config = json.loads((run_dir / "config.json").read_text())
    assert config["algo"] == "ppo" and config["hyperparams"]["n_steps"] == 32
    assert "torch" in config["versions"]
    summary = json.loads((run_dir / "training.json").read_text())
    assert summary["timesteps"] >= 2048
    evaluations = json.loads((run_dir / "evaluation.json").read_text())
    assert [e["policy"] for e in evaluations] == ["ppo (trained)", "pd", "bangbang"]
    assert evaluations[1]["success_rate"] == 1.0  # the PD baseline on the same episodes
    assert "| pd |" in (run_dir / "report.md").read_text()
    assert latest_checkpoint(run_dir / "checkpoints")["timesteps"] >= 1024


def test_save_load_round_trip_gives_identical_deterministic_actions(run_dir):
    model = weights.load_model(run_dir / "policy.pt")
    stats = weights.load_stats(run_dir / "obs_stats.npz").vecnormalize(
        make_vec_env(small_config(run_dir), 4, 0), training=False)
    obs = stats.venv.reset()
    expected, _ = model.predict(stats.normalize_obs(obs), deterministic=True)
    # picks up obs_stats.npz beside the model; "mode" is SB3's own deterministic action
    loaded = SB3Policy(run_dir / "policy.pt", action="mode")
    actions, _ = loaded.predict(obs, deterministic=True)
    assert np.array_equal(actions, expected)
    again, _ = SB3Policy(run_dir / "policy.pt", action="mode").predict(obs)
    assert np.array_equal(again, actions)


def test_the_checkpoint_at_the_last_step_is_the_final_model(run_dir):
    """The callback checkpoints step 2048 before PPO's last update; the run must end with
    checkpoint 2048 holding the final weights, or selecting "the checkpoint at 2048" (the suite)
    and loading the final model give different policies for the same step count."""
    ckpt = latest_checkpoint(run_dir / "checkpoints")
    assert ckpt["timesteps"] == 2048
    final = weights.load_model(run_dir / "policy.pt").policy.state_dict()
    at_end = weights.load_model(run_dir / "checkpoints" / ckpt["model"]).policy.state_dict()
    assert final.keys() == at_end.keys()
    assert all(torch.equal(final[k], at_end[k]) for k in final)
    with np.load(run_dir / "obs_stats.npz") as a, np.load(run_dir / "checkpoints" /
                                                           ckpt["stats"]) as b:
        assert all(np.array_equal(a[k], b[k]) for k in a.files)


def test_the_main_jobs_ppo_acts_with_its_mode_and_on_request_with_its_mean_throttle(run_dir):
    """The main job's recipe sets policy_action "mode" (saved in config.json); the mean throttle
    (the auto rule's choice for PPO in throttle mode) is E[clip(mu + sigma eps, 0, 1)]."""
    from rbenv.agents.policies.sb3 import expected_throttle

    assert json.loads((run_dir / "config.json").read_text())["policy_action"] == "mode"
    assert SB3Policy(run_dir / "policy.pt").action == "mode"
    policy = SB3Policy(run_dir / "policy.pt", action="mean_throttle")
    model = policy.model
    n_obs = model.observation_space.shape[0]
    obs = np.random.default_rng(2).uniform(-1, 1, (5, n_obs)).astype(np.float32)
    with torch.no_grad():
        dist = model.policy.get_distribution(
            torch.as_tensor(policy.normalize(obs))).distribution
    expected = expected_throttle(dist.mean.numpy(), dist.stddev.numpy()).astype(np.float32)
    actions, _ = policy.predict(obs)
    np.testing.assert_array_equal(actions, expected)
    single, _ = policy.predict(obs[0])
    assert single.shape == (12,)
    np.testing.assert_allclose(single, expected[0], rtol=1e-6)
    assert (actions >= 0).all() and (actions <= 1).all()
    # It differs from clip(mu, 0, 1) exactly where the noise reaches across the clip bounds.
    mode, _ = SB3Policy(run_dir / "policy.pt", action="mode").predict(obs)
    assert not np.array_equal(actions, np.clip(mode, 0, 1))
    with pytest.raises(ValueError, match="action must be one of"):
        SB3Policy(run_dir / "policy.pt", action="mean")


@pytest.mark.slow
def test_resume_after_a_real_kill(tmp_path, capsys):
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "rbenv.agents.cli", "train", "--timesteps", "10000000",
           "--n-envs", "8", "--out", str(out), "--checkpoint-every", "1024",
           "--eval-every", "100000000", "--hyperparams", json.dumps(SMALL), "--no-report",
           "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.time() + 180
        while time.time() < deadline and latest_checkpoint(out / "checkpoints") is None:
            if proc.poll() is not None:
                pytest.fail(f"training exited early: {proc.stderr.read().decode()[-2000:]}")
            time.sleep(0.2)
        time.sleep(1.0)  # let it run on, so the kill may land mid-save
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    ckpt = latest_checkpoint(out / "checkpoints")
    assert ckpt is not None and ckpt["timesteps"] >= 1024
    assert not (out / "policy.pt").exists()  # the kill came before the end of training
    done = ckpt["timesteps"]
    # Resume with a new total; the saved config (hyperparameters, seed, scene) is reused.
    cfg = TrainConfig(out=str(out), timesteps=done + 2048)
    train(cfg, resume=True, progress_bar=False, report=False)
    printed = capsys.readouterr().out
    assert f"stale lock {str(out / 'run.lock')!r} from pid {proc.pid}" in printed
    assert f"from {done} timesteps" in printed
    summary = json.loads((out / "training.json").read_text())
    assert summary["resumed_from"] == done and summary["wall_time_s"] > 0
    assert not list(out.rglob("*.tmp"))  # a temporary left by the kill is cleaned up
    assert summary["timesteps"] >= done + 2048
    policy = json.loads((out / "policy.json").read_text())
    assert policy["num_timesteps"] == summary["timesteps"]
    assert not list(out.rglob("*.pkl")) and not list(out.rglob("*.zip"))


def test_evaluate_cli_writes_json_and_plot(tmp_path):
    out_json, out_png = tmp_path / "pd.json", tmp_path / "pd.png"
    assert cli_main(["evaluate", "--policy", "pd", "--episodes", "6", "--seed", "3",
                     "--json", str(out_json), "--plot", str(out_png)]) == 0
    data = json.loads(out_json.read_text())
    assert set(data) >= {"policy", "episodes", "success_rate", "settle_time_s", "fuel",
                         "final_error_deg"}
    assert data["episodes"] == 6 and data["success_rate"] == 1.0
    assert set(data["settle_time_s"]) == {"median", "p90"} and "mean" in data["fuel"]
    assert out_png.stat().st_size > 1000


def test_evaluate_rejects_unknown_policy():
    with pytest.raises(ValueError, match="'nope' is not a scripted policy of rbenv/Satellite"):
        cli_main(["evaluate", "--policy", "nope", "--episodes", "1"])


def test_cli_env_kwargs_reach_the_env_and_the_saved_config(tmp_path):
    out = tmp_path / "torque"
    assert cli_main(["train", "--timesteps", "512", "--n-envs", "4", "--out", str(out),
                     "--hyperparams", json.dumps(SMALL), "--checkpoint-every", "256",
                     "--eval-every", "100000", "--env-kwargs", '{"action_mode": "torque"}',
                     "--no-report"]) == 0
    config = json.loads((out / "config.json").read_text())
    recipe = shipped_settings("ppo", scene="cubesat-12u", engine="sb3")["env_kwargs"]
    assert config["env_kwargs"] == {**recipe, "action_mode": "torque"}
    model = weights.load_model(out / "policy.pt")
    assert model.action_space.shape == (3,)  # torque mode: one action per body axis


def test_periodic_evaluation_acts_as_a_loaded_policy_does(run_dir):
    from rbenv.agents.training.sb3 import PeriodicEval

    model = weights.load_model(run_dir / "policy.pt")
    for env_kwargs, chosen, action in (({}, None, "mean_throttle"), ({}, "mode", "mode"),
                                       ({"action_mode": "torque"}, None, "mode")):
        callback = PeriodicEval(None, run_dir / "unused.npz", 10, 1, 0,
                                run_config={"scene": "cubesat-12u", "env_kwargs": env_kwargs,
                                            "policy_action": chosen})
        callback.model = model
        assert callback.policy().action == action


def test_a_scene_entry_of_the_training_settings_adds_its_env_options_to_training():
    """rbenv train on a wheel scene trains with the failure weight its training settings give
    that scene; the default scene gets the main job's time and fuel weights, and the caller's
    --env-kwargs win."""
    from rbenv.agents.settings import tuned
    from rbenv.agents.training.config import TrainConfig

    wheels = TrainConfig(algo="ppo", scene="cubesat-6u-rw").resolve()
    assert wheels.env_kwargs["reward_weights"] == tuned.WHEELS_FAILURE["reward_weights"]
    assert TrainConfig(algo="ppo").resolve().env_kwargs == {
        "reward_weights": {"time": 0.2, "fuel": 3.0}}
    assert "reward_weights" not in TrainConfig(algo="ppo", scene="microsat-100kg").resolve(
    ).env_kwargs
    mine = TrainConfig(algo="ppo", scene="cubesat-6u-rw",
                       env_kwargs={"reward_weights": {"failure": 50.0}}).resolve()
    assert mine.env_kwargs["reward_weights"] == {"failure": 50.0}
    wheels.env_kwargs["reward_weights"]["failure"] = -1.0  # a copy: the settings are untouched
    assert tuned.WHEELS_FAILURE["reward_weights"]["failure"] == 200.0


def test_track_v1_trains_with_its_scenes_fuel_weights_and_only_there():
    """boom-sat: the lower fuel weight; cubesat-12u: the higher one of its own recipe."""
    from rbenv.agents.settings import shipped, tuned
    from rbenv.agents.training.config import TrainConfig

    track = "rbenv/SatelliteTrack-v1"
    boom = TrainConfig(algo="ppo", env_id=track, scene="boom-sat").resolve()
    assert boom.env_kwargs["reward_weights"] == tuned.BOOM_TRACK_FUEL["reward_weights"]
    small = TrainConfig(algo="ppo", env_id=track, scene="cubesat-12u").resolve()
    assert small.env_kwargs["reward_weights"] == {"fuel": 3.0}
    assert shipped.TRACK_V1_PPO_12U["env_kwargs"] == small.env_kwargs
    for env_id, scene in ((track, "cubesat-12u-dr"), ("rbenv/SatelliteTrack-v0", "boom-sat"),
                          ("rbenv/SatelliteReorient-v1", "boom-sat")):
        cfg = TrainConfig(algo="ppo", env_id=env_id, scene=scene).resolve()
        assert "reward_weights" not in cfg.env_kwargs, (env_id, scene)


def test_reorient_v1_on_boom_sat_gets_the_longer_ppo_budget_and_only_there():
    from rbenv.agents.training.suite import default_timesteps

    v1 = "rbenv/SatelliteReorient-v1"
    assert default_timesteps("ppo", v1, "boom-sat") == 2_000_000
    # On the default scene the suite trains SB3's own recipe there (2 M steps); on the other
    # scenes, the budget measured there.
    assert default_timesteps("ppo", v1, "cubesat-12u") == 2_000_000
    assert default_timesteps("ppo", v1, "cubesat-12u-rw") == 1_500_000
    assert default_timesteps("ppo", "rbenv/SatelliteReorient-v0", "boom-sat") == 4_000_000


def test_a_linear_learning_rate_falls_from_its_value_to_zero_and_resumes_where_it_was(tmp_path):
    """RL Zoo's "lin_X": X at the first update, X·(remaining fraction) later, 0 at the end;
    the config keeps the string, so a resumed run rebuilds the same schedule."""
    from rbenv.agents.training.sb3 import algo_class, model_kwargs

    cfg = small_config(tmp_path / "lin", hyperparams={**SMALL, "learning_rate": "lin_3e-3"})
    cfg = cfg.resolve()
    env = make_vec_env(cfg, cfg.n_envs, 0)
    model = algo_class("ppo")("MlpPolicy", env, device="cpu", **model_kwargs(cfg, env))
    assert model.lr_schedule(1.0) == pytest.approx(3e-3)
    assert model.lr_schedule(0.25) == pytest.approx(7.5e-4)
    assert model.lr_schedule(0.0) == 0.0
    # The last rollout can pass the budget (remaining < 0): no negative, ascending step.
    assert model.lr_schedule(-0.01) == 0.0
    env.close()
    out = train(cfg, progress_bar=False, report=False)
    assert json.loads((out / "config.json").read_text())["hyperparams"]["learning_rate"] \
        == "lin_3e-3"


@pytest.mark.parametrize("spec", ["lin_", "lin_-1e-3", "exp_1e-3", "lin_inf", "3e-3"])
def test_a_learning_rate_string_that_is_no_linear_schedule_is_refused(spec):
    from rbenv.agents.training.sb3 import model_kwargs
    from rbenv.core.errors import InvalidParameterError

    cfg = TrainConfig(hyperparams={"learning_rate": spec}).resolve()
    with pytest.raises(InvalidParameterError, match=rf"learning_rate .*'lin_X'.*{spec!r}"):
        model_kwargs(cfg, None)


def test_a_bad_schedule_is_refused_by_the_dry_run_before_anything_is_written(tmp_path):
    from rbenv.agents import cli

    out = tmp_path / "run"
    assert cli.console(["train", "--hyperparams", '{"learning_rate": "lin_x"}', "--dry-run",
                        "--out", str(out)]) == 2
    assert not out.exists()


@pytest.mark.parametrize("normalize, match", [
    ({"foo": 1}, r"normalize has unknown key\(s\) \['foo'\]; keys are norm_obs"),
    ({"gamma": 0.9}, r"unknown key\(s\) \['gamma'\].*gamma is the hyperparameters'"),
    ({"norm_obs": "yes"}, r"normalize\['norm_obs'\] must be true or false, got 'yes'"),
    ({"clip_obs": -1}, r"normalize\['clip_obs'\] must be > 0.0, got -1"),
    ([1], r"normalize must be a JSON object"),
])
def test_bad_normalize_options_are_named_before_training(normalize, match):
    from rbenv.core.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match=match):
        TrainConfig(normalize=normalize).resolve()
    TrainConfig(normalize={"norm_obs": False, "clip_obs": 5.0}).resolve()  # a valid one


def test_stop_success_ends_training_at_the_first_validation_that_reaches_it(tmp_path):
    """On a scene whose success needs only a 2 s hold inside 170°, the first periodic
    evaluation succeeds: training stops there, on the policy it measured, and says so."""
    from importlib import resources

    text = (resources.files("rbenv") / "scenes" / "cubesat-12u.toml").read_text()
    easy = tmp_path / "easy.toml"
    easy.write_text(text.replace("success_angle_deg = 1.0", "success_angle_deg = 170.0")
                    .replace("success_rate = 0.01 ", "success_rate = 0.17 ")
                    .replace("max_initial_angle_deg = 180.0", "max_initial_angle_deg = 30.0"))
    cfg = small_config(tmp_path / "run", timesteps=4096, scene=str(easy), stop_success=0.75,
                       eval_every=512, checkpoint_every=100_000)
    out = train(cfg, progress_bar=False, report=True)
    summary = json.loads((out / "training.json").read_text())
    stop = summary["stopped_at_success"]
    # The CPU time and the load beside the wall time: what a timing on a busy machine needs.
    assert 0 < summary["session_cpu_time_s"] and summary["load_average_1min"] >= 0
    assert stop["success_rate"] >= 0.75 and stop["episodes"] == 4
    assert summary["timesteps"] == stop["timesteps"] == 512  # 8 envs x 64 steps
    with np.load(out / "eval" / "evaluations.npz") as log:
        assert list(log["timesteps"]) == [512]
    # The final policy is the checkpoint of that step: the weights the evaluation measured.
    assert latest_checkpoint(out / "checkpoints")["timesteps"] == 512
    report = (out / "report.md").read_text()
    assert "validation episodes succeeded (--stop-success)" in report
    assert f"wall time: {summary['wall_time_s']:.0f} s (8 envs" in report  # seconds, not 0.0 min


@pytest.mark.parametrize("value", [-0.1, 1.5, True, "1"])
def test_stop_success_must_be_a_rate(value):
    from rbenv.core.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match=r"stop_success must be a success rate"):
        TrainConfig(stop_success=value).resolve()


def test_a_run_saved_before_the_run_defaults_resumes_as_it_trained(tmp_path):
    """config.json of a Reorient-v1 PPO run written when stop_success null meant "never stop"
    resumes without stopping; one written with 1.0 keeps it."""
    from dataclasses import asdict

    from rbenv.agents.training.config import resumed_config

    cfg = TrainConfig(env_id="rbenv/SatelliteReorient-v1", scene="cubesat-12u-dr",
                      out=str(tmp_path)).resolve()
    assert cfg.stop_success == 1.0  # the id's run default for a new run on that scene
    for saved, resumed in ((None, 0.0), (1.0, 1.0)):
        (tmp_path / "config.json").write_text(json.dumps({**asdict(cfg),
                                                          "stop_success": saved}))
        assert resumed_config(TrainConfig, tmp_path).stop_success == resumed

