"""``rbenv train --algo sac|td3|tqc|crossq``: short runs with the shipped settings.

Each run is a few thousand steps (no learning is expected); what is checked is the plumbing:
the run folder and report exist, and every setting not overridden here came from
``rbenv.agents.zoo.<algo>``, the module ``rl_zoo3 --conf-file`` reads.
"""

import importlib
import json

import numpy as np
import pytest
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import load_policy
from rbenv.agents.training.config import ZOO_KEYS, TrainConfig
from rbenv.agents.training.sb3 import train
from rbenv.core.errors import InvalidParameterError

pytest.importorskip("sb3_contrib", reason="sb3-contrib is not installed (train extra)")

OFF_POLICY = ("sac", "td3", "tqc", "crossq")
# Small enough for a test: gradient steps start after 512 of the 2048 steps.
SHORT = {"learning_starts": 512, "gradient_steps": 1, "batch_size": 64, "buffer_size": 4096}


def shipped(algo: str) -> dict:
    return importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[
        "rbenv/SatelliteReorient-v0"]


@pytest.mark.slow
@pytest.mark.parametrize("algo", OFF_POLICY)
def test_short_run_uses_the_shipped_settings_and_reports(tmp_path, algo):
    out = tmp_path / algo
    cfg = TrainConfig(algo=algo, timesteps=2048, out=str(out), hyperparams=dict(SHORT),
                      checkpoint_every=1024, eval_every=1024, eval_episodes=4,
                      report_episodes=4)
    train(cfg, progress_bar=False, report=True)
    for name in ("config.json", "policy.pt", "obs_stats.npz", "training.json", "report.md",
                 "evaluation.json", "eval/evaluations.npz"):
        assert (out / name).exists(), name
    config = json.loads((out / "config.json").read_text())
    settings = shipped(algo)
    model_settings = {k: v for k, v in settings.items() if k not in ZOO_KEYS}
    expected = json.loads(json.dumps({**model_settings, **SHORT}))  # tuples become lists
    assert config["algo"] == algo and config["hyperparams"] == expected
    assert config["n_envs"] == settings["n_envs"]
    assert config["env_kwargs"] == settings["env_kwargs"]
    assert config["normalize"] == dict(settings["normalize"])
    summary = json.loads((out / "training.json").read_text())
    assert summary["timesteps"] == 2048 and summary["gradient_updates"] > 0
    evaluations = json.loads((out / "evaluation.json").read_text())
    assert evaluations[0]["policy"] == f"{algo} (trained)"
    assert f"{algo.upper()}" in (out / "report.md").read_text()

    policy = load_policy(out)
    assert type(policy.model).__name__.lower() == algo
    assert policy.model.action_space.shape == (3,)  # torque actions, from the shipped env_kwargs
    if algo == "td3":  # the zoo's noise_type/noise_std become the same NormalActionNoise
        from rbenv.agents.training.sb3 import model_kwargs

        noise = model_kwargs(TrainConfig(algo="td3").resolve(), policy.model)["action_noise"]
        assert np.allclose(noise._sigma, settings["noise_std"])


def test_cli_algo_choice_reads_the_shipped_module(tmp_path):
    out = tmp_path / "td3"
    assert cli_main(["train", "--algo", "td3", "--timesteps", "1024", "--out", str(out),
                     "--hyperparams", json.dumps(SHORT), "--eval-every", "100000000",
                     "--no-report", "--no-progress"]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["hyperparams"]["noise_std"] == shipped("td3")["noise_std"]
    assert config["hyperparams"]["tau"] == shipped("td3")["tau"]
    assert config["env_kwargs"]["action_mode"] == "torque"


def test_unknown_algo_is_refused():
    from rbenv.core.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="crossq"):
        TrainConfig(algo="ddpg").resolve()


def _evaluations(out) -> list[tuple[float, float, int]]:
    with np.load(out / "eval" / "evaluations.npz") as d:
        return [(float(np.mean(s)), float(np.mean(r)), int(t))
                for s, r, t in zip(d["successes"], d["results"], d["timesteps"], strict=True)]


@pytest.mark.slow
def test_keep_best_ends_on_the_best_validated_policy(tmp_path):
    out = tmp_path / "sac"
    cfg = TrainConfig(algo="sac", timesteps=3072, out=str(out), hyperparams=dict(SHORT),
                      checkpoint_every=1024, eval_every=1024, eval_episodes=4,
                      report_episodes=4)
    assert cfg.keep_best is None
    train(cfg, progress_bar=False, report=True)
    assert json.loads((out / "config.json").read_text())["keep_best"] is True  # off-policy
    kept = json.loads((out / "training.json").read_text())["kept"]
    history = _evaluations(out)
    assert [t for *_, t in history] == [1024, 2048, 3072]
    rate, ret, steps = max(history, key=lambda e: (e[0], e[1], -e[2]))
    assert (kept["timesteps"], kept["success_rate"], kept["mean_return"]) == (steps, rate, ret)
    assert kept["last"]["timesteps"] == 3072
    # The run's policy is the kept one: its own step count, and the checkpoint's weights.
    assert json.loads((out / "policy.json").read_text())["num_timesteps"] == steps
    assert load_policy(out).model.num_timesteps == steps
    with np.load(out / "checkpoints" / f"obs_stats_{steps}.npz") as ckpt_stats, \
            np.load(out / "obs_stats.npz") as final_stats:
        assert np.array_equal(final_stats["obs_mean"], ckpt_stats["obs_mean"])
    assert f"{steps:,} timesteps" in (out / "report.md").read_text()


def test_without_keep_best_the_last_step_is_the_policy(tmp_path):
    out = tmp_path / "sac"
    train(TrainConfig(algo="sac", timesteps=2048, out=str(out), hyperparams=dict(SHORT),
                      eval_every=1000, eval_episodes=4, keep_best=False),
          progress_bar=False, report=False)
    assert "kept" not in json.loads((out / "training.json").read_text())
    assert json.loads((out / "policy.json").read_text())["num_timesteps"] == 2048
    assert TrainConfig(algo="ppo").resolve().keep_best is False


def test_max_minutes_ends_the_run_with_a_final_model(tmp_path):
    out = tmp_path / "td3"
    with pytest.warns(UserWarning, match="no gradient step"):  # stopped before learning_starts
        assert cli_main(["train", "--algo", "td3", "--timesteps", "4096", "--out", str(out),
                         "--hyperparams", json.dumps(SHORT), "--max-minutes", "1e-9",
                         "--eval-episodes", "4", "--no-report", "--no-progress"]) == 0
    summary = json.loads((out / "training.json").read_text())
    assert summary["stopped_by_time_limit"] is True
    assert summary["timesteps"] < 4096  # stopped at its first step
    assert json.loads((out / "policy.json").read_text())["num_timesteps"] == summary["kept"][
        "timesteps"] == summary["timesteps"]  # evaluated at its last step, the only one
    for bad in (0, -1.0, True):
        with pytest.raises(InvalidParameterError, match="max_minutes"):
            TrainConfig(algo="sac", max_minutes=bad).resolve()
