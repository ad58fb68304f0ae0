"""The native vector env against Gymnasium's own SyncVectorEnv: DISABLED autoreset with
reset_mask, per-sub-env seeds, and the exceptions it raises."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rbenv

ID = rbenv.ENV_ID
N = 4


def _pair(mode):
    native = gym.make_vec(ID, num_envs=N, autoreset_mode=mode)
    sync = gym.make_vec(ID, num_envs=N, vectorization_mode="sync",
                        vector_kwargs={"autoreset_mode": mode})
    return native, sync


def _lose_control(n_envs, steps, seed=0):
    """Sub-envs 0 and 1 fire two thrusters (they spin past the rate limit); the rest idle."""
    a = -np.ones((steps, n_envs, 12), np.float32)
    a[:, :2, -2:] = 1.0
    return a


def test_disabled_mode_with_reset_mask_matches_sync_vector_env():
    native, sync = _pair(AutoresetMode.DISABLED)
    assert native.autoreset_mode is AutoresetMode.DISABLED
    assert sync.metadata["autoreset_mode"] is AutoresetMode.DISABLED
    o_n, _ = native.reset(seed=3)
    o_s, _ = sync.reset(seed=3)
    np.testing.assert_array_equal(o_n, o_s)
    ended = np.zeros(N, bool)
    for a in _lose_control(N, 200):
        o_n, r_n, te_n, tr_n, _ = native.step(a)
        o_s, r_s, te_s, tr_s, _ = sync.step(a)
        np.testing.assert_allclose(o_n, o_s, atol=1e-6)
        np.testing.assert_allclose(r_n, r_s, atol=1e-9)
        np.testing.assert_array_equal(te_n | tr_n, te_s | tr_s)
        ended |= te_n | tr_n
        if ended.any() and not ended.all():
            break
    assert ended.any() and not ended.all()
    with pytest.raises(gym.error.ResetNeeded, match="reset_mask"):
        native.step(np.zeros((N, 12)))  # Gymnasium's SyncVectorEnv refuses this too
    last = o_n.copy()
    o_n, info_n = native.reset(options={"reset_mask": ended})
    o_s, info_s = sync.reset(options={"reset_mask": ended})
    np.testing.assert_array_equal(o_n, o_s)  # the ended sub-envs' next episode, bit for bit
    np.testing.assert_array_equal(o_n[~ended], last[~ended])  # the others untouched
    np.testing.assert_array_equal(info_n["_attitude_error_deg"], ended)
    np.testing.assert_array_equal(info_s["_attitude_error_deg"], ended)


def test_np_random_seed_is_one_per_sub_env_like_sync():
    native, sync = _pair(AutoresetMode.NEXT_STEP)
    native.reset(seed=11)
    sync.reset(seed=11)
    assert native.np_random_seed == tuple(sync.np_random_seed) == (11, 12, 13, 14)
    native.reset(seed=[5, 7, 9, 2])
    assert native.np_random_seed == (5, 7, 9, 2)


def test_exceptions_follow_gymnasium():
    native, sync = _pair(AutoresetMode.NEXT_STEP)
    native.reset(seed=0)
    sync.reset(seed=0)
    with pytest.raises(TypeError):
        native.step(0.5)
    with pytest.raises(ValueError, match="shape"):
        native.step(np.zeros((N + 1, 12)))
    with pytest.raises(TypeError, match="reset_mask"):  # SyncVectorEnv: TypeError too
        native.reset(options={"reset_mask": np.ones(N, int)})
    with pytest.raises(ValueError, match="seed"):
        native.reset(seed=[1, 2])
    fresh = gym.make_vec(ID, num_envs=N, autoreset_mode=AutoresetMode.DISABLED)
    with pytest.raises(gym.error.ResetNeeded):
        fresh.reset(options={"reset_mask": np.array([True, False, False, False])})
