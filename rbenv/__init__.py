"""rbenv: attitude control of a satellite (thrusters, reaction wheels, torque rods), as Gymnasium
environments.

``import rbenv`` registers four tasks on one plant, each with a single env and a native NumPy
vector env (its ``vector_entry_point``)::

    import gymnasium as gym
    import rbenv

    env = gym.make("rbenv/SatelliteReorient-v2", scene="cubesat-12u")
    envs = gym.make_vec("rbenv/SatelliteDetumble-v1", num_envs=1024)
    env = gym.make("rbenv/SatelliteTrack-v1", randomize={"inertia_scale": 0.2})
    env = gym.make("rbenv/SatelliteDesaturate-v1")  # a wheel and rod scene: cubesat-6u-rw

The v0 ids of reorient, detumble and track stay registered (their episodes are v1's; their
observation and reward are the first release's), and Gymnasium calls them out of date.
Tools that take only an id string can use ``"rbenv:rbenv/SatelliteReorient-v2"``, which makes
Gymnasium import rbenv first. Scenes: :func:`list_scenes`, :func:`load_scene`, :class:`Scene`.

The package in layers, each importing only those below it (docs/design.md, "Layers"):
``rbenv.envs`` (registration, the single, NumPy-vector and torch-vector shells, the env core and
its options), ``rbenv.tasks`` (what each task asks of the satellite), ``rbenv.satellite`` (the
plant: actuators, scenes, orbit, sensing, allocation, randomization, state) and ``rbenv.core``
(rigid-body physics); ``rbenv.agents`` (controllers, policies, training) sits above them all.
"""

from __future__ import annotations

import os as _os
from importlib.metadata import PackageNotFoundError, version

# The layers core/ and agents/ are subpackages, rbenv.core and rbenv.agents. A wheel holds them
# inside rbenv/ (pyproject's package-dir); a source checkout keeps them beside it. In a checkout,
# resolve them from this same checkout, whatever an editable install elsewhere points at.
_checkout = _os.path.dirname(_os.path.dirname(_os.path.abspath(__file__)))
if not _os.path.isdir(_os.path.join(__path__[0], "core")) and _os.path.isfile(
        _os.path.join(_checkout, "core", "__init__.py")):
    __path__.append(_checkout)

from rbenv.envs import env as _env
from rbenv.envs import goal, registry
from rbenv.envs import vector_env as _vector_env
from rbenv.envs.env import SatelliteDetumbleEnv, SatelliteReorientEnv, SatelliteTrackEnv
from rbenv.envs.vector_env import (
    SatelliteDetumbleVectorEnv,
    SatelliteReorientVectorEnv,
    SatelliteTrackVectorEnv,
)
from rbenv.satellite.randomization import Randomization
from rbenv.satellite.scene import Scene, list_scenes, load_scene, scene_variant
from rbenv.tasks import desaturate, detumble, reorient, track
from rbenv.tasks.reorient import ReorientWeights as RewardWeights

# The shipped ids, one registry call each (rbenv.envs.registry.register) with the classes that
# make it. A new task adds its line here; an id without classes of its own is the same call
# without them.
registry.register(reorient.SPEC, env=SatelliteReorientEnv, vector_env=SatelliteReorientVectorEnv)
registry.register(detumble.SPEC, env=SatelliteDetumbleEnv, vector_env=SatelliteDetumbleVectorEnv)
registry.register(track.SPEC, env=SatelliteTrackEnv, vector_env=SatelliteTrackVectorEnv)
registry.register(desaturate.SPEC, env=_env.SatelliteDesaturateEnv,
                  vector_env=_vector_env.SatelliteDesaturateVectorEnv)
registry.register(reorient.SPEC_V1, env=_env.SatelliteReorientV1Env,
                  vector_env=_vector_env.SatelliteReorientV1VectorEnv)
registry.register(detumble.SPEC_V1, env=_env.SatelliteDetumbleV1Env,
                  vector_env=_vector_env.SatelliteDetumbleV1VectorEnv)
registry.register(track.SPEC_V1, env=_env.SatelliteTrackV1Env,
                  vector_env=_vector_env.SatelliteTrackV1VectorEnv)
registry.register(reorient.SPEC_V2, env=_env.SatelliteReorientV2Env,
                  vector_env=_vector_env.SatelliteReorientV2VectorEnv)
registry.register(desaturate.SPEC_V1, env=_env.SatelliteDesaturateV1Env,
                  vector_env=_vector_env.SatelliteDesaturateV1VectorEnv)
# The goal-conditioned form of Reorient-v1: its own id, not a task of its own (no vector or
# torch shell; registry.specs() and ENV_IDS leave it out).
registry.register(goal.SPEC, env=goal.GoalReorientEnv)

try:
    __version__ = version("rbenv")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

__all__ = [
    "DESATURATE_ID",
    "DETUMBLE_ID",
    "ENV_ID",
    "ENV_IDS",
    "MAX_EPISODE_STEPS",
    "TRACK_ID",
    "Randomization",
    "RewardWeights",
    "SatelliteDetumbleEnv",
    "SatelliteDetumbleVectorEnv",
    "SatelliteReorientEnv",
    "SatelliteReorientVectorEnv",
    "SatelliteTrackEnv",
    "SatelliteTrackVectorEnv",
    "Scene",
    "__version__",
    "list_scenes",
    "load_scene",
    "scene_variant",
]

# The current version of each task (v1: v0's episodes, a new observation and reward; Reorient
# v2: v1's with a reward that prices time and propellant; Desaturate v1: v0's episodes, the
# policy commanding the rods with the wheels' attitude hold in the loop); the older ids stay
# registered (Desaturate-v0 for scenes without rods, cubesat-12u-rw's thrusters), and
# Gymnasium calls them out of date.
ENV_ID = reorient.SPEC_V2.env_id
DETUMBLE_ID = detumble.SPEC_V1.env_id
TRACK_ID = track.SPEC_V1.env_id
DESATURATE_ID = desaturate.SPEC_V1.env_id
MAX_EPISODE_STEPS = registry.MAX_EPISODE_STEPS
# id -> (single env class name, vector env class name), for every registered task.
ENV_IDS = {s.env_id: (s.class_stem + "Env", s.class_stem + "VectorEnv")
           for s in registry.specs()}
