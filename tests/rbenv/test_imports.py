"""Dependency direction core <- rbenv <- agents: rbenv and core never pull in learners."""

from __future__ import annotations

import subprocess
import sys

FORBIDDEN = ("torch", "stable_baselines3", "agents", "pygame")


def test_rbenv_and_core_import_no_learning_stack_or_agents():
    code = (
        "import sys, numpy as np, gymnasium as gym, core, rbenv\n"
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


def test_no_package_imports_the_benchmarks():
    """benchmarks/ is not installed: core, rbenv and agents must not import it (the CLI's
    `rbenv bench` loads it from a checkout on purpose)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    pattern = re.compile(r"^\s*(from benchmarks\b|import benchmarks\b)", re.M)
    offenders = [str(p.relative_to(root)) for pkg in ("core", "rbenv", "agents")
                 for p in (root / pkg).rglob("*.py")
                 if p.name != "cli.py" and pattern.search(p.read_text())]
    assert offenders == []
