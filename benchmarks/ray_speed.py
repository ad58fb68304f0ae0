"""Sampling throughput: RLlib with 0, 1 and 2 env runners against SB3, on this machine.

Run ``python -m benchmarks.ray_speed`` in the venv with the ray extra. Every configuration
collects env steps with its policy in the loop (forward pass, action sampling, env step,
episode bookkeeping), as during training, and no gradient step:

- SB3: ``PPO.collect_rollouts`` on ``rbenv train``'s SB3 env (64 native-vector envs);
- RLlib, 0 runners: the driver's own env runner (64 envs);
- RLlib, 1 and 2 runners: remote env runner processes of 64 envs each, sampled in parallel.

The configurations are interleaved over several rounds and the median kept, so the ratios come
from one run on one machine. Results: ``benchmarks/results/ray_speed.json`` and ``.png``.
"""

from __future__ import annotations

import os
import time

import numpy as np

from benchmarks.common import pyplot, save_figure, table, write_json

ROUNDS = 3
STEPS = 16_384  # env steps per measurement
ENVS = 64
RUNNERS = (0, 1, 2)


def _sb3():
    """A function that collects STEPS env steps with SB3 PPO; returns steps collected."""
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import make_vec_env
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    cfg = TrainConfig(n_envs=ENVS).resolve()
    env = VecNormalize(make_vec_env(cfg, ENVS, 0))
    model = PPO("MlpPolicy", env, seed=0, device="cpu", **cfg.hyperparams)
    _, callback = model._setup_learn(10**12, None)
    callback.on_training_start(locals(), globals())
    n_steps = cfg.hyperparams["n_steps"]

    def collect() -> int:
        done = 0
        while done < STEPS:
            model.collect_rollouts(model.env, callback, model.rollout_buffer, n_steps)
            done += n_steps * ENVS
        return done

    return collect, lambda: env.close()


def _rllib(runners: int):
    """A function that samples at least STEPS env steps on ``runners`` env runners."""
    from ray.rllib.execution.rollout_ops import synchronous_parallel_sample
    from rbenv.agents.training.rllib import RLlibConfig, algorithm_config, register_env

    register_env()
    cfg = RLlibConfig(env_runners=runners, envs_per_runner=ENVS).resolve()
    algo = algorithm_config(cfg).build_algo()

    def collect() -> int:
        episodes = synchronous_parallel_sample(worker_set=algo.env_runner_group,
                                               max_env_steps=STEPS, concat=True,
                                               _uses_new_env_runners=True)
        return int(sum(e.env_steps() for e in episodes))

    return collect, algo.stop


def measure(rounds: int = ROUNDS) -> list[dict]:
    import torch
    from rbenv.agents.training.ray_cluster import connect, shutdown

    torch.set_num_threads(1)
    started = connect(None, num_cpus=max(RUNNERS) + 1)
    makers = {"SB3 PPO, 1 process": _sb3,
              **{f"RLlib, {n} env runner{'s' if n != 1 else ''}": (lambda n=n: _rllib(n))
                 for n in RUNNERS}}
    samplers, closers = {}, []
    try:
        for name, make in makers.items():
            collect, close = make()
            collect()  # warm-up: allocations, first episodes, remote actors up
            samplers[name] = collect
            closers.append(close)
        rates: dict[str, list[float]] = {name: [] for name in samplers}
        for _ in range(rounds):
            for name, collect in samplers.items():
                start = time.perf_counter()
                steps = collect()
                rates[name].append(steps / (time.perf_counter() - start))
    finally:
        for close in closers:
            close()
        shutdown(started)
    base = float(np.median(rates["SB3 PPO, 1 process"]))
    return [{"config": name, "env_steps_per_s": float(np.median(v)), "samples": v,
             "relative_to_sb3": float(np.median(v)) / base} for name, v in rates.items()]


def plot(rows: list[dict]):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    labels = [r["config"].replace(", ", "\n") for r in rows]
    values = [r["env_steps_per_s"] for r in rows]
    ax.bar(labels, values, color=["C0"] + ["C1"] * (len(rows) - 1))
    for i, v in enumerate(values):
        ax.text(i, v, f"{v:,.0f}", ha="center", va="bottom")
    ax.set_ylabel("env steps/s while sampling (policy in the loop)")
    ax.set_title(f"Sampling throughput, {ENVS} envs per process, {os.cpu_count()} cores "
                 f"(median of {ROUNDS})")
    fig.tight_layout()
    return fig


def main() -> dict:
    load_before = os.getloadavg()  # others' load on a shared machine, for the record
    rows = measure()
    print(table([{k: r[k] for k in ("config", "env_steps_per_s", "relative_to_sb3")}
                 for r in rows], ["config", "env_steps_per_s", "relative_to_sb3"]))
    import ray

    write_json("ray_speed", {"rounds": ROUNDS, "env_steps_per_measurement": STEPS,
                             "envs_per_process": ENVS, "ray": ray.__version__,
                             "load_average_before": load_before, "rows": rows})
    save_figure(plot(rows), "ray_speed")
    return {"rows": rows}


if __name__ == "__main__":
    from benchmarks.common import no_options

    no_options(__doc__)
    main()
