"""The ray extra's guard and ``--address``: a clear message without Ray, a quick named failure
for an address where no cluster answers, and a run against a single-node cluster on 127.0.0.1."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from rbenv.agents.training.ray_cluster import (
    MissingExtraError,
    RayAddressError,
    check_reachable,
    require_ray,
)


def test_missing_extra_names_the_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray now raises ImportError
    with pytest.raises(MissingExtraError, match=r'pip install -e "\.\[ray\]"') as info:
        require_ray("--engine rllib")
    assert "--engine rllib" in str(info.value)


@pytest.mark.parametrize("bad", ["localhost", "host:port", ":6379", "10.0.0.1:0"])
def test_malformed_address_is_named(bad):
    with pytest.raises(RayAddressError, match="address must be") as info:
        check_reachable(bad)
    assert repr(bad) in str(info.value)


def test_unreachable_address_fails_fast_and_names_it(raytools):
    address = f"127.0.0.1:{raytools.free_port()}"  # bound and released: nothing listens there
    cmd = [sys.executable, "-m", "rbenv.agents.training.tune", "--ray", "--address", address,
           "--quick",
           "--out", "unused"]
    r = subprocess.run(cmd, env=raytools.ray_env(loopback=True), capture_output=True,
                       text=True, timeout=60, cwd=raytools.REPO)
    assert r.returncode != 0
    assert f"no Ray cluster answers at address '{address}'" in r.stderr


def test_rllib_on_single_node_cluster_via_address(raytools, tmp_path):
    """A head on 127.0.0.1 started with ray start; rllib training joins it with --address and
    places one env runner there; the run folder is complete and the node stops by pid."""
    env = raytools.ray_env(loopback=True)
    port = raytools.free_port()
    head = raytools.RayNode(["--head", "--node-ip-address=127.0.0.1", f"--port={port}",
                             "--num-cpus=2", "--include-dashboard=false"], env)
    address = f"127.0.0.1:{port}"
    try:
        raytools.wait_for_nodes(address, 1, env)
        out = tmp_path / "run"
        cmd = [sys.executable, "-m", "rbenv.agents.training.rllib", "--address", address,
               "--env-runners", "1",
               "--envs-per-runner", "16", "--timesteps", "4096", "--checkpoint-every", "4096",
               "--eval-every", "4096", "--hyperparams",
               '{"train_batch_size_per_learner": 2048, "minibatch_size": 512, "num_epochs": 1}',
               "--report-episodes", "8", "--out", str(out)]
        r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600,
                           cwd=raytools.REPO)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        summary = json.loads((out / "training.json").read_text())
        assert summary["timesteps"] >= 4096 and summary["env_runners"] == 1
        assert json.loads((out / "config.json").read_text())["engine"] == "rllib"
        assert "ppo (RLlib, trained)" in (out / "report.md").read_text()
        assert (out / "checkpoints" / "latest.json").is_file()
        # rbenv evaluate takes the RLlib run folder like an SB3 one (its task and options);
        # RLlib's checkpoints are pickles, so only with --trust-pickle.
        evaluate = [sys.executable, "-m", "rbenv", "evaluate", "--policy", str(out),
                    "--episodes", "8", "--seed", "1000000"]
        r = subprocess.run(evaluate, env=env, capture_output=True, text=True, timeout=300,
                           cwd=raytools.REPO)
        assert r.returncode == 2 and "--trust-pickle" in r.stderr, r.stderr[-2000:]
        r = subprocess.run([*evaluate, "--trust-pickle"], env=env, capture_output=True,
                           text=True, timeout=300, cwd=raytools.REPO)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
        assert "| 8 |" in r.stdout
    finally:
        head.stop()
    assert head.leftover == [], f"Ray processes outlived SIGTERM: {head.leftover}"


def test_rllib_resume_after_kill(raytools, tmp_path):
    """kill -9 during `rbenv train --engine rllib`, then --resume: training continues from the
    last complete checkpoint and the run finishes with its report."""
    import os
    import shutil
    import signal
    import tempfile
    import time

    ray_tmp = tempfile.mkdtemp(prefix="rbt", dir="/tmp")  # short: Ray's socket paths
    env = {**raytools.ray_env(loopback=True), "RAY_TMPDIR": ray_tmp}
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "rbenv", "train", "--engine", "rllib", "--envs-per-runner",
           "16", "--timesteps", "40960", "--checkpoint-every", "4096", "--eval-every", "40960",
           "--hyperparams", '{"train_batch_size_per_learner": 2048, "minibatch_size": 512, '
           '"num_epochs": 1}', "--out", str(out)]
    first = subprocess.Popen(cmd, env=env, cwd=raytools.REPO, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, start_new_session=True)
    pointer = out / "checkpoints" / "latest.json"
    try:
        deadline = time.monotonic() + 300
        while not pointer.is_file() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert first.poll() is None, "training ended before its first checkpoint"
        killed_at = json.loads(pointer.read_text())["timesteps"]
    finally:
        try:
            os.killpg(first.pid, signal.SIGKILL)  # the driver and the Ray processes it started
        except ProcessLookupError:
            pass
        first.wait(60)
    assert killed_at < 40960
    # RLlib's checkpoints are pickles: a resume without the flag is refused, naming it
    r = subprocess.run([*cmd, "--resume"], env=env, capture_output=True, text=True,
                       timeout=600, cwd=raytools.REPO)
    assert r.returncode != 0 and "--trust-pickle" in r.stderr, r.stderr[-3000:]
    r = subprocess.run([*cmd, "--resume", "--trust-pickle"], env=env, capture_output=True,
                       text=True, timeout=600, cwd=raytools.REPO)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "resuming rllib ppo" in r.stdout
    summary = json.loads((out / "training.json").read_text())
    assert summary["resumed_from"] >= killed_at and summary["timesteps"] >= 40960
    assert (out / "report.md").is_file() and (out / "policy").is_dir()
    assert raytools.processes_naming(ray_tmp) == []
    shutil.rmtree(ray_tmp, ignore_errors=True)
