"""The layers core <- rbenv <- agents <- cli, checked statically by import-linter.

The contracts live in pyproject.toml ([tool.importlinter]). import-linter reads a package from
its folder, so the test lays the package out as the wheel does (core/ and agents/ inside rbenv/,
pyproject's package-dir) in a temporary folder and lints that. Every import counts, also those
inside functions.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("importlinter")

ROOT = Path(__file__).resolve().parents[1]
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc")


def installed_layout(dest: Path) -> Path:
    """The wheel's layout of the package under ``dest``: rbenv/, rbenv/core/, rbenv/agents/."""
    shutil.copytree(ROOT / "rbenv", dest / "rbenv", ignore=IGNORE)
    for sub in ("core", "agents"):
        shutil.copytree(ROOT / sub, dest / "rbenv" / sub, ignore=IGNORE)
    return dest


def lint(layout: Path) -> subprocess.CompletedProcess:
    lint_imports = Path(sys.executable).with_name("lint-imports")
    return subprocess.run([str(lint_imports), "--no-cache", str(ROOT / "pyproject.toml")],
                          cwd=layout, env={"PYTHONPATH": str(layout), "PATH": ""},
                          capture_output=True, text=True, timeout=300)


def test_the_layer_contracts_hold(tmp_path):
    done = lint(installed_layout(tmp_path))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "7 kept, 0 broken" in done.stdout


@pytest.mark.parametrize("module, line", [
    ("core/kernels.py", "from rbenv.env import SatelliteReorientEnv"),  # core -> rbenv
    ("rbenv/plant.py", "from rbenv.agents import controllers"),  # rbenv -> agents
    ("agents/policies/evaluate.py", "from rbenv.agents import cli"),  # agents -> cli
    ("agents/baselines/controllers.py", "from rbenv.agents.policies import load_policy"),
    ("agents/policies/weights.py", "from rbenv.agents.training import engine"),  # -> training
    ("agents/training/engine.py", "from rbenv.agents.training import sb3"),  # engine -> back end
    ("agents/training/rllib.py", "from rbenv.agents.training import sb3"),  # back end -> back end
    ("agents/policies/runfolder.py", "from rbenv.agents.policies import sb3"),  # format -> loader
    ("rbenv/transition.py", "import benchmarks.common"),  # the package -> benchmarks/
])
def test_an_upward_import_breaks_a_contract(tmp_path, module, line):
    """The check can fail: one upward import, even inside a function, is reported."""
    layout = installed_layout(tmp_path)
    package = module.partition("/")[0]
    path = layout / "rbenv" / module if package in ("core", "agents") else layout / module
    path.write_text(path.read_text() + f"\n\ndef _upward():\n    {line}\n")
    done = lint(layout)
    assert done.returncode != 0 and "BROKEN" in done.stdout, done.stdout + done.stderr
