"""``--ray`` suite on Ray Tune: a trial whose process is killed is retried and resumes from the
last checkpoint of its training run; the aggregate is the serial suite's."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest


def test_killed_trial_resumes_from_its_checkpoint(raytools, tmp_path):
    out = tmp_path / "suite"
    cmd = [sys.executable, "-m", "rbenv.agents.training.tune", "--ray", "--tasks", "detumble",
           "--scenes",
           "cubesat-12u", "--seeds", "1", "--timesteps", "80000", "--episodes", "4",
           "--max-failures", "2", "--out", str(out)]
    log = open(tmp_path / "tune.log", "w")
    sweep = subprocess.Popen(cmd, env=raytools.ray_env(loopback=True), stdout=log,
                             stderr=subprocess.STDOUT, cwd=raytools.REPO, start_new_session=True)
    killed = None
    try:
        deadline = time.monotonic() + 600
        while killed is None and time.monotonic() < deadline and sweep.poll() is None:
            pointers = list(out.glob("cells/*/run/checkpoints/latest.json"))
            cell = pointers[0].parents[2] if pointers else None
            if cell is not None and (cell / "tune_trial.json").is_file():
                pointer = pointers[0]
                trial = json.loads((cell / "tune_trial.json").read_text())
                at = json.loads(pointer.read_text())["timesteps"]
                os.kill(trial["pid"], signal.SIGKILL)  # the trial's Ray worker process
                killed = (trial["pid"], at)
            time.sleep(0.1)
        assert killed is not None, "no checkpoint was written before the sweep ended"
        assert sweep.wait(900) == 0, (tmp_path / "tune.log").read_text()[-4000:]
    finally:
        if sweep.poll() is None:
            os.killpg(sweep.pid, signal.SIGTERM)
            sweep.wait(60)
        log.close()
    pid, at = killed
    trial = json.loads((cell / "tune_trial.json").read_text())
    assert trial["attempt"] == 2 and trial["pid"] != pid
    training = json.loads((cell / "run" / "training.json").read_text())
    assert training["resumed_from"] is not None and training["resumed_from"] >= at
    assert training["timesteps"] >= 80000
    suite = json.loads((out / "suite.json").read_text())
    assert suite["missing"] == [] and suite["cells"] == [cell.name]
    assert (out / "suite.md").read_text().count("detumble") >= 2


def test_ray_suite_writes_the_serial_tables(raytools, tmp_path):
    """Same cells, serial and on Tune: the same result files and rows (training is seeded)."""
    pytest.importorskip("rbenv.agents.training.suite")
    base = ["--tasks", "detumble", "--scenes", "cubesat-12u", "--seeds", "1", "--timesteps",
            "2048", "--episodes", "4"]
    env = raytools.ray_env(loopback=True)
    for extra, name in (([], "serial"), (["--ray"], "ray")):
        module = "rbenv.agents.training.tune" if extra else "rbenv.agents.training.suite"
        r = subprocess.run([sys.executable, "-m", module, *base, *extra, "--out",
                            str(tmp_path / name)], env=env, capture_output=True, text=True,
                           timeout=600, cwd=raytools.REPO)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    serial, ray = (json.loads((tmp_path / n / "suite.json").read_text())
                   for n in ("serial", "ray"))
    assert ray["cells"] == serial["cells"]  # the cells' names
    first = [json.loads((tmp_path / n / "cells" / ray["cells"][0] / "result.json").read_text())
             for n in ("serial", "ray")]
    for key in ("policy", "baselines"):
        assert first[1][key] == first[0][key]
    assert (tmp_path / "ray" / "suite.md").is_file() and (tmp_path / "ray" /
                                                           "learning_curves.png").is_file()
