"""How far an evaluated policy is from the limit: its settle time and propellant as ratios to
per-episode lower bounds (:mod:`rbenv.envs.bounds`, derived in docs/bounds.md).

A ratio of 1 would be perfect and no policy goes below it. The bounds hold for thruster
reorientation on a scene whose torques the bounds know: thrusters alone, the nominal model (no
domain randomization), no per-step disturbance noise and no orbit torques. Anywhere else
:func:`episode_bounds` returns the reason none is defined, and the evaluation says it.

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

from rbenv.envs import bounds as rb
from rbenv.satellite.scene import Scene

__all__ = ["EpisodeBounds", "episode_bounds", "ratios", "summary", "why_undefined"]


@dataclass(frozen=True, eq=False)
class EpisodeBounds:
    """Lower bounds of N seeded episodes. settle_s (N,) s: earliest settle (control-step
    time); fuel_kg (N,) kg: least propellant of any successful policy; the starts (angle (N,)
    rad, omega_B (N, 3) rad/s, bias_B (N, 3) N·m) and the scene's limits, for the bound at a
    policy's own settle time."""

    settle_s: np.ndarray
    fuel_kg: np.ndarray
    angle: np.ndarray
    omega_B: np.ndarray
    bias_B: np.ndarray
    limits: rb.SceneLimits


def why_undefined(scene: Scene, task_table: str) -> str | None:
    """None when the bounds hold for this task on this scene, else the reason in words."""
    if task_table != "reorient":
        return (f"the bounds cover reorientation; task {task_table!r} has none yet "
                "(docs/bounds.md)")
    kinds = sorted(scene.actuators)
    if kinds != ["thrusters"]:
        return (f"the bounds cover thrusters alone; scene {scene.name!r} has {kinds} "
                "(docs/bounds.md)")
    if scene.orbit.enabled:
        return f"scene {scene.name!r} has orbit torques, which the bounds do not account for"
    if scene.randomization.enabled:
        return f"scene {scene.name!r} randomizes the model; the bounds need the nominal one"
    if scene.disturbance.model == "random" and scene.disturbance.noise_sigma > 0.0:
        return f"scene {scene.name!r} has per-step disturbance noise, which no bound covers"
    return None


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
    limits = rb.scene_limits(scene)
    starts = rb.episode_starts(episodes, seed, env_id=env_id, **kwargs)
    settle = rb.settle_time_bound(limits, starts["angle"], starts["omega_B"],
                                  starts["bias_B"])["sampled"]
    fuel = rb.fuel_bound(limits, starts["angle"], starts["omega_B"], starts["bias_B"])["kg"]
    return EpisodeBounds(settle_s=settle, fuel_kg=fuel, angle=starts["angle"],
                         omega_B=starts["omega_B"], bias_B=starts["bias_B"], limits=limits)


def ratios(success, settle_time_s, fuel_kg, bounds: EpisodeBounds) -> dict:
    """Per-episode ratios (see the module) of one policy's outcomes, arrays of length N."""
    ok = np.asarray(success, bool)
    settle = np.where(ok, settle_time_s, np.nan)
    fuel = np.where(ok, fuel_kg, np.nan)
    lim = bounds.limits
    own = rb.fuel_bound(lim, bounds.angle, bounds.omega_B, bounds.bias_B,
                        time_s=np.where(ok, settle, lim.settle_time_max))["kg"]
    with np.errstate(divide="ignore", invalid="ignore"):
        return {"settle_ratio": settle / bounds.settle_s,
                "fuel_ratio": np.where(bounds.fuel_kg > 0, fuel / bounds.fuel_kg, np.nan),
                "fuel_ratio_own_time": np.where(own > 0, fuel / own, np.nan)}


def summary(per_episode: dict, bounds: EpisodeBounds) -> dict:
    """The JSON form: each ratio's median and quartiles over the episodes that have one, the
    bounds' medians, and ``per_episode``: the bounds and each ratio episode by episode (null
    where an episode has none)."""
    def listed(x):
        return [None if not np.isfinite(v) else float(v) for v in np.asarray(x, float)]
    out = {"defined": True,
           "bounds": {"settle_time_s_median": float(np.median(bounds.settle_s)),
                      "fuel_kg_median": float(np.median(bounds.fuel_kg))},
           "per_episode": {"settle_bound_s": listed(bounds.settle_s),
                           "fuel_bound_kg": listed(bounds.fuel_kg),
                           **{name: listed(v) for name, v in per_episode.items()}}}
    for name, values in per_episode.items():
        v = np.asarray(values, float)
        v = v[np.isfinite(v)]
        out[name] = ({"median": None, "p25": None, "p75": None, "n": 0} if not len(v) else
                     {"median": float(np.median(v)), "p25": float(np.percentile(v, 25)),
                      "p75": float(np.percentile(v, 75)), "n": len(v)})
    return out
