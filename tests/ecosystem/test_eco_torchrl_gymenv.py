"""TorchRL's ``GymEnv(id)`` itself, on every rbenv id and every scene the id accepts.

``GymEnv`` first passes ``frameskip`` to ``gymnasium.make`` and drops it only when the
TypeError reads like Python's "unexpected keyword argument 'frameskip'"; an env whose message
reads otherwise cannot be made by id at all.
"""

from __future__ import annotations

import warnings

import pytest

import rbenv
from rbenv.envs import registry
from rbenv.envs.goal import GOAL_ID

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")
torchrl_envs = pytest.importorskip("torchrl.envs", reason="torchrl is not installed "
                                   "(ecosystem extra)")

GRID = [(spec.env_id, scene) for spec in registry.specs() for scene in rbenv.list_scenes()
        if spec.runs_on(scene)] + [(GOAL_ID, scene) for scene in rbenv.list_scenes()]


@pytest.fixture(autouse=True)
def _one_thread():
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


@pytest.mark.parametrize(("env_id", "scene"), GRID)
def test_gym_env_makes_and_steps_every_id_on_every_scene(env_id, scene):
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
        env = torchrl_envs.GymEnv(env_id, scene=scene)
    env.set_seed(0)
    rollout = env.rollout(3, break_when_any_done=False)
    assert rollout.batch_size == torch.Size([3])
    assert torch.isfinite(rollout["next", "reward"]).all()
    env.close()

