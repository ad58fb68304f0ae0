"""What an env id needs, and nothing about training: :class:`TaskSpec`.

A task module declares its entry beside its task class::

    SPEC = TaskSpec(env_id="myorg/PointSun-v0", task=PointSun, make=make_point_sun,
                    env_doc="Point body +x at the Sun.")

and :func:`rbenv.envs.registry.register` makes it a Gymnasium id. Baselines, hyperparameters and
training budgets are keyed by the same id in :mod:`rbenv.agents.settings`, above this package.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.scene import DEFAULT_SCENE, load_scene
from rbenv.tasks.base import Task

__all__ = ["MAX_EPISODE_STEPS", "TaskSpec"]

_ID = re.compile(r"^[A-Za-z0-9_.-]+/[A-Za-z0-9_.]+-v\d+$")
MAX_EPISODE_STEPS = 160  # control steps of every shipped scene (the scene may end sooner)


@dataclass(frozen=True)
class TaskSpec:
    """A task's env entry, checked when made.

    env_id: Gymnasium id ``"namespace/Name-vN"`` (the version is the env's: a reward or
    observation change makes a new one, and ``env_doc`` keeps the Version History). task: the
    :class:`rbenv.tasks.base.Task` subclass. make: its maker, ``make(plant, reward_weights=,
    max_initial_angle_deg=, max_initial_rate=, task_options=)``. env_doc: the env classes'
    docstring. default_scene: the scene ``gym.make(env_id)`` uses (None: the package's default,
    cubesat-12u). needs: scene tables the task cannot run without (``("wheels",)``; checked by
    :meth:`runs_on`). max_episode_steps: Gymnasium's registered limit.
    """

    env_id: str
    task: type
    make: Callable
    env_doc: str = ""
    default_scene: str | None = None
    needs: tuple = ()
    max_episode_steps: int = MAX_EPISODE_STEPS

    def __repr__(self) -> str:
        """Short: Gymnasium quotes the registered kwargs (this entry) in its errors."""
        return f"TaskSpec({self.env_id!r}, task={self.task.__name__})"

    def __post_init__(self):
        where = f"task entry {self.env_id!r}"
        if not isinstance(self.env_id, str) or not _ID.match(self.env_id):
            raise InvalidParameterError(
                f"task entry env_id must look like 'namespace/Name-v0', got {self.env_id!r}")
        if not (isinstance(self.task, type) and issubclass(self.task, Task)):
            raise InvalidParameterError(f"{where}: task must be a rbenv.tasks.base.Task "
                                        f"subclass, got {self.task!r}")
        if not callable(self.make):
            raise InvalidParameterError(f"{where}: make must be callable, got {self.make!r}")

    @property
    def scene(self) -> str:
        """The scene ``gym.make(env_id)`` uses: :attr:`default_scene`, else the package's."""
        return self.default_scene or DEFAULT_SCENE

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
        tables = load_scene(scene).actuators
        return all(tables.get(name) is not None for name in self.needs)
