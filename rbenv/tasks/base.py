"""What every task is: the small interface between the plant and a Gymnasium env.

A task decides how an episode starts (relative to a target of its own), what the policy sees,
how it is rewarded, and when the episode succeeds or fails. It never integrates anything: the
plant (:mod:`rbenv.satellite.plant`) moves the satellite, and one transition function
(:mod:`rbenv.envs.transition`) calls plant and task in the same order for the single env (floats)
and the vector env (arrays). This follows dm_control's split of an environment into physics and
task, written here as pure functions of explicit state, as Brax writes its ``step``.

A task class declares:

* ``name`` (its registry entry, :mod:`rbenv.envs.registry`, holds the env id);
* ``observation_structure``: name → width, in observation order (Gymnasium MuJoCo's habit),
  and ``observation_scale``: name → the physical unit of one observation unit (e.g. the rate
  limit in rad/s), so controllers decode observations by name (:meth:`Task.decode`);
* ``WeightsType``: its reward weights, a frozen :class:`Weights` dataclass whose fields name
  the reward terms in order (``info["reward_<name>"]``; they sum to the reward); the terms
  type ``Terms`` (a namedtuple of the same names) is derived from it, never declared;
* ``state_fields``: its per-episode state, name → :data:`rbenv.satellite.state` kind;
* ``reset_options``: the names accepted in ``reset(options=...)`` and their widths;
* ``error_info_key``: the info entry that measures how far from the goal it is (reports).

and implements :meth:`sample_start`, :meth:`complete_start`, :meth:`observe`,
:meth:`evaluate` and :meth:`info`, plus :meth:`advance_target` when the target moves.
"""

from __future__ import annotations

import functools
import math
from collections import namedtuple
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError

_DEG = 180.0 / math.pi
MAX_WEIGHT = 1e6  # a reward weight above this only risks overflow in the return


@functools.cache
def terms_type(weights_cls: type) -> type:
    """The namedtuple of one step's reward terms of a :class:`Weights` dataclass: its field
    names, in field order (built once per class). A subclass that adds no field shares its
    parent's type; the type is reachable as ``weights_cls.Terms`` (so it pickles)."""
    names = tuple(f.name for f in fields(weights_cls))
    parent = weights_cls.__mro__[1]
    if parent is not Weights and issubclass(parent, Weights) \
            and tuple(f.name for f in fields(parent)) == names:
        return terms_type(parent)
    terms = namedtuple("Terms", names)
    terms.__module__ = weights_cls.__module__
    terms.__qualname__ = f"{weights_cls.__qualname__}.Terms"
    terms.__doc__ = (f"Reward terms of one step ({weights_cls.__name__}'s fields); they sum, "
                     "left to right, to the reward.")
    return terms


class _DerivedTerms:
    """Class attribute ``Terms`` of every :class:`Weights` subclass: :func:`terms_type`."""

    def __get__(self, instance, owner):
        return terms_type(owner)


@dataclass(frozen=True)
class Weights:
    """Base of every task's reward weights: each a finite number ≥ 0 (the sign is in the term).

    The fields are the task's reward terms, in order: ``Terms`` is the namedtuple of one
    step's terms with the same names (:func:`terms_type`). ``from_mapping`` takes a dict
    overriding the defaults; unknown names are errors.
    """

    Terms = _DerivedTerms()  # not a field: no annotation

    def __post_init__(self):
        for f in fields(self):
            value = validation.number(f"reward_weights[{f.name!r}]", getattr(self, f.name),
                                      low=0.0, high=MAX_WEIGHT)
            object.__setattr__(self, f.name, value)

    @classmethod
    def from_mapping(cls, mapping):
        """Defaults overridden by ``mapping`` (None: all defaults); unknown names are errors."""
        if mapping is None:
            return cls()
        if isinstance(mapping, cls):
            return mapping
        if not isinstance(mapping, dict):
            raise InvalidParameterError(
                f"reward_weights must be a dict of term -> weight, got {mapping!r}")
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(mapping) - set(names))
        if unknown:
            raise InvalidParameterError(
                f"reward_weights has unknown term(s) {unknown}; terms are {names}")
        return cls(**mapping)


