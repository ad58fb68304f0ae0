"""A user's mistake on the command line: every argument is checked before anything is written,
and each mistake ends in one line (the argument, the value, what would be valid, a
did-you-mean for a near miss), exit status 2, no traceback; a missing extra names the extra."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import rbenv.agents.training
from rbenv.agents import cli
from rbenv.agents.training.engine import RunLock

TINY = ["--timesteps", "256", "--n-envs", "4", "--hyperparams",
        json.dumps({"n_steps": 32, "batch_size": 64, "n_epochs": 1}),
        "--env-kwargs", json.dumps({"max_episode_steps": 30}), "--checkpoint-every", "128",
        "--eval-every", "128", "--eval-episodes", "2", "--no-report", "--no-progress"]


def console(argv, capsys) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of the command line ``rbenv ARGV``."""
    try:
        code = cli.console(argv)
    except SystemExit as e:  # argparse's own errors
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(argv, capsys) -> str:
    code, out, err = console(argv, capsys)
    assert code == 2, (code, out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    command = f"rbenv {argv[0]}" if argv[0] in cli.COMMANDS else "rbenv"
    assert err.startswith(f"{command}: error: "), err
    return err


MISTAKES = {
    "missing path": (["evaluate", "--policy", "runs/does-not-exist"],
                     ["argument --policy", "'runs/does-not-exist' does not exist",
                      "pd, bangbang, innocube-pd, innocube-slew, mpc, zero, random"]),
    "policy case": (["evaluate", "--policy", "PD"], ["argument --policy", "did you mean 'pd'?"]),
    "policy of another task": (["evaluate", "--policy", "bdot"],
                               ["argument --policy", "rbenv/SatelliteDetumble-v1", "--env-id"]),
    "baseline not on this scene": (
        ["evaluate", "--policy", "bdot", "--env-id", "rbenv/SatelliteDetumble-v1"],
        ["argument --policy", "cannot act on scene 'cubesat-12u'", "runs on cubesat-6u-rw"]),
    "baseline not on the scene asked for": (
        ["evaluate", "--policy", "bdot", "--env-id", "rbenv/SatelliteDetumble-v1", "--scene",
         "cubesat-12u-rw"],
        ["argument --policy", "cannot act on scene 'cubesat-12u-rw'", "runs on cubesat-6u-rw"]),
    "baseline not on the scene asked for, scene first, v0": (
        ["evaluate", "--scene", "cubesat-12u-rw", "--env-id", "rbenv/SatelliteDetumble-v0",
         "--policy", "bdot"],
        ["argument --policy", "cannot act on scene 'cubesat-12u-rw'", "runs on cubesat-6u-rw"]),
    "baseline not on the scene of --env-kwargs": (
        ["evaluate", "--env-kwargs", '{"scene": "cubesat-12u-rw"}', "--policy", "bdot",
         "--env-id", "rbenv/SatelliteDetumble-v1"],
        ["argument --policy", "cannot act on scene 'cubesat-12u-rw'"]),
    "replay scene in env options": (
        ["replay", "telemetry", "--scene", "innocube-3u", "--policy", "innocube-pd",
         "--env-kwargs", '{"scene": "cubesat-6u-rw"}'],
        ["argument --env-kwargs", "must not hold 'scene'", "'cubesat-6u-rw'", "--scene"]),
    "env option": (["evaluate", "--policy", "pd", "--env-kwargs", '{"integrater": "rk4"}'],
                   ["argument --env-kwargs", "'integrater' is not an env option",
                    "did you mean 'integrator'?"]),
    "evaluate scene": (["evaluate", "--policy", "pd", "--scene", "cubesat12u"],
                       ["argument --scene", "did you mean 'cubesat-12u'?"]),
    "env id": (["evaluate", "--policy", "pd", "--env-id", "rbenv/SatelliteReorient-v9"],
               ["argument --env-id", "did you mean 'rbenv/SatelliteReorient-v"]),
    "option name": (["evaluate", "--polcy", "pd"], ["did you mean '--policy'?"]),
    "command": (["trian"], ["did you mean 'train'?"]),
    "algo": (["train", "--algo", "sacc"], ["argument --algo", "did you mean 'sac'?"]),
    "video suffix": (["evaluate", "--policy", "pd", "--video", "x.avi"],
                     ["argument --video", ".gif, .mp4"]),
    "torchrl option with sb3": (["train", "--quick"],
                                ["argument --quick", "belongs to --engine torchrl"]),
    "sb3 option with torchrl": (["train", "--engine", "torchrl", "--n-envs", "8"],
                                ["argument --n-envs", "belongs to --engine sb3"]),
    "rllib option with torchrl": (["train", "--engine", "torchrl", "--address", "auto"],
                                  ["argument --address", "belongs to --engine rllib"]),
    "option two engines read": (["train", "--engine", "rllib", "--stop-success", "1"],
                                ["argument --stop-success",
                                 "belongs to --engine sb3 and --engine torchrl"]),
    "torchrl quick resume": (["train", "--engine", "torchrl", "--quick", "--resume"],
                             ["argument --quick", "not one of --resume"]),
    "sb3 hyperparameter": (["train", "--hyperparams", '{"n_step": 8, "n_envs": 4}'],
                           ["hyperparams: ['n_envs', 'n_step']", "keyword arguments of PPO",
                            "n_envs is --n-envs", "n_step: did you mean 'n_steps'?"]),
    "torchrl hyperparameter": (["train", "--engine", "torchrl", "--hyperparams",
                                '{"rollout": 8}'],
                               ["hyperparams: ['rollout']", "n_envs, n_steps"]),
    "torchrl hyperparameter value": (["train", "--engine", "torchrl", "--hyperparams",
                                      '{"gamma": 1.5}'],
                                     ["gamma must be a finite number in (0, 1]", "1.5"]),
    "torchrl algo": (["train", "--engine", "torchrl", "--algo", "sac"],
                     ["argument --algo", "--engine torchrl's algorithms: ppo"]),
    "suite scene": (["suite", "--scenes", "cubesat12u", "--aggregate-only"],
                    ["argument --scenes", "did you mean 'cubesat-12u'?"]),
}


@pytest.mark.parametrize(("argv", "expected"), MISTAKES.values(), ids=list(MISTAKES))
def test_a_mistake_is_one_line_naming_the_argument_and_what_is_valid(argv, expected, capsys,
                                                                     tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    err = one_line_error(argv, capsys)
    for text in expected:
        assert text in err, (text, err)
    assert list(tmp_path.iterdir()) == []  # nothing written


BDOT_ON_6U = {"--policy": "bdot", "--scene": "cubesat-6u-rw"}


@pytest.mark.parametrize("version", ["v0", "v1"])
@pytest.mark.parametrize("order", [("--policy", "--env-id", "--scene"),
                                   ("--scene", "--policy", "--env-id"),
                                   ("--env-id", "--scene", "--policy"),
                                   ("--env-kwargs", "--policy", "--env-id")])
def test_a_baseline_is_checked_on_the_scene_asked_for_in_any_order(order, version, tmp_path,
                                                                   capsys):
    """The README's B-dot command: the policy is checked on --scene (or --env-kwargs' scene),
    not on the task's default scene, whichever comes first; then its episodes run."""
    values = {**BDOT_ON_6U, "--env-id": f"rbenv/SatelliteDetumble-{version}",
              "--env-kwargs": '{"scene": "cubesat-6u-rw"}'}
    argv = ["evaluate", *(w for flag in order for w in (flag, values[flag])),
            "--episodes", "1", "--json", str(tmp_path / "bdot.json")]
    code, _, err = console(argv, capsys)
    assert code == 0, err
    summary = json.loads((tmp_path / "bdot.json").read_text())
    assert summary["policy"] == "bdot" and summary["scene"] == "cubesat-6u-rw"
    assert summary["episodes"] == 1


def test_a_dry_run_checks_the_run_folder_and_writes_nothing(tmp_path, capsys):
    """--dry-run: a new run into another run's folder is refused as the real start would be,
    one with --force or into a new folder passes, and nothing is written or removed."""
    out = tmp_path / "run"
    code, printed, err = console(["train", "--out", str(out), "--dry-run", *TINY], capsys)
    assert code == 0 and "dry run: every check passed; nothing written" in printed, err
    assert not out.exists()
    assert "--dry-run" in _help(["train"], capsys)
    out.mkdir()
    (out / "config.json").write_text("{}")
    err = one_line_error(["train", "--out", str(out), "--dry-run", *TINY], capsys)
    assert "is not empty (it holds config.json)" in err and "--force" in err
    code, printed, err = console(["train", "--out", str(out), "--dry-run", "--force", *TINY],
                                 capsys)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["config.json"]


def test_a_dry_run_names_a_live_run_holding_the_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.console(["train", "--out", str(out), *TINY]) == 0
    capsys.readouterr()
    before = sorted(p.name for p in out.rglob("*"))
    lock = RunLock(out).acquire()  # a live run, as another process would hold it
    try:
        err = one_line_error(["train", "--out", str(out), "--resume", "--timesteps", "512",
                              "--dry-run"], capsys)
    finally:
        lock.release()
    assert "is in use by pid" in err and str(os.getpid()) in err
    code, printed, err = console(["train", "--out", str(out), "--resume", "--timesteps", "512",
                                  "--dry-run"], capsys)
    assert code == 0 and "the run would resume in" in printed, err
    assert sorted(p.name for p in out.rglob("*")) == before
    assert json.loads((out / "training.json").read_text())["timesteps"] == 256


def test_a_typo_in_the_scene_writes_nothing_and_the_retry_then_works(tmp_path, capsys):
    out = tmp_path / "run"
    err = one_line_error(["train", "--scene", "cubesat12u", "--out", str(out), *TINY], capsys)
    assert "argument --scene" in err and "did you mean 'cubesat-12u'?" in err
    assert not out.exists()  # no config.json, no run.lock, no folder
    assert cli.console(["train", "--scene", "cubesat-12u", "--out", str(out), *TINY]) == 0
    assert json.loads((out / "training.json").read_text())["timesteps"] == 256


def test_resume_of_a_folder_holding_a_bad_config_says_so(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.json").write_text(json.dumps({"engine": "sb3", "algo": "ppo",
                                                 "scene": "cubesat12u"}))
    err = one_line_error(["train", "--resume", "--out", str(out)], capsys)
    assert "holds a configuration that cannot run" in err and "config.json" in err
    assert "'cubesat12u'" in err and "--force" in err
    assert sorted(p.name for p in out.iterdir()) == ["config.json"]  # no lock left behind


