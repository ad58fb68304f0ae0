"""How far two revisions' closed-loop episodes part, where their digests differ.

    python -m benchmarks.episode_drift --baseline /path/to/old/checkout [--seeds 20]

:mod:`benchmarks.episode_digest` says *whether* a change moves any bit. When it does on
purpose (making one satellite step exactly as one sub-env of a batch moved the single env's
last bits on some CPUs), this says *how far*: every task id on every scene, each
driven by its first scripted baseline (closed loop, so a difference can grow) for ``--seeds``
full episodes (seeds 1000 + i) on both trees. It reports the largest reward and observation
differences over every step, and the episodes whose length or success differ. Each tree runs in
a fresh interpreter (``PYTHONPATH`` set to it).

Writes ``<out>/episode_drift.json`` (default ``benchmarks/results``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from benchmarks import common

PROBE = r"""
import json, sys, warnings
import gymnasium as gym
import numpy as np
import rbenv
from rbenv.agents.baselines.controllers import BASELINES, applicable_baselines

warnings.simplefilter("ignore")
SEEDS = int(sys.argv[1])
out = {}
for env_id in sorted(rbenv.ENV_IDS):
    for scene in rbenv.list_scenes():
        if not rbenv.envs.registry.get(env_id).runs_on(scene):
            continue
        names = applicable_baselines(env_id, scene)
        if not names:
            continue
        env = gym.make(env_id, scene=scene)
        policy = BASELINES[env.unwrapped.task.name][names[0]].from_env(env)
        for seed in range(SEEDS):
            obs, info = env.reset(seed=1000 + seed)
            rewards, observations = [], []
            while True:
                action, _ = policy.predict(obs, deterministic=True)
                obs, reward, terminated, truncated, info = env.step(action)
                rewards.append(float(reward))
                observations.append(np.asarray(obs, float).tolist())
                if terminated or truncated:
                    break
            out[f"{env_id}|{scene}|{names[0]}|{seed}"] = {
                "rewards": rewards, "obs": observations,
                "success": bool(info.get("is_success", False))}
print(json.dumps(out))
"""


def compare(old: dict, new: dict) -> dict:
    """Largest differences between two runs' episodes (same keys)."""
    parted = sorted(k for k in old if len(old[k]["rewards"]) != len(new[k]["rewards"])
                    or old[k]["success"] != new[k]["success"])
    same = [k for k in old if k not in parted]
    reward = max((float(np.max(np.abs(np.subtract(old[k]["rewards"], new[k]["rewards"]))))
                  for k in same), default=0.0)
    obs = max((float(np.max(np.abs(np.subtract(old[k]["obs"], new[k]["obs"])))) for k in same),
              default=0.0)
    identical = sum(old[k]["rewards"] == new[k]["rewards"] and old[k]["obs"] == new[k]["obs"]
                    for k in old)
    return {"episodes": len(old), "steps": sum(len(e["rewards"]) for e in old.values()),
            "bit_identical_episodes": identical, "max_abs_reward_diff": reward,
            "max_abs_obs_diff": obs, "length_or_success_differs": parted}


def main(argv=()) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--baseline", required=True, help="source tree of the old revision")
    p.add_argument("--new", default=str(Path(__file__).resolve().parents[1]),
                   help="source tree of the new revision (default: this one)")
    p.add_argument("--seeds", type=int, default=20, help="episodes per id and scene")
    p.add_argument("--out", default=None,
                   help="folder for episode_drift.json (default: the benchmark results folder)")
    args = p.parse_args(argv)
    trees = {"old": Path(args.baseline).resolve(), "new": Path(args.new).resolve()}
    runs = {name: common.run_in_tree(tree, PROBE, str(args.seeds))
            for name, tree in trees.items()}
    data = {"trees": {k: {"path": str(v), "commit": common.commit(v)} for k, v in trees.items()},
            "seeds": args.seeds,
            **compare(runs["old"], runs["new"])}
    out = Path(args.out) if args.out else common.RESULTS
    out.mkdir(parents=True, exist_ok=True)
    (out / "episode_drift.json").write_text(json.dumps(data, indent=2) + "\n")
    print(json.dumps({k: v for k, v in data.items() if k != "trees"}, indent=1))
    return data


if __name__ == "__main__":
    main(sys.argv[1:])