@dataclass(frozen=True, eq=False)
class Task:
    """Base class of the tasks; subclasses are frozen dataclasses built by :func:`make_task`."""

    name: ClassVar[str]
    observation_structure: ClassVar[dict]
    Terms: ClassVar[type]  # WeightsType.Terms, set by __init_subclass__; never declared
    state_fields: ClassVar[dict]
    reset_options: ClassVar[dict] = {}
    OPTIONS: ClassVar[dict] = {}
    success_terminates: ClassVar[bool] = True
    error_info_key: ClassVar[str | None] = None  # the info key of its error measure (reports)
    moving_target: ClassVar[bool] = False  # advance_target is called every step
    start_slots: ClassVar[int] = 32  # slots of stream "task" that sample_start draws (a hint)
    WeightsType: ClassVar[type] = Weights
    scene_table: ClassVar[str | None] = None  # the scene's [tasks.<x>] table read (None: name)
    # True: the task closes an inner loop: :meth:`command` turns the policy's action into the
    # plant's every step (Desaturate-v1's wheel attitude hold); scripted baselines read it.
    inner_loop: ClassVar[bool] = False

    plant: object  # rbenv.satellite.plant.Plant

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "Terms" in cls.__dict__:
            raise TypeError(
                f"{cls.__name__} declares Terms; the reward terms are the fields of its "
                f"WeightsType ({cls.WeightsType.__name__}), from which Terms is derived")
        cls.Terms = cls.WeightsType.Terms

    @classmethod
    def table_name(cls) -> str:
        """The scene table ``[tasks.<x>]`` this task reads (a later version reads its v0's)."""
        return cls.scene_table or cls.name

    # ------------------------------------------------------------------- observation layout

    @classmethod
    def observation_size(cls) -> int:
        """Length of the observation vector."""
        return sum(cls.observation_structure.values())

    @classmethod
    def observation_slices(cls) -> dict:
        """name → slice into the observation, in order."""
        out, start = {}, 0
        for name, width in cls.observation_structure.items():
            out[name] = slice(start, start + width)
            start += width
        return out

    def observation_scale(self) -> dict:
        """name → physical value of one observation unit (1.0 for dimensionless entries)."""
        return {name: 1.0 for name in self.observation_structure}

    def decode(self, obs) -> dict:
        """Observation(s) (..., size) → name → float64 array in physical units (SI)."""
        obs = np.asarray(obs, dtype=float)
        scale = self.observation_scale()
        return {name: obs[..., s] * scale[name] for name, s in self.observation_slices().items()}

    # ------------------------------------------------------------------- thresholds
    # Read every step, so computed once here from the scene (frozen, like everything else).
    rate_limit: float = field(init=False)  # rad/s: |ω| above it is loss of control
    inv_rate_limit: float = field(init=False)  # s/rad
    success_rate: float = field(init=False)  # rad/s: settled below this rate (or rate error)
    success_angle: float = field(init=False)  # rad: on target below this error
    hold_steps: int = field(init=False)  # consecutive steps inside the thresholds for success
    reward_keys: tuple = field(init=False)  # "reward_<term>" info keys, in term order

    def __post_init__(self):
        scene = self.plant.scene
        ep = scene.episode
        for name, value in (("rate_limit", ep.rate_limit), ("inv_rate_limit", 1.0 / ep.rate_limit),
                            ("success_rate", ep.success_rate),
                            ("success_angle", math.radians(ep.success_angle_deg)),
                            ("hold_steps", scene.hold_steps),
                            ("reward_keys", tuple("reward_" + t for t in self.Terms._fields))):
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------------- interface

    def sample_start(self, draws) -> dict:
        """Raw start values (components, see :mod:`rbenv.satellite.state`): "q", "omega_B" and the
        task's target fields; from the "task" stream of
        :class:`rbenv.satellite.draws.EpisodeDraws`."""
        raise NotImplementedError

    def complete_start(self, start: dict, xp) -> None:
        """Add the derived state fields (errors, counters) to ``start`` (in place)."""
        raise NotImplementedError

    def observe(self, st, q, w, xp) -> tuple:
        """Observation components from the measured attitude ``q`` and rate ``w``."""
        raise NotImplementedError

    def evaluate(self, st, effort, xp):
        """After a physics step: ``(terms, success, failure)``; sets the task's own fields on
        ``st`` (the transition's new state). effort: the actuators' effort over the step, a
        fraction of their full rate (:class:`rbenv.satellite.actuators.Contribution`)."""
        raise NotImplementedError

    def info(self, st, xp) -> dict:
        """The task's info values (units in the key names)."""
        raise NotImplementedError

    def command(self, st, action, xp):
        """The plant's action for the policy's ``action`` at state ``st`` (only tasks with
        ``inner_loop``; a new array, ``action`` unchanged)."""
        raise NotImplementedError

    def advance_target(self, st) -> None:
        """Move the target over one control step (only tasks with a moving target)."""

    def target(self, st):
        """The target attitude (4 components) for rendering, or None (no target)."""
        return None

    def error_angle(self, st):
        """The attitude error (rad) for rendering, or None."""
        return None

    def with_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None):
        """The task with new initial-condition ranges (curriculum); None keeps a value."""
        raise InvalidParameterError(f"task {self.name!r} has no initial ranges to change")


