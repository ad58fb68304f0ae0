"""The tasks of rbenv: each a module with one :class:`rbenv.tasks.base.Task` subclass, its
maker and its env entry (``SPEC``, a :class:`rbenv.tasks.spec.TaskSpec`, registered as a
Gymnasium id by ``rbenv/__init__.py`` through :mod:`rbenv.envs.registry`).

:func:`build` resolves env options into the (plant, task) pair that the env core runs.
"""

from __future__ import annotations

from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.plant import Plant, make_plant
from rbenv.satellite.scene import load_scene
from rbenv.tasks.base import Task, option_table
from rbenv.tasks.detumble import Detumble
from rbenv.tasks.reorient import Reorient
from rbenv.tasks.spec import TaskSpec
from rbenv.tasks.track import Track

__all__ = ["TABLE_MAKERS", "Detumble", "Reorient", "Task", "TaskSpec", "Track", "build"]

# Scene option table name ([tasks.<name>]) -> the entry whose maker reads it, for every
# registered task: rbenv.envs.registry.register adds each entry's, so a bad value in any task's
# table fails when an env of any task is made on the scene.
TABLE_MAKERS: dict[str, TaskSpec] = {}


def build(spec: TaskSpec, scene=None, *, integrator=None, control_dt=None, substeps=None,
          action_mode="throttle", allocator="pinv", randomize=None, reward_weights=None,
          max_initial_angle_deg=None, max_initial_rate=None, task_options=None,
          compiled=False) -> tuple[Plant, Task]:
    """The plant and the task of ``spec`` for these env options (validated)."""
    if scene is None:
        scene = spec.scene
    scene = load_scene(scene).for_task(spec.task.table_name())
    plant = make_plant(scene, integrator=integrator, control_dt=control_dt, substeps=substeps,
                       action_mode=action_mode, allocator=allocator, randomize=randomize,
                       compiled=compiled)
    task = spec.make(plant, reward_weights=reward_weights,
                     max_initial_angle_deg=max_initial_angle_deg,
                     max_initial_rate=max_initial_rate, task_options=task_options)
    check_other_task_tables(plant, spec.task.table_name())
    return plant, task


def check_other_task_tables(plant: Plant, own_table: str) -> None:
    """Check the scene's option tables of the other tasks too (``[tasks.<other>]``), with
    their own makers (:data:`TABLE_MAKERS`): a bad value there fails when any env is made on
    the scene, not only when that task's is, and the error names the table and its task.
    ``own_table``: the table the env's task has read already (a v1 task reads its v0's).

    A table whose task cannot run on the scene (it lacks a table the task needs, as
    ``[wheels]`` for desaturation) is not run through its maker: only its option names are
    checked, since its values mean nothing here and the env asked for is another task's."""
    for table in plant.scene.tasks:
        spec = TABLE_MAKERS.get(table)
        if table == own_table or spec is None:
            continue
        try:
            scene = plant.scene.for_task(table)
            if spec.runs_on(scene):
                spec.make(make_plant(scene))
            else:
                option_table(scene, spec.task, None)
        except InvalidParameterError as exc:
            raise type(exc)(f"scene {plant.scene.name!r}, table [tasks.{table}] (options of "
                            f"task {spec.name!r}, checked whatever task is made): "
                            f"{exc}") from None
