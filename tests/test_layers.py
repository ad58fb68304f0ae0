"""The layers core <- rbenv <- agents <- cli, and inside rbenv registration <- shells <- env
core <- tasks <- plant, checked statically by import-linter; and no import cycle anywhere.

The contracts live in pyproject.toml ([tool.importlinter]). import-linter reads a package from
its folder, so the test lays the package out as the wheel does (core/ and agents/ inside rbenv/,
pyproject's package-dir) in a temporary folder and lints that. Every import counts, also those
inside functions.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10: the tomli dependency
    import tomli as tomllib

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
    assert "8 kept, 0 broken" in done.stdout


@pytest.mark.parametrize("module, line", [
    ("core/kernels.py", "from rbenv.envs.env import SatelliteReorientEnv"),  # core -> rbenv
    ("rbenv/satellite/plant.py", "from rbenv.agents import controllers"),  # rbenv -> agents
    ("agents/policies/evaluate.py", "from rbenv.agents import cli"),  # agents -> cli
    ("agents/baselines/controllers.py", "from rbenv.agents.policies import load_policy"),
    ("agents/policies/weights.py", "from rbenv.agents.training import engine"),  # -> training
    ("agents/training/engine.py", "from rbenv.agents.training import sb3"),  # engine -> back end
    ("agents/training/rllib.py", "from rbenv.agents.training import sb3"),  # back end -> back end
    ("agents/policies/runfolder.py", "from rbenv.agents.policies import sb3"),  # format -> loader
    ("rbenv/envs/transition.py", "import benchmarks.common"),  # the package -> benchmarks/
    ("rbenv/tasks/base.py", "from rbenv.envs import registry"),  # tasks -> registration
    ("rbenv/envs/transition.py", "from rbenv.envs import env"),  # env core -> shell
    ("rbenv/satellite/plant.py", "from rbenv.tasks import build"),  # plant -> tasks
    ("rbenv/envs/registry.py", "from rbenv.agents import settings"),  # env package -> training
    ("rbenv/hyperparams/__init__.py", "from rbenv.agents import settings"),  # a new rbenv folder
])
@pytest.mark.slow
def test_an_upward_import_breaks_a_contract(tmp_path, module, line):
    """The check can fail: one upward import, even inside a function, is reported."""
    layout = installed_layout(tmp_path)
    package = module.partition("/")[0]
    path = layout / "rbenv" / module if package in ("core", "agents") else layout / module
    path.parent.mkdir(exist_ok=True)
    text = path.read_text() if path.exists() else ""
    path.write_text(text + f"\n\ndef _upward():\n    {line}\n")
    done = lint(layout)
    assert done.returncode != 0 and "BROKEN" in done.stdout, done.stdout + done.stderr


def test_only_the_entry_point_of_rbenv_sits_above_agents():
    """``python -m rbenv`` (rbenv/__main__.py) is the one module of the env package that may
    import agents: the layers contract is exhaustive, so a new folder of rbenv is refused unless
    named in a layer, and its top layer names only ``__main__``."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    contract = next(c for c in config["tool"]["importlinter"]["contracts"]
                    if c["name"] == "core <- rbenv <- agents <- cli")
    assert contract["exhaustive"] is True
    assert contract["layers"][:2] == ["__main__", "agents"], contract["layers"]


# Tarjan's algorithm over grimp's graph of every import (the graph import-linter checks), run
# in a fresh interpreter: rbenv imported here would shadow the laid-out package.
CYCLES = r"""
import json, sys
import grimp

graph = grimp.build_graph("rbenv", cache_dir=None)
index, low, stack, on_stack, cycles = {}, {}, [], set(), []

def edges(module):
    return iter(sorted(graph.find_modules_directly_imported_by(module)))

for root in sorted(graph.modules):
    if root in index:
        continue
    index[root] = low[root] = len(index)
    stack.append(root)
    on_stack.add(root)
    work = [(root, edges(root))]
    while work:
        module, todo = work[-1]
        for nxt in todo:
            if nxt not in index:
                index[nxt] = low[nxt] = len(index)
                stack.append(nxt)
                on_stack.add(nxt)
                work.append((nxt, edges(nxt)))
                break
            if nxt in on_stack:
                low[module] = min(low[module], index[nxt])
        else:
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[module])
            if low[module] == index[module]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == module:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
json.dump(cycles, sys.stdout)
"""


def import_cycles(layout: Path) -> list[list[str]]:
    """The import cycles of the package in ``layout``: each strongly connected component of
    more than one module, counting every import (also those inside functions)."""
    done = subprocess.run([sys.executable, "-c", CYCLES], cwd=layout,
                          env={"PYTHONPATH": str(layout), "PATH": ""},
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_no_module_is_part_of_an_import_cycle(tmp_path):
    cycles = import_cycles(installed_layout(tmp_path))
    assert cycles == [], cycles


def test_a_function_level_import_that_closes_a_loop_is_a_cycle(tmp_path):
    """The count can fail: plant importing the registry inside a function closes a loop."""
    layout = installed_layout(tmp_path)
    path = layout / "rbenv" / "satellite" / "plant.py"
    path.write_text(path.read_text() + "\n\ndef _loop():\n    from rbenv.envs import registry\n")
    cycles = import_cycles(layout)
    assert any({"rbenv.satellite.plant", "rbenv.envs.registry"} <= set(c) for c in cycles), cycles
