"""The Gymnasium ids of rbenv: one :class:`rbenv.tasks.spec.TaskSpec` each, and nothing about
training.

Every id goes through one call, :func:`register`: its entry (id, task class and maker, docs,
default scene, the scene tables it needs) and the classes that make it. It refuses an id
already taken by another task and registers the id with Gymnasium, every id alike: its entry
points are :func:`make_env` (``gym.make``) and :func:`make_vector_env` (``gym.make_vec``),
given the entry as ``task``. They take ``backend`` and make the shell of it: on NumPy the
id's own classes (``SatelliteReorientEnv`` of :mod:`rbenv.envs.env`,
``SatelliteReorientVectorEnv`` of :mod:`rbenv.envs.vector_env`, named where the id is
registered) or, for an id registered without classes,
:class:`rbenv.envs.env.AttitudeEnv` and :class:`rbenv.envs.vector_env.AttitudeVectorEnv`
themselves; on torch :class:`rbenv.envs.torch_env.TorchEnv` and
:class:`rbenv.envs.torch_env.TorchVectorEnv`.

An id whose single-env class is not an :class:`~rbenv.envs.env.AttitudeEnv` is another form
of a task (the goal form of Reorient-v1, :mod:`rbenv.envs.goal`): it is made on NumPy from its
options alone, ``gym.make_vec`` copies it (Gymnasium's ``SyncVectorEnv``), and it is not a
task of its own: :func:`specs`, :func:`get`, :func:`by_name`, ``rbenv.ENV_IDS`` and the tools
that list tasks (training, the evaluation report) skip it; :func:`ids` lists every id.

A new task is one module (a :class:`rbenv.tasks.base.Task` subclass, its maker and its entry)
plus one call::

    register(TaskSpec(env_id="myorg/PointSun-v0", task=PointSun, make=make_point_sun))

Training a task (``rbenv train``, the learning suite, the evaluation report's scripted
baselines) needs its settings too: an entry keyed by the same id in
:mod:`rbenv.agents.settings`, which sits above this package.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym

from rbenv import tasks
from rbenv.core.errors import InvalidParameterError
from rbenv.envs.adapter import check_backend
from rbenv.envs.env import AttitudeEnv
from rbenv.envs.vector_env import AttitudeVectorEnv
from rbenv.tasks.spec import MAX_EPISODE_STEPS, TaskSpec

__all__ = ["MAX_EPISODE_STEPS", "TaskSpec", "by_name", "get", "ids", "make_env",
           "make_vector_env", "register", "specs", "unregister"]


@dataclass(frozen=True)
class _Entry:
    """What one id runs: its task entry and its NumPy classes (``vector_env`` None: a form's,
    copied by ``gym.make_vec``)."""

    spec: TaskSpec
    env: type
    vector_env: type | None

    @property
    def is_task(self) -> bool:
        """A task id (the attitude shells, every backend), not another form of one."""
        return issubclass(self.env, AttitudeEnv)


_ENTRIES: dict[str, _Entry] = {}


def register(spec: TaskSpec, env: type | None = None, vector_env: type | None = None
             ) -> TaskSpec:
    """Register ``spec``'s id with Gymnasium (the entry was checked when it was made).

    env, vector_env: the id's own classes on NumPy: subclasses of
    :class:`~rbenv.envs.env.AttitudeEnv` and :class:`~rbenv.envs.vector_env.AttitudeVectorEnv`
    whose ``task_spec`` is ``spec`` (None: those two, given ``spec`` as ``task``); or, for
    another form of a task, any ``gym.Env`` class made from the env options alone, without a
    vector class. Registering the same id again replaces the entry (a reload); a different
    task under an id already taken raises.
    """
    if not isinstance(spec, TaskSpec):
        raise InvalidParameterError(f"register takes a rbenv.tasks.spec.TaskSpec, got "
                                    f"{type(spec).__name__} {spec!r}")
    entry = _Entry(spec, AttitudeEnv if env is None else env, vector_env)
    _check_classes(entry)
    if entry.is_task and vector_env is None:
        entry = _Entry(spec, entry.env, AttitudeVectorEnv)
    old = _ENTRIES.get(spec.env_id)
    if old is not None and old.spec.task is not spec.task:
        raise InvalidParameterError(
            f"task entry {spec.env_id!r} is already registered for task {old.spec.task.name!r}")
    if entry.is_task:
        names = {s.name: s.env_id for s in specs() if s.env_id != spec.env_id}
        if spec.name in names and _ENTRIES[names[spec.name]].spec.task is not spec.task:
            raise InvalidParameterError(f"task name {spec.name!r} of {spec.env_id!r} is already "
                                        f"used by {names[spec.name]!r}")
    _ENTRIES[spec.env_id] = entry
    _sync_table_makers()
    if spec.env_id in gym.registry:
        del gym.registry[spec.env_id]
    gym.register(id=spec.env_id, entry_point=f"{__name__}:make_env",
                 vector_entry_point=f"{__name__}:make_vector_env" if entry.is_task else None,
                 max_episode_steps=spec.max_episode_steps, kwargs={"task": spec})
    return spec


def _check_classes(entry: _Entry) -> None:
    """Named errors for classes that do not make ``entry.spec``'s id."""
    where = f"register({entry.spec.env_id!r})"
    if not (isinstance(entry.env, type) and issubclass(entry.env, gym.Env)):
        raise InvalidParameterError(f"{where}: env must be a gymnasium.Env class, got "
                                    f"{entry.env!r}")
    shells = ((entry.env, AttitudeEnv, "env"), (entry.vector_env, AttitudeVectorEnv,
                                                 "vector_env"))
    if not entry.is_task:
        if entry.vector_env is not None:
            raise InvalidParameterError(
                f"{where}: vector_env needs env to be an AttitudeEnv subclass (another form "
                f"of a task, {entry.env.__name__}, is copied by gym.make_vec), got "
                f"{entry.vector_env!r}")
        return
    for cls, base, name in shells:
        if cls is None or cls is base:
            continue
        if not (isinstance(cls, type) and issubclass(cls, base)):
            raise InvalidParameterError(f"{where}: {name} must be a subclass of "
                                        f"{base.__name__}, got {cls!r}")
        if cls.task_spec != entry.spec:
            raise InvalidParameterError(
                f"{where}: {name} {cls.__name__} runs {cls.task_spec!r}, not this entry: set "
                f"its task_spec to the entry registered")


