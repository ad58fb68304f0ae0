"""rbenv agents, in four parts, each importing only the parts below it:

- :mod:`rbenv.agents.settings`: the training settings of each env id (scripted baselines,
  hyperparameters, budgets), apart from the envs;
- :mod:`rbenv.agents.baselines`: scripted controllers and the trajectory optimiser;
- :mod:`rbenv.agents.policies`: trained and scripted policies behind one ``predict()``
  (loading SB3 and RLlib models from run folders) and their seeded evaluation;
- :mod:`rbenv.agents.training`: one run-folder engine (config, checkpoints, resume, lock,
  report) with Stable-Baselines3 and Ray RLlib as its back ends, and the learning suite.

The ``rbenv`` console command (:mod:`rbenv.agents.cli`) sits on top. Depends on rbenv and
core, never the other way round (import-linter contracts in pyproject.toml).
"""
