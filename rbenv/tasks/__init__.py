"""The tasks of rbenv: each a module with one :class:`rbenv.tasks.base.Task` subclass.

:data:`TASKS` maps a task name to its maker; :func:`build` resolves env options into the
(plant, task) pair that both env adapters run. A new task is one module here plus one line in
:data:`TASKS` and its registration in ``rbenv/__init__.py``.
"""

from __future__ import annotations

from core.errors import InvalidParameterError
from rbenv.plant import Plant, make_plant
from rbenv.tasks.base import Task
from rbenv.tasks.detumble import Detumble, make_detumble
from rbenv.tasks.reorient import Reorient, make_reorient
from rbenv.tasks.track import Track, make_track

__all__ = ["TASKS", "Detumble", "Reorient", "Task", "Track", "build"]

TASKS = {"reorient": make_reorient, "detumble": make_detumble, "track": make_track}


def build(task_name: str, scene=None, *, integrator=None, control_dt=None, substeps=None,
          action_mode="throttle", allocator="pinv", randomize=None, reward_weights=None,
          max_initial_angle_deg=None, max_initial_rate=None, task_options=None,
          compiled=False) -> tuple[Plant, Task]:
    """The plant and the task named ``task_name`` for these env options (validated)."""
    if task_name not in TASKS:
        raise InvalidParameterError(f"task must be one of {sorted(TASKS)}, got {task_name!r}")
    plant = make_plant(scene, integrator=integrator, control_dt=control_dt, substeps=substeps,
                       action_mode=action_mode, allocator=allocator, randomize=randomize,
                       compiled=compiled)
    task = TASKS[task_name](plant, reward_weights=reward_weights,
                            max_initial_angle_deg=max_initial_angle_deg,
                            max_initial_rate=max_initial_rate, task_options=task_options)
    return plant, task