def make_env(task: TaskSpec, backend: str = "numpy", **options):
    """``gym.make(id, backend=..., **options)``: the single env of entry ``task`` on
    ``backend`` ("numpy", default: the id's own class, :mod:`rbenv.envs.env`; "torch":
    :class:`rbenv.envs.torch_env.TorchEnv`, needs torch). Each shell checks its options."""
    entry = _entry_of(task)
    if entry is not None and not entry.is_task:
        if check_backend(backend):
            raise InvalidParameterError(
                f"backend must be 'numpy' for {task.env_id!r} ({entry.env.__name__} runs on "
                f"NumPy only), got {backend!r}")
        return entry.env(**options)
    if check_backend(backend):
        from rbenv.envs.torch_env import TorchEnv

        return TorchEnv(task=task, **options)
    return (AttitudeEnv if entry is None else entry.env)(task=task, **options)


def make_vector_env(num_envs: int = 1, task: TaskSpec | None = None, backend: str = "numpy",
                    **options):
    """``gym.make_vec(id, num_envs=N, backend=..., **options)``: the native vector env of
    entry ``task`` on ``backend`` ("numpy", default: the id's own class,
    :mod:`rbenv.envs.vector_env`; "torch": :class:`rbenv.envs.torch_env.TorchVectorEnv`)."""
    if check_backend(backend):
        from rbenv.envs.torch_env import TorchVectorEnv

        return TorchVectorEnv(num_envs, task=task, **options)
    entry = _entry_of(task)
    cls = AttitudeVectorEnv if entry is None or not entry.is_task else entry.vector_env
    return cls(num_envs, task=task, **options)


def _entry_of(task) -> _Entry | None:
    """The registration of ``task``'s id where it runs ``task`` (equal, not identical:
    ``gym.make`` hands the entry point a deep copy of the registered kwargs); else None, and
    the generic shells run the entry given."""
    entry = _ENTRIES.get(getattr(task, "env_id", None))
    return entry if entry is not None and entry.spec == task else None


def _sync_table_makers() -> None:
    """:data:`rbenv.tasks.TABLE_MAKERS` from the entries: each scene table's first entry (a v1
    task reads its v0's table)."""
    tasks.TABLE_MAKERS.clear()
    for spec in specs():
        tasks.TABLE_MAKERS.setdefault(spec.task.table_name(), spec)


def unregister(env_id: str) -> None:
    """Remove an entry and its Gymnasium id (a test's task, say); unknown ids are ignored."""
    if _ENTRIES.pop(env_id, None) is not None:
        _sync_table_makers()
        if env_id in gym.registry:
            del gym.registry[env_id]


def get(env_id: str) -> TaskSpec:
    """The entry of a registered id; the error lists the registered ids."""
    entry = _ENTRIES.get(env_id) if isinstance(env_id, str) else None
    if entry is None or not entry.is_task:
        raise InvalidParameterError(
            f"env_id must be one of the registered rbenv tasks "
            f"{sorted(s.env_id for s in specs())}, got {env_id!r}")
    return entry.spec


def by_name(task_name: str) -> TaskSpec:
    """The entry whose task is named ``task_name`` ("reorient", ...)."""
    for spec in specs():
        if spec.name == task_name:
            return spec
    raise InvalidParameterError(
        f"task must be one of {sorted(s.name for s in specs())}, got {task_name!r}")


def specs() -> tuple:
    """The entry of every registered task id, in registration order (not the other forms)."""
    return tuple(e.spec for e in _ENTRIES.values() if e.is_task)


def ids() -> tuple:
    """Every id registered here, the other forms of tasks (the goal form) among them, in
    registration order."""
    return tuple(_ENTRIES)
