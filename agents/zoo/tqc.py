"""TQC (sb3-contrib) settings for RL Baselines3 Zoo (``--algo tqc --conf-file
rbenv.agents.zoo.tqc``), the same that ``rbenv train --algo tqc`` uses.

SAC's recipe (:mod:`rbenv.agents.settings.off_policy`) with TQC's own defaults (25 quantiles per
critic, 2 dropped per net) and a 200k-step budget: 99.7 % held out was measured after
169k steps, and TQC's update costs about twice SAC's, so the budget is set by wall time.
Measured on ``SatelliteReorient-v0``/cubesat-12u
(``docs/off-policy.md``); the v1 ids carry their own measured budgets
(``n_timesteps``, in their training entries' recipes); the other settings are
shared, untuned per id.
"""

from __future__ import annotations

from rbenv.agents.zoo import zoo_table

hyperparams = zoo_table("tqc")
