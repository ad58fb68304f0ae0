"""SAC settings for RL Baselines3 Zoo, the same that ``rbenv train --algo sac`` uses::

    python -m rl_zoo3.train --algo sac --env rbenv/SatelliteReorient-v1 --gym-packages rbenv \\
        --conf-file rbenv.agents.zoo.sac

The shared off-policy recipe (:mod:`rbenv.agents.settings.off_policy`): torque actions with ``pinv``
allocation, 32 sub-envs, observation normalisation only, lr 1e-3, batch 512, 8 gradient steps
per 32 env steps, tau 0.01, net [256, 256]. Measured on ``SatelliteReorient-v0``/cubesat-12u
(``docs/off-policy.md``); the v1 ids carry their own measured budgets
(``n_timesteps``, in their training entries' recipes); the other settings are
shared, untuned per id.
"""

from __future__ import annotations

from rbenv.agents.zoo import zoo_table

hyperparams = zoo_table("sac")
