"""PPO's cost per sample on Reorient-v1: envs × steps per rollout, torch threads, torch.compile.

Run ``python -m benchmarks.ppo_throughput`` (``--quick``: a smoke form). SB3's PPO with the
shipped Reorient-v1 settings (batch 4096, 3 epochs, 64×64) learns ``--samples`` env steps
after a one-rollout warm-up, per case; the figure is samples per second of process CPU time
(the wall time and the load average are stored beside it: on a shared machine the wall time
measures the load). ``--cases NAME ...`` runs some of them (``--out`` names the results file).
Results: ``benchmarks/results/ppo_throughput.json``.

torch.compile (the compile cases): the policy's networks (``mlp_extractor``, ``action_net``,
``value_net``) are compiled modules, so rollouts and updates both run them; SB3's Python
around them (buffers, distributions, the optimizer step) stays eager. The warm-up rollout and
update pay the compilation (both batch shapes), outside the timed samples.
"""

from __future__ import annotations

import argparse
import os
import time

from benchmarks.common import table, write_json

ENV_ID = "rbenv/SatelliteReorient-v1"
# (name, envs, steps per rollout, torch threads, torch.compile, torch's own tanh): every case
# updates on 8192 samples. The shipped settings' "tanh" is rbenv's (NumPy's on the CPU,
# rbenv.agents.policies.activations); the "torch.tanh" cases build SB3's default torch.nn.Tanh.
CASES = [("256x32, 1 thread", 256, 32, 1, False, False),
         ("256x32, 1 thread, torch.tanh", 256, 32, 1, False, True),
         ("1024x8, 1 thread", 1024, 8, 1, False, False),
         ("2048x4, 1 thread", 2048, 4, 1, False, False),
         ("2048x4, 1 thread, torch.tanh", 2048, 4, 1, False, True),
         ("256x32, 2 threads", 256, 32, 2, False, False),
         ("256x32, 1 thread, torch.compile", 256, 32, 1, True, False),
         ("1024x8, 1 thread, torch.compile", 1024, 8, 1, True, False)]


def compile_policy(policy) -> None:
    """Replace the policy's networks by their torch.compile'd modules (same parameters)."""
    import torch

    for name in ("mlp_extractor", "action_net", "value_net"):
        setattr(policy, name, torch.compile(getattr(policy, name)))


def measure(n_envs: int, n_steps: int, threads: int, samples: int,
            compiled: bool = False, torch_tanh: bool = False) -> dict:
    import torch
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import algo_class, make_vec_env, model_kwargs
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(threads)
    cfg = TrainConfig(env_id=ENV_ID, n_envs=n_envs, hyperparams={"n_steps": n_steps}).resolve()
    if torch_tanh:
        cfg.hyperparams["policy_kwargs"]["activation_fn"] = torch.nn.Tanh
    env = VecNormalize(make_vec_env(cfg, n_envs, 0), gamma=cfg.hyperparams["gamma"],
                       **cfg.normalize)
    model = algo_class("ppo")("MlpPolicy", env, seed=0, device="cpu", **model_kwargs(cfg, env))
    if compiled:
        compile_policy(model.policy)
    cpu_w, wall_w = time.process_time(), time.perf_counter()
    model.learn(n_envs * n_steps)  # warm-up: one rollout and its update (and the compilation)
    # Inductor compiles in worker processes: their CPU is the children's, not the process's.
    warmup_cpu, warmup_wall = time.process_time() - cpu_w, time.perf_counter() - wall_w
    load0, cpu0, wall0 = os.getloadavg()[0], time.process_time(), time.perf_counter()
    model.learn(samples, reset_num_timesteps=False)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    env.close()
    return {"n_envs": n_envs, "n_steps": n_steps, "threads": threads, "compiled": compiled,
            "activation": "torch.tanh" if torch_tanh else
            str(cfg.hyperparams["policy_kwargs"].get("activation_fn", "torch.tanh")),
            "samples": samples, "warmup_cpu_s": warmup_cpu,
            "warmup_wall_s": warmup_wall, "cpu_s": cpu, "wall_s": wall,
            "samples_per_cpu_s": samples / cpu,
            "load_before": round(load0, 2), "load_after": round(os.getloadavg()[0], 2)}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=163_840)
    p.add_argument("--quick", action="store_true", help="a seconds-long smoke run (CI)")
    p.add_argument("--cases", nargs="+", default=None, choices=[c[0] for c in CASES],
                   metavar="NAME", help="run these cases only (default: all)")
    p.add_argument("--out", default="ppo_throughput", help="results name (JSON)")
    args = p.parse_args(argv)
    samples = 16_384 if args.quick else args.samples
    cases = CASES[:2] if args.quick else [c for c in CASES
                                          if args.cases is None or c[0] in args.cases]
    rows = []
    for name, n_envs, n_steps, threads, compiled, torch_tanh in cases:
        rows.append({"case": name, **measure(n_envs, n_steps, threads, samples, compiled,
                                             torch_tanh)})
        print(rows[-1], flush=True)
    write_json("ppo_throughput_quick" if args.quick else args.out,
               {"env_id": ENV_ID, "cases": rows})
    print(table(rows, ["case", "samples_per_cpu_s", "warmup_cpu_s", "warmup_wall_s", "cpu_s",
                       "wall_s", "load_before", "load_after"]))


if __name__ == "__main__":
    main()
