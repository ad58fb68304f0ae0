"""Stable-Baselines3 on its own terms: ``make_vec_env`` over the plain id, each algorithm learns.

``rbenv train`` goes through :class:`rbenv.agents.training.sb3_vec_env.SB3VecEnv`; this checks the
path a new user
takes without it (SB3's ``DummyVecEnv`` of single envs), for a few hundred steps per algorithm.
"""

from __future__ import annotations

import numpy as np
import pytest

import rbenv

sb3 = pytest.importorskip("stable_baselines3", reason="stable-baselines3 is not installed "
                          "(train extra)")
torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402

SMALL = {
    "PPO": {"n_steps": 64, "batch_size": 64, "n_epochs": 1},
    "A2C": {"n_steps": 8},
    "SAC": {"learning_starts": 64, "batch_size": 32, "buffer_size": 1000},
    "TD3": {"learning_starts": 64, "batch_size": 32, "buffer_size": 1000},
}


@pytest.mark.parametrize("algo", sorted(SMALL))
def test_algorithm_learns_through_make_vec_env(algo):
    torch.set_num_threads(1)
    venv = make_vec_env(rbenv.ENV_ID, n_envs=2, seed=0)
    model = getattr(sb3, algo)("MlpPolicy", venv, seed=0, device="cpu",
                               policy_kwargs={"net_arch": [16, 16]}, **SMALL[algo])
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(256)
    assert model.num_timesteps >= 256
    changed = [not torch.equal(a, b) for a, b in zip(before, model.policy.parameters(),
                                                     strict=True)]
    assert any(changed), "no parameter moved: nothing was learned"
    obs = venv.reset()
    action, _ = model.predict(obs, deterministic=True)
    assert action.shape == (2, *venv.action_space.shape)
    assert np.all(np.abs(action) <= 1)
    venv.close()
