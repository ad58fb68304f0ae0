"""Tests mirror the packages: code under core/ is tested under tests/core/, rbenv/ under
tests/rbenv/, agents/<part>/ under tests/agents/<part>/, benchmarks/ under tests/benchmarks/."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
# Each package folder and the test folder that mirrors it.
MIRROR = {"core": "core", "rbenv": "rbenv", "agents": "agents",
          "agents/baselines": "agents/baselines", "agents/flight": "agents/flight",
          "agents/policies": "agents/policies", "agents/training": "agents/training",
          "agents/settings": "agents/settings", "agents/zoo": "agents/zoo",
          "benchmarks": "benchmarks"}
# What a test folder's files must import (one name at least); benchmarks/ is above every package,
# and the rest of rbenv above core.
SUBJECT = {"core": "rbenv.core", "rbenv": "rbenv", "agents": "rbenv.agents",
           "agents/baselines": "rbenv.agents.baselines", "agents/flight": "rbenv.agents.flight",
           "agents/policies": "rbenv.agents.policies", "agents/training": "rbenv.agents.training",
           "agents/settings": "rbenv.agents.settings", "agents/zoo": "rbenv.agents.zoo",
           "benchmarks": "benchmarks"}


def _under(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def _above(folder: str, name: str) -> bool:
    if folder == "benchmarks":
        return False
    if folder == "core" and _under(name, "rbenv") and not _under(name, "rbenv.core"):
        return name != "rbenv"  # `import rbenv` only to reach rbenv.core
    return _under(name, "benchmarks")


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names |= {node.module, *(f"{node.module}.{a.name}" for a in node.names)}
    return names


def _test_files(folder: str) -> list[Path]:
    return sorted((TESTS / folder).glob("test_*.py"))


@pytest.mark.parametrize("package", MIRROR)
def test_every_package_folder_has_its_test_folder(package):
    assert (ROOT / package / "__init__.py").is_file(), package
    assert _test_files(MIRROR[package]), f"no tests/{MIRROR[package]}/test_*.py"


@pytest.mark.parametrize("folder", SUBJECT)
def test_each_test_file_imports_its_package_and_no_layer_above(folder):
    wrong = []
    for path in _test_files(folder):
        imports = _imports(path)
        named = SUBJECT[folder] in path.read_text()  # e.g. in the code a child process runs
        if not (named or any(_under(n, SUBJECT[folder]) for n in imports)):
            wrong.append(f"{path.name} imports nothing of {SUBJECT[folder]}")
        wrong += [f"{path.name} imports {n}" for n in sorted(imports) if _above(folder, n)]
    assert not wrong, wrong
