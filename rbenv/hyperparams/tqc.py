"""TQC (sb3-contrib) settings, read by ``rbenv train --algo tqc`` and by RL Baselines3 Zoo
(``--algo tqc --conf-file rbenv.hyperparams.tqc``).

SAC's recipe (:mod:`rbenv.hyperparams._off_policy`) with TQC's own defaults (25 quantiles per
critic, 2 dropped per net) and a 200k-step budget: issue 22 measured 99.7 % held out after
169k steps, and TQC's update costs about twice SAC's, so the budget is set by wall time.
Measured on ``SatelliteReorient-v0``/cubesat-12u
(``docs/off-policy.md``); the other ids get the same numbers, untuned.
"""

from __future__ import annotations

from rbenv import registry

hyperparams = registry.zoo_hyperparams("tqc")
