"""rbenv: attitude control of a satellite (thrusters, reaction wheels, torque rods), as Gymnasium
environments.

``import rbenv`` registers four tasks on one plant, each with a single env and a native NumPy
vector env (its ``vector_entry_point``)::

    import gymnasium as gym
    import rbenv

    env = gym.make("rbenv/SatelliteReorient-v2", scene="cubesat-12u")
    envs = gym.make_vec("rbenv/SatelliteDetumble-v1", num_envs=1024)
    env = gym.make("rbenv/SatelliteTrack-v1", randomize={"inertia_scale": 0.2})
    env = gym.make("rbenv/SatelliteDesaturate-v0")  # a wheel scene: cubesat-6u-rw

The v0 ids of reorient, detumble and track stay registered (their episodes are v1's; their
observation and reward are the first release's), and Gymnasium calls them out of date.
Tools that take only an id string can use ``"rbenv:rbenv/SatelliteReorient-v2"``, which makes
Gymnasium import rbenv first. Scenes: :func:`list_scenes`, :func:`load_scene`, :class:`Scene`.

The package in layers, each importing only those below it (docs/design.md, "Layers"):
``rbenv.envs`` (registration, the single, NumPy-vector and torch-vector shells, the env core and
its options), ``rbenv.tasks`` (what each task asks of the satellite), ``rbenv.satellite`` (the
plant: actuators, scenes, orbit, sensing, allocation, randomization, state) and ``rbenv.core``
(rigid-body physics); ``rbenv.agents`` (controllers, policies, training) sits above them all.
The module paths of version 0.2 (``rbenv.env``, ``rbenv.scene``, ``rbenv.actuators``, ...) still
import, as the same module objects (:data:`MOVED`; docs/api.md names the canonical paths).
"""

from __future__ import annotations

import importlib as _importlib
import importlib.abc as _abc
import importlib.util as _util
import os as _os
import sys as _sys
from importlib.metadata import PackageNotFoundError, version

# The layers core/ and agents/ are subpackages, rbenv.core and rbenv.agents. A wheel holds them
# inside rbenv/ (pyproject's package-dir); a source checkout keeps them beside it. In a checkout,
# resolve them from this same checkout, whatever an editable install elsewhere points at.
_checkout = _os.path.dirname(_os.path.dirname(_os.path.abspath(__file__)))
if not _os.path.isdir(_os.path.join(__path__[0], "core")) and _os.path.isfile(
        _os.path.join(_checkout, "core", "__init__.py")):
    __path__.append(_checkout)

# Module paths of version 0.2 -> the folder that holds the module now: `rbenv.scene` is
# `rbenv.satellite.scene`, `rbenv.actuators.wheels` is `rbenv.satellite.actuators.wheels`.
MOVED = {name: "satellite" for name in (
    "actuators", "allocation", "disturbances", "draws", "orbit", "plant", "randomization",
    "scene", "scene_schema", "sensing", "state", "telemetry", "torch_draws", "usage")}
MOVED |= {name: "envs" for name in (
    "adapter", "bounds", "env", "goal", "options", "registry", "rendering", "torch_compile",
    "torch_env", "transition", "vector_env")}


class _MovedModules(_abc.MetaPathFinder, _abc.Loader):
    """Imports an old path (:data:`MOVED`) as the module at its new path: the same object, so
    its classes, its state and a test's monkeypatch are shared, and nothing loads twice."""

    @staticmethod
    def new_name(fullname: str) -> str | None:
        parts = fullname.split(".")
        if len(parts) < 2 or parts[0] != __name__ or parts[1] not in MOVED:
            return None
        return ".".join([__name__, MOVED[parts[1]], *parts[1:]])

    def find_spec(self, fullname, path=None, target=None):
        if self.new_name(fullname) is None:
            return None
        return _util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        return _importlib.import_module(self.new_name(spec.name))

    def exec_module(self, module):
        """Nothing to run: the module ran once, under its new name."""


if not any(isinstance(finder, _MovedModules) for finder in _sys.meta_path):
    _sys.meta_path.insert(0, _MovedModules())


def __getattr__(name: str):
    """``rbenv.scene`` and the other old paths as attributes, without an import statement."""
    if name in MOVED:
        return _importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


from rbenv.envs import goal, registry
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

# The shipped tasks: one registry entry each (rbenv.envs.registry). A new task adds its line here.
for _spec in (reorient.SPEC, detumble.SPEC, track.SPEC, desaturate.SPEC,
              reorient.SPEC_V1, detumble.SPEC_V1, track.SPEC_V1, reorient.SPEC_V2):
    registry.register(_spec)

goal.register()  # the goal-conditioned form of Reorient-v1: its own Gymnasium id

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
# v2: v1's with a reward that prices time and propellant); the older ids stay registered, and
# Gymnasium calls them out of date.
ENV_ID = reorient.SPEC_V2.env_id
DETUMBLE_ID = detumble.SPEC_V1.env_id
TRACK_ID = track.SPEC_V1.env_id
DESATURATE_ID = desaturate.SPEC.env_id
MAX_EPISODE_STEPS = registry.MAX_EPISODE_STEPS
# id -> (single env class name, vector env class name), for every registered task.
ENV_IDS = {s.env_id: (s.class_stem + "Env", s.class_stem + "VectorEnv")
           for s in registry.specs()}
