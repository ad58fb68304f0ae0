"""PPO settings for RL Baselines3 Zoo: ``--conf-file rbenv.agents.zoo.ppo``.

Derived from the training entries (:mod:`rbenv.agents.settings`): one per id, each the same
dict that ``rbenv train`` uses (:data:`rbenv.agents.settings.tuned.PPO`). The zoo steps 64
single envs in a ``DummyVecEnv`` rather than the native vector env, so it is slower per step,
but it learns the same task at the same budget.
"""

from __future__ import annotations

from rbenv.agents.zoo import zoo_table

hyperparams = zoo_table("ppo")
