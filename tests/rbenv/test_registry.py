"""One registration route: every id, the goal form's too, goes through
``rbenv.envs.registry.register`` with the classes that make it, named at the call; defining a
class registers nothing."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.envs import env as single_env
from rbenv.envs import registry, vector_env
from rbenv.envs.goal import GOAL_ID, GoalReorientEnv
from rbenv.tasks import reorient

COPY_ID = "rbenvtest/ReorientCopy-v1"


@pytest.mark.parametrize("spec", registry.specs(), ids=lambda s: s.env_id)
def test_each_shipped_class_runs_its_entry_and_carries_its_documentation(spec):
    """The per-id classes' docstrings are the texts the subclass hook wrote before: the
    entry's env documentation, and for the vector class a pointer to the single one."""
    single, vector = (getattr(m, n) for m, n in zip((single_env, vector_env),
                                                     rbenv.ENV_IDS[spec.env_id], strict=True))
    assert single.task_spec is spec and vector.task_spec is spec
    assert single.__doc__ == spec.env_doc and "**Version History**" in single.__doc__
    assert vector.__doc__ == (f"Vector form of :class:`rbenv.{single.__name__}` "
                              "(see :class:`AttitudeVectorEnv`).")
    assert type(gym.make(spec.env_id).unwrapped) is single
    assert type(gym.make_vec(spec.env_id, num_envs=2)) is vector


def test_defining_a_class_registers_nothing():
    before = registry.ids()

    class Another(single_env.AttitudeEnv):
        task_spec = reorient.SPEC

    assert registry.ids() == before
    assert type(gym.make(reorient.SPEC.env_id).unwrapped) is rbenv.SatelliteReorientEnv


@pytest.fixture
def copy_id():
    """A test id: Reorient-v1's entry under another id, registered by the test."""
    yield dataclasses.replace(reorient.SPEC_V1, env_id=COPY_ID)
    registry.unregister(COPY_ID)


def test_an_id_without_classes_runs_on_the_generic_shells_through_the_same_call(copy_id):
    registry.register(copy_id)
    assert registry.get(COPY_ID) is copy_id and COPY_ID in registry.ids()
    env, venv = gym.make(COPY_ID).unwrapped, gym.make_vec(COPY_ID, num_envs=2)
    assert type(env) is single_env.AttitudeEnv and type(venv) is vector_env.AttitudeVectorEnv
    ours, theirs = env.reset(seed=5)[0], gym.make(reorient.SPEC_V1.env_id).reset(seed=5)[0]
    np.testing.assert_array_equal(ours, theirs)  # the same entry: the same episode
    registry.unregister(COPY_ID)
    assert COPY_ID not in gym.registry and COPY_ID not in registry.ids()


def test_a_class_that_runs_another_entry_is_refused_by_name(copy_id):
    with pytest.raises(InvalidParameterError,
                       match=r"env SatelliteReorientV1Env runs .*task_spec"):
        registry.register(copy_id, env=single_env.SatelliteReorientV1Env)
    with pytest.raises(InvalidParameterError,
                       match="vector_env must be a subclass of AttitudeVectorEnv"):
        registry.register(copy_id, vector_env=single_env.AttitudeEnv)
    assert COPY_ID not in gym.registry


def test_the_goal_form_is_registered_by_the_same_call_and_listed_only_as_an_id():
    assert GOAL_ID in registry.ids() and GOAL_ID not in rbenv.ENV_IDS
    assert GOAL_ID not in [s.env_id for s in registry.specs()]
    with pytest.raises(InvalidParameterError, match="registered rbenv tasks"):
        registry.get(GOAL_ID)
    spec = gym.spec(GOAL_ID)
    assert spec.entry_point == "rbenv.envs.registry:make_env"
    assert spec.vector_entry_point is None  # make_vec copies it (SyncVectorEnv)
    assert spec.kwargs["task"].task is reorient.SPEC_V1.task
    assert type(gym.make(GOAL_ID).unwrapped) is GoalReorientEnv
    with pytest.raises(InvalidParameterError, match=r"backend must be 'numpy'.*got 'torch'"):
        gym.make(GOAL_ID, backend="torch")


@pytest.mark.parametrize("env_id", [GOAL_ID, "rbenv/SatelliteReorient-v1"])
def test_an_unknown_option_gets_the_same_named_error_on_the_goal_form_as_on_v1(env_id):
    with pytest.raises(TypeError, match=r"__init__\(\) got an unexpected keyword argument "
                                        r"'bogus'; the valid options are action_mode, "):
        gym.make(env_id, bogus=1)
