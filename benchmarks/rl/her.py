"""SAC or TQC with SB3's ``HerReplayBuffer`` on ``rbenv/SatelliteReorientGoal-v1``.

Trains on the goal-conditioned form of Reorient-v1 (:mod:`rbenv.envs.goal`) with the off-policy
recipe of :mod:`rbenv.agents.settings.off_policy` where it applies (torque actions with ``pinv``
allocation, 32 envs, lr 1e-3, batch 512, buffer 1M, learning_starts 10k, 8 gradient steps per
vector step, gamma 0.99, tau 0.01, net [256, 256]), HER relabelling with the ``future``
strategy, 4 sampled goals and ``copy_info_dict=True`` (the env's ``compute_reward`` needs the
step's info), for a wall-clock budget. SB3's ``DummyVecEnv`` runs the Dict-observation envs;
``VecNormalize`` normalises the ``observation`` entry only (``--normalize none``: nothing).

``--features goal-error`` adds to the networks' input Reorient-v1's error features computed
from the goals (:class:`rbenv.agents.training.her.GoalErrorFeatures`; SB3's default input,
``flat``, has only the two absolute attitudes), and ``--relabel-done reached`` ends a
relabelled transition where its substituted goal is reached
(:class:`rbenv.agents.training.her.ReachedHerReplayBuffer`; SB3 copies the real ``done``).
``docs/off-policy.md`` (its HER section) has the runs.

Every ``--eval-every`` env steps the deterministic policy is validated on 100 episodes seeded
2,000,000 + i (never the held-out seeds); the best validated policy (success rate, then mean
return, the earlier at a tie) is kept, as ``rbenv train --keep-best`` does, and judged on the
500 held-out episodes seeded 1,000,000 + i beside the PD on the same episodes
(``rbenv/SatelliteReorient-v1``: the goal form's episodes are v1's, seed for seed). The
machine's 1-min load average is sampled every 10 s while training.

Writes ``benchmarks/results/rl/her/<name>.json`` (settings, versions, steps, wall time,
steps/s, load, validation curve, held-out result) and regenerates ``summary.md`` from every
JSON in that folder. Model weights go to ``--run-dir`` (outside git) if given: a
``torch.save`` of tensors only (``torch.load(weights_only=True)`` reads it) and an ``.npz``.

    python -m benchmarks.rl.her --algo sac --max-minutes 15 --seed 0 \\
        --name sac-her-seed0 --run-dir /work/runs-her/sac-her-seed0
    python -m benchmarks.rl.her --quick --out /tmp/her-quick
    python -m benchmarks.rl.her summary [--out DIR]
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import shlex
import subprocess
import sys
import threading
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents.policies.evaluate import EvalResult, settle_time_s

from benchmarks.common import fmt
from rbenv.envs.goal import GOAL_ID

RESULTS = Path(__file__).resolve().parents[1] / "results" / "rl" / "her"
PLAIN_ID = "rbenv/SatelliteReorient-v1"
SCENE = "cubesat-12u"
HELD_OUT_SEED, VALIDATION_SEED = 1_000_000, 2_000_000
# The shipped recipe's keys that are model arguments (the rest: vec env, budget, wrappers).
NOT_MODEL_KEYS = ("policy", "n_envs", "n_timesteps", "normalize", "env_kwargs",
                  "monitor_kwargs")
# --quick: a run of a few seconds that exercises every part (not a measurement).
QUICK = {"n_envs": 2, "timesteps": 600, "eval_every": 400, "eval_episodes": 3,
         "held_out_episodes": 6, "max_minutes": 5.0,  # the step cap ends it, not the clock
         "model": {"learning_starts": 400, "batch_size": 64, "gradient_steps": 1,
                   "buffer_size": 10_000, "policy_kwargs": {"net_arch": [32, 32]}}}


# --- load average -----------------------------------------------------------------------------

class LoadSampler:
    """The machine's load averages every ``period`` s, in a daemon thread, while running."""

    def __init__(self, period: float = 10.0):
        self.period, self.rows = float(period), []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _sample(self) -> None:
        self.rows.append((time.time(), *os.getloadavg()))

    def _run(self) -> None:
        self._sample()
        while not self._stop.wait(self.period):
            self._sample()

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self._sample()

    def summary(self) -> dict:
        load1 = np.array([r[1] for r in self.rows])
        return {"samples": len(self.rows), "period_s": self.period,
                "load1_mean": float(load1.mean()), "load1_min": float(load1.min()),
                "load1_max": float(load1.max())}


# --- evaluation -------------------------------------------------------------------------------

