"""benchmarks.desaturate_laws: its "scaled 0.003" law is the unload baseline's rod law (the
reference the sweep is read against), and "clipped" differs only where a rod saturates."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines.controllers import Unload

from benchmarks.desaturate_laws import ENV_ID, RodLaw


def test_the_scaled_law_at_unloads_gain_is_unload_and_clipping_differs_only_at_a_limit():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(ENV_ID)
    obs = np.array([env.reset(seed=s)[0] for s in range(20)])
    unload = Unload.from_env(env).predict(obs)[0]
    scaled = RodLaw.from_env(env, kind="scaled", k=0.003).predict(obs)[0]
    np.testing.assert_array_equal(scaled, unload)
    small = RodLaw.from_env(env, kind="scaled", k=1e-4).predict(obs)[0]
    clipped = RodLaw.from_env(env, kind="clipped", k=1e-4).predict(obs)[0]
    assert np.abs(small[:, 3:]).max() < 1.0  # no rod at its limit: the two agree
    np.testing.assert_allclose(clipped, small, rtol=1e-6)
    big = RodLaw.from_env(env, kind="clipped", k=0.003).predict(obs)[0]
    assert np.abs(big[:, 3:]).max() == 1.0 and not np.allclose(big, unload)
