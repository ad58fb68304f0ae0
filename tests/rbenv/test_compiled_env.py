"""The envs stepped by the numba-compiled kernels (extra ``rbenv[fast]``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core.errors import InvalidParameterError

import rbenv

pytest.importorskip("numba", reason="the compiled path needs the extra rbenv[fast] (numba)")


@pytest.mark.slow
@pytest.mark.parametrize("env_id", [rbenv.ENV_ID, rbenv.TRACK_ID])
def test_compiled_vector_env_equals_the_numpy_one(env_id):
    plain = gym.make_vec(env_id, num_envs=32)
    fast = gym.make_vec(env_id, num_envs=32, compiled=True)
    o_p, _ = plain.reset(seed=9)
    o_f, _ = fast.reset(seed=9)
    actions = np.random.default_rng(4).uniform(-1, 1, (60, 32, 12))
    actions[:, :8, -2:] = 1.0  # some sub-envs lose control and autoreset
    for a in actions:
        o_p, r_p, te_p, tr_p, _ = plain.step(a)
        o_f, r_f, te_f, tr_f, _ = fast.step(a)
        np.testing.assert_array_equal(o_p, o_f)
        np.testing.assert_array_equal(r_p, r_f)
        np.testing.assert_array_equal(te_p | tr_p, te_f | tr_f)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", sorted(i for i in rbenv.ENV_IDS  # rigid bodies only
                                           if rbenv.envs.registry.get(i).runs_on("cubesat-12u")))
@pytest.mark.parametrize(("scene", "integrator"), [("cubesat-12u", None),
                                                   ("boom-sat", "rk4"),
                                                   ("microsat-100kg", "euler"),
                                                   ("cubesat-12u", "semi_implicit")])
def test_compiled_single_env_equals_the_float_one_bit_for_bit(env_id, scene, integrator):
    """The single env's compiled kernel is the float kernel: every output is identical,
    through faults, sensor noise, translation (boom-sat, microsat) and resets."""
    kwargs = {"scene": scene} | ({"integrator": integrator} if integrator else {})
    plain, fast = gym.make(env_id, **kwargs), gym.make(env_id, compiled=True, **kwargs)
    o_p, _ = plain.reset(seed=5)
    o_f, _ = fast.reset(seed=5)
    np.testing.assert_array_equal(o_p, o_f)
    rng = np.random.default_rng(8)
    for _ in range(300):
        a = rng.uniform(-1, 1, plain.action_space.shape).astype(np.float32)
        out_p, out_f = plain.step(a), fast.step(a)
        np.testing.assert_array_equal(out_p[0], out_f[0])
        assert out_p[1:4] == out_f[1:4]
        assert out_p[4] == out_f[4]
        if out_p[2] or out_p[3]:
            plain.reset()
            fast.reset()
    assert plain.unwrapped.plant.advance_kernel is not fast.unwrapped.plant.advance_kernel


def test_compiled_refuses_what_it_cannot_compile():
    with pytest.raises(InvalidParameterError, match="midpoint"):
        gym.make(rbenv.ENV_ID, compiled=True, scene="boom-sat")
    with pytest.raises(InvalidParameterError, match="midpoint"):
        gym.make_vec(rbenv.ENV_ID, num_envs=2, compiled=True, integrator="midpoint")
    with pytest.raises(InvalidParameterError, match="randomized inertias"):
        gym.make_vec(rbenv.ENV_ID, num_envs=2, compiled=True, scene="cubesat-12u-dr")
    with pytest.raises(InvalidParameterError, match="compiled"):
        gym.make_vec(rbenv.ENV_ID, num_envs=2, compiled="yes")
