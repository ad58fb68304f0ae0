"""rbenv agents, in six parts, each importing only the parts below it (the last three side by
side):

- :mod:`rbenv.agents.settings`: the training settings of each env id (scripted baselines,
  hyperparameters, budgets), apart from the envs;
- :mod:`rbenv.agents.baselines`: scripted controllers, model-predictive control and the
  trajectory optimiser;
- :mod:`rbenv.agents.policies`: trained and scripted policies behind one ``predict()``
  (loading SB3 and RLlib models from run folders), their seeded evaluation and their export;
- :mod:`rbenv.agents.training`: one run-folder engine (config, checkpoints, resume, lock,
  report) with Stable-Baselines3 (and SBX), Ray RLlib and TorchRL as its back ends, and the
  learning suite;
- :mod:`rbenv.agents.flight`: flight telemetry, its replay and the identification of a scene
  from it;
- :mod:`rbenv.agents.zoo`: the settings as RL Baselines3 Zoo reads them
  (``--conf-file rbenv.agents.zoo.ppo``).

The ``rbenv`` console command (:mod:`rbenv.agents.cli`) sits on top. Depends on rbenv and
core, never the other way round (import-linter contracts in pyproject.toml).
"""