def test_a_bad_value_inside_the_env_options_is_named_before_anything_is_written(tmp_path,
                                                                               capsys):
    out = tmp_path / "run"
    err = one_line_error(["train", "--out", str(out), "--env-kwargs",
                          '{"action_mode": "thrust"}'], capsys)
    assert "action_mode" in err and "'thrust'" in err and "torque" in err
    assert not out.exists()


@pytest.mark.parametrize(("argv", "module", "extra", "unloaded"), [
    (["train", "--engine", "torchrl", "--quick"], "torchrl", "ecosystem", "torchrl"),
    (["train", "--algo", "sac"], "stable_baselines3", "train", "sb3"),
])
def test_a_missing_extra_names_the_extra_to_install(argv, module, extra, unloaded, tmp_path,
                                                    capsys, monkeypatch):
    for name in [module, *(n for n in sys.modules if n.startswith(module + "."))]:
        monkeypatch.setitem(sys.modules, name, None)  # its import fails as if not installed
    monkeypatch.delitem(sys.modules, f"rbenv.agents.training.{unloaded}", raising=False)
    monkeypatch.delattr(rbenv.agents.training, unloaded, raising=False)
    out = tmp_path / "run"
    err = one_line_error([*argv, "--out", str(out)], capsys)
    assert f"needs {module}" in err and f"the {extra} extra" in err
    assert f'pip install -e ".[{extra}]"' in err
    assert not out.exists()


