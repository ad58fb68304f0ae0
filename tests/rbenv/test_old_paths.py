"""The module paths of version 0.2 (``rbenv.env``, ``rbenv.scene``, ``rbenv.actuators.wheels``,
...) import as the very module objects of their folders (``rbenv.envs``, ``rbenv.satellite``),
through the one table ``rbenv.MOVED``; the repository's own code uses the new paths only."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import pytest

import rbenv

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("old", sorted(rbenv.MOVED))
def test_an_old_path_is_the_module_at_its_new_path(old):
    if old.startswith("torch_"):
        pytest.importorskip("torch")
    new = importlib.import_module(f"rbenv.{rbenv.MOVED[old]}.{old}")
    assert importlib.import_module(f"rbenv.{old}") is new
    assert getattr(rbenv, old) is new  # as an attribute, without an import statement
    assert new.__name__ == f"rbenv.{rbenv.MOVED[old]}.{old}"


def test_old_paths_reach_submodules_and_classes_without_a_second_copy():
    from rbenv.actuators.wheels import Wheels as OldWheels
    from rbenv.env import SatelliteReorientEnv as OldEnv

    from rbenv.envs.env import SatelliteReorientEnv
    from rbenv.satellite.actuators.wheels import Wheels

    assert OldWheels is Wheels and OldEnv is SatelliteReorientEnv
    import rbenv.actuators.wheels as old_wheels

    assert old_wheels is sys.modules["rbenv.satellite.actuators.wheels"]
    files = {}
    for name, module in list(sys.modules.items()):
        path = getattr(module, "__file__", None)
        if name.startswith("rbenv.") and path:
            files.setdefault(path, set()).add(id(module))
    assert all(len(ids) == 1 for ids in files.values()), "a module loaded twice"


def test_a_name_that_never_was_a_module_still_fails():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("rbenv.no_such_module")
    with pytest.raises(AttributeError, match="no_such_module"):
        rbenv.no_such_module  # noqa: B018


def test_the_repository_code_uses_the_new_paths():
    """Old paths are for users; in the repository they would hide which layer a module is in."""
    old = re.compile(r"\brbenv\.(" + "|".join(rbenv.MOVED) + r")\b")
    own = {ROOT / "rbenv" / "__init__.py", Path(__file__).resolve()}
    found = []
    for folder in ("rbenv", "core", "agents", "benchmarks", "tests"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path in own:
                continue
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if old.search(line):
                    found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not found, "\n".join(found)
