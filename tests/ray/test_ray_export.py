"""Issue 31 for RLlib: an RLlib PPO run's MLP exported to C and ONNX is the run's own policy.

A tiny RLlib run on a private local Ray instance; its module is read (with trust_pickle: the
run is our own), exported, compiled under flight code's strict flags, and compared with the
run's ``predict(obs, deterministic=True)`` on observations of its own seeded episodes.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("ray")
from rbenv.agents.policies import export as ex
from rbenv.agents.policies import load_policy
from rbenv.agents.policies.compiled import CPolicy
from rbenv.agents.training.rllib import RLlibConfig, train

CC = shutil.which("cc")
HAVE_ONNX = all(importlib.util.find_spec(m) for m in ("onnx", "onnxruntime"))


@pytest.mark.skipif(CC is None, reason="no system C compiler (cc)")
def test_an_rllib_mlp_exports_to_c_and_onnx(tmp_path):
    out = tmp_path / "run"
    cfg = RLlibConfig(out=str(out), timesteps=1024, envs_per_runner=16, checkpoint_every=1024,
                      eval_every=1024, eval_episodes=2, report_episodes=2,
                      env_kwargs={"max_episode_steps": 30},
                      hyperparams={"train_batch_size_per_learner": 512, "minibatch_size": 256,
                                   "num_epochs": 1})
    train(cfg, report=False, progress=False)
    policy = load_policy(out, trust_pickle=True)
    obs = ex.episode_observations(policy, episodes=16, steps=64, seed=3)
    formats = ["c", "onnx"] if HAVE_ONNX else ["c"]
    export_dir = tmp_path / "export"
    with pytest.raises(ValueError, match="trust_pickle"):
        ex.export(out, formats, export_dir)
    done = ex.export(out, formats, export_dir, trust_pickle=True)
    assert done.footprint["head"] == "clip"
    lib = tmp_path / "strict.so"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-shared",
                    "-fPIC", str(export_dir / "policy.c"), "-o", str(lib), "-lm"], check=True)
    shutil.copy(export_dir / "export.json", tmp_path / "export.json")
    want, _ = policy.predict(obs, deterministic=True)
    span = policy.high - policy.low
    got, _ = CPolicy(lib).predict(obs)
    assert np.max(np.abs(got - want) / span) <= 1e-5
    if HAVE_ONNX:
        assert np.max(np.abs(ex.run_onnx(export_dir / "policy.onnx", obs) - want) / span) <= 1e-5
    assert np.ptp(want, axis=0).max() > 1e-4  # the actions vary: the comparison is not vacuous
