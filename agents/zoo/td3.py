"""TD3 settings for RL Baselines3 Zoo (``--algo td3 --conf-file
rbenv.agents.zoo.td3``), the same that ``rbenv train --algo td3`` uses.

SAC's recipe (:mod:`rbenv.agents.settings.off_policy`) with Gaussian exploration noise of standard
deviation 0.1 (the zoo's ``noise_type``/``noise_std``; ``rbenv train`` builds the same
``NormalActionNoise``). Measured on ``SatelliteReorient-v0``/cubesat-12u
(``docs/off-policy.md``); the v1 ids carry their own measured budgets
(``n_timesteps``, in their training entries' recipes); the other settings are
shared, untuned per id.
"""

from __future__ import annotations

from rbenv.agents.zoo import zoo_table

hyperparams = zoo_table("td3")
