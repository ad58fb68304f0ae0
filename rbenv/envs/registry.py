"""The Gymnasium ids of rbenv: one :class:`rbenv.tasks.spec.TaskSpec` each, and nothing about
training.

:func:`register` takes an entry (id, task class and maker, docs, default scene, the scene
tables it needs), refuses an id already taken by another task, and registers the id with
Gymnasium, every id alike: its entry points are :func:`make_env` (``gym.make``) and
:func:`make_vector_env` (``gym.make_vec``), given the entry as ``task``. They take ``backend``
and make the shell of it: on NumPy the id's own class where it has one (``class
SatelliteReorientEnv(AttitudeEnv)`` in :mod:`rbenv.envs.env`, ``class
SatelliteReorientVectorEnv(AttitudeVectorEnv)`` in :mod:`rbenv.envs.vector_env`), else
:class:`rbenv.envs.env.AttitudeEnv` and :class:`rbenv.envs.vector_env.AttitudeVectorEnv`
themselves; on torch :class:`rbenv.envs.torch_env.TorchEnv` and
:class:`rbenv.envs.torch_env.TorchVectorEnv`. ``rbenv.ENV_IDS`` and every tool that lists
tasks read this registry.

A new task is one module (a :class:`rbenv.tasks.base.Task` subclass, its maker and its entry)
plus one call::

    register(TaskSpec(env_id="myorg/PointSun-v0", task=PointSun, make=make_point_sun))

Training a task (``rbenv train``, the learning suite, the evaluation report's scripted
baselines) needs its settings too: an entry keyed by the same id in
:mod:`rbenv.agents.settings`, which sits above this package.
"""

from __future__ import annotations

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from rbenv import tasks
from rbenv.core.errors import InvalidParameterError
from rbenv.envs import env as single_env
from rbenv.envs import vector_env
from rbenv.envs.adapter import check_backend
from rbenv.envs.options import ENV_OPTIONS
from rbenv.satellite.scene import load_scene
from rbenv.satellite.usage import check_choice
from rbenv.tasks.spec import MAX_EPISODE_STEPS, TaskSpec

__all__ = ["MAX_EPISODE_STEPS", "VECTOR_OPTIONS", "TaskSpec", "by_name", "check_env_options",
           "get", "make_env", "make_vector_env", "plain_env", "register", "specs",
           "unregister"]

_SPECS: dict[str, TaskSpec] = {}


def register(spec: TaskSpec) -> TaskSpec:
    """Register ``spec``'s id with Gymnasium (the entry was checked when it was made).

    Registering the same id again replaces the entry (a reload); a different task under an id
    already taken raises.
    """
    if not isinstance(spec, TaskSpec):
        raise InvalidParameterError(f"register takes a rbenv.tasks.spec.TaskSpec, got "
                                    f"{type(spec).__name__} {spec!r}")
    old = _SPECS.get(spec.env_id)
    if old is not None and old.task is not spec.task:
        raise InvalidParameterError(
            f"task entry {spec.env_id!r} is already registered for task {old.task.name!r}")
    names = {s.name: s.env_id for s in _SPECS.values() if s.env_id != spec.env_id}
    if spec.name in names and _SPECS[names[spec.name]].task is not spec.task:
        raise InvalidParameterError(
            f"task name {spec.name!r} of {spec.env_id!r} is already used by {names[spec.name]!r}")
    _SPECS[spec.env_id] = spec
    _sync_table_makers()
    if spec.env_id in gym.registry:
        del gym.registry[spec.env_id]
    gym.register(id=spec.env_id, entry_point=f"{__name__}:make_env",
                 vector_entry_point=f"{__name__}:make_vector_env",
                 max_episode_steps=spec.max_episode_steps, kwargs={"task": spec})
    return spec


def make_env(task: TaskSpec, backend: str = "numpy", **options):
    """``gym.make(id, backend=..., **options)``: the single env of entry ``task`` on
    ``backend`` ("numpy", default: the id's own class, :mod:`rbenv.envs.env`; "torch":
    :class:`rbenv.envs.torch_env.TorchEnv`, needs torch). Each shell checks its options."""
    if check_backend(backend):
        from rbenv.envs.torch_env import TorchEnv

        return TorchEnv(task=task, **options)
    return _shell(single_env.SHELLS, single_env.AttitudeEnv, task)(task=task, **options)


