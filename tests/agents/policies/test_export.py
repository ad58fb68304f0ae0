"""Issue 31: a run folder exported to C99 and ONNX is the run's own policy, verified not assumed.

One short training run per algorithm (PPO, SAC, TD3, TQC, CrossQ). Its export is compiled with
the system compiler under the strict flags of flight code, called through ctypes, run under
onnxruntime, and compared with the run's ``predict(obs, deterministic=True)`` on thousands of
observations from the policy's own seeded episodes: equal to 1e-5 of each action's range. The
C policy then flies the env (``rbenv evaluate --policy DIR/policy.c``) and meets the run's
success and propellant on the same seeded episodes.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch
from rbenv.agents.cli import main as cli_main
from rbenv.agents.policies import export as ex
from rbenv.agents.policies import load_policy
from rbenv.agents.policies.compiled import CPolicy
from rbenv.agents.policies.evaluate import evaluate
from rbenv.agents.policies.sb3 import RunPolicy
from rbenv.agents.training.config import TrainConfig
from rbenv.agents.training.sb3 import train

ALGOS = ("ppo", "sac", "td3", "tqc", "crossq")
SHORT = {"max_episode_steps": 30}
STRICT = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic")
CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no system C compiler (cc)")
HAVE_ONNX = all(importlib.util.find_spec(m) for m in ("onnx", "onnxruntime"))
needs_onnx = pytest.mark.skipif(not HAVE_ONNX, reason="no onnx/onnxruntime (the export extra)")
FORMATS = ["c", "onnx"] if HAVE_ONNX else ["c"]


def _hyper(algo: str) -> dict:
    if algo == "ppo":
        return {"n_steps": 32, "batch_size": 64, "n_epochs": 1}
    return {"learning_starts": 64, "batch_size": 32, "buffer_size": 1000}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A tiny run folder per algorithm (256 env steps: the function, not a good policy)."""
    torch.set_num_threads(1)
    out = {}
    for algo in ALGOS:
        folder = tmp_path_factory.mktemp(algo) / "run"
        cfg = TrainConfig(algo=algo, timesteps=256, n_envs=4, out=str(folder),
                          hyperparams=_hyper(algo), env_kwargs=SHORT, checkpoint_every=10**6,
                          eval_every=10**6, eval_episodes=2, report_episodes=2)
        train(cfg, progress_bar=False, report=False)
        out[algo] = folder
    return out


@pytest.fixture(scope="module")
def observations(runs):
    """2048 observations per algorithm from 32 seeded episodes of the run's own policy."""
    return {algo: ex.episode_observations(load_policy(run), episodes=32, steps=64, seed=100)
            for algo, run in runs.items()}


