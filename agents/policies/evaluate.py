"""Seeded evaluation of any policy with SB3's ``predict``: scripted baselines or trained models.

All episodes run side by side in one native vector env, episode i seeded with ``seed + i``, so
every policy evaluated with the same seed meets exactly the same initial attitudes, targets,
tumbles and disturbances. Reports success rate, settle time, fuel and final error, and
records the first few episodes for plots.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents import settings
from rbenv.agents.baselines.controllers import (
    BASELINES,
    NotApplicable,
    RandomPolicy,
    ZeroPolicy,
    baseline,
    env_parts,
)
from rbenv.agents.policies import optimality
from rbenv.agents.policies.envcheck import plain_env
from rbenv.agents.policies.load import load_policy

import rbenv
from rbenv.envs.rendering import save_video
from rbenv.satellite.usage import InvalidChoiceError, invalid_choice

ANY_TASK = ("zero", "random")  # scripted policies of every task, beside each id's baselines
SENSED_ERROR = "sensed_attitude_error_deg"  # info key of scenes with sensors as flown
ESTIMATED_ERROR = "estimated_attitude_error_deg"  # info key of scenes with an [estimator]
SENSED_NOTE = "success is judged on the true state, while the policy sees the sensed one"
GYRO_SEEN = "attitude integrated from the gyro"


def _baselines(env_id: str) -> tuple[str, ...]:
    """The scripted baselines of a registered ``env_id`` (its training settings'; none
    without settings)."""
    rbenv.envs.registry.get(env_id)  # a named error for an id not registered
    ids = {entry.env_id: entry for entry in settings.entries()}
    return tuple(ids[env_id].baselines) if env_id in ids else ()


def scripted(env_id: str | None = None) -> tuple[str, ...]:
    """The scripted policy names of ``env_id``'s task (its training settings' baselines, then
    zero and random), or of every registered task (None)."""
    ids = [s.env_id for s in rbenv.envs.registry.specs()] if env_id is None else [env_id]
    names = dict.fromkeys(name for i in ids for name in _baselines(i))
    return (*names, *ANY_TASK)


def _stem(env_id: str) -> str:
    """``SatelliteReorient`` of ``rbenv/SatelliteReorient-v1``: the task, whatever version."""
    return env_id.split("/", 1)[-1].rsplit("-v", 1)[0]


def scripted_by_task() -> str:
    """The scripted policies of each task, for help texts: ``pd, bangbang (SatelliteReorient);
    ...; zero, random (any task)``."""
    tasks: dict[str, tuple] = {}
    for spec in rbenv.envs.registry.specs():
        tasks.setdefault(_stem(spec.env_id), _baselines(spec.env_id))
    return "; ".join(f"{', '.join(names)} ({task})" for task, names in tasks.items()) + \
        f"; {', '.join(ANY_TASK)} (any task)"


def check_policy(policy: str, env_id: str = rbenv.ENV_ID, options: dict | None = None) -> None:
    """A scripted policy of ``env_id``'s task, or an existing path; with ``options`` (its
    ``gym.make`` options, the scene among them: the ones the policy will run in) also one that
    can act on that scene. Else an :class:`InvalidChoiceError` saying which: the path that does
    not exist, the scripted names with a did-you-mean, the task a baseline belongs to, or the
    scenes it runs on. Without ``options`` the scene is not checked: call it again once the
    scene is known (``{}``: the task's default scene)."""
    if Path(policy).exists():
        return
    own = scripted(env_id)
    if policy in ANY_TASK:
        return
    if policy in own:
        if options is not None:
            _check_runs_on(policy, env_id, dict(options))
        return
    elsewhere = [s.env_id for s in rbenv.envs.registry.specs() if policy in _baselines(s.env_id)]
    if elsewhere:
        raise InvalidChoiceError("policy", policy, (
            f"{policy!r} is a scripted policy of {', '.join(elsewhere)}, not of {env_id}, "
            f"whose scripted policies are {', '.join(own)}; pick the task with --env-id"))
    if any(sep in policy for sep in ("/", "\\")) or Path(policy).suffix:
        raise InvalidChoiceError("policy", policy, (
            f"{policy!r} does not exist (no such run folder or model file); a scripted policy "
            f"of {env_id} is one of {', '.join(own)}"))
    raise invalid_choice("policy", policy, own, what=f"a scripted policy of {env_id}:",
                         extra="or give a run folder, its policy.pt or a checkpoint policy_N.pt")


def _check_runs_on(policy: str, env_id: str, options: dict) -> None:
    """The baseline ``policy`` can act on the scene of ``options``; else the scenes it can."""
    def runs(opts) -> bool:
        env = plain_env(env_id, opts)
        try:
            make_policy(policy, env)
            return True
        except NotApplicable:
            return False
        finally:
            env.close()

    if runs(options):
        return
    spec = rbenv.envs.registry.get(env_id)
    able = [s for s in rbenv.list_scenes() if spec.runs_on(s) and runs({**options, "scene": s})]
    scene = options.get("scene") or spec.scene
    raise InvalidChoiceError("policy", policy, (
        f"{policy!r} cannot act on scene {scene!r} (its actuators lack what it needs); it runs "
        f"on {', '.join(able) or 'no shipped scene'} (--scene)"))


def settle_time_s(end_time_s, hold_s: float, control_dt_s: float):
    """When a successful episode's hold began (s): the step that ended it (``time_s`` of its
    info, s) less the hold, plus the one control step the hold's count includes."""
    return end_time_s - hold_s + control_dt_s


@dataclass
class EvalResult:
    """Per-episode outcomes (arrays of length ``episodes``) and recorded traces."""

    policy: str
    scene: str
    seed: int
    success: np.ndarray
    settle_time_s: np.ndarray  # time the success hold began; NaN when not successful
    fuel_kg: np.ndarray  # NaN without thrusters
    final_error_deg: np.ndarray
    episode_time_s: np.ndarray
    energy_J: np.ndarray = None  # electrical energy of wheels and rods; NaN without them
    traces: list[dict] = field(default_factory=list)
    # What the policy sees in place of the true state (:func:`sensed_observation`), or None.
    observation: str | None = None
    sensed_final_error_deg: np.ndarray = None  # the error it believes at the end (sensors on)
    # Achieved / lower bound per episode (:mod:`rbenv.agents.policies.optimality`: settle_ratio,
    # fuel_ratio, fuel_ratio_own_time) and its JSON summary, or {"defined": False, "reason"}.
    optimality_per_episode: dict = field(default_factory=dict)
    optimality: dict = field(default_factory=dict)

    @property
    def episodes(self) -> int:
        return len(self.success)

    def summary(self) -> dict:
        """The JSON summary: policy, episodes, success_rate, settle_time_s, fuel, final error;
        where the policy sees a sensed state, ``observation`` says what it sees (success
        reads the true one) and ``final_error_deg`` adds the sensed error's median."""
        sensed = self.sensed_error_median
        settled = self.settle_time_s[np.isfinite(self.settle_time_s)]
        def q(p):
            return float(np.percentile(settled, p)) if len(settled) else None
        return {
            "policy": self.policy,
            "scene": self.scene,
            "seed": self.seed,
            "episodes": self.episodes,
            "success_rate": float(np.mean(self.success)),
            "settle_time_s": {"median": q(50), "p90": q(90)},
            "fuel": {"mean": float(np.mean(self.fuel_kg)), "unit": "kg"},
            "energy": {"mean": None if self.energy_J is None else float(np.mean(self.energy_J)),
                       "unit": "J"},
            "final_error_deg": {"median": float(np.median(self.final_error_deg)),
                                **({"sensed_median": sensed} if sensed is not None else {})},
            **({"observation": {"sensed": self.observation, "note": SENSED_NOTE}}
               if self.observation else {}),
            **({"optimality": self.optimality} if self.optimality else {}),
        }

    @property
    def sensed_error_median(self) -> float | None:
        """Median of the final attitude error the policy believes (deg); None when the scene's
        info does not carry it (no sensors as flown, or a task without a target)."""
        e = self.sensed_final_error_deg
        return None if e is None or not np.isfinite(e).any() else float(np.nanmedian(e))


def make_policy(name: str, env, seed: int = 0):
    """A scripted policy of the env's task (:func:`scripted`) or a path to a saved model; env
    single or vector."""
    task = env_parts(env)[1].name
    if name in BASELINES[task]:
        return baseline(env, name)
    n_act = getattr(env, "single_action_space", env.action_space).shape[0]
    if name == "zero":
        return ZeroPolicy(n_act)
    if name == "random":
        return RandomPolicy(n_act, seed)
    if Path(name).exists():
        return load_policy(name)
    raise invalid_choice("policy", name, (*BASELINES[task], *ANY_TASK),
                         what=f"a scripted policy of {task}:",
                         extra="or give a run folder, its policy.pt or a checkpoint policy_N.pt")


def evaluate(policy, *, episodes: int = 100, seed: int = 0, scene: str | None = None,
             name: str | None = None, record: int = 3, env_kwargs: dict | None = None,
             batch: int = 1000, env_id: str = rbenv.ENV_ID, action: str = "auto",
             trust_pickle: bool = False) -> EvalResult:
    """Run ``episodes`` seeded episodes of ``policy`` (str name or object with ``predict``).

    env_id: any registered rbenv id (reorient, detumble, track); episode i is seeded
    ``seed + i``, so every policy evaluated with the same seed meets the same episodes.
    action: for a model given by path, how it acts (:class:`rbenv.agents.policies.sb3.RunPolicy`).
    trust_pickle: a model given by path may be a pickle-based file (see
    :func:`rbenv.agents.policies.load_policy`).
    """
    env_kwargs = dict(env_kwargs or {})
    label = name or (policy if isinstance(policy, str) else type(policy).__name__)
    if isinstance(policy, str) and policy not in scripted() and Path(policy).exists():
        policy = load_policy(policy, action, trust_pickle=trust_pickle)
        env_kwargs = {**policy.env_kwargs, **env_kwargs}  # the run's env options first
    if scene is not None:
        env_kwargs["scene"] = scene
    parts = []
    for start in range(0, episodes, batch):
        n = min(batch, episodes - start)
        parts.append(_run_batch(policy, n, seed + start, env_kwargs, record if start == 0 else 0,
                                env_id))
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]
           if k not in ("traces", "scene", "observation")}
    result = EvalResult(policy=str(label), scene=parts[0]["scene"], seed=seed,
                        traces=parts[0]["traces"], observation=parts[0]["observation"], **cat)
    return with_optimality(result, env_id, env_kwargs)


