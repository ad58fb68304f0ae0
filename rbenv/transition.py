"""The one transition of every rbenv env: (plant, task, state, action, draws) → outcome.

Both Gymnasium adapters call these functions, the single env with Python floats and the vector
env with (N,) arrays (``xp`` is the :mod:`core.backend` namespace of the state):

* :func:`start` builds episode starts for the envs being reset from their counter-based draws
  (:mod:`rbenv.draws`) and the reset options;
* :func:`step` applies an action: plant actuation, physics, target motion, task evaluation,
  observation and info, in that order;
* :func:`observe` and :func:`info` give the observation components and the info dict.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core import validation
from core.errors import InvalidParameterError, NonFiniteError
from rbenv.plant import STATE_FIELDS, Plant, StepNoise, nan_action_error

__all__ = ["Outcome", "info", "observe", "start", "state_kinds", "step"]

MAX_RESET_RATE = 1e6  # rad/s: |ω_B| allowed in reset options (squares stay far from overflow)


class Outcome(NamedTuple):
    """What one step returns: observation components, reward, its terms (the task's
    NamedTuple), success and failure flags, and the info dict."""

    obs: tuple
    reward: object
    terms: tuple
    success: object
    failure: object
    info: dict


def state_kinds(task) -> dict:
    """Field name → storage kind for the plant and ``task`` together."""
    return {**STATE_FIELDS, **task.state_fields}


def step(plant: Plant, task, st, action: np.ndarray, noise: StepNoise, xp,
         own_action: bool = False) -> Outcome:
    """Advance ``st`` by one control step under ``action`` (float64, validated shape).

    own_action: the caller made ``action`` for this call, so it may be clipped in place.
    """
    u = plant.throttle(action, in_place=own_action)
    if st.health is not None or st.pending is not None:
        u = plant.apply_faults_and_delay(st, u, noise.faults)
    st.throttle = u
    wrench = plant.wrench(st, u, xp)
    try:
        plant.advance_state(st, wrench, noise.disturbance, xp)
    except NonFiniteError:
        # A NaN action (throttle mode lets it through to the thrust) is the caller's error.
        if np.isnan(np.asarray(action, dtype=float)).any():
            raise nan_action_error(action) from None
        raise
    if task.moving_target:
        task.advance_target(st)
    terms, success, failure = task.evaluate(st, wrench.thrust_N * plant.inv_total_thrust, xp)
    obs = task.observe(st, st.q, st.w, xp) if noise.sensor is None else \
        observe(plant, task, st, noise.sensor, xp)
    return tuple.__new__(Outcome, (obs, sum(terms), terms, success, failure,
                                   info(plant, task, st, terms, success, xp)))


def observe(plant: Plant, task, st, sensor_noise, xp) -> tuple:
    """Observation components; with sensor noise, from the noisy measurement."""
    if sensor_noise is None:
        return task.observe(st, st.q, st.w, xp)
    q, w = plant.measure(st, sensor_noise)
    return task.observe(st, q, w, xp)


def info(plant: Plant, task, st, terms, success, xp) -> dict:
    """The info dict: the task's values, plant bookkeeping, success and the reward terms."""
    out = task.info(st, xp)
    out["fuel_kg"] = st.fuel_kg
    out["impulse_Ns"] = st.impulse_Ns
    out["time_s"] = st.steps * plant.control_dt
    out["is_success"] = success
    out.update(zip(task.reward_keys, terms))  # noqa: B905 (same length by construction)
    if st.x is not None:
        v = st.v
        out["speed_mps"] = xp.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if st.health is not None:
        out["failed_thrusters"] = plant.n - st.health.sum(axis=-1)
    return out


def render_values(plant: Plant, task, st, index: int | None = None) -> dict:
    """Keyword arguments of :meth:`rbenv.rendering.Renderer.frame` for one satellite.

    index: the sub-env of a batch state, or None for a single env's state.
    """
    def pick(c):
        return float(c if index is None else c[index])

    q = np.array([pick(c) for c in st.q])
    target = task.target(st)
    w = np.array([pick(c) for c in st.w])
    throttle = st.throttle if index is None else st.throttle[index]
    angle = task.error_angle(st)
    return {"q": q, "q_target": None if target is None else np.array([pick(c) for c in target]),
            "throttle": np.asarray(throttle, dtype=float),
            "error_deg": float(np.degrees(pick(angle))) if angle is not None else 0.0,
            "rate_dps": float(np.degrees(np.linalg.norm(w))),
            "time_s": pick(st.steps) * plant.control_dt}


def zero_terms(task, value=0.0) -> tuple:
    """The task's reward terms, all ``value`` (the reset info)."""
    return task.Terms(*([value] * len(task.Terms._fields)))


# --------------------------------------------------------------------------- episode start


def start(plant: Plant, task, draws, options=None, rows=None) -> dict:
    """Start values (see :mod:`rbenv.state`) of new episodes for the ``draws.n`` envs.

    options: the reset options (names in ``task.reset_options``); for the vector env their
    leading axis is num_envs and ``rows`` selects the rows of the envs being reset.
    """
    xp, m = draws.xp, draws.n
    s = task.sample_start(draws)
    _override(task, s, options, rows, draws)
    s.update(plant.sample_start(draws))
    task.complete_start(s, xp)
    zero = xp.zeros(m)
    s.update(w=s.pop("omega_B"), fuel_kg=zero, impulse_Ns=zero, steps=zero,
             throttle=np.zeros((m, plant.n)))
    if plant.translation:
        s["x"] = s["v"] = (zero, zero, zero)
    rnd = plant.randomization
    if rnd is not None and rnd.delay_probability > 0.0:
        s["pending"] = np.zeros((m, plant.n))
    return s


def _override(task, s: dict, options, rows, draws) -> None:
    """Replace sampled start values by reset options (validated, named in errors)."""
    if not options:
        return
    if not isinstance(options, dict):
        raise InvalidParameterError(
            f"reset options must be a dict of name -> value, got {validation.show(options)}")
    allowed = task.reset_options
    unknown = sorted(set(options) - set(allowed) - {"reset_mask"})
    if unknown:
        raise InvalidParameterError(
            f"reset options has unknown key(s) {unknown}; allowed: {sorted(allowed)}")
    for key, width in allowed.items():
        if key not in options:
            continue
        name = f"reset options[{key!r}]"
        arr = validation.finite_array(name, options[key])
        shape = (width,) if rows is None else ("num_envs", width)
        if rows is not None:
            if arr.ndim != 2 or arr.shape[1] != width:
                raise InvalidParameterError(f"{name} must have shape {shape}, got {arr.shape}")
            arr = arr[rows]
        elif arr.shape != (width,):
            raise InvalidParameterError(f"{name} must have shape {shape}, got {arr.shape}")
        arr = np.broadcast_to(arr, (draws.n, width))
        if width == 4:
            arr = validation.unit_quaternion(name, arr)
            arr = arr / np.linalg.norm(arr, axis=-1, keepdims=True)
        elif np.linalg.norm(arr, axis=-1).max(initial=0.0) > MAX_RESET_RATE:
            raise InvalidParameterError(
                f"{name} must have |ω| <= {MAX_RESET_RATE:g} rad/s, got {arr.tolist()}")
        s[key] = draws.components(np.array(arr, dtype=float).T)