def _strict_library(folder, tmp_path):
    """policy.c compiled as flight code would be (warnings are errors), as a shared library."""
    lib = tmp_path / "strict.so"
    cmd = [CC, *STRICT, "-shared", "-fPIC", str(folder / "policy.c"), "-o", str(lib), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    shutil.copy(folder / "export.json", tmp_path / "export.json")
    return lib


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("algo", ALGOS)
def test_c_and_onnx_reproduce_the_runs_predict(algo, runs, observations, tmp_path):
    out = tmp_path / "export"
    done = ex.export(runs[algo], FORMATS, out)
    policy = load_policy(runs[algo])
    obs = observations[algo]
    assert len(obs) >= 2000
    want, _ = policy.predict(obs, deterministic=True)
    span = policy.model.action_space.high - policy.model.action_space.low
    c_policy = CPolicy(_strict_library(out, tmp_path))
    got_c, _ = c_policy.predict(obs)
    outputs = [got_c] + ([ex.run_onnx(out / "policy.onnx", obs)] if HAVE_ONNX else [])
    for got in outputs:
        assert got.shape == want.shape and got.dtype == np.float32
        assert np.max(np.abs(got - want) / span) <= 1e-5
    # The check is not vacuous: the actions vary across the observations.
    assert np.ptp(want, axis=0).max() > 1e-3
    assert set(done.errors) == {"network", *FORMATS}
    header = (out / "policy.h").read_text()
    n_obs, n_act = obs.shape[1], want.shape[1]
    assert f"#define RBENV_OBS_DIM {n_obs}" in header
    assert f"#define RBENV_ACT_DIM {n_act}" in header
    assert "void rbenv_policy(const float *obs, float *action);" in header
    layout = gym.make(policy.env_id).unwrapped.observation_structure  # name -> width
    for name in (str(runs[algo]), policy.env_id, "cubesat-12u", *layout):
        assert name in header


@pytest.mark.slow
@needs_onnx
def test_onnx_passes_the_checker_and_keeps_a_dynamic_batch(runs, tmp_path):
    import onnx

    ex.export(runs["sac"], "onnx", tmp_path)
    model = onnx.load(str(tmp_path / "policy.onnx"))
    onnx.checker.check_model(model, full_check=True)
    (inp,), (out,) = model.graph.input, model.graph.output
    n_obs = load_policy(runs["sac"]).model.observation_space.shape[0]
    assert [d.dim_param or d.dim_value for d in inp.type.tensor_type.shape.dim] == ["n", n_obs]
    assert inp.name == "obs" and out.name == "action"
    props = {p.key: json.loads(p.value) for p in model.metadata_props}
    assert props["env_id"] == load_policy(runs["sac"]).env_id


@pytest.mark.slow
@needs_cc
def test_ppo_mode_action_is_the_clipped_mean(runs, observations, tmp_path):
    """PPO exported as it acts with --action mode: clip(mu, low, high), no libm beyond tanhf."""
    policy = load_policy(runs["ppo"], action="mode")
    obs = observations["ppo"]
    ex.export(policy, FORMATS, tmp_path, check_observations=obs)
    assert json.loads((tmp_path / "footprint.json").read_text())["head"] == "clip"
    want, _ = policy.predict(obs)
    got, _ = CPolicy(tmp_path / "policy.c").predict(obs)
    assert np.max(np.abs(got - want)) <= 2e-5
    if HAVE_ONNX:
        assert np.max(np.abs(ex.run_onnx(tmp_path / "policy.onnx", obs) - want)) <= 2e-5
    assert "erfcf" not in (tmp_path / "policy.c").read_text()


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_the_object_holds_no_mutable_global_and_calls_only_libm(algo, runs, tmp_path):
    """nm: the only function defined outside is rbenv_policy; every datum is read-only; the
    only undefined symbols are the libm functions footprint.json counts (no malloc)."""
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("no nm (binutils)")
    ex.export(runs[algo], "c", tmp_path)
    obj = tmp_path / "policy.o"
    subprocess.run([CC, *STRICT, "-c", str(tmp_path / "policy.c"), "-o", str(obj)], check=True)
    symbols = [line.split() for line in subprocess.run(
        [nm, str(obj)], capture_output=True, text=True, check=True).stdout.splitlines()]
    kinds = {s[-2]: s[-1] for s in symbols if len(s) >= 2}
    defined = {(s[-2], s[-1]) for s in symbols if len(s) == 3}
    assert ("T", "rbenv_policy") in defined
    assert not [s for s in defined if s[0] in "DdBbCG"], defined  # writable data or bss
    undefined = {name for kind, name in ((s[0], s[1]) for s in symbols if len(s) == 2)
                 if kind == "U"}
    counted = set(json.loads((tmp_path / "footprint.json").read_text())["transcendental_calls"])
    assert undefined <= counted and "malloc" not in undefined, (undefined, kinds)


@pytest.mark.slow
def test_footprint_counts_the_networks_arithmetic(runs, tmp_path):
    """Multiply-adds and bytes from the weights themselves: sum of n_in n_out over the dense
    layers, plus one per observation entry for the normalisation; the head's constants and
    libm calls as the policy acts: the run's own action (the main job's recipe: its mode, a
    clip) and its mean throttle (std and bounds, erfcf and expf per action)."""
    from rbenv.agents.policies.sb3 import SB3Policy

    params = torch.load(runs["ppo"] / "policy.pt", weights_only=True)["params"]["policy"]
    dense = [params[k] for k in params if k.endswith(".weight")
             and (k.startswith("mlp_extractor.policy_net") or k.startswith("action_net"))]
    n_obs, n_act = dense[0].shape[1], dense[-1].shape[0]
    macs = sum(w.shape[0] * w.shape[1] for w in dense) + n_obs
    hidden = sum(w.shape[0] for w in dense[:-1])
    for source, head, per_action, calls in (
            (runs["ppo"], "clip", 2, {"tanhf": hidden}),
            (SB3Policy(runs["ppo"], action="mean_throttle"), "mean_throttle", 4,
             {"tanhf": hidden, "erfcf": 3 * n_act, "expf": 2 * n_act})):
        out = tmp_path / head
        fp = ex.export(source, "c", out).footprint
        consts = sum(w.numel() + w.shape[0] for w in dense) + 2 * n_obs + per_action * n_act
        assert fp["head"] == head
        assert fp["multiply_adds"] == macs
        assert fp["weight_bytes"] == 4 * consts
        assert fp["transcendental_calls"] == calls
        assert json.loads((out / "footprint.json").read_text()) == fp


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_the_c_policy_flies_the_env_with_the_runs_success_and_propellant(algo, runs, tmp_path,
                                                                        capsys):
    """rbenv evaluate --policy DIR/policy.c against the run on the same seeded episodes."""
    ex.export(runs[algo], "c", tmp_path)
    run = evaluate(str(runs[algo]), episodes=16, seed=7, record=0)
    flown = evaluate(str(tmp_path / "policy.c"), episodes=16, seed=7, record=0)
    np.testing.assert_array_equal(flown.success, run.success)
    np.testing.assert_allclose(flown.fuel_kg, run.fuel_kg, rtol=1e-4, atol=1e-9)
    assert np.nanmean(run.fuel_kg) > 0  # propellant was spent: the comparison is not 0 == 0
    cli_main(["evaluate", "--policy", str(tmp_path / "policy.c"), "--episodes", "4", "--seed",
              "7", "--json", str(tmp_path / "c.json")])
    summary = json.loads((tmp_path / "c.json").read_text())
    assert summary["episodes"] == 4
    np.testing.assert_allclose(summary["fuel"]["mean"], np.mean(run.fuel_kg[:4]), rtol=1e-4)


@pytest.mark.slow
def test_cli_prints_and_writes_the_footprint(runs, tmp_path, capsys):
    assert cli_main(["export", str(runs["td3"]), "--format", "c", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    fp = json.loads((tmp_path / "footprint.json").read_text())
    assert f"multiply-adds per call: {fp['multiply_adds']}" in printed
    assert f"weights (flash): {fp['weight_bytes']} bytes" in printed
    info = json.loads((tmp_path / "export.json").read_text())
    n_obs = load_policy(runs["td3"]).model.observation_space.shape[0]
    assert info["algo"] == "td3" and info["obs_dim"] == n_obs


# --- refusals ----------------------------------------------------------------------------------

def _in_memory(algo_cls, policy="MlpPolicy", **policy_kwargs):
    import gymnasium as gym

    import rbenv

    env = gym.make(rbenv.ENV_ID, **SHORT)
    model = algo_cls(policy, env, policy_kwargs=policy_kwargs, device="cpu")
    return RunPolicy(model, None, {"env_id": rbenv.ENV_ID, "env_kwargs": SHORT}, action="mode")


def test_an_unknown_activation_is_refused_by_name(tmp_path):
    from stable_baselines3 import PPO

    policy = _in_memory(PPO, activation_fn=torch.nn.Softsign)
    with pytest.raises(ex.UnsupportedActivationError, match="Softsign"):
        ex.export(policy, "c", tmp_path)
    assert not (tmp_path / "policy.c").exists()


def test_a_recurrent_policy_is_refused_by_name(tmp_path):
    from sb3_contrib import RecurrentPPO

    policy = _in_memory(RecurrentPPO, "MlpLstmPolicy")
    with pytest.raises(ex.RecurrentPolicyError, match="LSTM"):
        ex.export(policy, "c", tmp_path)


def test_a_scripted_baseline_needs_no_export(tmp_path):
    from rbenv.agents.policies.evaluate import make_policy

    import rbenv

    env = __import__("gymnasium").make(rbenv.ENV_ID)
    with pytest.raises(ex.UnsupportedPolicyError, match="scripted baseline"):
        ex.export(make_policy("zero", env), "c", tmp_path)


@pytest.mark.slow
def test_a_missing_export_extra_is_named(runs, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "onnx", None)
    with pytest.raises(ex.MissingExportExtraError, match=r"rbenv\[export\]"):
        ex.export(runs["ppo"], "onnx", tmp_path)
    monkeypatch.setattr(sys, "argv", ["rbenv", "export", str(runs["ppo"]), "--format", "onnx",
                                      "--out", str(tmp_path)])
    assert cli_main() == 2  # from the command line: one line naming the extra, status 2
    assert "rbenv[export]" in capsys.readouterr().err


@pytest.mark.slow
def test_a_wrong_format_is_named(runs, tmp_path):
    with pytest.raises(ValueError, match="format must be one of"):
        ex.export(runs["ppo"], "tflite", tmp_path)


# --- the flight computer ------------------------------------------------------------------------

ARM = shutil.which("arm-none-eabi-gcc")


@pytest.mark.slow
@pytest.mark.skipif(ARM is None, reason="no arm-none-eabi-gcc (Debian: gcc-arm-none-eabi "
                                        "libnewlib-arm-none-eabi)")
def test_cross_compiles_for_a_cortex_m4_with_fpu(runs, tmp_path):
    """The C builds for -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard; its read-only
    data holds the weights (arm-none-eabi-size)."""
    done = ex.export(runs["ppo"], "c", tmp_path)
    obj = tmp_path / "policy.o"
    subprocess.run([ARM, *STRICT, "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16",
                    "-mfloat-abi=hard", "-c", str(tmp_path / "policy.c"), "-o", str(obj)],
                   check=True)
    size = subprocess.run([shutil.which("arm-none-eabi-size"), "-A", str(obj)],
                          capture_output=True, text=True, check=True).stdout
    sections = {p[0]: int(p[1]) for p in (line.split() for line in size.splitlines())
                if len(p) >= 2 and p[1].isdigit()}
    assert sections.get(".rodata", 0) >= done.footprint["weight_bytes"] - 64
    assert sections.get(".data", 0) == 0 and sections.get(".bss", 0) == 0


def test_a_c_file_without_its_manifest_is_named(tmp_path):
    (tmp_path / "policy.c").write_text("void rbenv_policy(const float *o, float *a) {}\n")
    with pytest.raises(ValueError, match=r"export\.json"):
        load_policy(tmp_path / "policy.c")


@pytest.mark.slow
@needs_cc
def test_int8_weights_are_written_exactly_and_their_error_is_measured(runs, observations,
                                                                     tmp_path):
    """--precision int8: the C computes the quantised network (to 1e-5 of the range), a
    quarter of the weight bytes, and the export reports how far that is from the run."""
    obs = observations["sac"]
    f32 = ex.export(runs["sac"], "c", tmp_path / "f32", check_observations=obs)
    done = ex.export(runs["sac"], FORMATS, tmp_path / "q8", check_observations=obs,
                     precision="int8")
    flight = ex.to_int8(ex.from_policy(load_policy(runs["sac"])))
    got, _ = CPolicy(tmp_path / "q8" / "policy.c").predict(obs)
    assert ex.max_error(flight, got, flight(obs)) <= 1e-5
    want, _ = load_policy(runs["sac"]).predict(obs)
    measured = ex.max_error(flight, got, want)
    assert 0 < done.errors["int8_vs_policy"] == pytest.approx(measured, abs=1e-5)
    assert done.errors["int8_vs_policy"] < 0.05  # 8 bits per weight: about 1 % of the range
    assert "static const signed char W0" in (tmp_path / "q8" / "policy.c").read_text()
    assert done.footprint["weights"] == "int8"
    assert done.footprint["weight_bytes"] < 0.3 * f32.footprint["weight_bytes"]
    with pytest.raises(ValueError, match="precision must be one of"):
        ex.export(runs["sac"], "c", tmp_path / "x", precision="int4")
