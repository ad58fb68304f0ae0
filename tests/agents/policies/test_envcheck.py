"""The command line's env checks (rbenv.agents.policies.envcheck): an env made once by id, so
that a wrong id, option name or value is named before anything runs."""

from __future__ import annotations

import pytest
from rbenv.agents.policies.envcheck import CALLER_VECTOR_OPTIONS, check_env_options, plain_env
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.envs import options
from rbenv.envs.goal import GOAL_ID
from rbenv.satellite.usage import InvalidChoiceError


def test_callers_may_set_only_the_episode_length_of_the_vector_options():
    assert CALLER_VECTOR_OPTIONS == ("max_episode_steps",)
    assert set(CALLER_VECTOR_OPTIONS) < set(options.VECTOR_OPTIONS)


def test_a_good_id_and_options_pass_and_the_env_is_the_ids_own_unwrapped():
    check_env_options(rbenv.ENV_ID, {"scene": "cubesat-12u", "max_episode_steps": 20})
    env = plain_env(rbenv.ENV_ID, {"integrator": "euler"})
    try:
        assert type(env).__name__ == rbenv.ENV_IDS[rbenv.ENV_ID][0]
        assert env.plant.scene.physics.integrator == "euler"
    finally:
        env.close()


@pytest.mark.parametrize(("env_id", "opts", "error", "named"), [
    ("rbenv/Nope-v0", {}, InvalidChoiceError, "env_id"),
    (GOAL_ID, {}, InvalidChoiceError, "env_id"),  # another form, not a task of its own
    (rbenv.ENV_ID, {"num_envs": 4}, InvalidChoiceError, "num_envs"),  # the commands set it
    (rbenv.ENV_ID, {"integrater": "rk4"}, InvalidChoiceError, "integrater"),
    (rbenv.ENV_ID, {"control_dt": -1.0}, InvalidParameterError, "control_dt"),
])
def test_a_bad_id_option_or_value_is_named(env_id, opts, error, named):
    with pytest.raises(error, match=named):
        check_env_options(env_id, opts)
