"""Envs made by id for the command line's checks and the evaluation of one scripted policy:
what ``rbenv train`` and ``rbenv evaluate`` need before anything runs or is written.

:func:`check_env_options` makes an id's single env once, so that a wrong id, scene, option name
or value is named before a run starts; :func:`plain_env` makes it without ``gym.make``'s
wrappers and notices. The env options themselves are declared in :mod:`rbenv.envs.options`.
"""

from __future__ import annotations

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from rbenv.envs import registry
from rbenv.envs.options import ENV_OPTIONS, VECTOR_OPTIONS
from rbenv.satellite.scene import load_scene
from rbenv.satellite.usage import check_choice

# The vector env's options that the commands set themselves (rbenv train and evaluate choose
# the batch size and the autoreset mode), and those a caller of the commands may set besides
# the env options: the rest of rbenv.envs.options.VECTOR_OPTIONS.
SET_BY_COMMANDS: tuple[str, ...] = ("num_envs", "autoreset_mode")
CALLER_VECTOR_OPTIONS: tuple[str, ...] = tuple(n for n in VECTOR_OPTIONS
                                               if n not in SET_BY_COMMANDS)


def check_env_options(env_id: str, options: dict) -> None:
    """Make ``env_id``'s single env once with ``options`` (``gym.make`` keyword arguments, the
    scene among them; :data:`CALLER_VECTOR_OPTIONS` are checked by name only) and close it, so
    that a wrong id, scene, option name or value is named before anything is trained or
    written. Raises the named errors of :mod:`rbenv.core.errors` (:class:`InvalidChoiceError`
    for an id, scene or option name not known)."""
    known = [spec.env_id for spec in registry.specs()]
    check_choice("env_id", env_id, known, what="a registered rbenv task:")
    for name in options:
        check_choice("env_kwargs", name, (*ENV_OPTIONS, *CALLER_VECTOR_OPTIONS),
                     what="an env option:")
    if options.get("scene") is not None:
        load_scene(options["scene"])
    plain_env(env_id, {k: v for k, v in options.items()
                       if k not in CALLER_VECTOR_OPTIONS}).close()


def plain_env(env_id: str, options: dict):
    """``env_id``'s single env made from its entry point with ``options``, without
    ``gym.make``'s wrappers and notices (for checks; close it after use)."""
    spec = gym.spec(env_id)  # its kwargs: the entry the entry point makes (task=)
    return load_env_creator(spec.entry_point)(**{**spec.kwargs, **options})
