"""``rbenv train --algo sac|td3|tqc|crossq``: short runs with the settings rbenv/hyperparams ships.

Each run is a few thousand steps (no learning is expected); what is checked is the plumbing:
the run folder and report exist, and every setting not overridden here came from
``rbenv/hyperparams/<algo>.py``, the file ``rl_zoo3 --conf-file`` reads.
"""

import importlib
import json

import numpy as np
import pytest
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import load_policy
from rbenv.agents.training.config import ZOO_KEYS, TrainConfig
from rbenv.agents.training.sb3 import train

pytest.importorskip("sb3_contrib", reason="sb3-contrib is not installed (train extra)")

OFF_POLICY = ("sac", "td3", "tqc", "crossq")
# Small enough for a test: gradient steps start after 512 of the 2048 steps.
SHORT = {"learning_starts": 512, "gradient_steps": 1, "batch_size": 64, "buffer_size": 4096}


def shipped(algo: str) -> dict:
    return importlib.import_module(f"rbenv.hyperparams.{algo}").hyperparams[
        "rbenv/SatelliteReorient-v0"]


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
