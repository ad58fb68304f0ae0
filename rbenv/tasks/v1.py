"""What the v1 tasks share: a continuous attitude observation, error features of order one at
the success thresholds, and a reward that pays completing the task, never hovering near it.

Each formula of the v1 observation and reward is written here once; the v1 task classes
(:class:`rbenv.tasks.reorient.ReorientV1`, ...) measure their errors exactly as v0 does and
hand them to these functions. The reasons (the v0 reward pays a policy for
staying inside the thresholds without finishing the hold; the canonical error quaternion
flips sign near 180° and its vector part is 0.009 at the 1° threshold).

**Observation features** (all in [-1, 1]):

* ``rot6(q_err)``: the first two columns of the error rotation matrix R(q_err), a continuous
  representation of SO(3) (Zhou et al. 2019; RANS v2 and Isaac Lab observe it);
* ``fine(v, |v|, v_s) = v / (v_s + |v|)``: a vector of length 1/2 at the success threshold
  v_s, 1 far away and 0 on the goal, with the direction of v (the attitude error as an
  axis-angle vector θ·axis, the body rate, the rate error): steep exactly where v0's features
  are flat.

**Reward** (per control step; ``ψ(x) = log(1 + x/x_s) / log(1 + x_max/x_s)``, 0 on the goal,
log 2 / log(1 + x_max/x_s) at the threshold x_s, 1 at x_max; its slope 1/(x_s + x) stays steep
down to the threshold): error ``−w·ψ(e)``; rate ``−w·ψ(|ω|)``; fuel ``−w·effort``; progress
``w·(ψ(e_prev) − ψ(e))`` (potential-based: it telescopes, so a path in and out of the goal
nets nothing); success ``+w`` once, on the step that completes the task; failure ``−w`` once,
on loss of control. Every per-step term but progress is ≤ 0, so a policy that hovers inside
the thresholds without completing earns at most the progress left, ``w_progress·ψ(e)`` <
``w_success`` (tests/rbenv/test_v1.py checks it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rbenv.tasks.base import Weights

_TINY = 1e-300


@dataclass(frozen=True)
class V1Weights(Weights):
    """v1 reward weights (see the module docstring; each a number ≥ 0, sign in the term).

    The fuel weight is reorientation's: PPO learned it with 1.0 on every seed tried (1.47 g
    against the PD's 1.36 g); 1.5 stalled at 0 % on one seed of three (1.41–1.43 g on the
    others), 2.0 on seed 0 (benchmarks/results/rl/v1). Success exceeds any progress a
    hovering policy can earn.
    """

    error: float = 0.1
    rate: float = 0.05
    fuel: float = 1.0
    progress: float = 10.0
    success: float = 20.0
    failure: float = 25.0


_TERMS = V1Weights.Terms  # looked up once: terms() runs every step


def log_scale(x, x_s: float, x_max: float, xp):
    """ψ(x) = log(1 + x/x_s) / log(1 + x_max/x_s): 0 at 0, 1 at x_max (x ≥ 0, any units)."""
    return xp.log1p(x * (1.0 / x_s)) * (1.0 / math.log1p(x_max / x_s))


def log_scale_drop(x_prev, x, x_s: float, x_max: float, xp):
    """ψ(x_prev) − ψ(x), written as log1p((x_prev − x)/(x_s + x))/log(1 + x_max/x_s) so that
    a small step is not the difference of two nearly equal logarithms (round-off)."""
    return xp.log1p((x_prev - x) / (x_s + x)) * (1.0 / math.log1p(x_max / x_s))


def terms(wt: V1Weights, drop, psi, psi_rate, effort, success, failure) -> tuple:
    """The reward terms (``V1Weights.Terms``) from the error's ψ drop over the step
    (:func:`log_scale_drop`) and ψ after it, the rate's ψ, the actuators' effort (fraction of
    full rate) and the success/failure flags of the step."""
    return tuple.__new__(_TERMS, (
        -wt.error * psi,
        -wt.rate * psi_rate,
        -wt.fuel * effort,
        wt.progress * drop,
        wt.success * success,
        -wt.failure * failure,
    ))


def fine(v: tuple, norm, v_s: float) -> tuple:
    """``v / (v_s + |v|)`` (3 components, length in [0, 1), 1/2 at |v| = v_s)."""
    s = 1.0 / (v_s + norm)
    return (v[0] * s, v[1] * s, v[2] * s)


def rot6(e: tuple) -> tuple:
    """First two columns of R(e) for a unit quaternion e = (w, x, y, z) (6 components)."""
    w, x, y, z = e
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y),
            2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x))


def axis_angle_fine(e: tuple, angle, angle_s: float, xp) -> tuple:
    """``fine`` of the axis-angle vector θ·axis of a canonical error quaternion e (w ≥ 0)
    whose angle is ``angle`` (rad): ``e_v·θ/(sin(θ/2)·(θ_s + θ))``."""
    f = angle / xp.maximum(xp.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), _TINY)
    return fine((e[1] * f, e[2] * f, e[3] * f), angle, angle_s)


def rate_features(w: tuple, inv_limit: float, rate_s: float, xp) -> tuple:
    """``ω/L`` clipped to [-1, 1] (3), then ``fine(ω, |ω|, ω_s)`` (3)."""
    clip = xp.clip
    norm = xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    return (clip(w[0] * inv_limit, -1.0, 1.0), clip(w[1] * inv_limit, -1.0, 1.0),
            clip(w[2] * inv_limit, -1.0, 1.0), *fine(w, norm, rate_s))


def matrix_from_rot6(r6: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from rot6 features (..., 6): Gram–Schmidt on the two
    columns, the third their cross product."""
    a = np.asarray(r6, dtype=float)
    c0 = a[..., 0:3] / np.linalg.norm(a[..., 0:3], axis=-1, keepdims=True)
    c1 = a[..., 3:6] - np.sum(c0 * a[..., 3:6], axis=-1, keepdims=True) * c0
    c1 = c1 / np.linalg.norm(c1, axis=-1, keepdims=True)
    return np.stack([c0, c1, np.cross(c0, c1)], axis=-1)


def quaternion_from_rot6(r6: np.ndarray) -> np.ndarray:
    """Canonical unit quaternions (..., 4) from rot6 features (..., 6), for decoding."""
    from rbenv.core.quaternion import from_matrix

    return from_matrix(matrix_from_rot6(r6))


class V1Decode:
    """Mixin of the v1 tasks that observe ``rot6_err``: :meth:`decode` adds the canonical
    error quaternion ``q_err`` (4) recovered from it, so the scripted controllers, which read
    ``q_err`` by name, drive v1 ids unchanged."""

    def decode(self, obs) -> dict:
        out = super().decode(obs)
        out["q_err"] = quaternion_from_rot6(out["rot6_err"])
        return out


def version_history(v0_id: str, extra: str = "") -> str:
    """The Version History paragraph of a v1 env docstring (Gymnasium's convention)."""
    return f"""**Version History**

    * v1: new observation and reward (:mod:`rbenv.tasks.v1`). The observation is
      continuous in the attitude (two rotation-matrix columns instead of a sign-flipped
      quaternion) and carries error features equal to 1/2 at the success thresholds; the
      reward pays success once, at completion, instead of every step inside the thresholds
      (v0 paid hovering: a final PPO model on detumble scored 1.7 %), its error term is
      steep down to the threshold, and fuel weighs more. Physics, starts, success and
      failure are {v0_id}'s, episode for episode.{extra}
    * v0: see ``{v0_id}``.
    """
