"""Replay: fly a policy closed loop from each logged start, and compare with the flight.

For every sub-maneuver of the telemetry (:mod:`rbenv.agents.flight.telemetry`) one env starts
from the logged first sample: attitude error ``q`` (target-relative, so ``q_target`` is the
identity), body rate ``omega_B`` and wheel speeds ``wheel_speed``; the wheels are past their
start-up delay (``wheel_clock_s``) when a command was logged earlier in the folder. All
sub-maneuvers fly side by side in one vector env for as long as the longest; each is compared
with its log at the logged time stamps.

The scene's wheels must be laid out so that the logged speed (rpm) is the state's
``wheel_speed`` (rad/s relative to the body, along each wheel's axis): innocube-3u's axes are
−x, −y, −z for that reason.

Metrics (each on the error at the logged time stamps, deg, the rotation angle of the
target-relative quaternion): ``steady_deg`` its mean over the last 20 s; ``settle_1deg_s`` the
first time after which it stays below 1° to the end (None if it ends above); the difference
``|error(rbenv) − error(flight)|`` over every logged sample. The flight logs its on-board
estimate, so the simulated error is the sensed one where the scene has sensors as flown
(``info["sensed_attitude_error_deg"]``), else the true one; the body rates likewise.

A sub-maneuver whose logged commands are all zero (or absent) was flown by no controller: the
flight computer had switched it off and the satellite drifted. Flying the policy there would
compare a slew with a drift, so such a piece is replayed open loop with its logged commands
(all zero: no wheel acceleration and no rod dipole), marked ``"mode": "open_loop"``, and left
out of the summary, which compares the policy with the flight on the closed-loop pieces only;
``summary["open_loop"]`` gives the drift pieces' count and median difference.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents.flight.telemetry import SubManeuver, load
from rbenv.agents.policies.evaluate import make_policy, scripted
from rbenv.agents.policies.load import load_policy

from rbenv.satellite.scene import Scene, load_scene

STEADY_WINDOW_S = 20.0  # s: steady error is the mean over the sub-maneuver's last 20 s
SETTLE_DEG = 1.0
_RPM = math.pi / 30.0  # rad/s per rpm
DEFAULT_ENV_KWARGS = {"action_mode": "acceleration"}  # the flight commands wheel accelerations
DEFAULT_ENV_ID = "rbenv/SatelliteReorient-v1"  # reorientation (v0 and v1 fly the same)
WHEEL_CLOCK_PAST_DELAY_S = 1e3  # s since the first command: past any start-up delay
SENSED_ERROR = "sensed_attitude_error_deg"  # info key of scenes with sensors as flown
CLOSED_LOOP, OPEN_LOOP = "closed_loop", "open_loop"  # how a sub-maneuver is replayed


@dataclass(frozen=True)
class ManeuverReplay:
    """One sub-maneuver: its log and rbenv's error at the logged time stamps (deg, NaN after
    the simulated episode ended early, e.g. on loss of control)."""

    maneuver: SubManeuver
    folder: str
    flight_deg: np.ndarray
    sim_deg: np.ndarray

    @property
    def mode(self) -> str:
        """:data:`OPEN_LOOP` where the flight controller was off, else :data:`CLOSED_LOOP`."""
        return OPEN_LOOP if self.maneuver.controller_off else CLOSED_LOOP

    def record(self) -> dict:
        diff = np.abs(self.sim_deg - self.flight_deg)
        m = self.maneuver
        return {"folder": self.folder, "index": m.index, "t0": m.t0,
                "duration_s": m.duration_s, "mode": self.mode,
                "median_abs_error_diff_deg": _median(diff),
                "flight": metrics(m.time_s, self.flight_deg),
                "sim": metrics(m.time_s, self.sim_deg)}


def metrics(time_s: np.ndarray, error_deg: np.ndarray) -> dict:
    """``{"settle_1deg_s", "steady_deg"}`` of an error trace at times ``time_s`` (s from the
    sub-maneuver's start)."""
    end = time_s[-1]
    last = (time_s >= end - STEADY_WINDOW_S) & np.isfinite(error_deg)
    steady = float(np.mean(error_deg[last])) if last.any() else None
    above = np.flatnonzero(~(error_deg < SETTLE_DEG))  # NaN counts as not settled
    if len(above) == 0:
        settle = float(time_s[0])
    elif above[-1] == len(error_deg) - 1:
        settle = None
    else:
        settle = float(time_s[above[-1] + 1])
    return {"settle_1deg_s": settle, "steady_deg": steady}


def replay(root, scene, policy, *, env_id: str | None = None, env_kwargs: dict | None = None,
           seed: int = 0, trust_pickle: bool = False) -> dict:
    """The replay of ``policy`` (a baseline name, a run folder or an object with ``predict``)
    in ``scene`` (name, .toml path or Scene) from every sub-maneuver under ``root``: the JSON
    record (see the module; ``"replays"`` holds the :class:`ManeuverReplay` objects and is
    left out of the JSON)."""
    maneuvers = load(root)
    label = policy if isinstance(policy, str) else type(policy).__name__
    kwargs = dict(DEFAULT_ENV_KWARGS)
    if isinstance(policy, str) and policy not in scripted() and Path(policy).exists():
        policy = load_policy(policy, trust_pickle=trust_pickle)
        # The run's env options (its action mode) fly it; the scene is the one replayed in.
        kwargs.update({k: v for k, v in policy.env_kwargs.items() if k != "scene"})
        env_id = env_id or policy.env_id
    kwargs.update(env_kwargs or {})
    env_id = env_id or DEFAULT_ENV_ID
    sim = simulate(maneuvers, scene, policy, env_id=env_id, env_kwargs=kwargs, seed=seed)
    replays = [ManeuverReplay(m, _folder_name(m.folder, root), m.error_deg, s["error_deg"])
               for m, s in zip(maneuvers, sim, strict=True)]
    records = [r.record() for r in replays]
    scene_name = scene.name if isinstance(scene, Scene) else load_scene(scene).name
    return {"scene": scene_name, "policy": str(label), "maneuvers": records,
            "summary": summary(replays, records), "replays": replays}


def summary(replays: list[ManeuverReplay], records: list[dict]) -> dict:
    """The policy against the flight over the closed-loop sub-maneuvers, and ``"open_loop"``:
    the count and median |difference| of the pieces no controller flew (None if none)."""
    closed = [i for i, r in enumerate(replays) if r.mode == CLOSED_LOOP]
    drift = [r for r in replays if r.mode == OPEN_LOOP]
    flight = np.concatenate([replays[i].flight_deg for i in closed] or [np.zeros(0)])
    sim = np.concatenate([replays[i].sim_deg for i in closed] or [np.zeros(0)])
    kept = [records[i] for i in closed]
    return {
        "median_abs_error_diff_deg": _median(np.abs(sim - flight)),
        "flight_steady_deg_mean": _mean([r["flight"]["steady_deg"] for r in kept]),
        "sim_steady_deg_mean": _mean([r["sim"]["steady_deg"] for r in kept]),
        "flight_settle_1deg_s_median": _median_or_none(
            [r["flight"]["settle_1deg_s"] for r in kept]),
        "sim_settle_1deg_s_median": _median_or_none([r["sim"]["settle_1deg_s"] for r in kept]),
        "open_loop": {"maneuvers": len(drift), "median_abs_error_diff_deg": _median(
            np.concatenate([np.abs(r.sim_deg - r.flight_deg) for r in drift]
                           or [np.zeros(0)]))}}


def simulate(maneuvers: list[SubManeuver], scene, policy, *, env_id: str, env_kwargs: dict,
             seed: int = 0) -> list[dict]:
    """rbenv at each maneuver's logged time stamps, flying ``policy`` closed loop from its
    logged start (one vector env, one env per maneuver): per maneuver ``{"error_deg": (M,),
    "rate_dps": (M, 3), "wheel_rpm": (M, 3)}`` (NaN after an episode ended early; wheel_rpm
    only with wheels). A maneuver whose controller was off gets its logged commands (all
    zero) instead of the policy's action."""
    if not maneuvers:
        return []
    n = len(maneuvers)
    base = scene if isinstance(scene, Scene) else load_scene(scene)
    dt = base.physics.control_dt
    steps = math.ceil(max(m.duration_s for m in maneuvers) / dt - 1e-9)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                        scene=_lengthened(base, steps * dt), **env_kwargs)
    try:
        if isinstance(policy, str):
            policy = make_policy(policy, envs, seed)
        obs, _ = envs.reset(seed=seed, options=start_options(maneuvers, envs.unwrapped.plant))
        wheels = envs.unwrapped.plant.actuator("wheels") is not None
        trace = {"error_deg": np.full((steps + 1, n), np.nan),
                 "rate_dps": np.full((steps + 1, n, 3), np.nan),
                 **({"wheel_rpm": np.full((steps + 1, n, 3), np.nan)} if wheels else {})}
        _record(trace, 0, envs, np.array([m.error_deg[0] for m in maneuvers]),
                np.ones(n, bool))
        alive = np.ones(n, bool)
        key = envs.unwrapped.task.error_info_key
        state, starts = None, np.ones(n, bool)
        off = np.array([m.controller_off for m in maneuvers])
        for k in range(1, steps + 1):
            action, state = policy.predict(obs, state=state, episode_start=starts,
                                           deterministic=True)
            if off.any():
                action = np.array(action, copy=True)
                action[off] = 0.0  # the logged commands: none
            obs, _, term, trunc, info = envs.step(action)
            starts = np.zeros(n, bool)
            _record(trace, k, envs, np.asarray(info.get(SENSED_ERROR, info[key])), alive)
            alive &= ~(term | trunc)
            if not alive.any():
                break
    finally:
        envs.close()
    out = []
    for i, m in enumerate(maneuvers):
        index = np.minimum(np.rint(m.time_s / dt).astype(int), steps)
        out.append({name: arr[index, i] for name, arr in trace.items()})
    return out


