"""Tuned hyperparameters for RL Baselines3 Zoo (``rl_zoo3``), one module per algorithm.

Each module holds ``hyperparams``, a dict keyed by env id in the zoo's own format, so the zoo
reads it by module name from any folder::

    python -m rl_zoo3.train --algo ppo --env rbenv/SatelliteReorient-v1 --gym-packages rbenv \\
        --conf-file rbenv.hyperparams.ppo
"""