def make_vector_env(num_envs: int = 1, task: TaskSpec | None = None, backend: str = "numpy",
                    **options):
    """``gym.make_vec(id, num_envs=N, backend=..., **options)``: the native vector env of
    entry ``task`` on ``backend`` ("numpy", default: the id's own class,
    :mod:`rbenv.envs.vector_env`; "torch": :class:`rbenv.envs.torch_env.TorchVectorEnv`)."""
    if check_backend(backend):
        from rbenv.envs.torch_env import TorchVectorEnv

        return TorchVectorEnv(num_envs, task=task, **options)
    cls = _shell(vector_env.SHELLS, vector_env.AttitudeVectorEnv, task)
    return cls(num_envs, task=task, **options)


def _shell(shells: dict, generic: type, task) -> type:
    """The class of ``task``'s id where it is a shipped id's (its docs and name), else
    ``generic``, which runs any entry given as ``task``. (Equal, not identical: ``gym.make``
    hands the entry point a deep copy of the registered kwargs.)"""
    cls = shells.get(getattr(task, "env_id", None))
    return cls if cls is not None and cls.task_spec == task else generic


def _sync_table_makers() -> None:
    """:data:`rbenv.tasks.TABLE_MAKERS` from the entries: each scene table's first entry (a v1
    task reads its v0's table)."""
    tasks.TABLE_MAKERS.clear()
    for spec in _SPECS.values():
        tasks.TABLE_MAKERS.setdefault(spec.task.table_name(), spec)


def unregister(env_id: str) -> None:
    """Remove an entry and its Gymnasium id (a test's task, say); unknown ids are ignored."""
    if _SPECS.pop(env_id, None) is not None:
        _sync_table_makers()
        if env_id in gym.registry:
            del gym.registry[env_id]


def get(env_id: str) -> TaskSpec:
    """The entry of a registered id; the error lists the registered ids."""
    try:
        return _SPECS[env_id]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"env_id must be one of the registered rbenv tasks {sorted(_SPECS)}, got "
            f"{env_id!r}") from None


def by_name(task_name: str) -> TaskSpec:
    """The entry whose task is named ``task_name`` ("reorient", ...)."""
    for spec in _SPECS.values():
        if spec.name == task_name:
            return spec
    raise InvalidParameterError(
        f"task must be one of {sorted(s.name for s in _SPECS.values())}, got {task_name!r}")


def specs() -> tuple:
    """Every registered entry, in registration order."""
    return tuple(_SPECS.values())


def check_env_options(env_id: str, options: dict) -> None:
    """Make ``env_id``'s single env once with ``options`` (``gym.make`` keyword arguments, the
    scene among them; :data:`VECTOR_OPTIONS` are checked by name only) and close it, so that a
    wrong id, scene, option name or value is named before anything is trained or written.
    Raises the named errors of :mod:`rbenv.core.errors` (:class:`InvalidChoiceError` for an id,
    scene or option name not known)."""
    known = [spec.env_id for spec in specs()]
    check_choice("env_id", env_id, known, what="a registered rbenv task:")
    for name in options:
        check_choice("env_kwargs", name, (*ENV_OPTIONS, *VECTOR_OPTIONS),
                     what="an env option:")
    if options.get("scene") is not None:
        load_scene(options["scene"])
    plain_env(env_id, {k: v for k, v in options.items() if k not in VECTOR_OPTIONS}).close()


# Options of the vector env that a caller of ``rbenv train`` or ``evaluate`` may set (the
# commands set num_envs and autoreset_mode themselves).
VECTOR_OPTIONS = ("max_episode_steps",)


def plain_env(env_id: str, options: dict):
    """``env_id``'s single env made from its entry point with ``options``, without
    ``gym.make``'s wrappers and notices (for checks; close it after use)."""
    spec = gym.spec(env_id)  # its kwargs: the entry an id without classes runs on (task=)
    return load_env_creator(spec.entry_point)(**{**spec.kwargs, **options})
