"""Training settings, keyed by env id: what :mod:`rbenv.envs.registry` leaves out.

Each id that ``rbenv train``, the learning suite or the evaluation report handles has one
:class:`TrainingSettings` entry: its scripted baselines, its hyperparameters (RL Zoo's format;
the shared dicts in :mod:`rbenv.agents.settings.tuned`), its budgets and the env options that
training adds on a scene. The shipped ids' entries are in :mod:`rbenv.agents.settings.shipped`;
a user's task registers its own::

    from rbenv.agents import settings
    from rbenv.agents.settings import tuned

    settings.register(settings.TrainingSettings(
        env_id="myorg/PointSun-v0", baselines={"pd": "mypkg.controllers:SunPD"},
        budget={"ppo": 500_000}, hyperparams={"ppo": tuned.PPO}))

RL Baselines3 Zoo reads the same dicts through ``--conf-file rbenv.agents.zoo.<algo>``.
"""

from __future__ import annotations

from rbenv.agents.settings.shipped import SHIPPED
from rbenv.agents.settings.table import (
    TrainingSettings,
    entries,
    get,
    register,
    unregister,
    zoo_hyperparams,
)

__all__ = ["TrainingSettings", "entries", "get", "register", "unregister", "zoo_hyperparams"]

for _entry in SHIPPED:
    register(_entry)
