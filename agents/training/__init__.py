"""Training: one run-folder engine (:mod:`.engine`: lock, new run, resume, schedule, evaluation
history, summary) driving three back ends, Stable-Baselines3 (:mod:`.sb3`, which also runs
SBX's JAX learners, ``--engine sbx``), Ray RLlib (:mod:`.rllib`) and TorchRL (:mod:`.torchrl`,
PPO on the torch env, ``--engine torchrl``), with one config (:mod:`.config`) and one report
(:mod:`.report`); the learning suite (:mod:`.suite`, on Ray Tune: :mod:`.tune`) and behaviour
cloning from a scripted controller (:mod:`.clone`) on top.

:mod:`.sb3` needs the train extra at import; :mod:`.rllib` imports Ray only to train.
"""
