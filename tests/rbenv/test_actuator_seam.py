"""The plant knows no actuator by name: it asks each through the protocol
rbenv.satellite.actuators.base.Actuator."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import rbenv.envs.adapter
import rbenv.envs.transition
import rbenv.satellite.plant

# Names of the shipped actuators and of what only one of them has (the thrusters' throttle,
# the wheels' rotors, the magnetorquers' rods and magnetometer).
ACTUATOR_WORDS = re.compile(r"thrust|throttl|wheel|rotor|magnetorquer|magnetometer|mtq|\brods?\b",
                            re.IGNORECASE)


def _names(source: str) -> list[str]:
    """Every identifier of a module (names, attributes, arguments, definitions, keywords,
    imports) and every string constant that is not a docstring."""
    tree = ast.parse(source)
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)
                  and isinstance(node.body[0].value, ast.Constant)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            out.append(node.id)
        elif isinstance(node, ast.Attribute):
            out.append(node.attr)
        elif isinstance(node, ast.arg):
            out.append(node.arg)
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            out.append(node.name)
        elif isinstance(node, ast.keyword) and node.arg:
            out.append(node.arg)
        elif isinstance(node, ast.alias):
            out.append(node.asname or node.name)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and id(node) not in docstrings:
            out.append(node.value)
    return out


def actuator_names(path: Path) -> list[str]:
    return [name for name in _names(path.read_text()) if ACTUATOR_WORDS.search(name)]


@pytest.mark.parametrize("module", [rbenv.satellite.plant, rbenv.envs.transition,
                                    rbenv.envs.adapter], ids=lambda m: m.__name__)
def test_the_plant_and_the_env_core_name_no_actuator(module):
    """The transition and the adapters draw, observe and inform through the actuators too."""
    assert actuator_names(Path(module.__file__)) == []


def test_the_count_can_fail(tmp_path):
    path = tmp_path / "probe.py"
    path.write_text('def f(plant):\n    """thrusters in a docstring do not count."""\n'
                    '    return plant.thrusters.n, "wheel_speed", plant.throttle(1)\n')
    assert sorted(actuator_names(path)) == ["throttle", "thrusters", "wheel_speed"]