def with_optimality(result: EvalResult, env_id: str, env_kwargs: dict) -> EvalResult:
    """``result`` with its per-episode ratios to the lower bounds of its episodes (the same
    seeds, id and env options), or the reason there are none."""
    bounds = optimality.episode_bounds(result.episodes, result.seed, env_id, env_kwargs)
    if isinstance(bounds, str):
        result.optimality = {"defined": False, "reason": bounds}
    else:
        result.optimality_per_episode = optimality.ratios(
            result.success, result.settle_time_s, result.fuel_kg, bounds)
        result.optimality = optimality.summary(result.optimality_per_episode, bounds)
    return result


def sensed_observation(plant) -> str | None:
    """What a policy sees in place of the plant's true attitude and rate, in words ("attitude
    integrated from the gyro, 1 control step late", "sensor noise"), or None when it sees the
    true state: the scene's ``[sensors]`` (as flown) and ``[sensor_noise]``. Success and the
    reward read the true state either way."""
    seen = []
    sensors = plant.sensors  # None unless [sensors] is on
    if sensors is not None and sensors.attitude == "gyro":
        seen.append(GYRO_SEEN)
    if plant.scene.sensors.attitude == "estimator":  # plant.sensors is None then
        seen.append("the attitude and rate the MEKF estimates")
    if sensors is not None and sensors.delay_steps:
        seen.append(f"{sensors.delay_steps} control step late")
    if plant.sensor_noise is not None:
        seen.append("sensor noise")
    return ", ".join(seen) or None