def run_episodes(predict, seeds, env_kwargs: dict, batch: int = 100) -> dict:
    """Seeded episodes of the goal env, ``batch`` side by side, acting with
    ``predict(obs_dict) -> actions``; per-episode arrays: success, settle time (s; NaN if not
    successful, as :func:`rbenv.agents.policies.evaluate.evaluate`), fuel (kg), final
    attitude error (deg) and return."""
    keys = ("success", "settle_time_s", "fuel_kg", "final_error_deg", "episode_time_s",
            "return")
    out = {k: [] for k in keys}
    seeds = [int(s) for s in seeds]
    for start in range(0, len(seeds), batch):
        part = seeds[start:start + batch]
        envs = [gym.make(GOAL_ID, scene=SCENE, **env_kwargs) for _ in part]
        plant = envs[0].unwrapped.env.plant
        hold, dt = plant.scene.episode.hold_time, plant.control_dt
        obs = [e.reset(seed=s)[0] for e, s in zip(envs, part, strict=True)]
        n = len(part)
        alive = np.ones(n, bool)
        res = {k: np.full(n, np.nan) for k in keys}
        res["return"][:] = 0.0
        while alive.any():
            idx = np.flatnonzero(alive)
            batch_obs = {k: np.stack([obs[i][k] for i in idx]) for k in obs[0]}
            actions = predict(batch_obs)
            for j, i in enumerate(idx):
                obs[i], reward, term, trunc, info = envs[i].step(actions[j])
                res["return"][i] += reward
                if term or trunc:
                    alive[i] = False
                    res["success"][i] = float(info["is_success"])
                    res["fuel_kg"][i] = info["fuel_kg"]
                    res["final_error_deg"][i] = info["attitude_error_deg"]
                    res["episode_time_s"][i] = info["time_s"]
                    if info["is_success"]:
                        res["settle_time_s"][i] = settle_time_s(info["time_s"], hold, dt)
        for e in envs:
            e.close()
        for k in keys:
            out[k].append(res[k])
    return {k: np.concatenate(v) for k, v in out.items()}


def summarise(policy: str, seed: int, res: dict) -> dict:
    """``rbenv evaluate --json``'s summary (:meth:`EvalResult.summary`; fuel in kg) of
    :func:`run_episodes`, with the mean return."""
    fields = {k: res[k] for k in ("success", "settle_time_s", "fuel_kg", "final_error_deg",
                                  "episode_time_s")}
    result = EvalResult(policy=policy, scene=SCENE, seed=seed, **fields)
    return {**result.summary(), "mean_return": float(np.mean(res["return"]))}


def pd_baseline(episodes: int) -> dict:
    from rbenv.agents.policies.evaluate import evaluate

    return evaluate("pd", episodes=episodes, seed=HELD_OUT_SEED, env_id=PLAIN_ID,
                    scene=SCENE, record=0).summary()


# --- training ---------------------------------------------------------------------------------

def model_settings(algo: str, quick: bool, changes: dict) -> tuple[dict, dict]:
    """The shipped off-policy recipe's model arguments for ``algo`` (on Reorient-v1), with
    the quick form's and the command line's changes."""
    from rbenv.agents import settings as training_settings

    shipped = training_settings.zoo_hyperparams(algo)[PLAIN_ID]
    settings = {k: v for k, v in shipped.items() if k not in NOT_MODEL_KEYS}
    if quick:
        settings.update(copy.deepcopy(QUICK["model"]))
    settings.update({k: v for k, v in changes.items() if v is not None})
    return settings, shipped


def make_env(args, n_envs: int, env_kwargs: dict):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = make_vec_env(GOAL_ID, n_envs=n_envs, seed=args.seed, vec_env_cls=DummyVecEnv,
                        env_kwargs={"scene": SCENE, **env_kwargs},
                        monitor_kwargs={"info_keywords": ("is_success",)})
    if args.normalize == "observation":
        return VecNormalize(venv, norm_obs=True, norm_reward=False,
                            norm_obs_keys=["observation"])
    return venv


def model_class(algo: str):
    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    from stable_baselines3 import SAC

    return SAC


