"""CrossQ (sb3-contrib) settings for RL Baselines3 Zoo (``--algo crossq --conf-file
rbenv.agents.zoo.crossq``), the same that ``rbenv train --algo crossq`` uses.

SAC's recipe (:mod:`rbenv.agents.settings.off_policy`) without ``tau``: CrossQ has no target
network (it normalises the critic's batches instead). Its critics are [256, 256] like the
actor, not sb3-contrib's default 1024 x 1024, which ran at 43 env-steps/s here.
The v1 ids carry their own measured budgets (``n_timesteps``, in their task entries'
recipes); the other settings are shared, untuned per id.
"""

from __future__ import annotations

from rbenv.agents.zoo import zoo_table

hyperparams = zoo_table("crossq")