def _record(trace: dict, k: int, envs, error_deg: np.ndarray, alive: np.ndarray) -> None:
    """Step ``k``'s error, body rate and wheel speeds of the envs still ``alive``."""
    st = envs.unwrapped._st  # the vector env's typed state: components of (N,) arrays
    trace["error_deg"][k, alive] = error_deg[alive]
    rate = getattr(st, "sensed_omega_B", None)  # the gyro's, with sensors as flown
    rate = st.omega_B if rate is None else rate
    trace["rate_dps"][k, alive] = np.degrees(np.stack(rate, axis=-1))[alive]
    if "wheel_rpm" in trace:
        trace["wheel_rpm"][k, alive] = (np.stack(st.wheel_speed, axis=-1) / _RPM)[alive]


def start_options(maneuvers: list[SubManeuver], plant) -> dict:
    """``reset(options=...)`` of the vector env: each env at its maneuver's first sample."""
    q = np.array([m.q[0] for m in maneuvers], float)
    n = len(maneuvers)
    options = {"q": q / np.linalg.norm(q, axis=1, keepdims=True),
               "q_target": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
               "omega_B": np.radians([m.rate_dps[0] for m in maneuvers])}
    widths = plant.reset_options
    if "wheel_speed" in widths:
        speed = np.array([m.wheel_rpm[0] for m in maneuvers]) * _RPM
        if speed.shape[1] != widths["wheel_speed"]:
            raise ValueError(
                f"the telemetry logs {speed.shape[1]} wheel speeds, scene "
                f"{plant.scene.name!r} has {widths['wheel_speed']} wheels")
        options["wheel_speed"] = speed
    if "wheel_clock_s" in widths:
        options["wheel_clock_s"] = np.array(
            [[WHEEL_CLOCK_PAST_DELAY_S if m.commanded_before else -1.0] for m in maneuvers])
    return options


