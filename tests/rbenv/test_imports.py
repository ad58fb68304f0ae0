"""rbenv and rbenv.core never pull in learners or agents at run time (the static layer check is
tests/test_layers.py)."""

from __future__ import annotations

import subprocess
import sys

FORBIDDEN = ("torch", "stable_baselines3", "rbenv.agents", "pygame")


def test_rbenv_and_core_import_no_learning_stack_or_agents():
    code = (
        "import sys, numpy as np, gymnasium as gym, rbenv.core, rbenv\n"
        "env = gym.make('rbenv/SatelliteReorient-v0', action_mode='torque')\n"
        "env.reset(seed=0); env.step(np.zeros(3, np.float32))\n"
        "envs = gym.make_vec('rbenv/SatelliteReorient-v0', num_envs=2)\n"
        "envs.reset(seed=0); envs.step(np.zeros((2, 12), np.float32))\n"
        f"bad = [m for m in {FORBIDDEN!r} if m in sys.modules]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"