def _run_batch(policy, n: int, seed: int, env_kwargs: dict, record: int,
               env_id: str = rbenv.ENV_ID) -> dict:
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                        **env_kwargs)
    plant, task = envs.unwrapped.plant, envs.unwrapped.task
    if isinstance(policy, str):
        policy = make_policy(policy, envs, seed)
    dt, hold = plant.control_dt, plant.scene.episode.hold_time
    error_key = task.error_info_key
    nan = np.full(n, np.nan)
    obs, _ = envs.reset(seed=seed)
    alive = np.ones(n, bool)
    out = {k: np.full(n, np.nan) for k in ("settle_time_s", "fuel_kg", "final_error_deg",
                                           "episode_time_s", "energy_J",
                                           "sensed_final_error_deg")}
    success = np.zeros(n, bool)
    traces = [{"time_s": [], "attitude_error_deg": [], "rate_dps": [], "throttle": []}
              for _ in range(record)]
    state, starts = None, np.ones(n, bool)
    while alive.any():
        action, state = policy.predict(obs, state=state, episode_start=starts, deterministic=True)
        obs, _, term, trunc, info = envs.step(action)
        starts = np.zeros(n, bool)
        for i in range(min(record, n)):
            if alive[i]:
                tr = traces[i]
                tr["time_s"].append(float(info["time_s"][i]))
                tr["attitude_error_deg"].append(float(info.get(error_key, nan)[i]))
                tr["rate_dps"].append(float(info.get("rate_dps", nan)[i]))
                a_i = np.asarray(action[i], float)
                thr = plant.actuator("thrusters")
                tr["throttle"].append((a_i if thr is None or len(plant.actuators) > 1
                                       else thr.command(a_i)).tolist())
        done = (term | trunc) & alive
        if done.any():
            idx = np.flatnonzero(done)
            success[idx] = np.asarray(info["is_success"])[idx]
            out["episode_time_s"][idx] = np.asarray(info["time_s"])[idx]
            out["fuel_kg"][idx] = np.asarray(info.get("fuel_kg", nan))[idx]
            energy = [np.asarray(v)[idx] for key, v in info.items() if key.endswith("_energy_J")]
            if energy:
                out["energy_J"][idx] = sum(energy[1:], energy[0])
            out["final_error_deg"][idx] = np.asarray(info.get(error_key, nan))[idx]
            believed = info.get(SENSED_ERROR, info.get(ESTIMATED_ERROR, nan))
            out["sensed_final_error_deg"][idx] = np.asarray(believed)[idx]
            ok = idx[success[idx]] if task.success_terminates else idx[:0]
            out["settle_time_s"][ok] = settle_time_s(out["episode_time_s"][ok], hold, dt)
            alive[idx] = False
    envs.close()
    return {"success": success, "traces": traces, "scene": plant.scene.name,
            "observation": sensed_observation(plant), **out}


