"""Issue 19, items 2 and 3: a run folder is data, and the checkpoint is the truth.

A run written now holds no pickle; loading (``load_policy``, ``rbenv evaluate --policy``,
``--resume``) never unpickles without ``trust_pickle``. A malicious pickle, one that creates a
marker file when unpickled, is planted in every place a run folder holds one (today's files and
the pickle-based files of runs written before the change), and nothing runs without the flag.
With the flag, an old-format folder still loads and resumes.
"""

import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import load_policy, weights
from rbenv.agents.policies import runfolder as runs
from rbenv.agents.policies import sb3 as sb3_policies
from rbenv.agents.policies.runfolder import RunFolderError, UntrustedPickleError
from rbenv.agents.policies.sb3 import SB3Policy
from rbenv.agents.training.config import TrainConfig
from rbenv.agents.training.sb3 import train

SMALL = {"n_steps": 32, "batch_size": 64, "n_epochs": 1}
SHORT = {"max_episode_steps": 30}


def tiny(out, **kw):
    base = dict(timesteps=256, n_envs=4, out=str(out), hyperparams=SMALL, env_kwargs=SHORT,
                checkpoint_every=128, eval_every=128, eval_episodes=2, report_episodes=4)
    return TrainConfig(**{**base, **kw})


def run(cfg, **kw):
    return train(cfg, progress_bar=False, report=False, **kw)


