"""Gymnasium's ``check_env`` and passive checker run on every id and scene in a base install.

A base install (``pip install rbenv``) has NumPy, SciPy and Gymnasium but none of the extras.
The child process below makes the extras unimportable, then runs the two Gymnasium checks of
tests/rbenv/test_gymnasium_contract.py (``check_env`` on every id x scene, and ``gym.make``'s
passive checker on every id x scene) and reports how many ran.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import rbenv

ROOT = Path(__file__).resolve().parents[2]
EXTRAS = ("stable_baselines3", "sb3_contrib", "torch", "ray", "matplotlib", "pygame", "numba",
          "tqdm", "imageio", "moviepy")
CHILD = """
import importlib.abc, sys
EXTRAS = {extras!r}

class NoExtras(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in EXTRAS:
            raise ModuleNotFoundError(f"No module named {{name!r}} (a base install)", name=name)

sys.meta_path.insert(0, NoExtras())
import pytest
code = pytest.main(["-q", "-p", "no:cacheprovider", "-k", "all_env_api or passive_env_checker",
                    {test!r}])
loaded = sorted(m for m in EXTRAS if m in sys.modules)
print("extras loaded:", loaded)
sys.exit(code or (3 if loaded else 0))
"""


@pytest.mark.slow
def test_check_env_and_the_passive_checker_pass_on_every_id_and_scene_without_extras():
    pairs = sum(rbenv.envs.registry.get(i).runs_on(s) for i in rbenv.ENV_IDS
                for s in rbenv.list_scenes())
    test = str(ROOT / "tests" / "rbenv" / "test_gymnasium_contract.py")
    done = subprocess.run([sys.executable, "-c", CHILD.format(extras=EXTRAS, test=test)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert f"{2 * pairs} passed" in done.stdout, done.stdout[-2000:]
    assert "extras loaded: []" in done.stdout
