"""Scripted baselines on every task and scene, on the same seeded episodes.

    python -m benchmarks.baselines [--episodes 1000] [--seed 1000000] [--out benchmarks/results]

For each registered task and each shipped scene, evaluates every scripted baseline the task has
(reorient: quaternion PD and eigenaxis bang-bang; detumble: rate damping; track: tracking PD
with feedforward) and the do-nothing policy, all on episodes ``seed … seed + episodes − 1``.
Writes ``baselines.json`` and ``baselines.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from rbenv.agents.baselines.controllers import applicable_baselines
from rbenv.agents.policies.evaluate import evaluate

import rbenv
from benchmarks import common


def run(episodes: int, seed: int) -> list[dict]:
    """One summary row per (task, scene, policy)."""
    rows = []
    for spec in rbenv.envs.registry.specs():
        env_id, task = spec.env_id, spec.name
        for scene in filter(spec.runs_on, rbenv.list_scenes()):  # desaturate: wheels only
            for policy in (*applicable_baselines(env_id, scene), "zero"):
                start = time.perf_counter()
                s = evaluate(policy, episodes=episodes, seed=seed, scene=scene, env_id=env_id,
                             record=0).summary()
                rows.append({"task": task, "scene": scene, "policy": policy,
                             "episodes": episodes, "success_rate": s["success_rate"],
                             "settle_time_median_s": s["settle_time_s"]["median"],
                             "fuel_mean_g": 1000 * s["fuel"]["mean"],
                             "final_error_median": s["final_error_deg"]["median"],
                             "wall_s": time.perf_counter() - start})
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as a Markdown table."""
    lines = ["| task | scene | policy | success | settle median (s) | fuel mean (g) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        settle = r["settle_time_median_s"]
        lines.append(f"| {r['task']} | {r['scene']} | {r['policy']} | "
                     f"{100 * r['success_rate']:.1f}% | "
                     f"{'—' if settle is None else f'{settle:.1f}'} | {r['fuel_mean_g']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=()) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--seed", type=int, default=1_000_000)
    p.add_argument("--out", default=None,
                   help="folder for the JSON and table (default: the benchmark results folder)")
    args = p.parse_args(argv)
    rows = run(args.episodes, args.seed)
    out = Path(args.out) if args.out else common.RESULTS
    out.mkdir(parents=True, exist_ok=True)
    (out / "baselines.json").write_text(json.dumps(
        {"episodes": args.episodes, "seed": args.seed, "rows": rows}, indent=2) + "\n")
    table = markdown(rows)
    (out / "baselines.md").write_text(table)
    print(table)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
