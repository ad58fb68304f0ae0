"""Run folders: resume, fall-back past corrupt checkpoints, confinement, locks, --force, loading.

Every run here is tiny (4 envs, 32-step rollouts, a few hundred timesteps); a module fixture
trains one run with checkpoints at 128, 256, 384 and 512 timesteps, and each test works on a
copy of it.
"""

import dataclasses
import fcntl
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import threading
import typing
from pathlib import Path

import numpy as np
import pytest
import torch
from rbenv.agents.policies import load_policy
from rbenv.agents.policies import runfolder as runs
from rbenv.agents.policies import sb3 as sb3_policies
from rbenv.agents.policies.runfolder import RunFolderError, RunLockedError
from rbenv.agents.training.config import TrainConfig
from rbenv.agents.training.engine import RunLock
from rbenv.agents.training.sb3 import train
from rbenv.core.errors import InvalidParameterError, RbenvValueError

import rbenv

SMALL = {"n_steps": 32, "batch_size": 64, "n_epochs": 1}
SHORT = {"max_episode_steps": 30}  # short episodes keep evaluations cheap


def tiny(out, **kw):
    base = dict(timesteps=512, n_envs=4, out=str(out), hyperparams=SMALL, env_kwargs=SHORT,
                checkpoint_every=128, eval_every=128, eval_episodes=2, report_episodes=4)
    return TrainConfig(**{**base, **kw})


def run(cfg, **kw):
    return train(cfg, progress_bar=False, report=False, **kw)


@pytest.fixture(scope="module")
def base_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("base") / "run"
    run(tiny(out))
    return out


@pytest.fixture
def copy(base_run, tmp_path):
    dst = tmp_path / "copy"
    shutil.copytree(base_run, dst)
    (dst / runs.LOCK).unlink(missing_ok=True)
    return dst


def summary(out):
    return json.loads((out / "training.json").read_text())


def params(out):
    from rbenv.agents.policies import weights

    return weights.read_tensors(out / "policy.pt")["params"]["policy"]


# --- resume ------------------------------------------------------------------------------------

