"""Training settings, keyed by env id: what :mod:`rbenv.envs.registry` leaves out.

Each id that ``rbenv train``, the learning suite or the evaluation report handles has one
:class:`TrainingSettings` entry: its scripted baselines and its recipes, one table keyed by
:class:`Recipe` (algorithm, engine, scene) whose dicts, in RL Zoo's format, hold every number
of a run: the hyperparameters, ``n_timesteps`` (the budget of ``rbenv train``, the learning
suite and RL Zoo alike), ``n_envs``, ``normalize``, the ``env_kwargs`` training adds and
``"run"``, ``rbenv train``'s run defaults. :meth:`TrainingSettings.recipe` merges them from
the general to the specific. The shipped ids' entries are in
:mod:`rbenv.agents.settings.shipped` (the shared dicts in :mod:`rbenv.agents.settings.tuned`);
a user's task registers its own::

    from rbenv.agents import settings
    from rbenv.agents.settings import Recipe, tuned

    settings.register(settings.TrainingSettings(
        env_id="myorg/PointSun-v0", baselines={"pd": "mypkg.controllers:SunPD"},
        recipes={Recipe("ppo"): {**tuned.PPO, "n_timesteps": 500_000},
                 Recipe("ppo", scene="boom-sat"): {"n_timesteps": 2_000_000},
                 Recipe("ppo", engine="torchrl"): tuned.TORCHRL_PPO}))

RL Baselines3 Zoo reads the general recipes through ``--conf-file rbenv.agents.zoo.<algo>``.
"""

from __future__ import annotations

from rbenv.agents.settings.shipped import SHIPPED
from rbenv.agents.settings.table import (
    Recipe,
    TrainingSettings,
    entries,
    get,
    register,
    unregister,
    zoo_hyperparams,
)

__all__ = ["Recipe", "TrainingSettings", "entries", "get", "register", "unregister",
           "zoo_hyperparams"]

for _entry in SHIPPED:
    register(_entry)
