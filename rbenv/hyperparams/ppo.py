"""PPO settings for RL Baselines3 Zoo: ``--conf-file rbenv.hyperparams.ppo``.

Derived from the task registry (:mod:`rbenv.registry`): one entry per registered id, each the
same dict that ``rbenv train`` uses (:data:`rbenv.hyperparams.tuned.PPO`). The zoo steps 64
single envs in a ``DummyVecEnv`` rather than the native vector env, so it is slower per step,
but it learns the same task at the same budget.
"""

from __future__ import annotations

from rbenv import registry

hyperparams = registry.zoo_hyperparams("ppo")
