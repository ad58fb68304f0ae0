"""A/B env speed of two source trees, measured in one run (alternating subprocesses).

    python -m benchmarks.ab_speed --baseline /path/to/old/checkout [--rounds 5] [--instructions]

A redesign must not lose speed, and on a shared machine only figures taken side by side mean
anything. This runs the same probe in a fresh interpreter for each tree (``PYTHONPATH`` set to
the tree), alternating trees round by round, and keeps the best of the rounds for each figure.
Times are process CPU time, so other programs on a shared machine inflate them little:

* ``single_us``: µs per step of the default env through ``gym.make`` (random throttles,
  resets inline), and ``pendulum_us`` for ``Pendulum-v1`` in the same process;
* ``vec_random``: env-steps/s of the native vector env at N = 4096, random throttles;
* ``vec_zero``: the same with all thrusters off (no episode ends);
* ``vec_reset_heavy``: one fixed random throttle for every sub-env and step (a few percent of
  the sub-envs lose control and autoreset each step);
* ``mem_bytes_per_env`` / ``mem_peak_bytes_per_env``: what the vector env at N = 4096 holds
  after 10 steps, and its peak, per sub-env (tracemalloc);
* ``single_instructions``, ``vec_zero_instructions``, ``vec_random_instructions``
  (``--instructions``, needs valgrind): instructions per step of the single env and of the
  vector env (N = 4096), counted by callgrind. Unlike times they do not move with the load.

Writes ``<out>/ab_speed.json`` (default ``benchmarks/results``) with both trees' figures and
the ratios new/old.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmarks import common

PROBE = common.PROBE_PRELUDE + r"""
def vec(kind, n=4096):
    env = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=n)
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    shape = env.action_space.shape
    if kind == "random":
        acts = rng.uniform(-1, 1, (16, *shape)).astype(np.float32)
    elif kind == "zero":
        acts = -np.ones((16, *shape), np.float32)
    else:
        acts = np.broadcast_to(rng.uniform(-1, 1, shape[1:]).astype(np.float32), (16, *shape))
    for i in range(20):  # warm up past the first episode ends
        env.step(acts[i % 16])
    def run(k):
        for i in range(k):
            env.step(acts[i % 16])
    return n / best(run, 20)

def memory(n=4096):  # bytes per sub-env held after 10 steps, and the peak (tracemalloc)
    import gc, tracemalloc
    gc.collect()
    tracemalloc.start()
    env = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=n)
    env.reset(seed=0)
    acts = np.random.default_rng(1).uniform(-1, 1, env.action_space.shape).astype(np.float32)
    for _ in range(10):
        env.step(acts)
    current, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return current / n, peak / n

mem, mem_peak = memory()
print(json.dumps({"single_us": 1e6 * single(gym.make("rbenv/SatelliteReorient-v0"), 3000),
                  "pendulum_us": 1e6 * single(gym.make("Pendulum-v1"), 3000),
                  "vec_random": vec("random"), "vec_zero": vec("zero"),
                  "vec_reset_heavy": vec("reset_heavy"),
                  "mem_bytes_per_env": mem, "mem_peak_bytes_per_env": mem_peak}))
"""

# Instructions per step, counted by valgrind's callgrind: deterministic, so a load on a shared
# machine cannot blur them. Arguments: the probe ("single", "vec_zero" or "vec_random") and the
# step count; the difference between two counts is the stepping alone.
COUNT = r"""
import sys
import gymnasium as gym
import numpy as np
import rbenv

probe, steps = sys.argv[1], int(sys.argv[2])
if probe == "single":
    env = gym.make("rbenv/SatelliteReorient-v0").unwrapped
    env.reset(seed=0)
    acts = 0.3 * np.random.default_rng(0).random((1000, *env.action_space.shape))
    for i in range(steps):
        _, _, te, tr, _ = env.step(acts[i % 1000].astype(np.float32))
        if te or tr:
            env.reset()
else:
    env = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=4096)
    env.reset(seed=0)
    shape = (16, *env.action_space.shape)
    acts = (-np.ones(shape) if probe == "vec_zero"
            else np.random.default_rng(1).uniform(-1, 1, shape)).astype(np.float32)
    for i in range(steps):
        env.step(acts[i % 16])
"""
STEPS = {"single": (0, 3000), "vec_zero": (2, 32), "vec_random": (2, 32)}


def instructions_per_step(tree: Path, probe: str) -> float:
    """Instructions per step of ``probe`` on ``tree`` (:func:`benchmarks.common.instructions`)."""
    low, high = STEPS[probe]
    count = [common.instructions(COUNT, probe, str(n), tree=tree) for n in (low, high)]
    return (count[1] - count[0]) / (high - low)


def _probe(tree: Path) -> dict:
    return common.run_in_tree(tree, PROBE)


def main(argv=()) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--baseline", required=True, help="source tree of the old revision")
    p.add_argument("--new", default=str(Path(__file__).resolve().parents[1]),
                   help="source tree of the new revision (default: this one)")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--instructions-only", action="store_true",
                   help="only the instruction counts (no timed rounds)")
    p.add_argument("--instructions", action="store_true",
                   help="also count instructions per step with valgrind (minutes)")
    p.add_argument("--out", default=None,
                   help="folder for ab_speed.json (default: the benchmark results folder)")
    args = p.parse_args(argv)
    trees = {"old": Path(args.baseline).resolve(), "new": Path(args.new).resolve()}
    best: dict = {name: {} for name in trees}
    for r in range(0 if args.instructions_only else args.rounds):
        for name, tree in trees.items():
            for key, value in _probe(tree).items():
                keep = min if key.endswith(("_us", "_per_env")) else max
                best[name][key] = keep(best[name].get(key, value), value)
        print(f"round {r + 1}/{args.rounds}: {best}", flush=True)
    if args.instructions or args.instructions_only:
        for name, tree in trees.items():
            for probe in STEPS:
                count = best[name][f"{probe}_instructions"] = instructions_per_step(tree, probe)
                print(f"{name}: {probe} {count:.0f} instructions per step", flush=True)
    for name in trees:
        b = best[name]
        if "single_us" in b:
            b["single_vs_pendulum"] = b["single_us"] / b["pendulum_us"]
            b["reset_heavy_vs_zero"] = b["vec_reset_heavy"] / b["vec_zero"]
    ratios = {key: best["new"][key] / best["old"][key] for key in best["new"]}
    data = {"trees": {k: str(v) for k, v in trees.items()}, "rounds": args.rounds,
            "best": best, "new_over_old": ratios,
            "notes": "µs, bytes and instruction figures: lower is better; steps/s figures: "
                     "higher is better"}
    out = Path(args.out) if args.out else common.RESULTS
    out.mkdir(parents=True, exist_ok=True)
    (out / "ab_speed.json").write_text(json.dumps(data, indent=2) + "\n")
    print(json.dumps(ratios, indent=2))
    return data


if __name__ == "__main__":
    main(sys.argv[1:])