class Validation:
    """Validation of the policy being trained and keep-best (in memory, and in ``run_dir``
    if given), fired from an SB3 callback every ``every`` env steps."""

    def __init__(self, model, env, seeds, env_kwargs, clock_start, run_dir: Path | None):
        self.model, self.env, self.seeds, self.env_kwargs = model, env, seeds, env_kwargs
        self.clock_start, self.run_dir = clock_start, run_dir
        self.curve: list[dict] = []
        self.best: dict | None = None
        self._best_state = self._best_rms = None

    def normalise(self, obs: dict) -> dict:
        from stable_baselines3.common.vec_env import VecNormalize

        return self.env.normalize_obs(obs) if isinstance(self.env, VecNormalize) else obs

    def predict(self, obs: dict) -> np.ndarray:
        return self.model.predict(self.normalise(obs), deterministic=True)[0]

    def __call__(self, steps: int) -> None:
        began = time.perf_counter()
        res = run_episodes(self.predict, self.seeds, self.env_kwargs)
        point = {"timesteps": int(steps), "wall_time_s": time.perf_counter() - self.clock_start,
                 "validation_s": time.perf_counter() - began,
                 "success_rate": float(np.mean(res["success"])),
                 "mean_return": float(np.mean(res["return"])),
                 "final_error_deg_median": float(np.median(res["final_error_deg"])),
                 "fuel_g_mean": 1e3 * float(np.mean(res["fuel_kg"])),
                 "load1": os.getloadavg()[0]}
        self.curve.append(point)
        print(f"validation at {steps}: {100 * point['success_rate']:.0f} % success, final error "
              f"median {point['final_error_deg_median']:.3g} deg, return "
              f"{point['mean_return']:.1f} ({point['wall_time_s'] / 60:.1f} min, load "
              f"{point['load1']:.2f})", flush=True)
        if self.best is None or (point["success_rate"], point["mean_return"]) > (
                self.best["success_rate"], self.best["mean_return"]):
            self.best = point
            self._best_state = copy.deepcopy(self.model.policy.state_dict())
            rms = getattr(self.env, "obs_rms", None)
            self._best_rms = copy.deepcopy(rms)
            if self.run_dir is not None:
                save_policy(self.run_dir, self._best_state, self._best_rms, steps)

    def restore_best(self) -> None:
        """Make the model (and the normaliser) the best validated policy."""
        self.model.policy.load_state_dict(self._best_state)
        if self._best_rms is not None:
            self.env.obs_rms = self._best_rms


def save_policy(run_dir: Path, state: dict, rms, steps: int) -> None:
    """Tensors only (``torch.load(weights_only=True)``) and the ``observation`` statistics as
    an ``.npz`` (``allow_pickle=False``); never committed."""
    import torch

    run_dir.mkdir(parents=True, exist_ok=True)
    torch.save({k: v.detach().cpu() for k, v in state.items()}, run_dir / "best_policy.pt")
    stats = {"timesteps": np.array(steps)}
    if rms is not None:
        stats.update(observation_mean=rms["observation"].mean,
                     observation_var=rms["observation"].var,
                     observation_count=np.array(rms["observation"].count))
    np.savez(run_dir / "best_obs_stats.npz", **stats)


def versions() -> dict:
    """What ``rbenv train`` records of a run's software and CPU, and the source commit."""
    from rbenv.agents.training.engine import versions as run_versions

    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(__file__).parent,
                                capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = None
    return {**run_versions(("torch", "stable_baselines3", "sb3_contrib")),
            "git_commit": commit}


