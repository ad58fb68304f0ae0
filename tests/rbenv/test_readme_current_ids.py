"""The README's Quick start runs without a single warning, and no README command makes an id
that Gymnasium calls out of date (a newer version of it is registered)."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import gymnasium as gym
import pytest

import rbenv

README = Path(__file__).resolve().parents[2] / "README.md"
ID = re.compile(r"rbenv/(\w+)-v(\d+)")
MAKES = re.compile(r"make(?:_vec)?\(|--env|rbenv:rbenv/|an id such as")


def _latest(name: str) -> int:
    return max(int(spec.version) for spec in gym.registry.values()
               if spec.namespace == "rbenv" and spec.name == name and spec.version is not None)


def test_the_defaults_are_the_current_versions():
    for env_id in (rbenv.ENV_ID, rbenv.DETUMBLE_ID, rbenv.TRACK_ID, rbenv.DESATURATE_ID):
        name, version = ID.fullmatch(env_id).groups()
        assert int(version) == _latest(name), env_id


def test_no_readme_command_makes_an_out_of_date_id():
    lines = [line for line in README.read_text().splitlines() if MAKES.search(line)]
    assert len(lines) >= 5
    old = [(line, m.group(0)) for line in lines for m in ID.finditer(line)
           if int(m.group(2)) < _latest(m.group(1))]
    assert not old, old


def test_the_quick_start_runs_without_a_warning():
    pytest.importorskip("pygame", reason="the Quick start renders (render extra)")
    block = re.search(r"## Quick start\n\n```python\n(.*?)```", README.read_text(), re.S)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no filter at all: Gymnasium's notices included
        exec(compile(block.group(1), str(README), "exec"), {})
