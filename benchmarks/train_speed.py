"""Training speed: PPO steps/s with 1 and 2 torch threads, alone and beside a busy process.

Run ``rbenv bench train_speed`` (or ``python -m benchmarks.train_speed``). The model is
``rbenv train``'s default PPO (64 native-vector envs, 128x128 MLP); each measurement times
``learn`` over whole rollouts (collection and gradient updates, as the progress bar counts
them). The four conditions are interleaved over several rounds and the median kept, so the
ratios come from one run on one machine. The competing process is a pure-Python busy loop
(one core), as a second job or an editor's indexer would be. Results:
``benchmarks/results/train_speed.json`` and ``.png``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

from benchmarks.common import pyplot, save_figure, table, write_json

ROUNDS = 3
ROLLOUTS = 3  # per measurement: 3 x 64 envs x 64 steps = 12,288 timesteps
THREADS = (1, 2)


def _model():
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.train import TrainConfig, make_vec_env

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


def plot(rows: list[dict]):
    plt = pyplot()
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
    ax.set_title(f"rbenv train (PPO defaults), {os.cpu_count()} cores (median of {ROUNDS})")
    fig.tight_layout()
    return fig


def main() -> dict:
    load_before = os.getloadavg()  # others' load on a shared machine, for the record
    rows = measure()
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
    write_json("train_speed", {"rounds": ROUNDS, "timesteps_per_measurement":
                               ROLLOUTS * 64 * 64, "load_average_before": load_before,
                               "rows": rows, "ratios": ratios})
    save_figure(plot(rows), "train_speed")
    return {"rows": rows, "ratios": ratios}


if __name__ == "__main__":
    main()
