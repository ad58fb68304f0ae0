"""How far an evaluated policy is from the limit: its settle time and propellant as ratios to
per-episode lower bounds (:mod:`rbenv.agents.baselines.bounds`, derived in docs/bounds.md).

A ratio of 1 would be perfect and no policy goes below it. Which bounds hold where:

* reorientation with thrusters alone, no orbit torques: the settle time and propellant bounds
  of docs/bounds.md (the rate-based settle bound, the weighted-rate propellant bound);
* reorientation with any other actuators (wheels, rods, thrusters beside them), orbit torques
  included: the energy-rate settle bound
  (:func:`rbenv.agents.baselines.bounds.energy_settle_bound`), no
  propellant bound (wheels and rods spend none; thrusters beside them share the torque);
* detumbling, any actuators: the energy-rate settle bound; with thrusters alone and no orbit
  torques also the propellant bound (:func:`rbenv.agents.baselines.bounds.detumble_fuel_bound`);
* nowhere else (tracking, unloading, a randomized model, per-step disturbance noise, drag or
  solar pressure): :func:`episode_bounds` returns the reason, and the evaluation says it.

Per episode (successful episodes only; NaN otherwise):

* ``settle_ratio``: settle time / the earliest any policy can settle in that episode;
* ``fuel_ratio``: propellant / the least any successful policy must spend in that episode;
* ``fuel_ratio_own_time``: propellant / the least needed to settle as early as this policy did.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines import bounds as rb

from rbenv.satellite.scene import Scene

__all__ = ["EpisodeBounds", "episode_bounds", "ratios", "summary", "why_undefined"]


@dataclass(frozen=True, eq=False)
class EpisodeBounds:
    """Lower bounds of N seeded episodes. settle_s (N,) s: earliest settle (control-step
    time); fuel_kg (N,) kg or None: least propellant of any successful policy; fuel_at: the
    propellant bound at a given settle time ((N,) s → (N,) kg), or None; how: which bounds."""

    settle_s: np.ndarray
    fuel_kg: np.ndarray | None
    fuel_at: object
    how: str


def why_undefined(scene: Scene, task_table: str) -> str | None:
    """None when a settle bound holds for this task on this scene, else the reason in words."""
    if task_table not in ("reorient", "detumble"):
        return (f"the bounds cover reorientation and detumbling; task {task_table!r} has none "
                "yet (docs/bounds.md)")
    return rb.why_no_torque_limits(scene)


def _thrusters_alone(scene: Scene) -> bool:
    return sorted(scene.actuators) == ["thrusters"] and not scene.orbit.torques


def episode_bounds(episodes: int, seed: int, env_id: str,
                   env_kwargs: dict | None = None) -> EpisodeBounds | str:
    """The bounds of episodes ``seed + i`` (i < episodes) of ``env_id`` with these ``gym.make``
    options, or the reason there are none (a str). Cached for options that JSON can key (each
    policy of one evaluation meets the same episodes)."""
    try:
        key = json.dumps(env_kwargs or {}, sort_keys=True)
    except TypeError:  # a Scene object or another non-JSON option: computed afresh
        return _compute(episodes, seed, env_id, dict(env_kwargs or {}))
    return _cached(episodes, seed, env_id, key)


@lru_cache(maxsize=8)
def _cached(episodes: int, seed: int, env_id: str, kwargs_json: str):
    return _compute(episodes, seed, env_id, json.loads(kwargs_json))


def _compute(episodes: int, seed: int, env_id: str, kwargs: dict):
    env = gym.make(env_id, **kwargs)
    try:
        base = env.unwrapped
        scene, table = base.plant.scene, base.task.table_name()
    finally:
        env.close()
    reason = why_undefined(scene, table)
    if reason is not None:
        return reason
    start = rb.episode_starts(episodes, seed, env_id=env_id, **kwargs)
    angle = start["angle"] if table == "reorient" else None
    settle = rb.energy_settle_bound(rb.torque_limits(scene), start["omega_B"], angle,
                                    start["bias_B"])["sampled"]
    if not _thrusters_alone(scene):
        return EpisodeBounds(settle, None, None, f"{table}: energy-rate settle bound")
    lim = rb.scene_limits(scene)
    w0, bias = start["omega_B"], start["bias_B"]
    if angle is not None:
        settle = np.maximum(settle, rb.settle_time_bound(lim, angle, w0, bias)["sampled"])
        def fuel_at(t):
            return rb.fuel_bound(lim, angle, w0, bias, time_s=t)["kg"]
    else:
        def fuel_at(t):
            return rb.detumble_fuel_bound(lim, w0, bias, time_s=t)["kg"]
    return EpisodeBounds(settle, fuel_at(None), fuel_at,
                         f"{table}: settle and propellant bounds (thrusters alone)")


def ratios(success, settle_time_s, fuel_kg, bounds: EpisodeBounds) -> dict:
    """Per-episode ratios (see the module) of one policy's outcomes, arrays of length N; the
    propellant ratios only where a propellant bound holds."""
    ok = np.asarray(success, bool)
    settle = np.where(ok, settle_time_s, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = {"settle_ratio": np.where(bounds.settle_s > 0, settle / bounds.settle_s, np.nan)}
        if bounds.fuel_kg is None:
            return out
        fuel = np.where(ok, fuel_kg, np.nan)
        own = bounds.fuel_at(np.where(ok, settle, np.nanmax(bounds.settle_s)))
        out["fuel_ratio"] = np.where(bounds.fuel_kg > 0, fuel / bounds.fuel_kg, np.nan)
        out["fuel_ratio_own_time"] = np.where(own > 0, fuel / own, np.nan)
    return out


def summary(per_episode: dict, bounds: EpisodeBounds) -> dict:
    """The JSON form: each ratio's median and quartiles over the episodes that have one, the
    bounds' medians, and ``per_episode``: the bounds and each ratio episode by episode (null
    where an episode has none)."""
    def listed(x):
        return [None if not np.isfinite(v) else float(v) for v in np.asarray(x, float)]
    fuel = bounds.fuel_kg
    out = {"defined": True, "bounds": {
               "which": bounds.how,
               "settle_time_s_median": float(np.median(bounds.settle_s)),
               "fuel_kg_median": None if fuel is None else float(np.median(fuel))},
           "per_episode": {"settle_bound_s": listed(bounds.settle_s),
                           **({} if fuel is None else {"fuel_bound_kg": listed(fuel)}),
                           **{name: listed(v) for name, v in per_episode.items()}}}
    for name, values in per_episode.items():
        v = np.asarray(values, float)
        v = v[np.isfinite(v)]
        out[name] = ({"median": None, "p25": None, "p75": None, "n": 0} if not len(v) else
                     {"median": float(np.median(v)), "p25": float(np.percentile(v, 25)),
                      "p75": float(np.percentile(v, 75)), "n": len(v)})
    return out
