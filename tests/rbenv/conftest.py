"""Shared helpers of the env tests."""

import numpy as np
import pytest


def step_alongside(venv, singles, actions, prev_done):
    """One vector-env step and the matching step of each single env.

    Under NEXT_STEP autoreset a sub-env that ended on the previous step is reset by this step
    with reward 0 and both flags False; its single env therefore resets instead of stepping.
    Returns the vector env's (obs, reward, terminated, truncated, info) and, per sub-env, the
    single env's (obs, reward, terminated, truncated, info).
    """
    out = venv.step(actions)
    singles_out = []
    for i, env in enumerate(singles):
        if prev_done[i]:
            o, inf = env.reset()
            singles_out.append((o, 0.0, False, False, inf))
        else:
            singles_out.append(env.step(actions[i]))
    return out, singles_out


def assert_sub_env_matches(single_env, single_out, venv, vec_out, i):
    """Flags, reward and the true state (q, ω) of sub-env ``i`` equal the single env's."""
    _, reward, terminated, truncated, _ = vec_out
    _, r, te, tr, _ = single_out
    assert (te, tr) == (terminated[i], truncated[i])
    assert abs(r - reward[i]) <= 1e-12
    sst, vst = single_env.unwrapped._st, venv.unwrapped._st
    np.testing.assert_allclose([*sst.q, *sst.omega_B], [c[i] for c in (*vst.q, *vst.omega_B)],
                               rtol=0, atol=1e-12)


@pytest.fixture
def lockstep():
    """(step_alongside, assert_sub_env_matches), for tests comparing a vector env with
    single envs seeded s + i through autoresets."""
    return step_alongside, assert_sub_env_matches
