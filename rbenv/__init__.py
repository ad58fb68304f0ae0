"""rbenv: reorient a thruster-actuated satellite, as Gymnasium environments.

``import rbenv`` registers ``rbenv/SatelliteReorient-v0`` (single env, plus the native NumPy
vector env as its ``vector_entry_point``)::

    import gymnasium as gym
    import rbenv

    env = gym.make("rbenv/SatelliteReorient-v0", scene="cubesat-12u")
    envs = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=1024)

Tools that take only an id string can use ``"rbenv:rbenv/SatelliteReorient-v0"``, which makes
Gymnasium import rbenv first. Scenes: :func:`list_scenes`, :func:`load_scene`, :class:`Scene`.
"""

from __future__ import annotations

import gymnasium as gym

from rbenv.env import SatelliteReorientEnv
from rbenv.scene import Scene, list_scenes, load_scene
from rbenv.task import RewardWeights
from rbenv.vector_env import SatelliteReorientVectorEnv

__all__ = [
    "ENV_ID",
    "MAX_EPISODE_STEPS",
    "RewardWeights",
    "SatelliteReorientEnv",
    "SatelliteReorientVectorEnv",
    "Scene",
    "list_scenes",
    "load_scene",
]

ENV_ID = "rbenv/SatelliteReorient-v0"
# Control steps per episode of the default scene (cubesat-12u: 80 s at 0.5 s); every shipped
# scene uses 160 steps. The env also truncates at its own scene's duration, so a shorter scene
# is honoured; for a custom scene with more steps pass max_episode_steps=scene.episode_steps.
MAX_EPISODE_STEPS = 160

if ENV_ID not in gym.registry:
    gym.register(
        id=ENV_ID,
        entry_point="rbenv.env:SatelliteReorientEnv",
        vector_entry_point="rbenv.vector_env:SatelliteReorientVectorEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
    )
