"""TorchRL's GymWrapper over the native vector env, in the two autoreset modes it accepts.

TorchRL (0.14) reads ``autoreset_mode`` as an attribute of a Gymnasium vector env and accepts
SAME_STEP or DISABLED; with DISABLED it resets only the finished sub-envs through
``reset(options={"reset_mask": mask})``. ``check_env_specs`` is its contract test. Gymnasium's
own ``SyncVectorEnv`` runs the same checks as the reference.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rbenv

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")
torchrl_envs = pytest.importorskip("torchrl.envs", reason="torchrl is not installed "
                                   "(ecosystem extra)")
from torchrl.envs.utils import check_env_specs  # noqa: E402

N_ENVS = 4
# Random thrust loses control well inside the 160-step limit, so every sub-env finishes at
# least once in this many steps and the rollout crosses resets.
STEPS = 200
MODES = (AutoresetMode.SAME_STEP, AutoresetMode.DISABLED)
VECTORIZATION = ("vector_entry_point", "sync")  # rbenv's native env, Gymnasium's reference


@pytest.fixture(autouse=True)
def _one_thread():
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def _wrapped(mode: AutoresetMode, vectorization: str):
    if vectorization == "sync":
        venv = gym.make_vec(rbenv.ENV_ID, num_envs=N_ENVS, vectorization_mode="sync",
                            vector_kwargs={"autoreset_mode": mode})
    else:
        venv = gym.make_vec(rbenv.ENV_ID, num_envs=N_ENVS, vectorization_mode=vectorization,
                            autoreset_mode=mode)
    assert venv.autoreset_mode == mode
    return venv, torchrl_envs.GymWrapper(venv)


@pytest.mark.parametrize("vectorization", VECTORIZATION)
@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.name)
def test_gym_wrapper_passes_check_env_specs(mode, vectorization):
    _, env = _wrapped(mode, vectorization)
    assert env.batch_size == torch.Size([N_ENVS])
    check_env_specs(env, seed=0)
    env.close()


@pytest.mark.parametrize("vectorization", VECTORIZATION)
@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.name)
def test_rollout_resets_only_the_finished_sub_envs(mode, vectorization):
    """Across a done, the finished sub-env starts a new episode and the others carry on."""
    _, env = _wrapped(mode, vectorization)
    env.set_seed(0)
    td = env.rollout(STEPS, break_when_any_done=False)
    assert td.batch_size == torch.Size([N_ENVS, STEPS])
    obs = td["observation"].numpy()                    # (N, T, d): the obs the action saw
    next_obs = td["next", "observation"].numpy()       # after the step, before any reset
    done = td["next", "done"].numpy()[..., 0]           # (N, T)
    assert np.isfinite(obs).all() and np.isfinite(td["next", "reward"].numpy()).all()
    assert done[:, :-1].any(axis=1).all(), "every sub-env should finish at least once"

    carried = ~done[:, :-1]
    np.testing.assert_array_equal(obs[:, 1:][carried], next_obs[:, :-1][carried])
    # A reset starts at rest: body rates (ω_B/L, obs "omega_B") are drawn within the
    # initial-rate range, far below the rate limit that ended most of these episodes.
    restarted = obs[:, 1:][done[:, :-1]]
    ended = next_obs[:, :-1][done[:, :-1]]
    assert not np.any(np.all(restarted == ended, axis=1))
    structure = gym.make(rbenv.ENV_ID).unwrapped.observation_structure
    start = sum(list(structure.values())[:list(structure).index("omega_B")])
    assert np.abs(restarted[:, start:start + 3]).max() < 0.5
    env.close()


def test_disabled_mode_is_driven_through_reset_mask():
    """TorchRL resets a partial batch by passing ``reset_mask`` to the native env."""
    venv, env = _wrapped(AutoresetMode.DISABLED, "vector_entry_point")
    masks = []
    reset = venv.reset

    def spy(*, seed=None, options=None):
        if options and "reset_mask" in options:
            masks.append(np.array(options["reset_mask"]))
        return reset(seed=seed, options=options)

    venv.reset = spy
    env.set_seed(0)
    env.rollout(STEPS, break_when_any_done=False)
    partial = [m for m in masks if 0 < m.sum() < N_ENVS]
    assert partial, "expected at least one reset of only some sub-envs"
    assert all(m.dtype == np.bool_ and m.shape == (N_ENVS,) for m in masks)
    env.close()
