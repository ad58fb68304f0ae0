"""Tuned hyperparameters for RL Baselines3 Zoo (``rl_zoo3``), one module per algorithm.

Each module holds ``hyperparams``, a dict keyed by env id in the zoo's own format, so the zoo
reads it by module name from any folder::

    python -m rl_zoo3.train --algo ppo --env rbenv/SatelliteReorient-v1 --gym-packages rbenv \\
        --conf-file rbenv.agents.zoo.ppo

The settings live in :mod:`rbenv.agents.settings`; these modules are the zoo's view of them
(the same dicts ``rbenv train`` uses), beside the settings in ``agents``: the env package
(``rbenv.envs``, ``rbenv.tasks``, ``rbenv.satellite``) never imports ``agents``.
"""

from __future__ import annotations

from rbenv.agents.settings import zoo_hyperparams


def zoo_table(algo: str) -> dict:
    """The zoo's table for ``algo``: :func:`rbenv.agents.settings.zoo_hyperparams`, with an
    activation written by name in ``policy_kwargs`` made the class the zoo hands to SB3
    (:func:`rbenv.agents.policies.activations.to_classes`; torch is imported only then)."""
    table = zoo_hyperparams(algo)
    for entry in table.values():
        if "activation_fn" in entry.get("policy_kwargs", {}):
            from rbenv.agents.policies.activations import to_classes

            entry["policy_kwargs"] = to_classes(entry["policy_kwargs"])
    return table