def test_an_unexpected_exception_keeps_its_traceback(monkeypatch):
    def broken(args):
        raise RuntimeError("a bug")

    monkeypatch.setitem(cli.COMMANDS, "evaluate", broken)
    with pytest.raises(RuntimeError, match="a bug"):
        cli.console(["evaluate", "--policy", "pd"])


def test_the_command_line_itself_prints_one_line_without_a_traceback(tmp_path):
    root = str(Path(__file__).resolve().parents[2])  # this checkout's rbenv, from any folder
    done = subprocess.run([sys.executable, "-m", "rbenv", "evaluate", "--policy",
                           "runs/does-not-exist"], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": root})
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "does not exist" in done.stderr


def _help(argv, capsys) -> str:
    with pytest.raises(SystemExit):
        cli.main([*argv, "--help"])
    return " ".join(capsys.readouterr().out.split())


def test_help_shows_defaults_and_every_scripted_policy(capsys):
    text = _help(["evaluate"], capsys)
    assert "(default: 100)" in text and "(default: 0)" in text and "(default: {})" in text
    assert "pd, bdot (SatelliteDetumble)" in text and "unload" in text


def test_train_help_groups_the_options_by_engine(capsys):
    text = _help(["train"], capsys)
    groups = ["common options", "sb3 options", "rllib options", "torchrl options"]
    at = [text.index(g) for g in groups]
    assert at == sorted(at)
    torchrl = text[at[3]:]
    assert "--quick" in torchrl and "--device" in torchrl
    assert "--quick" not in text[:at[3]].split("usage:")[-1].split("options:")[-1]
    assert "--save-replay-buffer" in text[at[1]:at[2]]
    assert "(default: 'ppo')" in text and "(default: 200000)" in text


def test_a_foreign_model_on_another_task_names_the_flags_that_pick_its_env(tmp_path, capsys):
    """An SB3 .zip without a config.json (RL Zoo's) trained on Reorient-v0 (7 observations),
    evaluated on the default v1 (15): one line naming --env-id, not a traceback."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    model = tmp_path / "zoo.zip"
    PPO("MlpPolicy", make_vec_env("rbenv/SatelliteReorient-v0", n_envs=1), n_steps=64,
        batch_size=64, device="cpu").save(model)
    with pytest.warns(UserWarning, match="sees raw observations"):
        err = one_line_error(["evaluate", "--policy", str(model), "--trust-pickle",
                              "--episodes", "2"], capsys)
    assert "observation shape (2, 15) does not match the policy's (7,)" in err
    assert "--env-id" in err


def test_a_bad_scene_from_env_kwargs_is_not_blamed_on_the_scene_flag(capsys):
    """The value came from --env-kwargs, so the error names the field, not ``--scene``."""
    err = one_line_error(["evaluate", "--policy", "pd", "--episodes", "1", "--env-kwargs",
                          '{"scene": "cubesat12u"}'], capsys)
    assert "argument --scene" not in err
    assert "scene: 'cubesat12u' is not a shipped name" in err
