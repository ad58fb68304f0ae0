"""Trained and scripted policies behind one ``predict()``: loading SB3 and RLlib models from run
folders (:func:`load_policy`), the run folder's format (:mod:`.runfolder`), pickle-free weights
(:mod:`.weights`) and seeded evaluation of any policy (:mod:`.evaluate`).

Below training (:mod:`rbenv.agents.training`), above the baselines
(:mod:`rbenv.agents.baselines`).
"""

from rbenv.agents.policies.load import Policy, load_policy

__all__ = ["Policy", "load_policy"]
