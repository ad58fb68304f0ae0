"""The wheel installs one top-level package, ``rbenv``, so it installs beside the OpenAI Agents SDK
(``openai-agents``, a top-level ``agents``) with both importable.

No network: the wheel is built from a copy of the repository with ``pip wheel --no-deps
--no-build-isolation`` (setuptools from the test extra) and installed with ``pip install
--no-deps --target``. The SDK comes from the ``compat`` extra, which .ci/run installs; without
it the coexistence test skips and says so.
"""

from __future__ import annotations

import importlib.metadata
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # builds the wheel and installs it (CI runs it)

try:
    import tomllib
except ImportError:  # Python 3.10: the tomli dependency
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "core", "rbenv", "agents")
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
# Run in the child before the SDK is imported: any attempt to resolve a name or open a
# connection is recorded and refused.
NO_NETWORK = """
import socket
attempts = []
def refuse(*args, **kwargs):
    attempts.append(args[:2])
    raise OSError("network refused by tests/test_packaging.py")
socket.socket.connect = socket.socket.connect_ex = refuse
socket.getaddrinfo = socket.create_connection = refuse
"""


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """rbenv's wheel, built offline from a copy of the checkout (the checkout stays clean)."""
    src, out = tmp_path_factory.mktemp("src"), tmp_path_factory.mktemp("wheel")
    for name in SOURCES:
        copy = shutil.copytree if (ROOT / name).is_dir() else shutil.copy2
        copy(ROOT / name, src / name, **({"ignore": IGNORE} if (ROOT / name).is_dir() else {}))
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                           "--no-build-isolation", "--no-index", "-q", "-w", str(out), str(src)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    (path,) = out.glob("rbenv-*.whl")
    return path


def test_the_wheel_holds_only_the_rbenv_package(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        top = {n.split("/")[0] for n in names}
        info = next(n for n in top if n.endswith(".dist-info"))
        declared = z.read(f"{info}/top_level.txt").decode().split() \
            if f"{info}/top_level.txt" in names else ["rbenv"]
    assert top == {"rbenv", info}, sorted(top)
    assert declared == ["rbenv"]
    for sub in ("envs", "tasks", "satellite", "satellite/actuators", "core", "agents",
                "agents/training", "agents/policies", "agents/baselines"):
        assert f"rbenv/{sub}/__init__.py" in names, sub
    assert "rbenv/scenes/cubesat-12u.toml" in names  # the shipped scenes, package data
    # the MPC's recorded evaluation, which rbenv train's report reads
    assert "rbenv/agents/policies/records/mpc-cubesat-12u.json" in names


def test_every_package_folder_is_listed_for_the_wheel():
    """pyproject's packages list names every folder with an __init__.py under the mapped ones,
    and the data-only folders its package-data names (and nothing else)."""
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    found = set(tool["package-data"])
    for package, folder in tool["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder)
            found.add(".".join([package, *rel.parts]))
    assert found == set(tool["packages"])


def test_rbenv_installs_beside_the_openai_agents_sdk_and_both_import(wheel, tmp_path):
    try:
        sdk_site = importlib.metadata.distribution("openai-agents").locate_file("")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("openai-agents is not installed (pip install -e '.[compat]'; .ci/run does)")
    target = tmp_path / "site"
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index",
                           "-q", "--target", str(target), str(wheel)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    assert sorted(p.name for p in target.iterdir()
                  if not p.name.endswith(".dist-info") and p.name != "bin") == \
        ["rbenv"]
    code = NO_NETWORK + """
import agents
from agents import Agent
import rbenv, rbenv.agents, rbenv.agents.cli
print(agents.__file__)
print(rbenv.__file__)
print(Agent.__name__, len(attempts))
"""
    # The installed wheel first on the path, then the SDK's site folder; the checkout (whose
    # agents/ folder is rbenv's) nowhere on it: cwd is tmp_path.
    path = os.pathsep.join([str(target), str(sdk_site)])
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, env={"PYTHONPATH": path, "PATH": ""})
    assert done.returncode == 0, done.stderr
    sdk, ours, result = done.stdout.split("\n")[:3]
    assert not sdk.startswith(str(target)), sdk  # the SDK's own agents package
    assert ours.startswith(str(target)), ours  # rbenv from the wheel
    assert result == "Agent 0", "importing openai-agents tried to reach the network"
