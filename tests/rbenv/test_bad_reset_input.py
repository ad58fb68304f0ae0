"""Bad reset input gets rbenv's named errors: seeds on every env, reset options' shapes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.envs.goal import GOAL_ID

V1 = "rbenv/SatelliteReorient-v1"
BAD_SEEDS = [(-1, r"seed must be >= 0, got -1"), (1.5, r"seed must be an integer, got 1\.5"),
             ("abc", r"seed must be an integer, got 'abc'"), (True, "seed must be an integer")]


def _envs():
    yield "single", gym.make(V1)
    yield "goal", gym.make(GOAL_ID)
    yield "vector", gym.make_vec(V1, num_envs=2)


@pytest.mark.parametrize(("seed", "message"), BAD_SEEDS)
def test_a_bad_seed_is_named_by_every_env(seed, message):
    for _, env in _envs():
        with pytest.raises(InvalidParameterError, match=message):
            env.reset(seed=seed)
        env.close()


@pytest.mark.parametrize("seed", [0, 7, np.int64(7), 2**64 + 7])
def test_good_seeds_still_give_the_seeded_episode(seed):
    obs, _ = gym.make(V1).reset(seed=seed)
    want, _ = gym.make(V1).reset(seed=int(seed) % 2**64)
    np.testing.assert_array_equal(obs, want)


@pytest.mark.parametrize("backend", ["numpy", "torch"])
@pytest.mark.parametrize("rows", [2, 4])
def test_a_reset_option_with_the_wrong_number_of_rows_is_named(backend, rows):
    if backend == "torch":
        pytest.importorskip("torch", reason="torch is not installed (train extra)")
    envs = gym.make_vec(V1, num_envs=3, backend=backend)
    with pytest.raises(InvalidParameterError,
                       match=rf"reset options\['omega_B'\] must have shape \(num_envs, 3\) = "
                             rf"\(3, 3\), one row per sub-env, got \({rows}, 3\)"):
        envs.reset(seed=0, options={"omega_B": np.zeros((rows, 3))})
    obs, _ = envs.reset(seed=0, options={"omega_B": np.zeros((3, 3))})  # the right shape works
    assert obs.shape[0] == 3


def test_a_single_env_reset_option_of_the_wrong_shape_is_named():
    with pytest.raises(InvalidParameterError,
                       match=r"reset options\['omega_B'\] must have shape \(3,\), got \(2, 3\)"):
        gym.make(rbenv.ENV_ID).reset(seed=0, options={"omega_B": np.zeros((2, 3))})
