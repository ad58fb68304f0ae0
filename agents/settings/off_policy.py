"""What the off-policy modules (sac, td3, tqc, crossq) share: one recipe.

Torque actions (3 axes, ``pinv`` allocation to the 12 thrusters), 32 native sub-envs,
observations normalised and rewards not (as the SB3 maintainers and the RL Zoo's ``sac.yml``
advise for off-policy learners), and 8 gradient steps per vector step of 32 envs: 0.25 updates
per env step. Each module copies this and overrides what differs.
"""

from __future__ import annotations

import copy

RECIPE = {
    "policy": "MlpPolicy",
    "n_envs": 32,
    "n_timesteps": 300_000,
    # The zoo reads this dict as VecNormalize's keyword arguments (gamma added from below).
    "normalize": {"norm_obs": True, "norm_reward": False},
    # gym.make options: part of the settings (the policy's action space depends on them).
    "env_kwargs": {"action_mode": "torque", "allocator": "pinv"},
    "learning_rate": 1e-3,
    "buffer_size": 1_000_000,
    "batch_size": 512,
    "learning_starts": 10_000,
    "train_freq": 1,
    "gradient_steps": 8,
    "gamma": 0.99,
    "tau": 0.01,
    "policy_kwargs": {"net_arch": [256, 256]},
    "monitor_kwargs": {"info_keywords": ("is_success",)},
}


def recipe(**changes) -> dict:
    """A deep copy of :data:`RECIPE` with ``changes`` applied (``None`` deletes a key)."""
    out = copy.deepcopy(RECIPE)
    for key, value in changes.items():
        if value is None:
            out.pop(key, None)
        else:
            out[key] = value
    return out
