"""Training speed: PPO with 1 and 2 torch threads, and every off-policy learner's env-steps/s.

Run ``rbenv bench train_speed`` (or ``python -m benchmarks.train_speed``; ``--quick`` for the
smoke form CI runs, written as ``train_speed_quick``). Results:
``benchmarks/results/train_speed.json`` and ``.png``.

PPO: the model is ``rbenv train``'s default (64 native-vector envs, 128x128 MLP); each
measurement times ``learn`` over whole rollouts (collection and gradient updates, as the progress
bar counts them). The four conditions are interleaved over several rounds and the median kept,
so the ratios come from one run on one machine. The competing process is a pure-Python busy loop
(one core), as a second job or an editor's indexer would be.

Off-policy: SAC, TD3, TQC and CrossQ with the settings ``rbenv train`` ships
(``agents/zoo/<algo>.py``), and SAC variants that trade sub-envs per step, batch size,
gradient steps and width. Each time ``learn`` end to end (after a prefilled buffer) over a fixed
number of gradient updates, so collection, replay sampling and updates all count; the rate with
no gradient step gives the collection cost alone. Target: 1,000 env-steps/s at 0.25 or more
gradient updates per env step.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import time
from typing import NamedTuple

import numpy as np

from benchmarks.common import RESULTS, pyplot, save_figure, table, write_json

ROUNDS = 3
ROLLOUTS = 3  # per measurement: 3 x 64 envs x 64 steps = 12,288 timesteps
THREADS = (1, 2)


def _model():
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import make_vec_env
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    cfg = TrainConfig().resolve()
    env = VecNormalize(make_vec_env(cfg, cfg.n_envs, 0))
    model = PPO("MlpPolicy", env, seed=0, device="cpu", **cfg.hyperparams)
    return model, cfg.n_envs * cfg.hyperparams["n_steps"]


def _busy():
    """A CPU-bound competitor on one core (a separate process; killed after the measurement)."""
    return subprocess.Popen([sys.executable, "-c", "while True: pass"])


def _steps_per_s(model, steps: int, threads: int) -> float:
    import torch

    torch.set_num_threads(threads)
    start = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    return steps / (time.perf_counter() - start)


def measure(rounds: int = ROUNDS, rollouts: int = ROLLOUTS) -> list[dict]:
    """Median steps/s for every (threads, competitor) pair, interleaved over ``rounds``."""
    model, rollout = _model()
    _steps_per_s(model, rollout, 1)  # warm-up: allocations, first rollout
    samples: dict[tuple, list[float]] = {(t, c): [] for c in (False, True) for t in THREADS}
    for _ in range(rounds):
        for threads, competitor in samples:
            busy = _busy() if competitor else None
            try:
                if busy:
                    time.sleep(0.3)  # let it reach full speed
                samples[threads, competitor].append(
                    _steps_per_s(model, rollouts * rollout, threads))
            finally:
                if busy:
                    busy.kill()
                    busy.wait()
    base = float(np.median(samples[1, False]))
    return [{"threads": t, "competing_process": c, "steps_per_s": float(np.median(v)),
             "samples": v, "relative_to_1_thread_alone": float(np.median(v)) / base}
            for (t, c), v in samples.items()]


def plot(rows: list[dict], ax=None):
    """PPO's bars; into ``ax`` if given (returns a figure to close, or the new figure)."""
    plt = pyplot()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(7.5, 3.8))
    labels, values, colors = [], [], []
    for r in rows:
        labels.append(f"{r['threads']} thread{'s' if r['threads'] > 1 else ''}\n"
                      f"{'+ 1 busy process' if r['competing_process'] else 'no competitor'}")
        values.append(r["steps_per_s"])
        colors.append("C0" if r["threads"] == 1 else "C1")
    ax.bar(labels, values, color=colors)
    for i, v in enumerate(values):
        ax.text(i, v, f"{v:,.0f}", ha="center", va="bottom")
    ax.set_ylabel("PPO training steps/s")
    ax.set_title(f"rbenv train (PPO defaults), {os.cpu_count()} cores (median of rounds)")
    if fig is not None:
        fig.tight_layout()
    return fig


# --- off-policy learners ----------------------------------------------------------------------

TARGET_STEPS_PER_S = 1_000
TARGET_UPDATES_PER_STEP = 0.25
OFF_POLICY = ("sac", "td3", "tqc", "crossq")
UPDATES = 160  # gradient updates timed per measurement (quick: 16)
OFF_ROUNDS = 2  # interleaved rounds, median kept (quick: 1)


def meets_target(env_steps_per_s: float, updates_per_env_step: float) -> bool:
    """The off-policy throughput target: 1,000 env-steps/s with 0.25 or more updates per step."""
    return bool(env_steps_per_s >= TARGET_STEPS_PER_S
                and updates_per_env_step >= TARGET_UPDATES_PER_STEP)