def train(args) -> dict:
    import torch
    from rbenv.agents.training.her import GoalErrorFeatures, ReachedHerReplayBuffer
    from stable_baselines3 import HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(args.threads)
    quick = args.quick
    n_envs = QUICK["n_envs"] if quick else args.n_envs
    settings, shipped = model_settings(args.algo, quick, {
        "learning_starts": args.learning_starts, "gradient_steps": args.gradient_steps})
    her = {"goal_selection_strategy": args.goal_selection_strategy,
           "n_sampled_goal": args.n_sampled_goal, "copy_info_dict": True}
    env_kwargs = dict(shipped["env_kwargs"])
    timesteps = QUICK["timesteps"] if quick else (args.timesteps or shipped["n_timesteps"])
    max_minutes = QUICK["max_minutes"] if quick else args.max_minutes
    every = QUICK["eval_every"] if quick else args.eval_every
    val_episodes = QUICK["eval_episodes"] if quick else args.eval_episodes
    held_out = QUICK["held_out_episodes"] if quick else args.held_out_episodes
    run_dir = Path(args.run_dir) if args.run_dir else None

    clock_start = time.perf_counter()
    env = make_env(args, n_envs, env_kwargs)
    kwargs = copy.deepcopy(settings)  # (SB3 adds keys to the policy_kwargs it is given)
    if args.features == "goal-error":
        angle = env.get_attr("task", [0])[0].success_angle
        kwargs["policy_kwargs"] = {**kwargs.get("policy_kwargs", {}),
                                   "features_extractor_class": GoalErrorFeatures,
                                   "features_extractor_kwargs": {"success_angle": angle}}
    buffer = ReachedHerReplayBuffer if args.relabel_done == "reached" else HerReplayBuffer
    model = model_class(args.algo)(
        "MultiInputPolicy", env, replay_buffer_class=buffer,
        replay_buffer_kwargs=dict(her), seed=args.seed, device="cpu", verbose=0, **kwargs)
    validation = Validation(model, env, range(VALIDATION_SEED, VALIDATION_SEED + val_episodes),
                            env_kwargs, clock_start, run_dir)
    limit_s = 60.0 * max_minutes

    class Callback(BaseCallback):
        def _on_training_start(self) -> None:
            self.next = every
            self.stopped = False

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next:
                validation(self.num_timesteps)
                self.next = (self.num_timesteps // every + 1) * every
            self.stopped = time.perf_counter() - clock_start >= limit_s
            return not self.stopped

    callback = Callback()
    with LoadSampler(2.0 if quick else 10.0) as load:
        model.learn(timesteps, callback=callback)
        steps = int(model.num_timesteps)
        if not validation.curve or validation.curve[-1]["timesteps"] != steps:
            validation(steps)  # the final model, validated like the others
        wall = time.perf_counter() - clock_start
    last = validation.curve[-1]
    validation.restore_best()
    obs_stats = None
    if validation._best_rms is not None:
        rms = validation._best_rms["observation"]
        obs_stats = {"mean": rms.mean.round(4).tolist(),
                     "std": np.sqrt(rms.var).round(4).tolist(), "count": float(rms.count)}
    print(f"trained {steps} steps in {wall / 60:.1f} min; kept the policy of step "
          f"{validation.best['timesteps']}; evaluating it on {held_out} held-out episodes",
          flush=True)
    trained = summarise(f"{args.algo}+her", HELD_OUT_SEED, run_episodes(
        validation.predict, range(HELD_OUT_SEED, HELD_OUT_SEED + held_out), env_kwargs))
    pd = pd_baseline(held_out)
    env.close()
    return {
        "name": args.name, "command": " ".join(shlex.quote(a) for a in args.argv),
        "settings": {"algo": args.algo, "env_id": GOAL_ID, "scene": SCENE, "seed": args.seed,
                     "n_envs": n_envs, "timesteps": timesteps, "max_minutes": max_minutes,
                     "quick": quick, "threads": args.threads, "model": settings,
                     "replay_buffer_class": buffer.__name__, "her": her,
                     "relabel_done": args.relabel_done,
                     "vec_env": "DummyVecEnv", "normalize": args.normalize,
                     "features": args.features,
                     "env_kwargs": env_kwargs, "eval_every": every,
                     "validation": {"episodes": val_episodes, "seed": VALIDATION_SEED},
                     "held_out": {"episodes": held_out, "seed": HELD_OUT_SEED,
                                  "deterministic": True}},
        "versions": versions(),
        "training": {"timesteps": steps, "wall_time_s": wall, "steps_per_s": steps / wall,
                     "validation_time_s": sum(p["validation_s"] for p in validation.curve),
                     "gradient_updates": int(getattr(model, "_n_updates", 0)),
                     "stopped_by_time_limit": bool(callback.stopped),
                     "kept": {**validation.best, "episodes": val_episodes, "last": last}},
        "load_average_during_training": load.summary(),
        "observation_statistics_of_kept_policy": obs_stats,
        "curve": validation.curve,
        "held_out": [trained, pd],
    }


# --- results ----------------------------------------------------------------------------------

def finite(value):
    """``value`` with every NaN or infinity replaced by None (strict JSON)."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _steps(n: int) -> str:
    return f"{n / 1000:.0f}k" if n >= 1000 else str(n)


def _cells(r: dict) -> str:
    return (f"{100 * r['success_rate']:.1f} % | {1e3 * r['fuel']['mean']:.2f} | "
            f"{fmt(r['settle_time_s']['median'], '.1f')} | "
            f"{r['final_error_deg']['median']:.3g}")


def summary(directory: Path) -> Path:
    """``summary.md`` from every JSON in ``directory``."""
    directory = Path(directory)
    runs = [json.loads(p.read_text()) for p in sorted(directory.glob("*.json"))]
    lines = ["| run | algo | input (--features) | relabelled done | env steps | "
             "wall (min; of it validation) | "
             "env-steps/s (load 1-min mean) | kept step | held-out success | fuel mean (g) | "
             "settle median (s) | final error median (deg) |", "|---" * 12 + "|"]
    pds = {}
    for d in runs:
        s, t = d["settings"], d["training"]
        load = d["load_average_during_training"]
        trained, pd = d["held_out"]
        pds.setdefault((pd["episodes"], pd["seed"]), pd)
        lines.append(f"| {d['name']} | {s['algo']}+HER | {s.get('features', 'flat')} | "
                     f"{s.get('relabel_done', 'copy')} | {t['timesteps']:,} | "
                     f"{t['wall_time_s'] / 60:.1f} ({t['validation_time_s'] / 60:.1f}) | "
                     f"{t['steps_per_s']:.0f} "
                     f"({load['load1_mean']:.1f}) | {t['kept']['timesteps']:,} | "
                     f"{_cells(trained)} |")
    for (episodes, seed), pd in pds.items():
        lines.append(f"| PD, Reorient-v1 (same {episodes} episodes, seeds {seed:,} + i) | — | — "
                     f"| — | — | — | — | — | {_cells(pd)} |")
    lines += ["", "Validation during training (deterministic, episodes seeded 2,000,000 + i; "
              "not the held-out set): success, and median final error (deg).", "",
              "| run | validation |", "|---|---|"]
    for d in runs:
        points = ", ".join(f"{_steps(p['timesteps'])}: {100 * p['success_rate']:.0f} % "
                           f"({p['final_error_deg_median']:.2g}°)" for p in d["curve"])
        lines.append(f"| {d['name']} | {points} |")
    lines += ["", "Commands: the `command` field of each JSON. Generated by "
              "`python -m benchmarks.rl.her summary`.", ""]
    path = directory / "summary.md"
    path.write_text("\n".join(lines))
    return path


def main(argv=None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python -m benchmarks.rl.her",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("action", nargs="?", choices=("train", "summary"), default="train",
                   help="train (default) or only regenerate summary.md")
    p.add_argument("--algo", choices=("sac", "tqc"), default="sac")
    p.add_argument("--max-minutes", type=float, default=15.0,
                   help="wall-clock budget of training, validations included")
    p.add_argument("--timesteps", type=int, default=None,
                   help="env-step cap (default: the shipped recipe's n_timesteps)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--n-envs", type=int, default=32)
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--eval-every", type=int, default=10_000, help="validation period, env steps")
    p.add_argument("--eval-episodes", type=int, default=100, help="validation episodes")
    p.add_argument("--held-out-episodes", type=int, default=500)
    p.add_argument("--n-sampled-goal", type=int, default=4)
    p.add_argument("--goal-selection-strategy", choices=("future", "final", "episode"),
                   default="future")
    p.add_argument("--normalize", choices=("observation", "none"), default="observation",
                   help="VecNormalize on the 'observation' entry only, or no normalisation")
    p.add_argument("--features", choices=("flat", "goal-error"), default="flat",
                   help="flat: SB3's CombinedExtractor (the three entries concatenated); "
                        "goal-error: also v1's error features computed from the goals")
    p.add_argument("--relabel-done", choices=("copy", "reached"), default="copy",
                   help="a relabelled transition's done: copy the real one (SB3), or end it "
                        "where the substituted goal is reached (ReachedHerReplayBuffer)")
    p.add_argument("--learning-starts", type=int, default=None,
                   help="override the recipe's learning_starts")
    p.add_argument("--gradient-steps", type=int, default=None,
                   help="override the recipe's gradient_steps per vector step")
    p.add_argument("--name", default=None, help="the JSON's name (default: <algo>-her-seed<N>)")
    p.add_argument("--out", default=None,
                   help=f"folder of the JSONs and summary.md (default {RESULTS}; "
                        "required with --quick)")
    p.add_argument("--run-dir", default=None,
                   help="folder for the kept policy's weights (outside git)")
    p.add_argument("--quick", action="store_true",
                   help="a few-second run of every part into --out (not a measurement)")
    args = p.parse_args(argv)
    if args.quick and args.out is None:
        p.error("--quick needs --out (it must not overwrite the committed results)")
    out = Path(args.out) if args.out else RESULTS
    if args.action == "summary":
        print(summary(out))
        return
    args.argv = ["python", "-m", "benchmarks.rl.her", *argv]
    args.name = args.name or f"{args.algo}-her-seed{args.seed}" + ("-quick" if args.quick else "")
    data = train(args)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{args.name}.json"
    path.write_text(json.dumps(finite(data), indent=2, allow_nan=False) + "\n")
    print(path)
    print(summary(out))


if __name__ == "__main__":
    main()