def format_table(result: dict) -> str:
    """A Markdown table: one row per sub-maneuver, then the summary."""
    def fmt(x, spec=".2f"):
        return "—" if x is None else format(x, spec)
    lines = [f"replay of {result['policy']} in scene {result['scene']}",
             "| folder | # | flown by | t0 (s) | duration (s) | median |diff| (deg) | settle<1° "
             "flight / rbenv (s) | steady flight / rbenv (deg) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in result["maneuvers"]:
        flight, sim = r["flight"], r["sim"]
        mode = "policy" if r["mode"] == CLOSED_LOOP else "nobody: open loop, logged commands 0"
        lines.append(
            f"| {r['folder']} | {r['index']} | {mode} | {r['t0']:.0f} | {r['duration_s']:.0f} "
            f"| {fmt(r['median_abs_error_diff_deg'])} "
            f"| {fmt(flight['settle_1deg_s'], '.0f')} / {fmt(sim['settle_1deg_s'], '.0f')} "
            f"| {fmt(flight['steady_deg'])} / {fmt(sim['steady_deg'])} |")
    s = result["summary"]
    lines.append(
        f"| all | | policy | | | {fmt(s['median_abs_error_diff_deg'])} "
        f"| {fmt(s['flight_settle_1deg_s_median'], '.0f')} / "
        f"{fmt(s['sim_settle_1deg_s_median'], '.0f')} (median) "
        f"| {fmt(s['flight_steady_deg_mean'])} / {fmt(s['sim_steady_deg_mean'])} (mean) |")
    drift = s["open_loop"]
    if drift["maneuvers"]:
        lines.append(
            f"{drift['maneuvers']} sub-maneuver(s) logged only zero commands (the flight "
            f"controller was off): replayed open loop with those commands and left out of the "
            f"'all' row; their median |diff| {fmt(drift['median_abs_error_diff_deg'])}°.")
    return "\n".join(lines)


def write_json(result: dict, path) -> Path:
    """The record without the replays, as JSON (the fields the module names, no others)."""
    data = {k: v for k, v in result.items() if k != "replays"}
    Path(path).write_text(json.dumps(data, indent=2) + "\n")
    return Path(path)


def plot(result: dict, path, others: dict | None = None) -> Path:
    """PNG: flight against rbenv, attitude error (log scale) over time, one panel per
    sub-maneuver; ``others`` (label → replay result of the same telemetry) adds curves."""
    try:
        import matplotlib
    except ImportError:
        raise ImportError("--plot needs matplotlib: pip install 'rbenv[train]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = {result["scene"]: result, **(others or {})}
    replays = result["replays"]
    cols = min(4, len(replays))
    rows = math.ceil(len(replays) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.8 * rows), squeeze=False,
                             sharey=True)
    for i, (ax, r) in enumerate(zip(axes.flat, replays, strict=False)):
        t = r.maneuver.time_s
        ax.semilogy(t, np.maximum(r.flight_deg, 1e-2), "k.-", ms=2, lw=0.8, label="flight")
        for j, (label, res) in enumerate(curves.items()):
            ax.semilogy(t, np.maximum(res["replays"][i].sim_deg, 1e-2), f"C{j}-", lw=1.2,
                        label=f"rbenv: {label}")
        ax.axhline(SETTLE_DEG, color="gray", ls=":", lw=0.8)
        ax.set_title(f"{r.folder} #{r.maneuver.index}", fontsize=8)
        ax.set_xlabel("time (s)")
    for ax in axes.flat[len(replays):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("attitude error (deg)")
    axes.flat[0].legend(fontsize=7)
    title = [f"{result['policy']}; steady error (mean of the last 20 s) flight "
             f"{result['summary']['flight_steady_deg_mean']:.2f}°"]
    for label, res in curves.items():
        s = res["summary"]
        title.append(f"{label}: median |diff| {s['median_abs_error_diff_deg']:.2f}°, "
                     f"steady {s['sim_steady_deg_mean']:.2f}°")
    fig.suptitle("; ".join(title), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def _lengthened(scene: Scene, duration_s: float) -> Scene:
    """``scene`` with its episode ``duration_s`` long and no success ending inside it (the
    hold lasts the whole episode)."""
    episode = dataclasses.replace(scene.episode, duration=duration_s, hold_time=duration_s)
    return dataclasses.replace(scene, episode=episode)


def _folder_name(folder: Path, root) -> str:
    rel = Path(folder).relative_to(Path(root))
    return str(rel) if str(rel) != "." else Path(folder).name


def _median(x: np.ndarray):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if len(x) else None


def _median_or_none(values: list):
    kept = [v for v in values if v is not None]
    return float(np.median(kept)) if kept else None


def _mean(values: list):
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None