def format_table(results: list[EvalResult]) -> str:
    """A Markdown table of the summaries. Where the scene's lower bounds are defined
    (:mod:`rbenv.agents.policies.optimality`) it adds settle time and propellant as medians of
    their per-episode ratios to the bounds, and a line under it with the bounds; where none is,
    a line says why. Where a policy sees a sensed state (a scene with sensors as flown or
    sensor noise) the table adds the sensed final error beside the true one, and a line under
    it says that success reads the true state."""
    summaries = [r.summary() for r in results]
    fuel = any(np.isfinite(s["fuel"]["mean"]) for s in summaries)  # thrusters: propellant
    sensed = any(r.sensed_error_median is not None for r in results)
    bounded = any(r.optimality.get("defined") for r in results)
    lines = ["| policy | episodes | success rate | settle time median (s) | settle time p90 (s) "
             f"| {'fuel mean (g)' if fuel else 'energy mean (J)'} | final error median (deg) |"
             + (" settle / bound | fuel / bound |" if bounded else "")
             + (" final error median, sensed (deg) |" if sensed else ""),
             "|---|---|---|---|---|---|---|" + ("---|---|" if bounded else "")
             + ("---|" if sensed else "")]
    def fmt(x, spec=".1f"):
        return "—" if x is None else format(x, spec)
    for s in summaries:
        effort = 1000 * s["fuel"]["mean"] if fuel else s["energy"]["mean"]
        opt = s.get("optimality", {})
        ratio = (f" {fmt(opt.get('settle_ratio', {}).get('median'), '.2f')} "
                 f"| {fmt(opt.get('fuel_ratio', {}).get('median'), '.1f')} |") if bounded else ""
        lines.append(
            f"| {s['policy']} | {s['episodes']} | {100 * s['success_rate']:.1f}% "
            f"| {fmt(s['settle_time_s']['median'])} | {fmt(s['settle_time_s']['p90'])} "
            f"| {fmt(effort, '.2f')} | {s['final_error_deg']['median']:.3g} |" + ratio
            + (f" {fmt(s['final_error_deg'].get('sensed_median'), '.3g')} |" if sensed else ""))
    lines += _optimality_notes(results)
    seen = dict.fromkeys((r.scene, r.observation) for r in results if r.observation)
    lines += [f"\nNote: {SENSED_NOTE} (scene {scene!r}: {what}"
              + ("; no [estimator] corrects it" if GYRO_SEEN in what else "") + ")."
              for scene, what in seen]
    return "\n".join(lines)


