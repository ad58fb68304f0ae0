"""The one transition of every rbenv env: (plant, task, state, action, draws) → outcome.

Both Gymnasium adapters call these functions, the single env with Python floats and the vector
env with (N,) arrays (``xp`` is the :mod:`rbenv.core.backend` namespace of the state):

* :func:`start` builds episode starts for the envs being reset from their counter-based draws
  (:mod:`rbenv.satellite.draws`) and the reset options;
* :func:`step` applies an action and returns ``(new_state, outcome)``: actuation, physics,
  target motion, task evaluation, observation and info, in that order. It never changes the
  state it is given, and it does not raise on divergence: ``outcome.diverged`` flags the
  satellites whose state left float64, and the adapters raise (:func:`raise_diverged`);
* :func:`observe` and :func:`info` give the observation components and the info dict.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.actuators.base import nan_action_error, one_row
from rbenv.satellite.plant import Plant, StepNoise
from rbenv.satellite.state import Layout
from rbenv.tasks.base import _DEG, error_quaternion

__all__ = ["Outcome", "info", "layout", "observe", "raise_diverged", "start", "step"]

MAX_RESET_RATE = 1e6  # rad/s: |ω_B| allowed in reset options (squares stay far from overflow)


class Outcome(NamedTuple):
    """What one step returns besides the new state: observation components, reward, its terms
    (the task's NamedTuple), success and failure flags, the info dict, ``diverged`` (bool, or
    (N,) bool: the state left float64; the other fields are then None), and Gymnasium's
    ``terminated`` (failure, or success where the task ends on it) and ``truncated`` (the
    episode's step limit reached)."""

    obs: tuple
    reward: object
    terms: tuple
    success: object
    failure: object
    info: dict
    diverged: object
    terminated: object
    truncated: object


def layout(plant: Plant, task) -> Layout:
    """The state layout of the plant, its actuators and ``task`` (a name clash raises)."""
    return Layout((*plant.state_parts, (f"task {task.name!r}", task.state_fields)))


def step(plant: Plant, task, st, action: np.ndarray, noise: StepNoise, xp,
         own_action: bool = False, donate: bool = False, max_steps: int | None = None,
         observe_truth: bool = True) -> tuple:
    """``(new_state, outcome)`` after one control step of ``st`` under ``action`` (float64 or
    float32, validated shape; the actuators' commands clip it into float64 arrays or floats).
    ``st`` is not changed, unless donated. max_steps: the episode's step limit (``truncated``);
    None: the scene's duration.

    own_action: the caller made ``action`` for this call, so it may be clipped in place.
    donate: the caller gives ``st`` up (it keeps only the new state), so the step updates it
    and returns it instead of a copy (JAX's buffer donation; the single env does this).
    observe_truth: False when the caller observes something else (the estimator's loop,
    rbenv.envs.estimated): the outcome's ``obs`` is None and the task's observation is skipped
    (it draws nothing and changes no state).
    """
    new = st if donate else st.copy()
    if task.inner_loop:  # the task's inner loop makes the plant's action (Desaturate-v1)
        action = task.command(new, action, xp)
    contribution = plant.actuate(new, action, noise, xp, in_place=own_action)
    diverged = plant.advance(new, contribution, noise.disturbance, xp)
    if diverged if type(diverged) is bool else xp.any(diverged):  # the adapter raises
        return new, tuple.__new__(Outcome, (None, None, None, None, None, None, diverged,
                                            None, None))
    if plant.sensors is not None:
        plant.sense(new, noise)
    if task.moving_target:
        task.advance_target(new)
    terms, success, failure = task.evaluate(new, contribution.effort, xp)
    obs = None if not observe_truth else task.observe(new, new.q, new.omega_B, xp) \
        if noise.sensor is None and not plant.observers and plant.sensors is None else \
        observe(plant, task, new, noise.sensor, xp)
    reward = sum(terms[1:], terms[0])  # left to right: one order for floats and arrays
    terminated = failure | (success & task.success_terminates)
    truncated = new.steps >= (plant.scene.episode_steps if max_steps is None else max_steps)
    return new, tuple.__new__(Outcome, (obs, reward, terms, success, failure,
                                        info(plant, task, new, terms, success, xp), diverged,
                                        terminated, truncated))


def raise_diverged(plant: Plant, st, action) -> None:
    """Raise for a diverged step: the named NaN-action error when ``action`` holds NaN (throttle
    mode lets it through to the thrust), else the plant's :class:`NonFiniteError`."""
    if np.isnan(np.asarray(action, dtype=float)).any():
        raise nan_action_error(action)
    raise plant.divergence_error(st.q, st.omega_B)


def observe(plant: Plant, task, st, sensor_noise, xp) -> tuple:
    """Observation components; with sensor noise, from the noisy measurement; with sensors
    as flown, from what they show (rbenv.satellite.sensing)."""
    if plant.sensors is not None:
        obs = task.observe(st, st.sensed_q, st.sensed_omega_B, xp)
    elif sensor_noise is None:
        obs = task.observe(st, st.q, st.omega_B, xp)
    else:
        q, w = plant.measure(st, sensor_noise)
        obs = task.observe(st, q, w, xp)
    return obs + plant.observe(st, xp, sensor_noise) if plant.observers else obs


def info(plant: Plant, task, st, terms, success, xp) -> dict:
    """The info dict: the task's values, the actuators' bookkeeping, the time, success and the
    reward terms (and the speed with translation)."""
    out = task.info(st, xp)
    for act in plant.actuators:
        act.info(st, xp, out)
    if plant.sensors is not None and getattr(st, "q_target_conj", None) is not None:
        # The attitude error the satellite believes (what its telemetry would log), degrees.
        out["sensed_attitude_error_deg"] = error_quaternion(st.q_target_conj, st.sensed_q,
                                                            xp)[1] * _DEG
    out["time_s"] = st.steps * plant.control_dt
    if plant.eclipse_known:
        out["eclipse"] = plant.eclipse(st, xp)
    out["is_success"] = success
    out.update(zip(task.reward_keys, terms))  # noqa: B905 (same length by construction)
    if st.x is not None:
        v = st.v
        out["speed_mps"] = xp.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return out


def render_values(plant: Plant, task, st, index: int | None = None) -> dict:
    """Keyword arguments of :meth:`rbenv.envs.rendering.Renderer.frame` for one satellite.

    index: the sub-env of a batch state, or None for a single env's state.
    """
    def pick(c):
        return float(c if index is None else c[index])

    target = task.target(st)
    angle = task.error_angle(st)
    out = {"q": one_row(st.q, index),
           "q_target": None if target is None else one_row(target, index),
           "error_deg": float(np.degrees(pick(angle))) if angle is not None else 0.0,
           "rate_dps": float(np.degrees(np.linalg.norm(one_row(st.omega_B, index)))),
           "time_s": pick(st.steps) * plant.control_dt}
    for act in plant.actuators:  # what each draws: plumes, discs, an arrow
        out.update(act.render_values(st, index))
    return out


def zero_terms(task, value=0.0) -> tuple:
    """The task's reward terms, all ``value`` (the reset info)."""
    return task.Terms(*([value] * len(task.Terms._fields)))


# --------------------------------------------------------------------------- episode start


def start(plant: Plant, task, draws, options=None, rows=None, num_envs=None) -> dict:
    """Start values (see :mod:`rbenv.satellite.state`) of new episodes for the ``draws.n`` envs.

    options: the reset options (names in ``task.reset_options`` and ``plant.reset_options``);
    for the vector env their leading axis is ``num_envs`` and ``rows`` selects the rows of the
    envs being reset.
    """
    s = task.sample_start(draws)
    if options:
        _check_option_names(options, {**task.reset_options, **plant.reset_options})
    _override(task.reset_options, s, options, rows, draws, num_envs)
    s.update(plant.sample_start(draws))
    if plant.reset_options:
        _override(plant.reset_options, s, options, rows, draws, num_envs)
        plant.check_start(s)
    task.complete_start(s, draws.xp)
    plant.complete_start(s, draws.xp)
    return s


def _check_option_names(options, allowed: dict) -> None:
    """Refuse reset options that are not a dict or name an unknown key."""
    if not isinstance(options, dict):
        raise InvalidParameterError(
            f"reset options must be a dict of name -> value, got {validation.show(options)}")
    unknown = sorted(set(options) - set(allowed) - {"reset_mask"})
    if unknown:
        raise InvalidParameterError(
            f"reset options has unknown key(s) {unknown}; allowed: {sorted(allowed)}")


def _override(allowed: dict, s: dict, options, rows, draws, num_envs=None) -> None:
    """Replace sampled start values by the reset options named in ``allowed`` (name → width;
    validated, named in errors). Names starting with "q" are quaternions."""
    if not options:
        return
    for key, width in allowed.items():
        if key not in options:
            continue
        name = f"reset options[{key!r}]"
        arr = validation.finite_array(name, options[key])
        if rows is not None:  # one row per sub-env, num_envs of them
            if arr.shape != (num_envs, width):
                raise InvalidParameterError(
                    f"{name} must have shape (num_envs, {width}) = {(num_envs, width)}, one "
                    f"row per sub-env, got {arr.shape}")
            arr = arr[rows]
        elif arr.shape != (width,):
            raise InvalidParameterError(f"{name} must have shape {(width,)}, got {arr.shape}")
        arr = np.broadcast_to(arr, (draws.n, width))
        if key.startswith("q"):
            arr = validation.unit_quaternion(name, arr)
            arr = arr / np.linalg.norm(arr, axis=-1, keepdims=True)
        elif np.linalg.norm(arr, axis=-1).max(initial=0.0) > MAX_RESET_RATE:
            raise InvalidParameterError(
                f"{name} must have |ω| <= {MAX_RESET_RATE:g} rad/s, got {arr.tolist()}")
        s[key] = draws.components(np.array(arr, dtype=float).T)
