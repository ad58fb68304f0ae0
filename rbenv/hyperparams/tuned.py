"""The tuned settings of each algorithm, in RL Baselines3 Zoo's format: the one source.

The task registry (:mod:`rbenv.registry`) points every task entry at these dicts; the zoo
files (``rbenv.hyperparams.ppo``, ...) and ``rbenv train`` read them from there.
"""

from __future__ import annotations

# rbenv train's PPO: 64 native sub-envs, VecNormalize, 2 M steps (the README's main job).
PPO = {
    "policy": "MlpPolicy",
    "n_envs": 64,
    "n_timesteps": 2_000_000,
    "normalize": True,
    "n_steps": 64,
    "batch_size": 1024,
    "n_epochs": 5,
    "learning_rate": 5e-4,
    "gamma": 0.99,
    "gae_lambda": 0.95,
    "clip_range": 0.2,
    "ent_coef": 0.0,
    "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0},
    # Log the task's success flag in monitor.csv beside the return.
    "monitor_kwargs": {"info_keywords": ("is_success",)},
}

# rbenv train's SAC (does not solve reorientation at this budget; see the learning docs).
SAC = {
    "policy": "MlpPolicy",
    "n_envs": 8,
    "n_timesteps": 200_000,
    "normalize": True,
    "learning_rate": 1e-3,
    "buffer_size": 300_000,
    "batch_size": 256,
    "learning_starts": 5_000,
    "train_freq": 1,
    "gradient_steps": 1,
    "gamma": 0.99,
    "tau": 0.01,
    "policy_kwargs": {"net_arch": [256, 256]},
    "monitor_kwargs": {"info_keywords": ("is_success",)},
}
