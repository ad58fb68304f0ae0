"""Long ``rbenv train`` runs of the off-policy learners with their shipped settings (issue 22).

Each run is an ordinary ``rbenv train`` run folder (kept outside git). ``collect`` copies what
the tables need from it into ``benchmarks/results/rl/off_policy/<name>.json``: the settings,
the training summary (steps, wall time, gradient updates), the report's held-out evaluation
(500 episodes, seeds 1,000,000 + i, deterministic policy, beside the PD and bang-bang on the
same episodes), the periodic evaluations, and the machine's load average during the run
(from a ``time load1 load5 load15`` log, if given). ``summary`` writes ``summary.md`` from
the JSONs, so every number in the docs regenerates from them.

    rbenv train --algo sac --out RUN --eval-every 50000 --checkpoint-every 50000
    python -m benchmarks.rl.off_policy collect RUN sac-reorient-seed0 \\
        --command "rbenv train ..." [--load LOADLOG]
    python -m benchmarks.rl.off_policy summary
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parents[1] / "results" / "rl" / "off_policy"
# Issue 22's targets on SatelliteReorient-v0/cubesat-12u.
TARGET_SUCCESS = {"sac": 0.99}
TARGET_MINUTES = {"sac": 15.0}


def _load_during(log: Path, start: float, end: float) -> dict | None:
    rows = []
    for line in Path(log).read_text().splitlines():
        parts = line.split()
        if len(parts) == 4 and start <= float(parts[0]) <= end:
            rows.append([float(p) for p in parts[1:]])
    if not rows:
        return None
    load1 = np.array(rows)[:, 0]
    return {"samples": len(rows), "load1_mean": float(load1.mean()),
            "load1_min": float(load1.min()), "load1_max": float(load1.max())}


def collect(run: Path, name: str, command: str, load_log: Path | None = None,
            checkpoints: list[tuple[int, float | None, Path, str]] = ()) -> Path:
    """``checkpoints``: (timesteps, training wall time at it as ``latest.json`` recorded it,
    ``rbenv evaluate --json`` file, its command) for checkpoints evaluated on the same held-out
    episodes as the final model."""
    run = Path(run)
    config = json.loads((run / "config.json").read_text())
    summary = json.loads((run / "training.json").read_text())
    evaluation = json.loads((run / "evaluation.json").read_text())
    curve = None
    if (run / "eval" / "evaluations.npz").is_file():
        with np.load(run / "eval" / "evaluations.npz") as d:
            curve = {"timesteps": d["timesteps"].tolist(),
                     "success_rate": [float(np.mean(s)) for s in d["successes"]],
                     "mean_return": [float(np.mean(r)) for r in d["results"]]}
    load = None
    if load_log is not None:
        end = (run / "training.json").stat().st_mtime
        load = _load_during(load_log, end - summary["wall_time_s"], end)
    data = {"name": name, "command": command,
            "settings": {k: config[k] for k in ("algo", "env_id", "scene", "seed", "n_envs",
                                                "timesteps", "hyperparams", "env_kwargs",
                                                "normalize", "threads")},
            "versions": config.get("versions"), "training": summary,
            "held_out": evaluation, "curve": curve, "load_average_during_training": load,
            "held_out_checkpoints": []}
    for steps, wall, path, how in checkpoints:
        result = json.loads(Path(path).read_text())
        result = result[0] if isinstance(result, list) else result
        data["held_out_checkpoints"].append({"timesteps": steps, "wall_time_s": wall,
                                             "command": how, "result": result})
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(data, indent=2) + "\n")
    return path


def _fmt(value, spec: str, missing: str = "—") -> str:
    return missing if value is None else format(value, spec)


def summary(directory: Path = RESULTS) -> Path:
    lines = ["| run | algo | env steps | wall time (min) | env-steps/s | gradient updates | "
             "load avg (1 min) | held-out success | fuel mean (g) | settle median (s) | "
             "final error median (deg) | target |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    baselines = {}
    for path in sorted(directory.glob("*.json")):
        data = json.loads(path.read_text())
        s, t = data["settings"], data["training"]
        trained, *others = data["held_out"]
        for b in others:
            baselines.setdefault(b["policy"], b)
        minutes = t["wall_time_s"] / 60
        algo = s["algo"]
        target = "—"
        if algo in TARGET_SUCCESS:
            met = (trained["success_rate"] >= TARGET_SUCCESS[algo]
                   and minutes <= TARGET_MINUTES[algo])
            target = (f"{'met' if met else 'missed'} (>= {TARGET_SUCCESS[algo]:.0%} in "
                      f"<= {TARGET_MINUTES[algo]:g} min)")
        load = data.get("load_average_during_training") or {}
        lines.append(
            f"| {data['name']} | {algo} | {t['timesteps']:,} | {minutes:.1f} | "
            f"{t['timesteps'] / t['wall_time_s']:.0f} | {t['gradient_updates']:,} | "
            f"{_fmt(load.get('load1_mean'), '.1f')} | "
            f"{100 * trained['success_rate']:.1f} % ({trained['episodes']} episodes) | "
            f"{1e3 * trained['fuel']['mean']:.2f} | "
            f"{_fmt(trained['settle_time_s']['median'], '.1f')} | "
            f"{trained['final_error_deg']['median']:.3g} | {target} |")
        for c in data.get("held_out_checkpoints", []):
            r = c["result"]
            wall = c.get("wall_time_s")
            lines.append(
                f"| {data['name']}, checkpoint {c['timesteps'] // 1000}k | {algo} | "
                f"{c['timesteps']:,} | {_fmt(wall and wall / 60, '.1f')} | — | — | — | "
                f"{100 * r['success_rate']:.1f} % ({r['episodes']} episodes) | "
                f"{1e3 * r['fuel']['mean']:.2f} | {_fmt(r['settle_time_s']['median'], '.1f')} | "
                f"{r['final_error_deg']['median']:.3g} | — |")
    lines += ["", "Periodic deterministic evaluation during training (100 episodes from seed "
              "10,000; not the held-out set):", "", "| run | success at timesteps |", "|---|---|"]
    for path in sorted(directory.glob("*.json")):
        data = json.loads(path.read_text())
        curve = data.get("curve") or {"timesteps": [], "success_rate": []}
        points = ", ".join(f"{t // 1000}k: {100 * r:.0f} %"
                           for t, r in zip(curve["timesteps"], curve["success_rate"], strict=True))
        lines.append(f"| {data['name']} | {points or '—'} |")
    lines += ["", "Scripted baselines on the same held-out episodes (torque-mode env options):",
              "", "| policy | success | fuel mean (g) | settle median (s) |", "|---|---|---|---|"]
    for name, b in baselines.items():
        lines.append(f"| {name} | {100 * b['success_rate']:.1f} % | "
                     f"{1e3 * b['fuel']['mean']:.2f} | "
                     f"{_fmt(b['settle_time_s']['median'], '.1f')} |")
    lines += ["", "Commands: the `command` field of each JSON. Generated by "
              "`python -m benchmarks.rl.off_policy summary`.", ""]
    path = directory / "summary.md"
    path.write_text("\n".join(lines))
    return path


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="action", required=True)
    c = sub.add_parser("collect", help="copy a run folder's results into a JSON")
    c.add_argument("run")
    c.add_argument("name")
    c.add_argument("--command", required=True, help="the exact command that trained the run")
    c.add_argument("--load", default=None, help="load-average log: 'unix_time l1 l5 l15' lines")
    c.add_argument("--checkpoint", nargs=4, action="append", default=[],
                   metavar=("STEPS", "WALL_S", "JSON", "COMMAND"),
                   help="a checkpoint: its timesteps, training wall time (s; '-' if unknown), "
                        "rbenv evaluate --json result and the command that made it")
    sub.add_parser("summary", help="write summary.md from the JSONs")
    args = p.parse_args(argv)
    if args.action == "collect":
        print(collect(Path(args.run), args.name, args.command,
                      Path(args.load) if args.load else None,
                      [(int(n), None if w == "-" else float(w), Path(j), c)
                       for n, w, j, c in args.checkpoint]))
    print(summary())


if __name__ == "__main__":
    main()
