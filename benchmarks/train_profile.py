"""Where training time goes: env stepping, wrappers, policy inference, gradient updates.

Run ``python -m benchmarks.train_profile`` (``--quick``: a smoke form). Profiles SB3's
``learn`` with cProfile on the process's CPU clock (so time the scheduler gives to other
processes is not counted) for the main job's PPO (the registry's settings, as shipped), the
fast PPO of :mod:`benchmarks.time_to_solve` and SAC as shipped for Reorient-v1, and splits the
time by the functions it passes through. Results: ``benchmarks/results/train_profile.json``.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import time

from benchmarks.common import RESULTS, table, write_json

ENV_ID = "rbenv/SatelliteReorient-v1"

# (name, algo, settings over the registry's, env steps profiled, env steps before it)
CASES = [
    # The shared PPO of every other id (today's main job on v0), on v1.
    ("ppo-main-job-v0-settings", "ppo", {"n_envs": 64, "hyperparams": {
        "n_steps": 64, "batch_size": 1024, "n_epochs": 5, "learning_rate": 5e-4,
        "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0}}}, 65_536, 0),
    ("ppo-v1-fast-path", "ppo", {}, 65_536, 0),  # Reorient-v1's own PPO (the registry's)
    # The same updates (8192 samples each) from 1024 envs x 8 steps instead of 256 x 32.
    ("ppo-v1-1024x8", "ppo", {"n_envs": 1024, "hyperparams": {"n_steps": 8}}, 65_536, 0),
    ("sac-shipped-v1", "sac", {}, 2_048, 10_016),
]

# (part, function key as pstats names it: (file suffix, function name))
PARTS = {
    "gradient updates": [("ppo/ppo.py", "train"), ("sac/sac.py", "train")],
    "rollout": [("on_policy_algorithm.py", "collect_rollouts"),
                ("off_policy_algorithm.py", "collect_rollouts")],
    "env step (rbenv vector env)": [("rbenv/envs/vector_env.py", "step")],
    "env wrappers (VecNormalize, VecMonitor, SB3VecEnv)": [("vec_normalize.py", "step_wait")],
}
# Policy inference: the rollout's calls of the policy (PPO: policy(obs); SAC: _sample_action).
INFERENCE = [("torch/nn/modules/module.py", "_wrapped_call_impl"),
             ("off_policy_algorithm.py", "_sample_action")]
ROLLOUT = PARTS["rollout"]


def _cum(stats: pstats.Stats, keys) -> float:
    total = 0.0
    for (file, _line, func), (_cc, _nc, _tt, ct, _callers) in stats.stats.items():
        if any(file.endswith(suffix) and func == name for suffix, name in keys):
            total += ct
    return total


def _cum_from(stats: pstats.Stats, keys, callers) -> float:
    """Cumulative time of the functions ``keys`` in their calls from ``callers``."""
    total = 0.0
    for (file, _line, func), (_cc, _nc, _tt, _ct, by) in stats.stats.items():
        if any(file.endswith(suffix) and func == name for suffix, name in keys):
            for (cfile, _cline, cfunc), value in by.items():
                if any(cfile.endswith(suffix) and cfunc == name for suffix, name in callers):
                    total += value[3]
    return total


def profile(name: str, algo: str, over: dict, steps: int, warm: int) -> dict:
    import torch
    from rbenv.agents.training.config import TrainConfig
    from rbenv.agents.training.sb3 import algo_class, make_vec_env, model_kwargs
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    cfg = TrainConfig(env_id=ENV_ID, algo=algo, seed=0, timesteps=steps + warm,
                      n_envs=over.get("n_envs"), hyperparams=over.get("hyperparams", {}))
    cfg = cfg.resolve()
    env = VecNormalize(make_vec_env(cfg, cfg.n_envs, 0), gamma=cfg.hyperparams.get("gamma", 0.99),
                       **(cfg.normalize or {"norm_obs": False, "norm_reward": False}))
    model = algo_class(algo)("MlpPolicy", env, seed=0, device="cpu", **model_kwargs(cfg, env))
    if warm:
        model.learn(warm)
    prof = cProfile.Profile(time.process_time)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    prof.enable()
    model.learn(steps, reset_num_timesteps=not warm)
    prof.disable()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    stats = pstats.Stats(prof)
    total = _cum(stats, [("on_policy_algorithm.py", "learn"), ("off_policy_algorithm.py",
                                                               "learn")])
    parts = {part: _cum(stats, keys) for part, keys in PARTS.items()}
    parts["policy inference"] = _cum_from(stats, INFERENCE, ROLLOUT)
    # Disjoint shares: the wrappers' time without the env's; the rollout's rest.
    parts["env wrappers (VecNormalize, VecMonitor, SB3VecEnv)"] -= \
        parts["env step (rbenv vector env)"]
    rollout = parts.pop("rollout")
    parts["rollout's other Python (buffers, callbacks, tensors)"] = rollout - sum(
        parts[k] for k in ("env step (rbenv vector env)", "policy inference",
                           "env wrappers (VecNormalize, VecMonitor, SB3VecEnv)"))
    parts["rest of learn"] = total - rollout - parts["gradient updates"]
    env.close()
    return {"case": name, "algo": algo, "n_envs": cfg.n_envs, "steps": steps,
            "updates": int(getattr(model, "_n_updates", 0)), "cpu_s": cpu, "wall_s": wall,
            "profiled_s": total, "share": {k: v / total for k, v in parts.items()},
            "settings": {k: v for k, v in cfg.hyperparams.items()}}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--cases", nargs="+", default=None, choices=[c[0] for c in CASES],
                   help="profile only these (the others are kept from the results file)")
    args = p.parse_args(argv)
    name_out = "train_profile_quick" if args.quick else "train_profile"
    kept = []
    if args.cases and (RESULTS / f"{name_out}.json").is_file():
        kept = [c for c in json.loads((RESULTS / f"{name_out}.json").read_text())["cases"]
                if c["case"] not in args.cases and c["case"] in {x[0] for x in CASES}]
    out = []
    for name, algo, over, steps, warm in CASES:
        if args.cases and name not in args.cases:
            continue
        if args.quick:
            steps, warm = (8_192, 0) if algo == "ppo" else (64, 256)
            over = {**over, "hyperparams": {**over.get("hyperparams", {}),
                                            **({"learning_starts": 128} if algo != "ppo"
                                               else {})}}
        out.append({**profile(name, algo, over, steps, warm), "load": list(os.getloadavg())})
        print(json.dumps({k: out[-1][k] for k in ("case", "cpu_s", "wall_s", "share")},
                         indent=1), flush=True)
    order = [c[0] for c in CASES]
    out = sorted(kept + out, key=lambda c: order.index(c["case"]))
    write_json(name_out, {"env_id": ENV_ID, "cases": out})
    rows = [{"case": r["case"], **{k: f"{100 * v:.0f} %" for k, v in r["share"].items()}}
            for r in out]
    print(table(rows, list(rows[0])))


if __name__ == "__main__":
    main()