def _optimality_notes(results: list[EvalResult]) -> list[str]:
    """The line under the table on the bounds: their medians, or why there are none."""
    defined = [r.optimality for r in results if r.optimality.get("defined")]
    if defined:
        b = defined[0]["bounds"]
        fuel = ("no propellant bound" if b["fuel_kg_median"] is None
                else f"propellant {1000 * b['fuel_kg_median']:.3f} g")
        return [f"\nOptimality: medians over successful episodes of achieved / lower bound per "
                f"episode (docs/bounds.md; 1 is the limit; {b['which']}). Bounds here (medians): "
                f"settle {b['settle_time_s_median']:.1f} s, {fuel}."]
    reasons = dict.fromkeys(r.optimality["reason"] for r in results if r.optimality)
    return [f"\nOptimality: no lower bounds here: {why}." for why in reasons]


def plot_episodes(results: list[EvalResult], path, episode: int = 0):
    """PNG: attitude error, body rate and thruster activity against time, one row per policy."""
    import matplotlib  # the train (or test) extra

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in results if len(r.traces) > episode]
    fig, axes = plt.subplots(len(rows), 3, figsize=(14, 2.6 * len(rows)), squeeze=False)
    for ax_row, r in zip(axes, rows, strict=True):
        tr = r.traces[episode]
        t = np.array(tr["time_s"])
        ax_row[0].semilogy(t, np.maximum(tr["attitude_error_deg"], 1e-3))
        ax_row[0].axhline(1.0, color="k", ls=":", lw=0.8)
        ax_row[0].set_ylabel(f"{r.policy}\nerror (deg)")
        ax_row[1].plot(t, tr["rate_dps"])
        ax_row[1].axhline(np.degrees(0.01), color="k", ls=":", lw=0.8)
        ax_row[1].set_ylabel("|ω| (deg/s)")
        u = np.array(tr["throttle"])
        ax_row[2].imshow(u.T, aspect="auto", origin="lower", cmap="Oranges", vmin=0, vmax=1,
                         extent=(t[0] - 0.5 * (t[1] - t[0]) if len(t) > 1 else 0, t[-1],
                                 -0.5, u.shape[1] - 0.5), interpolation="nearest")
        ax_row[2].set_ylabel("thruster")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    axes[0][0].set_title("attitude error (dotted: 1° success)")
    axes[0][1].set_title("body rate (dotted: 0.01 rad/s)")
    axes[0][2].set_title("thruster throttle (0–1)")
    fig.suptitle(f"Episode {episode} of scene {rows[0].scene} (seed {rows[0].seed + episode})")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


def write_json(results: list[EvalResult], path) -> Path:
    """One summary per policy (a list), or a single object for one policy."""
    data = [r.summary() for r in results]
    Path(path).write_text(json.dumps(data[0] if len(data) == 1 else data, indent=2) + "\n")
    return Path(path)


def record_video(policy, path, *, seed: int = 0, scene: str | None = None, fps: float = 8.0,
                 env_kwargs: dict | None = None, env_id: str = rbenv.ENV_ID,
                 trust_pickle: bool = False) -> Path:
    """Render one seeded episode of ``policy`` to a GIF or MP4 (needs the render extra)."""
    kwargs = dict(env_kwargs or {})
    if isinstance(policy, str) and policy not in scripted() and Path(policy).exists():
        policy = load_policy(policy, trust_pickle=trust_pickle)
        kwargs = {**policy.env_kwargs, **kwargs}
    if scene is not None:
        kwargs["scene"] = scene
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    if isinstance(policy, str):
        policy = make_policy(policy, env, seed)
    obs, _ = env.reset(seed=seed)
    frames, state, done = [env.render()], None, False
    while not done:
        action, state = policy.predict(obs, state=state, deterministic=True)
        obs, _, term, trunc, _ = env.step(action)
        frames.append(env.render())
        done = term or trunc
    env.close()
    return save_video(frames, path, fps=fps)