def test_base_run_has_checkpoints_history_and_a_trained_summary(base_run):
    names = sorted(p.name for p in (base_run / "checkpoints").glob("policy_*.pt"))
    assert names == ["policy_128.pt", "policy_256.pt", "policy_384.pt", "policy_512.pt"]
    s = summary(base_run)
    assert s["timesteps"] == 512 and s["trained"] and s["gradient_updates"] > 0
    assert s["wall_time_s"] > 0 and s["threads"] == 1
    with np.load(base_run / "eval" / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [128, 256, 384, 512]
    assert not (base_run / runs.LOCK).read_text()  # released cleanly: no stale record


def test_resume_continues_the_folder_given_not_the_one_in_config_json(copy, base_run):
    assert json.loads((copy / "config.json").read_text())["out"] == str(base_run)
    before = {p: p.stat().st_mtime_ns for p in base_run.rglob("*")}
    run(TrainConfig(out=str(copy), timesteps=640), resume=True)
    assert summary(copy)["timesteps"] == 640 and summary(copy)["resumed_from"] == 512
    assert (copy / "checkpoints" / "policy_640.pt").exists()
    assert {p: p.stat().st_mtime_ns for p in base_run.rglob("*")} == before


def test_resume_keeps_the_evaluation_history_and_accumulates_wall_time(copy):
    wall = summary(copy)["wall_time_s"]
    run(TrainConfig(out=str(copy), timesteps=768), resume=True)
    with np.load(copy / "eval" / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [128, 256, 384, 512, 640, 768]
        assert log["successes"].shape == (6, 2) and log["results"].shape == (6, 2)
    assert summary(copy)["wall_time_s"] > wall


def test_resume_of_a_finished_run_is_a_no_op(copy, capsys):
    files = {p: p.read_bytes() for p in copy.rglob("*") if p.is_file() and p.name != runs.LOCK}
    run(TrainConfig(out=str(copy)), resume=True)
    assert "already finished (512 timesteps); nothing to do" in capsys.readouterr().out
    assert {p: p.read_bytes() for p in files} == files


def test_resume_refuses_a_folder_that_is_not_a_run(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(RunFolderError, match=f"{tmp_path}.*is not a training run.*config.json"):
        run(TrainConfig(out=str(tmp_path)), resume=True)
    with pytest.raises(RunFolderError, match="does not exist"):
        run(TrainConfig(out=str(tmp_path / "missing")), resume=True)
    assert not (tmp_path / "missing").exists()


def test_resume_with_no_checkpoint_yet_starts_from_zero_and_says_so(copy, capsys):
    for name in ("checkpoints", "eval"):
        shutil.rmtree(copy / name)
    for name in ("policy.pt", "training.json"):
        (copy / name).unlink()
    run(TrainConfig(out=str(copy), timesteps=256), resume=True)
    assert "no checkpoint in" in capsys.readouterr().out
    assert summary(copy)["timesteps"] == 256 and summary(copy)["resumed_from"] is None


# --- corrupt and hostile files ----------------------------------------------------------------

def _truncate(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _flip_bytes(path):
    data = bytearray(path.read_bytes())
    for i in range(len(data) // 3, len(data) // 3 + 64):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))


CORRUPTIONS = {
    "model truncated": lambda d: _truncate(d / "policy_512.pt"),
    "model bytes flipped": lambda d: _flip_bytes(d / "policy_512.pt"),
    "model missing": lambda d: (d / "policy_512.pt").unlink(),
    "model empty": lambda d: (d / "policy_512.pt").write_bytes(b""),
    "stats truncated": lambda d: _truncate(d / "obs_stats_512.npz"),
    "stats garbage": lambda d: (d / "obs_stats_512.npz").write_bytes(b"PK\x03\x04garbage"),
    "stats missing": lambda d: (d / "obs_stats_512.npz").unlink(),
    "config garbage": lambda d: (d / "policy_512.json").write_text('{"algo": "ppo"'),
    "config foreign": lambda d: (d / "policy_512.json").write_text('{"algo": "dqn"}'),
    "config missing": lambda d: (d / "policy_512.json").unlink(),
}
NAMED = {"model": "policy_512.pt", "stats": "obs_stats_512.npz", "config": "policy_512.json"}


@pytest.mark.slow
@pytest.mark.parametrize("corrupt", CORRUPTIONS, ids=list(CORRUPTIONS))
def test_resume_falls_back_past_a_corrupt_checkpoint_and_names_the_file(copy, capsys, corrupt):
    CORRUPTIONS[corrupt](copy / "checkpoints")
    run(TrainConfig(out=str(copy), timesteps=640), resume=True)
    out = capsys.readouterr().out
    named = NAMED[corrupt.split()[0]]
    assert named in out and ("incomplete" if corrupt.endswith("missing") else "unusable") in out
    assert "falling back to the last complete checkpoint" in out and "policy_384.pt" in out
    assert summary(copy)["resumed_from"] == 384 and summary(copy)["timesteps"] == 640


LATEST = {
    "not json": "{nope",
    "a list": "[1, 2]",
    "missing key": '{"timesteps": 512, "model": "policy_512.pt"}',
    "bad steps": '{"timesteps": "x", "model": "policy_512.pt", '
                 '"stats": "obs_stats_512.npz"}',
    "path outside": '{"timesteps": 512, "model": "../../../../etc/passwd", '
                    '"stats": "obs_stats_512.npz"}',
    "absolute path": '{"timesteps": 512, "model": "policy_512.pt", '
                     '"stats": "/tmp/evil.npz"}',
}


@pytest.mark.parametrize("text", LATEST.values(), ids=list(LATEST))
def test_a_bad_latest_json_is_reported_and_the_newest_checkpoint_on_disk_is_used(copy, capsys,
                                                                                 text):
    (copy / "checkpoints" / "latest.json").write_text(text)
    run(TrainConfig(out=str(copy), timesteps=640), resume=True)
    out = capsys.readouterr().out
    assert "ignoring" in out and "latest.json" in out
    assert summary(copy)["resumed_from"] == 512


def test_a_symlink_out_of_the_run_folder_is_refused(copy, tmp_path):
    outside = tmp_path / "elsewhere.npz"
    shutil.copy(copy / "checkpoints" / "obs_stats_512.npz", outside)
    (copy / "checkpoints" / "link.npz").symlink_to(outside)
    with pytest.raises(RunFolderError, match="resolves outside"):
        runs.confined(copy / "checkpoints", "link.npz", "stats")


def test_every_checkpoint_corrupt_is_an_error_naming_them(copy):
    for p in (copy / "checkpoints").glob("policy_*.pt"):
        _truncate(p)
    with pytest.raises(RunFolderError, match=r"no usable checkpoint.*policy_512.pt.*policy_128.pt"):
        run(TrainConfig(out=str(copy), timesteps=640), resume=True)


@pytest.mark.parametrize("text", ["{", "[]", '{"algo": "ppo", "hyperparams": 3}',
                                  '{"algo": "dqn"}', '{"n_envs": -5}',
                                  '{"env_kwargs": [1]}'])
def test_a_corrupt_config_json_is_an_error_naming_it(copy, text):
    (copy / "config.json").write_text(text)
    with pytest.raises(RunFolderError, match=r"config.json"):
        run(TrainConfig(out=str(copy), timesteps=640), resume=True)


@pytest.mark.parametrize("target", ["policy.pt", "obs_stats.npz", "policy.json"])
def test_loading_a_corrupt_final_file_names_it(copy, target):
    _truncate(copy / target)
    with pytest.raises(RunFolderError, match=re.escape(target)):
        load_policy(copy)


def test_a_torn_evaluation_history_is_replaced_with_a_warning(copy):
    _truncate(copy / "eval" / "evaluations.npz")
    with pytest.warns(UserWarning, match="evaluations.npz"):
        run(TrainConfig(out=str(copy), timesteps=640), resume=True)
    with np.load(copy / "eval" / "evaluations.npz") as evals:
        assert evals["timesteps"].tolist() == [640]


# --- new runs, --force, locks, temporary files ------------------------------------------------

def test_a_new_run_into_a_non_empty_folder_needs_force(copy):
    (copy / "mine.txt").write_text("keep me")
    with pytest.raises(RunFolderError, match=r"not empty.*--force"):
        run(tiny(copy, timesteps=128))
    assert summary(copy)["timesteps"] == 512  # untouched
    run(tiny(copy, timesteps=128, checkpoint_every=64), force=True)
    assert summary(copy)["timesteps"] == 128
    assert not (copy / "checkpoints" / "policy_512.pt").exists()  # the old run is gone
    assert (copy / "mine.txt").read_text() == "keep me"  # files that are not the run's stay


HOLD_LOCK = textwrap.dedent("""
    import sys, time
    from rbenv.agents.training.engine import RunLock
    lock = RunLock(sys.argv[1]).acquire()
    print("locked", flush=True)
    time.sleep(120)
""")


def test_a_live_lock_refuses_a_second_run_and_a_killed_holder_leaves_a_stale_lock(copy):
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(copy)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(RunLockedError, match=f"in use by pid {holder.pid}"):
            run(TrainConfig(out=str(copy), timesteps=640), resume=True)
        with pytest.raises(RunLockedError):
            run(tiny(copy), force=True)
        assert summary(copy)["timesteps"] == 512
    finally:
        holder.kill()  # SIGKILL: no clean-up runs in the holder
        holder.wait()
        holder.stdout.close()
    lock = RunLock(copy).acquire()
    try:
        assert lock.stale["pid"] == holder.pid  # recognised as stale, and taken over
    finally:
        lock.release()


def _hold_without_record(run_dir) -> int:
    """Take ``run_dir``'s lock as a holder does in the moment before it writes its record."""
    fd = os.open(Path(run_dir) / "run.lock", os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return fd


def test_a_refused_start_waits_for_the_holders_record(tmp_path):
    fd = _hold_without_record(tmp_path)
    record = json.dumps({"pid": 4242, "host": "h", "started": "now"}).encode()
    writer = threading.Timer(0.2, os.pwrite, (fd, record, 0))
    writer.start()
    try:
        with pytest.raises(RunLockedError, match="in use by pid 4242 on h"):
            RunLock(tmp_path).acquire()
    finally:
        writer.join()
        os.close(fd)


def test_a_start_takes_the_lock_a_holder_lets_go_of_while_it_waits(tmp_path):
    fd = _hold_without_record(tmp_path)
    releaser = threading.Timer(0.2, os.close, (fd,))
    releaser.start()
    lock = RunLock(tmp_path).acquire()
    releaser.join()
    try:
        assert json.loads((tmp_path / "run.lock").read_text())["pid"] == os.getpid()
    finally:
        lock.release()


def test_a_holder_that_never_writes_a_record_is_named_another_process(tmp_path, monkeypatch):
    import rbenv.agents.training.engine as engine
    monkeypatch.setattr(engine, "LOCK_RECORD_WAIT_S", 0.1)
    fd = _hold_without_record(tmp_path)
    try:
        with pytest.raises(RunLockedError, match="in use by another process"):
            RunLock(tmp_path).acquire()
    finally:
        os.close(fd)


def _train_command(out, *, timesteps: int, checkpoint_every: int, eval_every: int) -> list:
    """``rbenv train`` in a child process: a small PPO run on 4 envs, short episodes."""
    return [sys.executable, "-m", "rbenv.agents.cli", "train", "--timesteps", str(timesteps),
            "--n-envs", "4", "--out", str(out), "--checkpoint-every", str(checkpoint_every),
            "--eval-every", str(eval_every), "--hyperparams", json.dumps(SMALL),
            "--env-kwargs", json.dumps(SHORT), "--no-report", "--no-progress"]


@pytest.mark.slow
def test_two_concurrent_runs_on_one_folder_one_refused(tmp_path):
    out = tmp_path / "shared"
    cmd = _train_command(out, timesteps=2048, checkpoint_every=256, eval_every=100000)
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    results = [(p.wait(timeout=300), *p.communicate()) for p in procs]
    codes = sorted(r[0] for r in results)
    errors = " ".join(r[2] for r in results)
    # Either the second start found the folder locked, or (if the first had finished) not
    # empty; both are refusals with a named reason, never an interleaved run.
    assert codes == [0, 2], results
    assert "rbenv train: error:" in errors
    assert "is in use by pid" in errors or "not empty" in errors
    assert summary(out)["timesteps"] == 2048
    steps = sorted(int(p.stem.split("_")[1]) for p in (out / "checkpoints").glob("policy_*.pt"))
    assert steps == list(range(256, 2049, 256))
    assert not list(out.rglob("*.tmp"))


def test_atomic_writes_use_unique_temporary_names(tmp_path):
    target = tmp_path / "shared.json"
    errors = []

    def writer(k):
        try:
            for i in range(50):
                runs.write_json(target, {"writer": k, "i": i, "pad": "x" * 5000})
        except Exception as e:  # pragma: no cover - the failure being tested for
            errors.append(e)

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert json.loads(target.read_text())["i"] == 49
    assert [p.name for p in tmp_path.iterdir()] == ["shared.json"]


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "f.txt"
    target.write_text("old")

    def fail(p):
        p.write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        runs.atomic_write(target, fail)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["f.txt"]


# --- configuration checks ---------------------------------------------------------------------

def test_sac_shorter_than_learning_starts_is_refused_before_training(tmp_path):
    with pytest.raises(InvalidParameterError, match="learning_starts"):
        run(TrainConfig(algo="sac", timesteps=2000, out=str(tmp_path / "sac")))
    assert not (tmp_path / "sac").exists()


@pytest.mark.parametrize("field,value", [("threads", 0), ("n_envs", -1), ("timesteps", True),
                                         ("n_envs", 2.5), ("checkpoint_every", 0)])
def test_bad_counts_are_named(tmp_path, field, value):
    with pytest.raises(InvalidParameterError, match=field):
        run(tiny(tmp_path / "x", **{field: value}))


# --- loading for deployment -------------------------------------------------------------------

def test_load_policy_gives_a_ready_policy_for_plain_gym_make(base_run):
    from rbenv.agents.policies import weights

    policy = load_policy(base_run, action="mode")  # SB3's own deterministic action
    env = policy.make_env()
    assert env.spec.max_episode_steps == SHORT["max_episode_steps"]  # the run's env options
    obs, _ = env.reset(seed=3)
    action, _ = policy.predict(obs)
    stats = sb3_policies.load_stats(base_run / "obs_stats.npz")
    expected, _ = weights.load_model(base_run / "policy.pt").predict(
        stats.normalize_obs(obs), deterministic=True)
    assert action.shape == (12,) and np.array_equal(action, expected)
    with pytest.raises(ValueError, match="observation shape"):
        policy.predict(np.zeros(3, np.float32))


def test_a_checkpoint_is_paired_with_its_own_statistics(base_run):
    ckpt = load_policy(base_run / "checkpoints" / "policy_128.pt")
    own = sb3_policies.load_stats(base_run / "checkpoints" / "obs_stats_128.npz")
    final = sb3_policies.load_stats(base_run / "obs_stats.npz")
    assert np.array_equal(ckpt.vecnormalize.obs_rms.mean, own.obs_rms.mean)
    assert not np.allclose(ckpt.vecnormalize.obs_rms.mean, final.obs_rms.mean)
    assert ckpt.config["n_envs"] == 4 and ckpt.env_kwargs["scene"] == "cubesat-12u"


@pytest.mark.parametrize("norm_reward", [True, False])
def test_a_run_without_observation_normalisation_checkpoints_resumes_and_loads(tmp_path,
                                                                                norm_reward):
    """SB3 keeps no ``obs_rms`` when ``norm_obs`` is off: the checkpoints still save (the
    identity), a resume continues, and the loaded policy acts on the raw observation."""
    from rbenv.agents.policies import weights

    out = tmp_path / "raw"
    normalize = {"norm_obs": False, "norm_reward": norm_reward}
    run(tiny(out, timesteps=256, normalize=normalize))
    stats = sb3_policies.load_stats(out / "checkpoints" / "obs_stats_256.npz")
    assert not stats.norm_obs and stats.norm_reward == norm_reward
    obs = np.linspace(-3.0, 3.0, 15).astype(np.float32)
    assert np.array_equal(stats.normalize_obs(obs), obs)
    run(tiny(out, timesteps=512, normalize=normalize), resume=True)
    assert summary(out)["timesteps"] == 512
    policy = load_policy(out, action="mode")
    expected, _ = weights.load_model(out / "policy.pt").predict(obs, deterministic=True)
    assert np.array_equal(policy.predict(obs)[0], expected)


def test_a_checkpoint_without_its_statistics_is_refused(copy):
    (copy / "checkpoints" / "obs_stats_256.npz").unlink()
    with pytest.raises(RunFolderError, match=r"obs_stats_256.npz"):
        load_policy(copy / "checkpoints" / "policy_256.pt")


def test_evaluate_uses_the_run_config_for_a_torque_mode_checkpoint(tmp_path):
    from rbenv.agents.cli import main as cli_main

    out = tmp_path / "torque"
    run(tiny(out, timesteps=256, env_kwargs={**SHORT, "action_mode": "torque"}))
    summary_path = tmp_path / "ckpt.json"
    assert cli_main(["evaluate", "--policy", str(out / "checkpoints" / "policy_128.pt"),
                     "--episodes", "3", "--json", str(summary_path)]) == 0
    assert json.loads(summary_path.read_text())["episodes"] == 3


def test_not_a_model_is_an_error_naming_it(tmp_path):
    bogus = tmp_path / "model.zip"
    bogus.write_text("not a zip")
    with pytest.raises(RbenvValueError, match=r"model.zip"), \
            pytest.warns(UserWarning, match="no vecnormalize.pkl beside"):  # found first
        load_policy(bogus)


# --- threads, reproducibility, tensorboard ----------------------------------------------------

def test_training_is_reproducible_given_seed_and_threads(tmp_path, base_run):
    run(tiny(tmp_path / "again"))
    a, b = params(base_run), params(tmp_path / "again")
    assert a.keys() == b.keys()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert torch.get_num_threads() == 1
    run(tiny(tmp_path / "seed1", seed=1))
    c = params(tmp_path / "seed1")
    assert not all(torch.equal(a[k], c[k]) for k in a)  # the comparison can fail


def test_threads_option_sets_torch_and_is_recorded(tmp_path):
    try:
        run(tiny(tmp_path / "two", timesteps=128, checkpoint_every=128, threads=2))
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(1)
    config = json.loads((tmp_path / "two" / "config.json").read_text())
    assert config["threads"] == 2 and config["versions"]["cpu"]
    assert summary(tmp_path / "two")["threads"] == 2


def test_tensorboard_logs_through_sb3(tmp_path):
    pytest.importorskip("tensorboard")
    run(tiny(tmp_path / "tbrun", timesteps=256), tensorboard=str(tmp_path / "tb"))
    events = list((tmp_path / "tb" / "tbrun").glob("events.out.tfevents.*"))
    assert events and events[0].stat().st_size > 100


def test_progress_bar_counts_this_sessions_steps_at_the_average_rate(copy, monkeypatch):
    import rbenv.agents.training.sb3 as train_module

    bars = []
    original = train_module.RateProgress._on_training_start

    def keep(self):
        original(self)
        bars.append(self.pbar)

    monkeypatch.setattr(train_module.RateProgress, "_on_training_start", keep)
    train(TrainConfig(out=str(copy), timesteps=768), resume=True, progress_bar=True,
          report=False)
    (bar,) = bars
    assert bar.total == 256 and bar.n == 256  # resumed at 512: only the new steps
    assert bar.smoothing == 0  # the rate shown is steps / elapsed, updates included


# Kill moments: during imports, then right after each of these files appears (so the kill lands
# between the writes of a checkpoint, an evaluation, or the final files).
KILL_WHEN = ("1 s after start", "config.json", "checkpoints/policy_128.pt",
             "checkpoints/policy_128.json", "checkpoints/obs_stats_256.npz",
             "eval/evaluations.npz", "checkpoints/policy_768.pt", "checkpoints/policy_1536.pt",
             "policy.pt", "policy.json", "training.json")


@pytest.mark.slow
@pytest.mark.parametrize("when", KILL_WHEN)
def test_kill_9_at_any_moment_then_resume_finishes_the_run(tmp_path, when):
    """A real SIGKILL at a spread of moments; resuming always completes the run."""
    import signal
    import time

    out = tmp_path / "run"
    cmd = _train_command(out, timesteps=1536, checkpoint_every=128, eval_every=256)
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        if when.endswith("after start"):
            time.sleep(1.0)
        else:
            deadline = time.time() + 240
            while not (out / when).exists() and proc.poll() is None and time.time() < deadline:
                time.sleep(0.005)
            assert proc.poll() is None or (out / when).exists(), proc.stderr.read()[-2000:]
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    cfg = TrainConfig(out=str(out), timesteps=1536)
    try:
        run(cfg, resume=True)
    except RunFolderError as e:  # killed before config.json existed: start it anew, no --force
        assert "is not a training run" in str(e) or "does not exist" in str(e)
        run(tiny(out, timesteps=1536, eval_every=256))
    assert summary(out)["timesteps"] == 1536
    assert not list(out.rglob("*.tmp"))
    with np.load(out / "eval" / "evaluations.npz") as evals:
        assert evals["timesteps"].tolist() == list(range(256, 1537, 256))
    policy = load_policy(out)
    n_obs = policy.model.observation_space.shape[0]
    assert policy.predict(np.zeros(n_obs, np.float32))[0].shape == (12,)


@pytest.mark.slow
def test_sac_resumes_with_its_replay_buffer_and_survives_a_corrupt_one(tmp_path, capsys):
    out = tmp_path / "sac"
    hyper = {"learning_starts": 100, "batch_size": 32, "buffer_size": 2000}
    run(tiny(out, algo="sac", timesteps=256, hyperparams=hyper, save_replay_buffer=True))
    buffers = sorted(p.name for p in (out / "checkpoints").glob("replay_buffer_*"))
    assert buffers == ["replay_buffer_256.npz"]  # only the latest is kept
    run(TrainConfig(out=str(out), timesteps=384), resume=True)
    restored = re.search(r"replay buffer restored: (\d+) transitions, (\d+) vector steps of 4 "
                         "envs", capsys.readouterr().out)
    # 64 vector steps of 4 envs, less the last one: SB3 stores a step after the callbacks run
    assert restored and 60 <= int(restored.group(2)) <= 64
    assert int(restored.group(1)) == 4 * int(restored.group(2))
    _truncate(out / "checkpoints" / "replay_buffer_384.npz")
    run(TrainConfig(out=str(out), timesteps=512), resume=True)
    printed = capsys.readouterr().out
    assert "replay_buffer_384.npz" in printed and "not restored" in printed
    assert summary(out)["timesteps"] == 512 and summary(out)["trained"]


@pytest.mark.slow
def test_an_off_policy_run_keeps_no_replay_buffer_unless_asked_and_resumes_without(tmp_path,
                                                                                   capsys):
    out = tmp_path / "sac"
    hyper = {"learning_starts": 100, "batch_size": 32, "buffer_size": 2000}
    run(tiny(out, algo="sac", timesteps=256, hyperparams=hyper))
    assert not list(out.rglob("replay_buffer_*"))
    run(TrainConfig(out=str(out), timesteps=384), resume=True)
    printed = capsys.readouterr().out
    assert "no replay buffer saved with checkpoint 256" in printed
    assert "starts with an empty buffer" in printed
    assert summary(out)["timesteps"] == 384 and summary(out)["resumed_from"] == 256
    assert summary(out)["gradient_updates"] > 0 and not list(out.rglob("replay_buffer_*"))
    # A config.json from before the flag existed kept its buffer; its resumes keep doing so.
    config = json.loads((out / "config.json").read_text())
    del config["save_replay_buffer"]
    (out / "config.json").write_text(json.dumps(config))
    run(TrainConfig(out=str(out), timesteps=512), resume=True)
    assert [p.name for p in out.rglob("replay_buffer_*")] == ["replay_buffer_512.npz"]


def test_a_deleted_latest_json_is_said_and_the_newest_checkpoint_on_disk_resumes(copy, capsys):
    (copy / "checkpoints" / "latest.json").unlink()
    run(TrainConfig(out=str(copy), timesteps=640), resume=True)
    printed = capsys.readouterr().out
    assert "checkpoint pointer" in printed and "latest.json' is missing" in printed
    assert summary(copy)["resumed_from"] == 512 and summary(copy)["timesteps"] == 640


def test_max_minutes_says_when_and_why_it_stopped_and_a_larger_limit_trains_on(tmp_path,
                                                                              capsys):
    out = tmp_path / "ppo"
    with pytest.warns(UserWarning, match="no gradient step"):  # stopped at its first step
        run(tiny(out, max_minutes=1e-9))
    printed = capsys.readouterr().out
    stopped = re.search(r"stopped by --max-minutes 1e-09: \d+\.\d min of training wall time "
                        r"\(all sessions of the run\) at (\d+) of 512 timesteps", printed)
    assert stopped and int(stopped.group(1)) == summary(out)["timesteps"] < 512
    assert f"--out {out} --resume --max-minutes M" in printed
    assert summary(out)["stopped_by_time_limit"] is True
    run(TrainConfig(out=str(out), max_minutes=60.0), resume=True)
    assert "stopped by" not in capsys.readouterr().out
    assert summary(out)["timesteps"] >= 512 and summary(out)["stopped_by_time_limit"] is False


@pytest.mark.slow
def test_td3_resumes_with_its_action_noise(tmp_path, capsys):
    """TD3's shipped settings name its exploration noise in the zoo's words (noise_type,
    noise_std); a resume builds the model from them as a new run does, with the noise."""
    out = tmp_path / "td3"
    hyper = {"learning_starts": 100, "batch_size": 32, "buffer_size": 2000}
    run(tiny(out, algo="td3", timesteps=256, hyperparams=hyper))
    run(TrainConfig(out=str(out), timesteps=384), resume=True)
    printed = capsys.readouterr().out
    assert "resuming td3" in printed and "unusable" not in printed
    assert summary(out)["timesteps"] == 384 and summary(out)["trained"]
    config = json.loads((out / "config.json").read_text())
    assert config["hyperparams"]["noise_type"] == "normal"


@pytest.mark.parametrize("text", ["{", '{"wall_time_s": 1}', '{"timesteps": "x"}'])
def test_a_corrupt_training_summary_is_named_and_the_run_rewrites_it(copy, capsys, text):
    (copy / "training.json").write_text(text)
    run(TrainConfig(out=str(copy)), resume=True)  # same total: only the final files are redone
    printed = capsys.readouterr().out
    assert "ignoring the training summary" in printed and "training.json" in printed
    assert summary(copy)["timesteps"] == 512 and summary(copy)["resumed_from"] == 512
    assert summary(copy)["wall_time_s"] > 0


def test_a_bare_sb3_model_loads_with_a_warning_about_missing_statistics(tmp_path):
    from rbenv.agents.training.sb3 import make_vec_env
    from rbenv.agents.training.sb3_vec_env import SB3VecEnv
    from stable_baselines3 import PPO

    env = make_vec_env(TrainConfig().resolve(), 2, 0)
    assert isinstance(env.venv, SB3VecEnv)
    PPO("MlpPolicy", env, n_steps=8, batch_size=16, seed=0, device="cpu").save(
        tmp_path / "model.zip")
    with pytest.raises(runs.UntrustedPickleError, match="trust_pickle=True"), \
            pytest.warns(UserWarning, match="no vecnormalize.pkl beside"):  # found first
        load_policy(tmp_path / "model.zip")  # a foreign SB3 .zip holds cloudpickled objects
    with pytest.warns(UserWarning, match="no vecnormalize.pkl beside"):
        policy = load_policy(tmp_path / "model.zip", trust_pickle=True)
    assert policy.vecnormalize is None and policy.config is None
    n_obs = policy.model.observation_space.shape[0]
    assert policy.predict(np.zeros((3, n_obs), np.float32))[0].shape == (3, 12)


def test_a_zoo_model_finds_its_statistics_and_a_bare_model_warns(tmp_path):
    """RL Zoo keeps vecnormalize.pkl in a folder named like the model; without any, a warning."""
    from rbenv.agents.policies.runfolder import LEGACY_STATS as FINAL_STATS
    from rbenv.agents.policies.runfolder import locate

    model = tmp_path / "rbenv-SatelliteReorient-v0.zip"
    model.write_bytes(b"zip")
    with pytest.warns(UserWarning, match="raw observations"):
        assert locate(model).stats is None
    (tmp_path / "rbenv-SatelliteReorient-v0").mkdir()
    (tmp_path / "rbenv-SatelliteReorient-v0" / FINAL_STATS).write_bytes(b"stats")
    assert locate(model).stats == tmp_path / "rbenv-SatelliteReorient-v0" / FINAL_STATS


def test_policy_action_auto_is_mean_throttle_only_for_a_gaussian_policy_in_throttle_mode():
    import gymnasium as gym
    from rbenv.agents.policies.sb3 import RunPolicy
    from rbenv.core.errors import InvalidParameterError
    from stable_baselines3 import PPO, SAC

    env = gym.make(rbenv.ENV_ID)
    ppo = PPO("MlpPolicy", env, n_steps=64, device="cpu")
    assert RunPolicy(ppo).action == "mean_throttle"
    assert RunPolicy(ppo, config={"env_kwargs": {"action_mode": "torque"}}).action == "mode"
    assert RunPolicy(ppo, action="mode").action == "mode"
    sac = SAC("MlpPolicy", env, buffer_size=100, device="cpu")
    assert RunPolicy(sac).action == "mode"
    with pytest.raises(InvalidParameterError, match=r"mean_throttle.*SAC"):
        RunPolicy(sac, action="mean_throttle")


def test_a_runs_policy_action_decides_what_auto_means_and_an_explicit_action_wins():
    import gymnasium as gym
    from rbenv.agents.policies.sb3 import POLICY_ACTIONS, RunPolicy
    from rbenv.agents.training.config import PolicyAction
    from rbenv.core.errors import InvalidParameterError
    from stable_baselines3 import PPO

    assert typing.get_args(PolicyAction) == POLICY_ACTIONS  # one set of names
    ppo = PPO("MlpPolicy", gym.make(rbenv.ENV_ID), n_steps=64, device="cpu")
    assert RunPolicy(ppo, config={"policy_action": "mode"}).action == "mode"
    assert RunPolicy(ppo, config={"policy_action": "auto"}).action == "mean_throttle"
    assert RunPolicy(ppo, config={"policy_action": None}).action == "mean_throttle"
    assert RunPolicy(ppo, config={"policy_action": "mode"}, action="mean_throttle").action \
        == "mean_throttle"
    with pytest.raises(InvalidParameterError, match=r"policy_action.*'sample'"):
        RunPolicy(ppo, config={"policy_action": "sample"})


def test_policy_action_is_a_run_default_a_flag_and_absent_from_old_runs(tmp_path):
    """The recipe's run default fills an unset policy_action, the caller's wins, a bad value is
    named, and a config.json written before the field existed loads as auto (not as the
    recipe's current default)."""
    from rbenv.agents.settings.table import RUN_KEYS
    from rbenv.agents.training.config import TrainConfig, resumed_config
    from rbenv.core.errors import InvalidParameterError

    assert "policy_action" in RUN_KEYS
    assert TrainConfig(algo="sac").resolve().policy_action == "auto"
    assert TrainConfig(algo="sac", policy_action="mode").resolve().policy_action == "mode"
    with pytest.raises(InvalidParameterError, match=r"policy_action must be one of .*'best'"):
        TrainConfig(algo="sac", policy_action="best").resolve()
    cfg = TrainConfig(algo="ppo", out=str(tmp_path / "run")).resolve()
    saved = {k: v for k, v in dataclasses.asdict(cfg).items() if k != "policy_action"}
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "config.json").write_text(json.dumps(saved))
    assert resumed_config(TrainConfig, tmp_path / "run").policy_action == "auto"


def test_the_mean_action_clips_each_entry_where_the_env_clips_it():
    """On a scene with wheels and thrusters, E[clip(μ + σε, low, high)] uses each entry's own
    bounds: [-1, 1] for the wheels, [0, 1] for the thrusters (Monte Carlo check)."""
    from rbenv.agents.policies.sb3 import RunPolicy, expected_throttle

    policy = object.__new__(RunPolicy)
    policy.config = {"env_id": rbenv.ENV_ID, "scene": "cubesat-12u-rw"}
    low, high = policy.clip_bounds
    assert list(low[:3]) == [-1.0] * 3 and list(low[3:]) == [0.0] * 12
    assert (high == 1.0).all()
    rng = np.random.default_rng(3)
    mean, std = rng.normal(0.0, 0.8, 15), np.full(15, 0.4)
    draws = np.clip(mean + std * rng.standard_normal((200_000, 15)), low, high).mean(axis=0)
    np.testing.assert_allclose(expected_throttle(mean, std, low, high), draws, atol=4e-3)
    assert expected_throttle(mean, std, low, high)[:3].min() < 0.0  # a wheel turns both ways
    assert np.array_equal(expected_throttle(mean, std), expected_throttle(mean, std, 0.0, 1.0))
