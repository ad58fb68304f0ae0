"""rbenv: attitude control of a thruster-actuated satellite, as Gymnasium environments.

``import rbenv`` registers three tasks on one plant, each with a single env and a native NumPy
vector env (its ``vector_entry_point``)::

    import gymnasium as gym
    import rbenv

    env = gym.make("rbenv/SatelliteReorient-v0", scene="cubesat-12u")
    envs = gym.make_vec("rbenv/SatelliteDetumble-v0", num_envs=1024)
    env = gym.make("rbenv/SatelliteTrack-v0", randomize={"inertia_scale": 0.2})

Tools that take only an id string can use ``"rbenv:rbenv/SatelliteReorient-v0"``, which makes
Gymnasium import rbenv first. Scenes: :func:`list_scenes`, :func:`load_scene`, :class:`Scene`.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

import gymnasium as gym

from rbenv.env import SatelliteDetumbleEnv, SatelliteReorientEnv, SatelliteTrackEnv
from rbenv.randomization import Randomization
from rbenv.scene import Scene, list_scenes, load_scene
from rbenv.tasks.reorient import ReorientWeights as RewardWeights
from rbenv.vector_env import (
    SatelliteDetumbleVectorEnv,
    SatelliteReorientVectorEnv,
    SatelliteTrackVectorEnv,
)

try:
    __version__ = version("rbenv")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

__all__ = [
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
]

ENV_ID = "rbenv/SatelliteReorient-v0"
DETUMBLE_ID = "rbenv/SatelliteDetumble-v0"
TRACK_ID = "rbenv/SatelliteTrack-v0"
# Control steps per episode of every shipped scene (80 s at 0.5 s, 160 s at 1 s, ...). The env
# also truncates at its own scene's duration, so a shorter scene is honoured; for a custom scene
# with more steps pass max_episode_steps=scene.episode_steps.
MAX_EPISODE_STEPS = 160
# id -> (single env class, vector env class), both in this package.
ENV_IDS = {
    ENV_ID: ("SatelliteReorientEnv", "SatelliteReorientVectorEnv"),
    DETUMBLE_ID: ("SatelliteDetumbleEnv", "SatelliteDetumbleVectorEnv"),
    TRACK_ID: ("SatelliteTrackEnv", "SatelliteTrackVectorEnv"),
}

for _id, (_single, _vector) in ENV_IDS.items():
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=f"rbenv.env:{_single}",
                     vector_entry_point=f"rbenv.vector_env:{_vector}",
                     max_episode_steps=MAX_EPISODE_STEPS)
