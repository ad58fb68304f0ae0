"""Tuned hyperparameters for RL Baselines3 Zoo (``rl_zoo3``), one module per algorithm.

Each module holds ``hyperparams``, a dict keyed by env id in the zoo's own format, so the zoo
reads it by module name from any folder::

    python -m rl_zoo3.train --algo ppo --env rbenv/SatelliteReorient-v1 --gym-packages rbenv \\
        --conf-file rbenv.hyperparams.ppo

The settings live in :mod:`rbenv.agents.settings` (training belongs to ``agents``, not to the
env package); these modules are a view of them, kept at this path so that the zoo command
above keeps working. They sit above ``agents`` in the layers (pyproject's import-linter
contracts): nothing in rbenv imports them.
"""
