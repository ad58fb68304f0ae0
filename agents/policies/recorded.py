"""Recorded evaluations of baselines too slow to rerun in every report (the MPC).

``rbenv train``'s report puts the trained policy beside the task's scripted baselines on the
same seeded episodes. The MPC (:class:`rbenv.agents.baselines.mpc.ModelPredictive`) solves a
linear programme per satellite and control step: its 500 report episodes take minutes where
the training took a minute, and it needs the ``mpc`` extra. Its outcome on a seeded episode is
fixed, so its evaluation on the report's default episodes is recorded here once, per episode,
by ``python -m benchmarks.mpc_record``, and the report shows it, labelled as recorded, whenever
its episodes are exactly those: one of the record's env ids (they share their episodes), the
record's scene, seed and episode count, and no env option but reward weights (which change
neither the episodes nor what the MPC does). ``rbenv train --report-mpc`` evaluates it afresh
instead, on any scene. A test reruns the first episodes and compares them with the record.

A record is JSON (``records/<policy>-<scene>.json``): ``policy``, ``env_ids``,
``scene``, ``seed``, ``episodes``, ``command``, ``recorded`` (date and commit), and
``per_episode``: ``success`` (bool), ``settle_time_s`` (s, null when not successful),
``fuel_kg`` (kg), ``final_error_deg`` (deg), ``episode_time_s`` (s), each a list of
``episodes`` values.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rbenv.agents.policies.evaluate import EvalResult, with_optimality
from rbenv.core.errors import InvalidParameterError

RECORDS = Path(__file__).with_name("records")
PER_EPISODE = ("success", "settle_time_s", "fuel_kg", "final_error_deg", "episode_time_s")
# Env options that change neither an episode's initial state and dynamics nor the MPC's
# commands: a recorded evaluation stands for runs that set only these.
NEUTRAL_ENV_KWARGS = frozenset({"reward_weights"})


@dataclass(frozen=True)
class Recorded:
    """A recorded evaluation matched to a report: the result and the line that says so."""

    result: EvalResult
    note: str


def record_path(policy: str, scene: str) -> Path:
    """Where the record of ``policy`` on ``scene`` lives (the ids it stands for are inside)."""
    return RECORDS / f"{policy}-{scene}.json"


def read_record(path) -> dict:
    """A record, checked: a named error for a file that is not one (never executes it)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InvalidParameterError(f"recorded evaluation {path}: not readable JSON ({e})") \
            from None
    need = ("policy", "env_ids", "scene", "seed", "episodes", "command", "recorded",
            "per_episode")
    missing = [k for k in need if not isinstance(data, dict) or k not in data]
    if missing:
        raise InvalidParameterError(f"recorded evaluation {path}: missing {missing}")
    n = data["episodes"]
    for key in PER_EPISODE:
        values = data["per_episode"].get(key)
        if not isinstance(values, list) or len(values) != n:
            raise InvalidParameterError(
                f"recorded evaluation {path}: per_episode.{key} must be a list of {n} values "
                f"(episodes), got {type(values).__name__}"
                + (f" of {len(values)}" if isinstance(values, list) else ""))
    return data


def as_result(data: dict, env_kwargs: dict | None = None) -> EvalResult:
    """The record as an :class:`EvalResult` named ``"<policy> (recorded)"``, with its ratios to
    the lower bounds computed here, as for a live evaluation."""
    per = data["per_episode"]
    def floats(key):
        return np.array([math.nan if v is None else float(v) for v in per[key]])
    n = data["episodes"]
    result = EvalResult(
        policy=f"{data['policy']} (recorded)", scene=data["scene"], seed=int(data["seed"]),
        success=np.array(per["success"], dtype=bool), settle_time_s=floats("settle_time_s"),
        fuel_kg=floats("fuel_kg"), final_error_deg=floats("final_error_deg"),
        episode_time_s=floats("episode_time_s"), energy_J=np.full(n, math.nan))
    return with_optimality(result, data["env_ids"][0], dict(env_kwargs or {}))


def lookup(policy: str, env_id: str, scene, env_kwargs: dict, episodes: int,
           seed: int) -> Recorded | None:
    """The record of ``policy`` that stands for these report episodes exactly, or None (no
    record for the task and scene, another id, seed or count, or an env option that may
    change the episodes or the policy's commands)."""
    if not isinstance(scene, str) or set(env_kwargs or {}) - NEUTRAL_ENV_KWARGS:
        return None
    path = record_path(policy, scene)
    if not path.is_file():
        return None
    data = read_record(path)
    if (env_id not in data["env_ids"] or data["scene"] != scene or data["seed"] != seed
            or data["episodes"] != episodes):
        return None
    note = (f"{data['policy']} (recorded): these same {episodes} episodes, recorded "
            f"{data['recorded']} by `{data['command']}` (rbenv/agents/policies/records/"
            f"{path.name}), not rerun here; `--report-mpc` reruns it (the mpc extra; minutes).")
    return Recorded(as_result(data, env_kwargs), note)
