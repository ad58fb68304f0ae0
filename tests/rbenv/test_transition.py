"""The transition is a function: it returns a new state, never changes its input, and reports
divergence as data (the adapters raise)."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core.backend import FLOAT, NUMPY
from rbenv.core.errors import NonFiniteError

import rbenv
from rbenv.envs import transition
from rbenv.satellite.plant import NO_NOISE


def _snapshot(st) -> dict:
    return {name: copy.deepcopy(value) for name, value in vars(st).items()
            if name != "model"}


def _equal(a, b) -> bool:
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    return np.array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize(("env_id", "scene"), [  # every id on the thruster scenes it runs on
    (i, s) for s in ("cubesat-12u", "cubesat-12u-dr", "boom-sat", "cubesat-12u-rw")
    for i in rbenv.ENV_IDS if rbenv.envs.registry.get(i).runs_on(s)])
def test_step_returns_a_new_state_and_leaves_its_input_unchanged(env_id, scene):
    for vector in (False, True):
        env = (gym.make_vec(env_id, num_envs=5, scene=scene) if vector
               else gym.make(env_id, scene=scene)).unwrapped
        env.reset(seed=4)
        st, xp = env._st, (NUMPY if vector else FLOAT)
        before = _snapshot(st)
        shape = (5, *env.single_action_space.shape) if vector else env.action_space.shape
        action = np.full(shape, 0.7)
        new, out = transition.step(env.plant, env.task, st, action, NO_NOISE, xp)
        assert new is not st
        for name, value in before.items():
            assert _equal(getattr(st, name), value), f"step changed the input's {name!r}"
        moved = [n for n in ("q", "omega_B", "steps", "fuel_kg") if not _equal(
            getattr(new, n), before[n])]
        assert moved == ["q", "omega_B", "steps", "fuel_kg"]
        assert not np.any(out.diverged)


def _run_until_diverged(env, action, xp):
    st = env._st
    for _ in range(300):
        st, out = transition.step(env.plant, env.task, st, action, NO_NOISE, xp)
        if np.any(out.diverged):
            return out
    raise AssertionError("the step never diverged")


@pytest.mark.filterwarnings("ignore:(overflow|invalid value) encountered:RuntimeWarning")
def test_divergence_is_a_flag_of_the_step_and_an_error_of_the_adapters():  # diverges on purpose
    """Explicit Euler with a huge step on a fast-spinning boom-sat blows up (as in test_env):
    the transition reports it, per satellite, and raises nothing; the adapters raise."""
    opts = {"scene": "boom-sat", "integrator": "euler", "control_dt": 40.0, "substeps": 1,
            "max_initial_rate": 0.049}
    fast = [0.03, 0.0, 0.049]
    env = gym.make(rbenv.ENV_ID, **opts).unwrapped
    env.reset(seed=0, options={"omega_B": np.array(fast)})
    out = _run_until_diverged(env, -np.ones(12), FLOAT)
    assert out.diverged is True and out.reward is None
    env.reset(seed=0, options={"omega_B": np.array(fast)})
    with pytest.raises(NonFiniteError, match="integrator='euler'"):
        for _ in range(300):
            env.step(-np.ones(12, np.float32))
    # The single env donates its state to the step: after a divergence it wants a reset.
    with pytest.raises(gym.error.ResetNeeded, match="the last step diverged"):
        env.step(np.zeros(12, np.float32))
    env.reset(seed=1)
    assert np.isfinite(env.step(np.zeros(12, np.float32))[0]).all()

    venv = gym.make_vec(rbenv.ENV_ID, num_envs=3, **opts).unwrapped
    venv.reset(seed=0, options={"omega_B": np.array([[0.0, 0.0, 0.0], fast, [0.0, 0.0, 0.0]])})
    out = _run_until_diverged(venv, np.zeros((3, 12)), NUMPY)
    assert out.diverged.tolist() == [False, True, False]  # per sub-env


def test_nan_throttle_is_named_as_the_action_not_as_divergence():
    env = gym.make(rbenv.ENV_ID)
    env.reset(seed=0)
    action = np.zeros(12, np.float32)
    action[3] = np.nan
    with pytest.raises(ValueError, match=r"NaN at index \(3,\)"):
        env.step(action)