def off_policy_configs(quick: bool = False) -> list[dict]:
    """What is measured: each algorithm as shipped, then SAC variants (name, changes)."""
    shipped = [{"name": f"{a} shipped", "algo": a, "changes": {}} for a in OFF_POLICY]
    if quick:
        return [shipped[0], {"name": "sac shipped, 2 threads", "algo": "sac", "changes": {},
                             "threads": 2}]

    def sac(name, n_envs=None, threads=1, **hp):
        return {"name": name, "algo": "sac", "changes": hp, "n_envs": n_envs,
                "threads": threads}

    return [
        *shipped,
        sac("sac shipped, 2 threads", threads=2),
        sac("sac shipped, fused Adam", policy_kwargs={"net_arch": [256, 256],
                                                      "optimizer_kwargs": {"fused": True}}),
        sac("sac 64 envs x 16 updates", n_envs=64, gradient_steps=16),
        sac("sac 128 envs x 32 updates", n_envs=128, gradient_steps=32),
        sac("sac batch 256", batch_size=256),
        sac("sac batch 2048, 2 updates", batch_size=2048, gradient_steps=2),
        sac("sac net 128x128", policy_kwargs={"net_arch": [128, 128]}),
        sac("sac net 64x64, batch 256", batch_size=256,
            policy_kwargs={"net_arch": [64, 64]}),
        sac("sac net 64x64, batch 256, 128 envs x 32", n_envs=128, gradient_steps=32,
            batch_size=256, policy_kwargs={"net_arch": [64, 64]}),
    ]


def _off_policy_model(spec: dict):
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import algo_class, make_vec_env, model_kwargs
    from stable_baselines3.common.vec_env import VecNormalize

    hp = {**copy.deepcopy(spec["changes"]), "buffer_size": 200_000}
    cfg = TrainConfig(algo=spec["algo"], n_envs=spec.get("n_envs"), hyperparams=hp).resolve()
    batch = cfg.hyperparams["batch_size"]
    # Prefill: enough transitions for one batch, and at least 16 vector steps.
    cfg.hyperparams["learning_starts"] = max(2 * batch, 16 * cfg.n_envs)
    env = VecNormalize(make_vec_env(cfg, cfg.n_envs, 0), gamma=cfg.hyperparams["gamma"],
                       **cfg.normalize)
    model = algo_class(cfg.algo)("MlpPolicy", env, seed=0, device="cpu",
                                  **model_kwargs(cfg, env))
    return model, cfg


class Timing(NamedTuple):
    """One timed ``learn``: wall seconds, and the CPU seconds of this process (every thread).

    With one thread, ``steps / cpu_s`` is the rate on a core of its own: on a shared machine
    the wall rate falls with the others' load, the CPU rate much less.
    """

    wall_s: float
    cpu_s: float


def _timed_learn(model, steps: int, threads: int) -> Timing:
    import torch

    torch.set_num_threads(threads)
    start, start_cpu = time.perf_counter(), time.process_time()
    model.learn(steps, reset_num_timesteps=False)
    return Timing(time.perf_counter() - start, time.process_time() - start_cpu)