def option_table(scene, task_cls, task_options) -> dict:
    """A task's options: its class defaults, then the scene's ``[tasks.<name>]`` table, then
    ``task_options`` (a dict); unknown names are errors."""
    merged = dict(task_cls.OPTIONS)
    table_name = task_cls.table_name()
    for where, table in ((f"scene [tasks.{table_name}]", scene.tasks.get(table_name)),
                         ("task_options", task_options)):
        if table is None:
            continue
        if not isinstance(table, dict):
            raise InvalidParameterError(f"{where} must be a dict of options, got {table!r}")
        unknown = sorted(set(table) - set(task_cls.OPTIONS))
        if unknown:
            raise InvalidParameterError(
                f"{where} has unknown option(s) {unknown}; {task_cls.name!r} takes "
                f"{sorted(task_cls.OPTIONS)}")
        merged.update(table)
    return merged


def error_quaternion(q_target_conj: tuple, q: tuple, xp) -> tuple[tuple, object]:
    """Canonical error ``q_err = q_target* ⊗ q`` (w ≥ 0) and its angle in [0, π] (rad).

    The vector part of q_err lies on the rotation axis, the same in body and target axes.
    """
    e = k.qmul(q_target_conj, q)
    s = xp.sign_nonneg(e[0])
    e = (s * e[0], s * e[1], s * e[2], s * e[3])
    return e, 2.0 * xp.atan2(xp.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), e[0])


def restricted_haar_angle(u, max_angle: float, xp=None):
    """Rotation angle of a Haar-uniform rotation conditioned on angle ≤ max_angle (rad).

    The Haar measure gives the angle the CDF ``(θ − sin θ)/π`` on [0, π]; this solves
    ``θ − sin θ = u·(θm − sin θm)`` for u in [0, 1) (a float or an array; ``xp`` its
    namespace) by Newton's method from ``∛(6t)``, which lies left of the root because
    ``θ − sin θ ≤ θ³/6``; the function is convex, so the iterates converge monotonically
    after the first step (clipped to [0, θm]).
    """
    if xp is None:
        from rbenv.core.backend import namespace

        xp = namespace(u)
    t = u * (max_angle - math.sin(max_angle))
    theta = xp.minimum(xp.power(6.0 * t, 1.0 / 3.0), max_angle)
    for _ in range(12):
        slope = xp.maximum(1.0 - xp.cos(theta), 1e-300)
        theta = xp.clip(theta - (theta - xp.sin(theta) - t) / slope, 0.0, max_angle)
    return theta


def unit(v: tuple, xp) -> tuple:
    """A 3-vector of components scaled to unit length (uniform direction from normals)."""
    inv = 1.0 / xp.maximum(xp.sqrt(k.dot(v, v)), 1e-300)
    return k.scale(v, inv)


def conj(q: tuple) -> tuple:
    """Conjugate of a quaternion given as 4 components."""
    return (q[0], -q[1], -q[2], -q[3])
