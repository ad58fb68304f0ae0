"""What the single-env and the vector-env adapters share: the plant, the task, their spaces.

Both adapters take the same env options (:data:`rbenv.envs.options.ENV_OPTIONS`, declared once in
:class:`rbenv.envs.options.EnvOptions`), build the (plant, task) pair with
:func:`rbenv.tasks.build`, and expose the same accessors; only how they hold the state
(floats or arrays) and Gymnasium's API shape differ.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from rbenv.envs import options, transition
from rbenv.satellite.draws import check_seed
from rbenv.tasks import build
from rbenv.tasks.spec import TaskSpec


def action_array(value, shape: tuple, *, copy: bool = False, name: str = "action") -> np.ndarray:
    """An action as float64 of ``shape``; a named error for anything else.

    Real numbers only, as ``Box.contains`` requires: strings (even numeric ones), complex
    numbers, bools, None and other objects raise ``TypeError``; a wrong shape raises
    :class:`InvalidParameterError` (a ``ValueError``). Each message names ``name``, the value
    and its shape. copy: always return a new array (the caller may clip it in place).
    """
    arr = value if isinstance(value, np.ndarray) else _as_array(value, shape, name)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be real numbers (int or float) of shape {shape}, got "
                        f"{validation.show(value)} of dtype {arr.dtype} and shape {arr.shape}")
    if arr.shape != shape:
        raise InvalidParameterError(f"{name} must have shape {shape}, got "
                                    f"{validation.show(value)} of shape {arr.shape}")
    return np.array(arr, dtype=np.float64) if copy else np.asarray(arr, dtype=np.float64)


def _as_array(value, shape: tuple, name: str) -> np.ndarray:
    try:
        return np.asarray(value)
    except ValueError:  # ragged nested sequences
        raise InvalidParameterError(f"{name} must be a rectangular array of shape {shape}, got "
                                    f"{validation.show(value)}") from None
    except (TypeError, RecursionError, OverflowError):
        raise TypeError(f"{name} must be real numbers of shape {shape}, got "
                        f"{validation.show(value)} of type {type(value).__name__}") from None


_MODES = {mode.value: mode for mode in AutoresetMode}


def autoreset_mode_of(value) -> AutoresetMode:
    """``value`` as an :class:`AutoresetMode` (the mode or its value; None: the default,
    :data:`rbenv.envs.options.AUTORESET_DEFAULT`, read now); a named error else."""
    if value is None:
        return options.AUTORESET_DEFAULT
    mode = value if isinstance(value, AutoresetMode) else _MODES.get(value)
    if mode is None:
        raise InvalidParameterError(
            f"autoreset_mode must be an AutoresetMode (NEXT_STEP, SAME_STEP or DISABLED) or one "
            f"of their values {sorted(_MODES)}, got {value!r}")
    return mode


def seed_list(seed, num_envs: int) -> list[int] | None:
    """The episode-start seed of each sub-env for a vector env's ``reset(seed=)``: sub-env i
    gets s + i for an int s, or entry i of a list (array, tensor) of ``num_envs`` seeds, each
    checked by :func:`rbenv.satellite.draws.check_seed`; None for None."""
    if seed is None:
        return None
    if isinstance(seed, (list, tuple, np.ndarray)) or (hasattr(seed, "tolist")
                                                       and not np.isscalar(seed)):
        if len(seed) != num_envs:
            raise InvalidParameterError(
                f"seed list must have num_envs = {num_envs} entries, got {len(seed)}")
        return [check_seed(s.item() if hasattr(s, "item") else s, f"seed[{i}]")
                for i, s in enumerate(seed)]
    s = check_seed(seed)
    return [s + i for i in range(num_envs)]


def check_backend(backend) -> bool:
    """True for ``backend="torch"``, False for "numpy"; a named error for anything else."""
    if backend not in ("numpy", "torch"):
        raise InvalidParameterError(
            f"backend must be 'numpy' or 'torch', got {validation.show(backend)}")
    return backend == "torch"


def task_of(cls: type, task) -> TaskSpec:
    """The entry an env runs: ``task`` (a :class:`TaskSpec`) if given, else the class's
    ``task_spec`` (set by each shipped id's class); a named error if neither."""
    spec = cls.task_spec if task is None else task
    if not isinstance(spec, TaskSpec):
        raise InvalidParameterError(
            f"{cls.__name__} needs task=<a rbenv.tasks.TaskSpec>, got {validation.show(task)}; "
            "gym.make(env_id) passes it for a registered id")
    return spec


class TaskAdapter:
    """Mixin of the env classes (:class:`rbenv.envs.env.AttitudeEnv`,
    :class:`rbenv.envs.vector_env.AttitudeVectorEnv`, :class:`rbenv.envs.torch_env.TorchVectorEnv`).

    A shipped id's class names its entry in ``task_spec`` and carries its documentation; the
    generic classes take the entry as the ``task`` option (``gym.make`` passes it for an id
    registered without classes of its own).
    """

    task_spec: ClassVar[TaskSpec | None] = None

    def _setup(self, o: dict, render_modes) -> tuple[gym.Space, gym.Space]:
        """Build plant and task from ``o`` (the shell's options by name,
        :func:`rbenv.envs.options.take`) for its ``task`` (None: the class's entry); returns
        the single-satellite action and observation spaces."""
        render_mode = o["render_mode"]
        self.task_spec = task_of(type(self), o["task"])
        self.plant, self.task = build(self.task_spec,
                                      **{name: o[name] for name in options.ENV_OPTIONS})
        if render_mode is not None and render_mode not in render_modes:
            raise InvalidParameterError(
                f"render_mode must be None or one of {list(render_modes)}, got {render_mode!r}")
        self.render_mode = render_mode
        self.observation_structure = {**self.task.observation_structure,
                                      **self.plant.observation_structure}
        if self.plant.scene.estimator is not None:  # the filter's 1σ (rbenv.envs.estimated)
            self.observation_structure["estimate_sigma"] = 6
        self._layout = transition.layout(self.plant, self.task)
        self._block_slots = {"task": self.task.start_slots, **self.plant.block_slots}
        size = sum(self.observation_structure.values())
        return (gym.spaces.Box(-1.0, 1.0, self.plant.action_shape, np.float32),
                gym.spaces.Box(-1.0, 1.0, (size,), np.float32))

    def _episode_steps(self, max_episode_steps) -> int:
        """Steps per episode for a vector env: the scene's, or fewer (``max_episode_steps``)."""
        steps = self.plant.scene.episode_steps
        if max_episode_steps is not None:
            steps = min(steps, validation.count("max_episode_steps", max_episode_steps,
                                                high=2**31))
        return steps

    @property
    def scene(self):
        """The :class:`rbenv.Scene` in use (after option overrides)."""
        return self.plant.scene

    @property
    def config(self):
        """The :class:`rbenv.satellite.plant.Plant` (scene, action mode, torque authority)."""
        return self.plant

    def set_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None) -> None:
        """Change the task's initial-condition ranges for every later episode start
        (curriculum); episodes already running keep theirs. max_initial_angle_deg in
        [0, 180]; max_initial_rate in rad/s, below the rate limit; None keeps a value."""
        self.task = self.task.with_initial_ranges(max_initial_angle_deg, max_initial_rate)

    def _ready_renderer(self):
        """The renderer (made on first use), or None after warning when no render_mode."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to "
                            "gym.make or gym.make_vec")
            return None
        if self._st is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        if self._renderer is None:
            from rbenv.envs.rendering import Renderer

            self._renderer = Renderer.for_scene(self.plant.scene)
        return self._renderer

    def _frame(self, index: int | None = None):
        """One (H, W, 3) uint8 frame of the satellite (sub-env ``index`` of a batch)."""
        return self._renderer.frame(**transition.render_values(self.plant, self.task, self._st,
                                                               index))

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_renderer"] = None  # a pygame surface/window does not pickle; re-made lazily
        return state