class Evil:
    """Unpickling this creates the marker file: the code a hostile run folder would run."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (Path.touch, (Path(self.marker),))  # made and closed


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("ppo") / "run"
    run(tiny(out))
    return out


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sac") / "run"
    hyper = {"learning_starts": 64, "batch_size": 32, "buffer_size": 1000}
    run(tiny(out, algo="sac", hyperparams=hyper, save_replay_buffer=True))
    return out


@pytest.fixture
def copy(ppo_run, tmp_path):
    dst = tmp_path / "copy"
    shutil.copytree(ppo_run, dst)
    (dst / runs.LOCK).unlink(missing_ok=True)
    return dst


def _no_pickle_anywhere(out):
    """Every file of the run is JSON, text, an image, a pickle-free .npz or weights-only .pt."""
    for path in out.rglob("*"):
        if not path.is_file() or path.name == runs.LOCK:
            continue
        suffix = path.suffix
        assert suffix in (".json", ".npz", ".pt", ".md", ".png"), path
        if suffix == ".json":
            json.loads(path.read_text())
        elif suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                for key in data.files:
                    assert data[key].dtype != object, (path, key)
        elif suffix == ".pt":
            torch.load(path, weights_only=True)


@pytest.mark.slow
def test_a_run_folder_holds_no_pickle(ppo_run, sac_run):
    for out in (ppo_run, sac_run):
        _no_pickle_anywhere(out)
    assert (sac_run / "checkpoints" / "replay_buffer_256.npz").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_weights_round_trip_restores_every_state_a_resume_needs(algo, ppo_run, sac_run,
                                                                tmp_path):
    """policy + optimizers (+ SAC's entropy coefficient), counters, statistics, buffer."""
    from rbenv.agents.training.sb3 import make_vec_env

    out = ppo_run if algo == "ppo" else sac_run
    cfg = runs.read_config(out)
    ckpt = out / "checkpoints" / "policy_256.pt"
    env = sb3_policies.load_stats(out / "checkpoints" / "obs_stats_256.npz",
                          make_vec_env(tiny(out, algo=algo, env_kwargs=cfg["env_kwargs"]), 4, 0))
    model = sb3_policies.load_model(ckpt, env=env, hyperparams=cfg["hyperparams"], seed=0)
    saved = weights.read_tensors(ckpt)
    assert model.num_timesteps == 256
    got = model.get_parameters()
    assert got.keys() == saved["params"].keys()
    optimizers = [k for k in got if k.endswith("optimizer")]
    assert optimizers, got.keys()
    for name in optimizers:  # Adam's moments, not a fresh optimizer
        state = got[name]["state"]
        assert state and all(torch.equal(state[i]["exp_avg"], saved["params"][name]["state"][i]
                                         ["exp_avg"]) for i in state)
        assert any(s["exp_avg"].abs().sum() > 0 for s in state.values())
    for key, tensor in got["policy"].items():
        assert torch.equal(tensor, saved["params"]["policy"][key]), key
    if algo == "sac":
        assert torch.equal(model.log_ent_coef.detach(), saved["variables"]["log_ent_coef"])
        size = weights.load_replay_buffer(model, out / "checkpoints" / "replay_buffer_256.npz")
        assert size > 0 and model.replay_buffer.observations[:size].any()
    stats = sb3_policies.load_stats(out / "checkpoints" / "obs_stats_256.npz")
    assert np.array_equal(env.obs_rms.mean, stats.obs_rms.mean) and stats.obs_rms.count > 1


# --- planted pickles ----------------------------------------------------------------------------

def _pickle_bytes(marker):
    return pickle.dumps(Evil(marker))


def _evil_zip(path, marker):
    """An SB3-like .zip whose cloudpickled 'data' entry and policy.pth run code when loaded."""
    import base64

    blob = base64.b64encode(_pickle_bytes(marker)).decode()
    data = {"policy_class": {":type:": "<class 'type'>", ":serialized:": blob}}
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("data", json.dumps(data))
        z.writestr("policy.pth", _pickle_bytes(marker))
        z.writestr("_stable_baselines3_version", "2.9.2")


def _evil_pt(path, marker):
    """A torch file whose pickle holds an object other than tensors."""
    torch.save({"format": weights.FORMAT, "params": {"policy": Evil(marker)}}, path)


def _evil_npz(path, marker):
    with open(path, "wb") as f:
        np.savez(f, obs_mean=np.array([Evil(marker)], dtype=object))


def _plant_everywhere(out, marker):
    """Replace every file a run folder holds a pickle in (old and new names) with a hostile
    one. Returns the planted paths."""
    ckpt = out / "checkpoints"
    planted = []
    for path in (out / "policy.pt", *ckpt.glob("policy_*.pt")):
        _evil_pt(path, marker)
        planted.append(path)
    for path in (out / "obs_stats.npz", *ckpt.glob("obs_stats_*.npz"),
                 *ckpt.glob("replay_buffer_*.npz"), out / runs.EVAL_LOG):
        _evil_npz(path, marker)
        planted.append(path)
    for steps in (128, 256):  # the pickle-based names of runs written before issue 19
        _evil_zip(ckpt / f"model_{steps}.zip", marker)
        for name in (f"vecnormalize_{steps}.pkl", f"replay_buffer_{steps}.pkl"):
            (ckpt / name).write_bytes(_pickle_bytes(marker))
        planted += [ckpt / f"model_{steps}.zip", ckpt / f"vecnormalize_{steps}.pkl"]
    _evil_zip(out / runs.LEGACY_MODEL, marker)
    (out / runs.LEGACY_STATS).write_bytes(_pickle_bytes(marker))
    return [*planted, out / runs.LEGACY_MODEL, out / runs.LEGACY_STATS]


def test_the_planted_pickles_do_run_code_when_unpickled(tmp_path):
    """The control: each hostile file is live, so the tests below can fail."""
    marker = tmp_path / "marker"
    (tmp_path / "x.pkl").write_bytes(_pickle_bytes(marker))
    pickle.loads((tmp_path / "x.pkl").read_bytes())
    assert marker.exists()
    marker.unlink()
    _evil_pt(tmp_path / "x.pt", marker)
    torch.load(tmp_path / "x.pt", weights_only=False)
    assert marker.exists()


def _loaders(out):
    """Every way a user loads a run folder or its files, without the trust flag."""
    ckpt = out / "checkpoints"
    return {
        "load_policy(run)": lambda: load_policy(out),
        "load_policy(policy.pt)": lambda: load_policy(out / "policy.pt"),
        "load_policy(policy_128.pt)": lambda: load_policy(ckpt / "policy_128.pt"),
        "load_policy(model.zip)": lambda: load_policy(out / runs.LEGACY_MODEL),
        "load_policy(model_128.zip)": lambda: load_policy(ckpt / "model_128.zip"),
        "SB3Policy(model.zip)": lambda: SB3Policy(out / runs.LEGACY_MODEL),
        "load_stats(vecnormalize.pkl)": lambda: sb3_policies.load_stats(out / runs.LEGACY_STATS),
        "load_model(model_256.zip)": lambda: sb3_policies.load_model(ckpt / "model_256.zip"),
        "rbenv evaluate": lambda: cli_main(["evaluate", "--policy", str(out),
                                            "--episodes", "1"]),
        "rbenv evaluate model.zip": lambda: cli_main(
            ["evaluate", "--policy", str(out / runs.LEGACY_MODEL), "--episodes", "1"]),
        "rbenv train --resume": lambda: cli_main(
            ["train", "--out", str(out), "--resume", "--timesteps", "512", "--no-progress",
             "--no-report"]),
    }


@pytest.mark.slow
@pytest.mark.parametrize("way", list(_loaders(Path("unused"))))
def test_nothing_planted_runs_without_the_flag(copy, tmp_path, way):
    marker = tmp_path / "marker"
    _plant_everywhere(copy, marker)
    with pytest.raises((RunFolderError, SystemExit)):
        _loaders(copy)[way]()
    assert not marker.exists()


@pytest.mark.slow
def test_refusals_name_the_trust_flag(copy, tmp_path):
    marker = tmp_path / "marker"
    for name in ("policy.pt", "policy.json", "obs_stats.npz"):  # only the old final files
        (copy / name).unlink()
    _evil_zip(copy / runs.LEGACY_MODEL, marker)
    (copy / runs.LEGACY_STATS).write_bytes(_pickle_bytes(marker))
    with pytest.raises(UntrustedPickleError, match=r"trust_pickle=True.*--trust-pickle"):
        load_policy(copy)
    with pytest.raises(UntrustedPickleError, match=r"vecnormalize.pkl.*trust_pickle=True"):
        sb3_policies.load_stats(copy / runs.LEGACY_STATS)
    with pytest.raises(UntrustedPickleError, match="--trust-pickle"):
        cli_main(["evaluate", "--policy", str(copy), "--episodes", "1"])
    assert not marker.exists()


@pytest.mark.slow
def test_a_resume_over_only_pickled_checkpoints_names_the_flag(copy, tmp_path):
    marker = tmp_path / "marker"
    ckpt = copy / "checkpoints"
    for path in [*ckpt.glob("policy_*"), *ckpt.glob("obs_stats_*"), ckpt / runs.LATEST]:
        path.unlink()
    for steps in (128, 256):
        _evil_zip(ckpt / f"model_{steps}.zip", marker)
        (ckpt / f"vecnormalize_{steps}.pkl").write_bytes(_pickle_bytes(marker))
    (copy / runs.SUMMARY).unlink()
    with pytest.raises(RunFolderError, match=r"model_256.zip.*trust_pickle=True"):
        run(TrainConfig(out=str(copy), timesteps=512), resume=True)
    assert not marker.exists()


# --- old run folders keep working with the flag ---------------------------------------------------

def _as_old_format(out):
    """Rewrite a run folder as rbenv wrote it before issue 19: SB3 .zip files and pickled
    VecNormalize statistics, by SB3's own save functions, as the old code called them."""
    from rbenv.agents.training.sb3 import make_vec_env

    venv = make_vec_env(tiny(out), 4, 0)
    ckpt = out / "checkpoints"
    pairs = [(out / "policy.pt", out / runs.LEGACY_MODEL, out / "obs_stats.npz",
              out / runs.LEGACY_STATS)]
    for steps in (128, 256):
        pairs.append((ckpt / f"policy_{steps}.pt", ckpt / f"model_{steps}.zip",
                      ckpt / f"obs_stats_{steps}.npz", ckpt / f"vecnormalize_{steps}.pkl"))
    hyperparams = runs.read_config(out)["hyperparams"]
    for pt, zip_path, npz, pkl in pairs:
        env = weights.load_stats(npz).vecnormalize(venv)
        weights.load_model(pt, env=env, hyperparams=hyperparams).save(zip_path)
        env.save(str(pkl))  # VecNormalize pickles itself
        for path in (pt, weights.config_path(pt), npz):
            path.unlink()
    runs.write_json(ckpt / runs.LATEST, {"timesteps": 256, "model": "model_256.zip",
                                         "vecnormalize": "vecnormalize_256.pkl"})
    return out


@pytest.mark.slow
def test_an_old_format_folder_loads_and_resumes_with_the_flag(copy, ppo_run, capsys):
    expected = load_policy(ppo_run, action="mode")
    _as_old_format(copy)
    assert not list(copy.rglob("*.pt"))
    policy = load_policy(copy, action="mode", trust_pickle=True)
    n_obs = expected.model.observation_space.shape[0]
    obs = np.random.default_rng(0).uniform(-1, 1, (4, n_obs)).astype(np.float32)
    assert np.array_equal(policy.predict(obs)[0], expected.predict(obs)[0])
    assert cli_main(["evaluate", "--policy", str(copy), "--episodes", "2",
                     "--trust-pickle"]) == 0
    run(TrainConfig(out=str(copy), timesteps=384), resume=True, trust_pickle=True)
    assert "from 256 timesteps (model_256.zip)" in capsys.readouterr().out
    summary = json.loads((copy / runs.SUMMARY).read_text())
    assert summary["resumed_from"] == 256 and summary["timesteps"] == 384
    assert (copy / "policy.pt").is_file()  # written in the pickle-free format from now on
    assert load_policy(copy).model.num_timesteps == 384


# --- item 3: the checkpoint is the truth ----------------------------------------------------------

@pytest.mark.slow
def test_a_pointer_that_disagrees_with_its_checkpoint_is_named_and_skipped(copy, capsys):
    ckpt = copy / "checkpoints"
    claim = 1_000_000_000
    runs.write_json(ckpt / runs.LATEST, {"timesteps": claim, "model": "policy_256.pt",
                                         "stats": "obs_stats_256.npz"})
    (copy / runs.SUMMARY).unlink()  # not finished: resume trains on
    run(TrainConfig(out=str(copy), timesteps=384), resume=True)
    out = capsys.readouterr().out
    assert f"latest.json' claims {claim} timesteps but the model" in out
    assert "holds 256" in out and "from 256 timesteps" in out
    summary = json.loads((copy / runs.SUMMARY).read_text())
    assert summary["resumed_from"] == 256 and summary["timesteps"] == 384
    assert summary["session_steps_per_s"] > 0


@pytest.mark.slow
def test_a_checkpoint_whose_name_disagrees_with_its_model_is_skipped(copy, capsys):
    ckpt = copy / "checkpoints"
    (ckpt / runs.LATEST).unlink()
    for suffix in (".pt", ".json"):  # a 128-step model under the name of 256
        shutil.copy(ckpt / f"policy_128{suffix}", ckpt / f"policy_256{suffix}")
    (copy / runs.SUMMARY).unlink()
    run(TrainConfig(out=str(copy), timesteps=384), resume=True)
    out = capsys.readouterr().out
    assert "policy_256.pt' claims 256 timesteps but the model" in out and "holds 128" in out
    assert json.loads((copy / runs.SUMMARY).read_text())["resumed_from"] == 128


# --- RLlib run folders: RLlib's own checkpoint format pickles, so loading needs the flag ----------

def test_rllib_folders_are_refused_without_the_flag_before_ray_is_imported(tmp_path):
    """Runs without Ray installed: the refusal comes before any import of ray."""
    from rbenv.agents.policies.rllib import RLlibPolicy
    from rbenv.agents.training import rllib

    out = tmp_path / "rllib-run"
    (out / runs.POLICY_DIR).mkdir(parents=True)
    (out / runs.POLICY_DIR / "class_and_ctor_args.pkl").write_bytes(
        _pickle_bytes(tmp_path / "marker"))
    runs.write_json(out / runs.CONFIG, {"engine": "rllib", "algo": "ppo"})
    with pytest.raises(UntrustedPickleError, match=r"RLlib.*trust_pickle=True"):
        RLlibPolicy(out)
    with pytest.raises(UntrustedPickleError, match="--trust-pickle"):
        cli_main(["evaluate", "--policy", str(out), "--episodes", "1"])
    with pytest.raises(UntrustedPickleError, match="--trust-pickle"):
        rllib.train(rllib.RLlibConfig(out=str(out)), resume=True)
    assert not (tmp_path / "marker").exists()
