"""``rbenv train --engine sbx``: SAC and TD3 in JAX (SBX) with sb3's run folders.

What is checked: an SBX policy saved by rbenv loads as SB3's torch policy and acts as the JAX
one did (two independent implementations of the same network agree); a resume restores the
complete JAX training state, and refuses a state that does not fit; the CLI's run folder,
resume and errors. Every run is a few hundred steps of 4 envs (no learning is expected).
"""

import json
import shutil
import sys

import numpy as np
import pytest
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import load_policy, weights
from rbenv.agents.policies.runfolder import RunFolderError
from rbenv.agents.policies.weights import ModelFileError
from rbenv.agents.training.config import TrainConfig
from rbenv.agents.training.sb3 import algo_class, make_vec_env, model_kwargs
from rbenv.core.errors import InvalidParameterError
from stable_baselines3.common.vec_env import VecNormalize

from rbenv.satellite.usage import MissingExtraError

pytest.importorskip("sbx", reason="sbx-rl is not installed (the sbx extra)")

SMALL = {"learning_starts": 64, "gradient_steps": 2, "batch_size": 32, "buffer_size": 2048,
         "policy_kwargs": {"net_arch": [16, 16]}}
SHORT = {"max_episode_steps": 30}


def trained(algo: str, steps: int = 256):
    """An SBX model after a few gradient steps (weights away from their initial values)."""
    cfg = TrainConfig(engine="sbx", algo=algo, n_envs=4, hyperparams=dict(SMALL),
                      env_kwargs=SHORT, timesteps=steps).resolve()
    env = VecNormalize(make_vec_env(cfg, cfg.n_envs, 0), norm_reward=False)
    model = algo_class(algo, "sbx")("MlpPolicy", env, seed=0, device="cpu",
                                    **model_kwargs(cfg, env))
    model.learn(steps)
    return cfg, env, model


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_saved_policy_loads_as_sb3_and_acts_as_the_jax_one(tmp_path, algo):
    _, env, model = trained(algo)
    path = tmp_path / "policy.pt"
    weights.save_model(model, path)
    loaded = weights.load_model(path)  # no env: SB3's torch policy, for inference
    assert type(loaded).__module__.startswith("stable_baselines3")
    obs = np.random.default_rng(0).normal(size=(64, *env.observation_space.shape))
    obs = obs.astype(np.float32)
    jax_action, _ = model.predict(obs, deterministic=True)
    torch_action, _ = loaded.predict(obs, deterministic=True)
    assert np.abs(jax_action).max() > 1e-3  # not a trivially zero policy
    np.testing.assert_allclose(torch_action, jax_action, atol=2e-5)
    assert json.loads(weights.config_path(path).read_text())["engine"] == "sbx"


@pytest.mark.slow
def test_resume_restores_every_array_of_the_jax_state(tmp_path):
    cfg, env, model = trained("sac")
    path = tmp_path / "policy.pt"
    weights.save_model(model, path)
    fresh = weights.load_model(path, env=env, hyperparams=model_kwargs(cfg, env), seed=1)
    assert weights.is_jax_model(fresh)
    saved = weights._leaves(weights._jax_states(model))
    restored = weights._leaves(weights._jax_states(fresh))
    assert saved.keys() == restored.keys() and any("opt_state" in k for k in saved)
    for key, value in saved.items():
        np.testing.assert_array_equal(restored[key], value, err_msg=key)
    assert fresh.num_timesteps == model.num_timesteps and fresh._n_updates == model._n_updates


@pytest.mark.slow
def test_a_state_that_does_not_fit_is_refused_naming_file_and_array(tmp_path):
    cfg, env, model = trained("td3", steps=128)
    path = tmp_path / "policy.pt"
    weights.save_model(model, path)
    state = weights.jax_state_path(path)
    with np.load(state) as data:
        arrays = {k: data[k] for k in data.files}
    key = next(k for k in arrays if "kernel" in k)
    arrays[key] = arrays[key][:-1]
    with open(state, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(ModelFileError, match=r"policy\.jax\.npz.*does not fit.*kernel"):
        weights.load_model(path, env=env, hyperparams=model_kwargs(cfg, env))
    state.unlink()
    with pytest.raises(ModelFileError, match=r"policy\.jax\.npz.*does not exist"):
        weights.load_model(path, env=env, hyperparams=model_kwargs(cfg, env))


def train_cli(out, *extra):
    return cli_main(["train", "--engine", "sbx", "--algo", "td3", "--n-envs", "4",
                     "--hyperparams", json.dumps(SMALL), "--env-kwargs", json.dumps(SHORT),
                     "--checkpoint-every", "128", "--eval-every", "128", "--eval-episodes",
                     "2", "--no-progress", "--out", str(out), *extra])


@pytest.mark.slow
def test_cli_run_folder_resume_and_evaluation(tmp_path, capsys):
    out = tmp_path / "run"
    assert train_cli(out, "--timesteps", "256", "--no-report") == 0
    config = json.loads((out / "config.json").read_text())
    assert config["engine"] == "sbx" and "jax" in config["versions"]
    for name in ("policy.pt", "policy.json", "policy.jax.npz", "obs_stats.npz"):
        assert (out / name).is_file(), name
    # A resume continues from the last checkpoint (its JAX state) to the new total.
    assert train_cli(out, "--timesteps", "384", "--resume", "--no-report") == 0
    assert "resuming td3" in capsys.readouterr().out
    assert json.loads((out / "training.json").read_text())["resumed_from"] == 256
    assert json.loads((out / "checkpoints" / "latest.json").read_text())["timesteps"] == 384
    # The run's policy is an SB3 policy with its statistics: evaluate reads it as any run.
    policy = load_policy(out)
    assert type(policy.model).__name__ == "TD3" and policy.env_kwargs["action_mode"] == "torque"
    assert cli_main(["evaluate", "--policy", str(out), "--episodes", "2"]) == 0
    # A folder trained by sbx is not resumed by sb3.
    shutil.rmtree(out / "eval")
    with pytest.raises(RunFolderError, match=r"not trained with --engine sb3.*'sbx'"):
        cli_main(["train", "--out", str(out), "--resume", "--no-progress"])


def test_sbx_takes_only_sac_and_td3():
    with pytest.raises(InvalidParameterError, match=r"sac, td3 for --engine sbx.*'ppo'"):
        TrainConfig(engine="sbx", algo="ppo").resolve()


def test_a_missing_sbx_names_its_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "sbx", None)  # import sbx fails as if not installed
    with pytest.raises(MissingExtraError, match=r'--engine sbx needs sbx.*the sbx extra'):
        train_cli(tmp_path / "run", "--timesteps", "256")
    assert not (tmp_path / "run").exists()


def test_a_hyperparameter_sbx_does_not_take_is_named_before_anything_is_written(tmp_path,
                                                                              capsys):
    from rbenv.agents.cli import console

    out = tmp_path / "run"
    assert console(["train", "--engine", "sbx", "--algo", "td3", "--out", str(out),
                    "--hyperparams", '{"tau": 0.01, "polyak": 0.99}']) == 2
    err = capsys.readouterr().err
    assert "hyperparams: ['polyak'] are not keyword arguments of TD3" in err
    assert "tau" in err.split("it takes", 1)[1]  # what it does take is listed
    assert not out.exists()
