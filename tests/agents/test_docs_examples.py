"""The worked examples of the docs run as they are: docs/tasks.md's new task (registered, made by
id, stepped, its baseline evaluated) and docs/scenes.md's custom scene flown by the PD."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents import settings
from rbenv.agents.policies.evaluate import evaluate

import rbenv

DOCS = Path(__file__).resolve().parents[2] / "docs"


def block(page: str, marker: str, language: str = "python") -> str:
    """The fenced code block right after ``<!-- example: MARKER -->`` on ``page``."""
    text = (DOCS / page).read_text().split(f"<!-- example: {marker} -->\n```{language}\n")[1]
    return text.split("```")[0]


def after(page: str, heading: str) -> str:
    """The first python block after the line ``heading`` on ``page``."""
    text = (DOCS / page).read_text().split(heading, 1)[1]
    return text.split("```python\n", 1)[1].split("```")[0]


@pytest.fixture
def spin_up(monkeypatch, capsys):
    module = types.ModuleType("docs_new_task")  # dataclasses look their module up
    monkeypatch.setitem(sys.modules, module.__name__, module)
    exec(compile(block("tasks.md", "a new task"), "docs/tasks.md", "exec"), module.__dict__)
    yield module
    rbenv.envs.registry.unregister("myorg/SpinUp-v0")
    settings.unregister("myorg/SpinUp-v0")


def test_the_new_task_of_tasks_md_registers_steps_and_evaluates(spin_up, capsys):
    assert "(3,)" in capsys.readouterr().out  # the example's own print: obs.shape
    env = gym.make("myorg/SpinUp-v0")
    obs, info = env.reset(seed=1)
    assert obs.shape == (3,) and info["rate_error_rad_s"] == pytest.approx(0.05)
    np.testing.assert_allclose(obs, [0.0, 0.0, -0.05 / env.unwrapped.task.rate_limit],
                               rtol=1e-6)  # at rest: the whole target rate is the error
    venv = gym.make_vec("myorg/SpinUp-v0", num_envs=3)
    vobs, _ = venv.reset(seed=1)
    np.testing.assert_array_equal(vobs[0], obs)
    result = evaluate("coast", episodes=4, env_id="myorg/SpinUp-v0")
    assert result.success.tolist() == [False] * 4  # coasting never spins up
    # its error measure, rate_error_rad_s: the disturbance of cubesat-12u alone moves it
    np.testing.assert_allclose(result.final_error_deg, 0.05, atol=1e-3)


def test_the_custom_scene_of_scenes_md_is_flown_by_the_pd(tmp_path, monkeypatch, capsys):
    (tmp_path / "my-3u.toml").write_text(block("scenes.md", "my-3u.toml", "toml"))
    monkeypatch.chdir(tmp_path)
    exec(compile(after("scenes.md", "Then fly it like a shipped scene:"), "docs/scenes.md",
                 "exec"), {"__name__": "docs_scene"})
    mass, outcome = capsys.readouterr().out.splitlines()[:2]
    assert float(mass.split()[0]) == pytest.approx(4.0)
    assert outcome.startswith("True")
