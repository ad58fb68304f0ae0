"""What every task is: the small interface between the plant and a Gymnasium env.

A task decides how an episode starts (relative to a target of its own), what the policy sees,
how it is rewarded, and when the episode succeeds or fails. It never integrates anything: the
plant (:mod:`rbenv.plant`) moves the satellite, and one transition function
(:mod:`rbenv.transition`) calls plant and task in the same order for the single env (floats)
and the vector env (arrays). This follows dm_control's split of an environment into physics and
task, written here as pure functions of explicit state, as Brax writes its ``step``.

A task class declares:

* ``name`` and its registered ``env_id``;
* ``observation_structure``: name → width, in observation order (Gymnasium MuJoCo's habit),
  and ``observation_scale``: name → the physical unit of one observation unit (e.g. the rate
  limit in rad/s), so controllers decode observations by name (:meth:`Task.decode`);
* ``Terms``: a NamedTuple of reward terms (``info["reward_<name>"]``; they sum to the reward);
* ``state_fields``: its per-episode state, name → :data:`rbenv.state` kind;
* ``reset_options``: the names accepted in ``reset(options=...)`` and their widths.

and implements :meth:`sample_start`, :meth:`complete_start`, :meth:`observe`,
:meth:`evaluate` and :meth:`info`, plus :meth:`advance_target` when the target moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from core import kernels as k
from core.errors import InvalidParameterError

_DEG = 180.0 / math.pi


@dataclass(frozen=True)
class Weights:
    """Base of every task's reward weights: each a finite number ≥ 0 (the sign is in the term).

    ``from_mapping`` takes a dict overriding the defaults; unknown names are errors.
    """

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            ok = isinstance(value, (int, float, np.integer, np.floating)) \
                and not isinstance(value, bool)
            if not ok or not math.isfinite(value) or not 0.0 <= value <= 1e6:
                raise InvalidParameterError(
                    f"reward_weights[{f.name!r}] must be a finite number in [0, 1e6], got "
                    f"{value!r}")
            object.__setattr__(self, f.name, float(value))

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
    env_id: ClassVar[str]
    observation_structure: ClassVar[dict]
    Terms: ClassVar[type]
    state_fields: ClassVar[dict]
    reset_options: ClassVar[dict] = {}
    OPTIONS: ClassVar[dict] = {}
    success_terminates: ClassVar[bool] = True
    WeightsType: ClassVar[type] = Weights

    plant: object  # rbenv.plant.Plant

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

    @property
    def rate_limit(self) -> float:
        """rad/s: |ω| above it is loss of control (terminated, not a success)."""
        return self.plant.scene.episode.rate_limit

    @property
    def success_rate(self) -> float:
        """rad/s: the rate (or rate error) below which the satellite counts as settled."""
        return self.plant.scene.episode.success_rate

    @property
    def success_angle(self) -> float:
        """rad: the attitude error below which the satellite counts as on target."""
        return math.radians(self.plant.scene.episode.success_angle_deg)

    @property
    def hold_steps(self) -> int:
        """Consecutive control steps inside the thresholds that make a success."""
        return self.plant.scene.hold_steps

    # ------------------------------------------------------------------- interface

    def sample_start(self, draws) -> dict:
        """Raw start values for ``draws.n`` episodes: "q" (N, 4), "omega_B" (N, 3) and the
        task's target fields; from the "task" stream of :class:`rbenv.draws.EpisodeDraws`."""
        raise NotImplementedError

    def complete_start(self, start: dict) -> None:
        """Add the derived state fields (errors, counters) to ``start`` (arrays, in place)."""
        raise NotImplementedError

    def observe(self, st, q, w, xp) -> tuple:
        """Observation components from the measured attitude ``q`` and rate ``w``."""
        raise NotImplementedError

    def evaluate(self, st, thrust_fraction, xp):
        """After a physics step: ``(terms, success, failure)``; updates the task's state."""
        raise NotImplementedError

    def info(self, st, xp) -> dict:
        """The task's info values (units in the key names)."""
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

    # ------------------------------------------------------------------- shared helpers

    def rate_info(self, st, xp) -> float:
        """|ω_B| in deg/s."""
        w = st.w
        return xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * _DEG


def option_table(scene, task_cls, task_options) -> dict:
    """A task's options: its class defaults, then the scene's ``[tasks.<name>]`` table, then
    ``task_options`` (a dict); unknown names are errors."""
    merged = dict(task_cls.OPTIONS)
    for where, table in ((f"scene [tasks.{task_cls.name}]", scene.tasks.get(task_cls.name)),
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


def restricted_haar_angle(u, max_angle: float):
    """Rotation angle of a Haar-uniform rotation conditioned on angle ≤ max_angle (rad).

    The Haar measure gives the angle the CDF ``(θ − sin θ)/π`` on [0, π]; this inverts it at
    ``u·(θm − sin θm)`` by bisection, for u a float or an array in [0, 1).
    """
    u = np.asarray(u, dtype=float)
    target = u * (max_angle - math.sin(max_angle))
    lo, hi = np.zeros_like(u), np.full_like(u, max_angle)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = mid - np.sin(mid) < target
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    out = 0.5 * (lo + hi)
    return float(out) if out.ndim == 0 else out


def unit_rows(normals: np.ndarray) -> np.ndarray:
    """Rows of ``normals`` (count, N) → (N, count) unit vectors (uniform directions)."""
    v = normals.T
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)


def rotate_rows(q: np.ndarray, v: np.ndarray, inverse: bool = False) -> np.ndarray:
    """(N, 4) quaternions applied to (N, 3) vectors (world←body, or body←world if inverse)."""
    comps = (k.rotate_inverse if inverse else k.rotate)(tuple(q.T), tuple(v.T))
    return np.stack(comps, axis=1)


def qmul_rows(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product of (N, 4) arrays."""
    return np.stack(k.qmul(tuple(p.T), tuple(q.T)), axis=1)


def exp_rows(v: np.ndarray) -> np.ndarray:
    """Row-wise exponential map of (N, 3) rotation vectors → (N, 4) unit quaternions."""
    return np.stack(k.exp(tuple(v.T)), axis=1)


def conj_rows(q: np.ndarray) -> np.ndarray:
    """Row-wise conjugate of (N, 4) quaternions."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])