def measure_off_policy(quick: bool = False) -> list[dict]:
    """env-steps/s, updates/s and the collection share for every configuration."""
    updates = 16 if quick else UPDATES
    rounds = 1 if quick else OFF_ROUNDS
    specs = off_policy_configs(quick)
    built = []
    for spec in specs:
        model, cfg = _off_policy_model(spec)
        threads = spec.get("threads", 1)
        _timed_learn(model, cfg.hyperparams["learning_starts"] + cfg.n_envs, threads)  # prefill
        built.append((spec, model, cfg, threads))
    samples = {spec["name"]: [] for spec in specs}
    for _ in range(rounds):
        for spec, model, cfg, threads in built:
            g = cfg.hyperparams["gradient_steps"]
            vector_steps = max(updates // g, 2)
            steps = vector_steps * cfg.n_envs
            before = model._n_updates
            timing = _timed_learn(model, steps, threads)
            samples[spec["name"]].append({"steps": steps, "seconds": timing.wall_s,
                                          "cpu_seconds": timing.cpu_s,
                                          "updates": model._n_updates - before})
    collect = {}
    rows = []
    for spec, model, cfg, threads in built:
        if cfg.n_envs not in collect:  # collection alone: no gradient step (1 thread)
            saved = model.gradient_steps
            model.gradient_steps = 0
            n = 32 * cfg.n_envs
            collect[cfg.n_envs] = n / _timed_learn(model, n, 1).wall_s
            model.gradient_steps = saved
        runs = samples[spec["name"]]
        rates = [r["steps"] / r["seconds"] for r in runs]
        rate = float(np.median(rates))
        cpu_rate = float(np.median([r["steps"] / r["cpu_seconds"] for r in runs]))
        per_step = cfg.hyperparams["gradient_steps"] / cfg.n_envs
        update_s = max(1 / rate - 1 / collect[cfg.n_envs], 0.0) / per_step
        rows.append({
            "name": spec["name"], "algo": cfg.algo, "threads": threads, "n_envs": cfg.n_envs,
            "gradient_steps": cfg.hyperparams["gradient_steps"],
            "batch_size": cfg.hyperparams["batch_size"],
            "net_arch": cfg.hyperparams["policy_kwargs"]["net_arch"],
            "updates_per_env_step": per_step, "env_steps_per_s": rate,
            "updates_per_s": rate * per_step, "ms_per_update": 1e3 * update_s,
            "collection_only_env_steps_per_s": collect[cfg.n_envs],
            "meets_target": meets_target(rate, per_step),
            "env_steps_per_cpu_s": cpu_rate,
            "meets_target_per_cpu_s": threads == 1 and meets_target(cpu_rate, per_step),
            "samples": runs})
        model.get_env().close()
    return rows


def plot_off_policy(rows: list[dict], ax) -> None:
    names = [f"{r['name']} ({r['updates_per_env_step']:g} upd/step)" for r in rows]
    values = [r["env_steps_per_s"] for r in rows]
    colors = ["C2" if r["meets_target"] else
              ("C0" if r["updates_per_env_step"] >= TARGET_UPDATES_PER_STEP else "C7")
              for r in rows]
    y = np.arange(len(rows))[::-1]
    ax.barh(y, values, color=colors)
    ax.set_yticks(y, names, fontsize=8)
    for yi, v in zip(y, values, strict=True):
        ax.text(v, yi, f" {v:,.0f}", va="center", fontsize=8)
    ax.plot([r["env_steps_per_cpu_s"] for r in rows], y, "k|", markersize=12,
            label="per CPU-second of the process (a core of its own)")
    ax.axvline(TARGET_STEPS_PER_S, color="C3", ls="--", lw=1,
               label=f"target {TARGET_STEPS_PER_S:,} env-steps/s at >= "
                     f"{TARGET_UPDATES_PER_STEP} updates/step")
    ax.set_xscale("log")
    ax.set_xlabel("env-steps/s, learn() end to end (grey: fewer updates/step than the target)")
    ax.set_ylim(-0.7, len(rows) + 1.0)  # room for the legend above the first row
    ax.legend(loc="upper right", fontsize=8)


def draw(data: dict, name: str) -> None:
    """The PNG of a written JSON: PPO's bars above, the off-policy rows below."""
    plt = pyplot()
    fig = plt.figure(figsize=(9, 8.5))
    top, bottom = fig.add_gridspec(2, 1, height_ratios=(1, 1.6)).subplots()
    plt.close(plot(data["rows"], top))
    plot_off_policy(data["off_policy"]["rows"], bottom)
    bottom.set_title(f"off-policy, shipped settings and SAC variants (1 thread unless named; "
                     f"load {data['load_average_before'][0]:.1f} before)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, name)


def main(quick: bool = False) -> dict:
    load_before = os.getloadavg()  # others' load on a shared machine, for the record
    rows = measure(rounds=1, rollouts=1) if quick else measure()
    print(table([{k: r[k] for k in ("threads", "competing_process", "steps_per_s",
                                    "relative_to_1_thread_alone")} for r in rows],
                ["threads", "competing_process", "steps_per_s", "relative_to_1_thread_alone"]))
    by = {(r["threads"], r["competing_process"]): r["steps_per_s"] for r in rows}
    ratios = {
        "1_thread_over_2_threads_alone": by[1, False] / by[2, False],
        "1_thread_over_2_threads_busy": by[1, True] / by[2, True],
        "busy_over_alone_1_thread": by[1, True] / by[1, False],
        "busy_over_alone_2_threads": by[2, True] / by[2, False],
    }
    print({k: round(v, 2) for k, v in ratios.items()})
    off = measure_off_policy(quick)
    columns = ["name", "n_envs", "gradient_steps", "batch_size", "updates_per_env_step",
               "env_steps_per_s", "env_steps_per_cpu_s", "updates_per_s", "ms_per_update",
               "collection_only_env_steps_per_s", "meets_target", "meets_target_per_cpu_s"]
    print(table([{k: r[k] for k in columns} for r in off], columns))
    load_after = os.getloadavg()
    name = "train_speed_quick" if quick else "train_speed"
    command = "python -m benchmarks.train_speed" + (" --quick" if quick else "")
    data = {"command": command, "rounds": 1 if quick else ROUNDS,
            "timesteps_per_measurement": (1 if quick else ROLLOUTS) * 64 * 64,
            "load_average_before": load_before, "load_average_after": load_after,
            "rows": rows, "ratios": ratios,
            "off_policy": {"target_env_steps_per_s": TARGET_STEPS_PER_S,
                           "target_updates_per_env_step": TARGET_UPDATES_PER_STEP,
                           "updates_per_measurement": 16 if quick else UPDATES,
                           "rounds": 1 if quick else OFF_ROUNDS, "rows": off}}
    write_json(name, data)
    draw(data, name)
    return {"rows": rows, "ratios": ratios, "off_policy": off}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="smoke form: 1 PPO rollout per condition, SAC only, 16 updates")
    parser.add_argument("--plot-only", action="store_true",
                        help="redraw the PNG from the JSON already written; measure nothing")
    args = parser.parse_args()
    if args.plot_only:
        name = "train_speed_quick" if args.quick else "train_speed"
        draw(json.loads((RESULTS / f"{name}.json").read_text()), name)
    else:
        main(quick=args.quick)
