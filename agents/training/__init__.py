"""Training: one run-folder engine (:mod:`.engine`: lock, new run, resume, schedule, evaluation
history, summary) driving two back ends, Stable-Baselines3 (:mod:`.sb3`, which also runs SBX's
JAX learners, ``--engine sbx``) and Ray RLlib (:mod:`.rllib`), with one config (:mod:`.config`)
and one report (:mod:`.report`); the learning suite (:mod:`.suite`, on Ray Tune: :mod:`.tune`)
on top.

:mod:`.sb3` needs the train extra at import; :mod:`.rllib` imports Ray only to train.
"""
