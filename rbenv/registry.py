"""One registry of tasks: everything a task id needs, in one entry, checked when it is made.

A :class:`TaskSpec` holds a task's env id, its class and maker, its scripted baselines, its
training budget and its tuned hyperparameters. :func:`register` checks the entry (a missing
baseline, budget or hyperparameter set is named here, never after training), makes the env
classes (single and vector) and registers the id with Gymnasium. Everything else derives from
the registry: ``rbenv.ENV_IDS``, the RL Zoo files in :mod:`rbenv.hyperparams`, ``rbenv train``'s
defaults, the evaluation report's baselines and the learning suite's grid.

A new task is one module (a :class:`rbenv.tasks.base.Task` subclass and its maker) plus one
:func:`register` call::

    register(TaskSpec(env_id="myorg/PointSun-v0", task=PointSun, make=make_point_sun,
                      baselines={"pd": "mypkg.controllers:SunPD"},
                      budget={"ppo": 500_000}, hyperparams={"ppo": PPO}))

Baselines are named by ``"module:attribute"`` strings (resolved by ``agents``, which sits above
this package) or given as objects; each resolves to a class with ``from_env(env)`` whose
instances have SB3's ``predict(obs, state)``.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import gymnasium as gym

from rbenv.core.errors import InvalidParameterError

__all__ = ["TaskSpec", "by_name", "get", "register", "specs", "unregister", "zoo_hyperparams"]

_ID = re.compile(r"^[A-Za-z0-9_.-]+/[A-Za-z0-9_.]+-v\d+$")
_REF = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
MAX_EPISODE_STEPS = 160  # control steps of every shipped scene (the scene may end sooner)


@dataclass(frozen=True)
class TaskSpec:
    """A registered task (see the module docstring).

    env_id: Gymnasium id ``"namespace/Name-vN"``. task: the Task subclass. make: its maker,
    ``make(plant, reward_weights=, max_initial_angle_deg=, max_initial_rate=, task_options=)``.
    baselines: scripted policy name → ``"module:Class"`` or class with ``from_env``.
    budget: algorithm → the learning suite's training timesteps, where they differ from the
    settings' ``n_timesteps`` (the v0 entries, whose committed suite results used them).
    scene_budgets: (algorithm, scene) → timesteps, where a scene needs more.
    scene_env_kwargs: (algorithm, scene) → env options that training adds on that scene
    (``rbenv train`` and the suite; a reward weight the scene needs, with the evidence beside
    it); the env's own defaults stay as they are. hyperparams: algorithm → settings in RL
    Zoo's format, shared by the ids (``rbenv.hyperparams.tuned``; every algorithm of ``budget``
    needs one). id_settings: algorithm → this id's own settings over the shared ones (its
    measured ``n_timesteps``, say); :meth:`settings` merges them, and ``rbenv train``, RL Zoo's
    files and the suite read that. env_doc: the env classes' docstring. default_scene: the
    scene ``gym.make(env_id)`` uses (None: the package's default, cubesat-12u). needs: scene
    tables the task cannot run without (``("wheels",)``);
    :meth:`runs_on` checks them.
    """

    env_id: str
    task: type
    make: Callable
    baselines: Mapping[str, object]
    hyperparams: Mapping[str, dict]
    budget: Mapping[str, int] = field(default_factory=dict)
    id_settings: Mapping[str, dict] = field(default_factory=dict)
    scene_budgets: Mapping[tuple, int] = field(default_factory=dict)
    scene_env_kwargs: Mapping[tuple, dict] = field(default_factory=dict)
    max_episode_steps: int = MAX_EPISODE_STEPS
    env_doc: str = ""
    default_scene: str | None = None
    needs: tuple = ()

    @property
    def name(self) -> str:
        """The task's short name (``task.name``: "reorient", ...)."""
        return self.task.name

    @property
    def class_stem(self) -> str:
        """``SatelliteReorient`` for ``rbenv/SatelliteReorient-v0`` (env class names)."""
        stem = self.env_id.split("/", 1)[1].rsplit("-v", 1)
        return stem[0] + ("" if stem[1] == "0" else f"V{stem[1]}")

    def runs_on(self, scene) -> bool:
        """Whether ``scene`` (a name, path or Scene) has every table the task needs."""
        from rbenv.scene import load_scene

        tables = load_scene(scene).actuators
        return all(tables.get(name) is not None for name in self.needs)

    def settings(self, algo: str) -> dict:
        """``algo``'s settings on this id, RL Zoo's format: the shared ``hyperparams[algo]``
        with ``id_settings[algo]`` over them (a deep copy)."""
        return copy.deepcopy({**self.hyperparams[algo], **self.id_settings.get(algo, {})})

    def timesteps(self, algo: str, scene: str | None = None) -> int:
        """The suite's training budget of ``algo`` (on ``scene``, where it needs more): the
        scene's, else ``budget``'s, else the settings' ``n_timesteps``."""
        if (algo, scene) in self.scene_budgets:
            return self.scene_budgets[algo, scene]
        return self.budget.get(algo) or self.settings(algo)["n_timesteps"]

    def training_env_kwargs(self, algo: str, scene: str | None = None) -> dict:
        """Env options that training ``algo`` on ``scene`` adds (a deep copy; {}: none)."""
        return copy.deepcopy(dict(self.scene_env_kwargs.get((algo, scene), {})))


_SPECS: dict[str, TaskSpec] = {}


def _check(spec: TaskSpec) -> None:
    """Refuse an incomplete entry, naming what is missing."""
    from rbenv.tasks.base import Task

    where = f"task entry {spec.env_id!r}"
    if not isinstance(spec.env_id, str) or not _ID.match(spec.env_id):
        raise InvalidParameterError(
            f"task entry env_id must look like 'namespace/Name-v0', got {spec.env_id!r}")
    if not (isinstance(spec.task, type) and issubclass(spec.task, Task)):
        raise InvalidParameterError(f"{where}: task must be a rbenv.tasks.base.Task subclass, "
                                    f"got {spec.task!r}")
    if not callable(spec.make):
        raise InvalidParameterError(f"{where}: make must be callable, got {spec.make!r}")
    if not isinstance(spec.baselines, Mapping) or not spec.baselines:
        raise InvalidParameterError(
            f"{where}: baselines must name at least one scripted policy (name -> "
            f"'module:Class'), got {spec.baselines!r}; `rbenv train` compares every policy "
            "with them")
    for name, ref in spec.baselines.items():
        if not (isinstance(ref, str) and _REF.match(ref)) and not hasattr(ref, "from_env"):
            raise InvalidParameterError(
                f"{where}: baselines[{name!r}] must be 'module:Class' or a class with "
                f"from_env(env), got {ref!r}")
    if not isinstance(spec.hyperparams, Mapping) or "ppo" not in spec.hyperparams:
        raise InvalidParameterError(
            f"{where}: hyperparams has no settings for 'ppo' (the default algorithm), got "
            f"{spec.hyperparams!r}")
    for name, table in (("budget", spec.budget), ("id_settings", spec.id_settings)):
        if not isinstance(table, Mapping):
            raise InvalidParameterError(f"{where}: {name} must be a dict keyed by algorithm, "
                                        f"got {table!r}")
    for key, kwargs in spec.scene_env_kwargs.items():
        if not (isinstance(key, tuple) and len(key) == 2 and isinstance(kwargs, Mapping)):
            raise InvalidParameterError(
                f"{where}: scene_env_kwargs must map (algorithm, scene) to a dict of env "
                f"options, got {key!r}: {kwargs!r}")
    budgets = {f"budget[{a!r}]": n for a, n in spec.budget.items()}
    budgets.update({f"scene_budgets[{key!r}]": n for key, n in spec.scene_budgets.items()})
    algos = dict.fromkeys([*spec.hyperparams, *spec.id_settings, *spec.budget,
                           *(algo for algo, _ in spec.scene_budgets)])
    for algo in algos:
        if not isinstance(spec.hyperparams.get(algo), Mapping):
            raise InvalidParameterError(
                f"{where}: hyperparams[{algo!r}] must be a dict of settings (RL Zoo format), "
                f"got {spec.hyperparams.get(algo)!r}; every algorithm with a budget or "
                "id_settings needs one")
        if not isinstance(spec.id_settings.get(algo, {}), Mapping):
            raise InvalidParameterError(f"{where}: id_settings[{algo!r}] must be a dict of "
                                        f"settings, got {spec.id_settings[algo]!r}")
        if algo not in spec.budget:
            budgets[f"the n_timesteps of {algo!r}'s settings"] = \
                spec.settings(algo).get("n_timesteps")
    for name, steps in budgets.items():
        if isinstance(steps, bool) or not isinstance(steps, int) or steps <= 0:
            raise InvalidParameterError(
                f"{where}: {name} must be a positive int of timesteps, got {steps!r}")


def register(spec: TaskSpec) -> TaskSpec:
    """Check ``spec``, make its env classes and register its id with Gymnasium.

    Registering the same id again replaces the entry (a reload); a different task under an id
    already taken raises.
    """
    from rbenv import env as single_env
    from rbenv import vector_env

    _check(spec)
    old = _SPECS.get(spec.env_id)
    if old is not None and old.task is not spec.task:
        raise InvalidParameterError(
            f"task entry {spec.env_id!r} is already registered for task {old.task.name!r}")
    names = {s.name: s.env_id for s in _SPECS.values() if s.env_id != spec.env_id}
    if spec.name in names and _SPECS[names[spec.name]].task is not spec.task:
        raise InvalidParameterError(
            f"task name {spec.name!r} of {spec.env_id!r} is already used by {names[spec.name]!r}")
    _SPECS[spec.env_id] = spec
    single = single_env.env_class(spec)
    vector = vector_env.vector_env_class(spec)
    if spec.env_id in gym.registry:
        del gym.registry[spec.env_id]
    gym.register(id=spec.env_id, entry_point=f"{single.__module__}:{single.__name__}",
                 vector_entry_point=f"{vector.__module__}:{vector.__name__}",
                 max_episode_steps=spec.max_episode_steps)
    return spec


def unregister(env_id: str) -> None:
    """Remove an entry and its Gymnasium id (a test's task, say); unknown ids are ignored."""
    if _SPECS.pop(env_id, None) is not None and env_id in gym.registry:
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


def zoo_hyperparams(algo: str) -> dict:
    """RL Zoo's table for ``algo``: env id → settings, for every entry that has them."""
    return {s.env_id: s.settings(algo) for s in _SPECS.values() if algo in s.hyperparams}
