"""Long ``rbenv train`` runs of the off-policy learners with their shipped settings.

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

from benchmarks.common import fmt

RESULTS = Path(__file__).resolve().parents[1] / "results" / "rl" / "off_policy"
# The off-policy targets on SatelliteReorient-v0 and -v1/cubesat-12u (PPO: success, and its
# propellant at most the PD's on the same episodes). A run trained with --keep-best is judged
# on the policy it kept (training.json's "kept" names its step) after its whole wall time.
TARGET_SUCCESS = {"sac": 0.99, "tqc": 0.95, "td3": 0.95, "crossq": 0.95, "ppo": 0.99}
TARGET_MINUTES = {"sac": 15.0, "tqc": 30.0, "td3": 30.0, "crossq": 30.0}
OTHER_TASKS_SUCCESS = 0.95  # the best off-policy learner on Detumble-v1 and Track-v1


def _training(run: Path) -> dict:
    """training.json, or for a run stopped before its end (a time limit) what its last
    checkpoint recorded (``stopped``: True)."""
    if (run / "training.json").is_file():
        return json.loads((run / "training.json").read_text())
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    meta = run / "checkpoints" / (Path(latest["model"]).stem + ".json")
    updates = json.loads(meta.read_text()).get("n_updates") if meta.is_file() else None
    return {"timesteps": latest["timesteps"], "wall_time_s": latest["wall_time_s"],
            "gradient_updates": updates, "stopped": True, "trained": False}


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
            checkpoints: list[tuple[int, float | None, Path, str]] = (),
            results: Path = RESULTS) -> Path:
    """``checkpoints``: (timesteps, training wall time at it as ``latest.json`` recorded it,
    ``rbenv evaluate --json`` file, its command) for checkpoints evaluated on the same held-out
    episodes as the final model."""
    run = Path(run)
    config = json.loads((run / "config.json").read_text())
    summary = _training(run)
    evaluation = json.loads((run / "evaluation.json").read_text()) \
        if (run / "evaluation.json").is_file() else None
    curve = None
    if (run / "eval" / "evaluations.npz").is_file():
        with np.load(run / "eval" / "evaluations.npz") as d:
            curve = {"timesteps": d["timesteps"].tolist(),
                     "success_rate": [float(np.mean(s)) for s in d["successes"]],
                     "mean_return": [float(np.mean(r)) for r in d["results"]]}
    load = None
    if load_log is not None:
        end = (run / ("checkpoints/latest.json" if summary.get("stopped")
                      else "training.json")).stat().st_mtime
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
    results.mkdir(parents=True, exist_ok=True)
    path = results / f"{name}.json"
    path.write_text(json.dumps(data, indent=2) + "\n")
    return path


def _target(algo: str, result: dict, minutes, pd: dict | None, env_id: str = "") -> str:
    """Whether a held-out result meets the off-policy target for ``algo`` on ``env_id`` (on
    Detumble and Track: the best off-policy learner >= 95 %, no time budget)."""
    if algo not in TARGET_SUCCESS:
        return "—"
    if algo in TARGET_MINUTES and "Reorient" not in env_id:
        ok = result["success_rate"] >= OTHER_TASKS_SUCCESS
        return f"{'met' if ok else 'missed'} (>= {OTHER_TASKS_SUCCESS:.0%})"
    ok = result["success_rate"] >= TARGET_SUCCESS[algo]
    rule = f">= {TARGET_SUCCESS[algo]:.0%}"
    if algo in TARGET_MINUTES:
        ok = ok and minutes is not None and minutes <= TARGET_MINUTES[algo]
        rule += f" in <= {TARGET_MINUTES[algo]:g} min"
    if algo == "ppo" and pd is not None:
        ok = ok and result["fuel"]["mean"] <= pd["fuel"]["mean"]
        rule += ", fuel <= PD's"
    return f"{'met' if ok else 'missed'} ({rule})"


def _result_cells(r: dict) -> str:
    return (f"{100 * r['success_rate']:.1f} % ({r['episodes']} episodes) | "
            f"{1e3 * r['fuel']['mean']:.2f} | {fmt(r['settle_time_s']['median'], '.1f')} | "
            f"{r['final_error_deg']['median']:.3g}")


def _rows(data: dict, baselines: dict) -> list:
    """The table rows of one run: its final model (or that it was stopped) and checkpoints."""
    s, t = data["settings"], data["training"]
    algo, minutes = s["algo"], t["wall_time_s"] / 60
    load = data.get("load_average_during_training") or {}
    head = (f"| {data['name']} | {s['env_id'].split('/')[-1]} | {algo} | {t['timesteps']:,} | "
            f"{minutes:.1f} | {t['timesteps'] / t['wall_time_s']:.0f} | "
            f"{fmt(t['gradient_updates'], ',')} | {fmt(load.get('load1_mean'), '.1f')} | ")
    pd = None
    if data["held_out"] is None:
        rows = [head + "stopped at its time limit: no final model | — | — | — | — |"]
    else:
        trained, *others = data["held_out"]
        for b in others:
            baselines.setdefault((s["env_id"], b["policy"]), b)
        pd = next((b for b in others if b["policy"] == "pd"), None)
        kept = t.get("kept")  # --keep-best: the policy is the best validated one
        cells = _result_cells(trained)
        if kept:
            cells = cells.replace(" episodes)", f" episodes; policy of step "
                                  f"{kept['timesteps']:,})", 1)
        rows = [head + f"{cells} | {_target(algo, trained, minutes, pd, s['env_id'])} |"]
    for c in data.get("held_out_checkpoints", []):
        r, wall = c["result"], c.get("wall_time_s")
        rows.append(f"| {data['name']}, checkpoint {c['timesteps'] // 1000}k | "
                    f"{s['env_id'].split('/')[-1]} | {algo} | {c['timesteps']:,} | "
                    f"{fmt(wall and wall / 60, '.1f')} | — | — | — | {_result_cells(r)} | "
                    f"{_target(algo, r, wall and wall / 60, pd, s['env_id'])} |")
    return rows


def summary(directory: Path = RESULTS) -> Path:
    lines = ["| run | env | algo | env steps | wall time (min) | env-steps/s | gradient updates "
             "| load avg (1 min) | held-out success | fuel mean (g) | settle median (s) | "
             "final error median (deg) | target |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    baselines: dict = {}
    runs = [json.loads(p.read_text()) for p in sorted(directory.glob("*.json"))]
    for data in runs:
        lines += _rows(data, baselines)
    lines += ["", "Periodic deterministic evaluation during training (100 validation episodes; "
              "not the held-out set):", "", "| run | success at timesteps |", "|---|---|"]
    for data in runs:
        curve = data.get("curve") or {"timesteps": [], "success_rate": []}
        points = ", ".join(f"{t // 1000}k: {100 * r:.0f} %"
                           for t, r in zip(curve["timesteps"], curve["success_rate"], strict=True))
        lines.append(f"| {data['name']} | {points or '—'} |")
    lines += ["", "Scripted baselines on the same held-out episodes (each run's env options):",
              "", "| env | policy | success | fuel mean (g) | settle median (s) |",
              "|---|---|---|---|---|"]
    for (env_id, name), b in baselines.items():
        lines.append(f"| {env_id.split('/')[-1]} | {name} | {100 * b['success_rate']:.1f} % | "
                     f"{1e3 * b['fuel']['mean']:.2f} | "
                     f"{fmt(b['settle_time_s']['median'], '.1f')} |")
    where = Path(directory).resolve().relative_to(RESULTS.parents[3])
    lines += ["", "Commands: the `command` field of each JSON. Generated by "
              f"`python -m benchmarks.rl.off_policy --results {where} summary`.", ""]
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
    p.add_argument("--results", default=str(RESULTS),
                   help="folder of the JSONs and summary.md (default: the off-policy study's)")
    args = p.parse_args(argv)
    results = Path(args.results)
    if args.action == "collect":
        print(collect(Path(args.run), args.name, args.command,
                      Path(args.load) if args.load else None,
                      [(int(n), None if w == "-" else float(w), Path(j), c)
                       for n, w, j, c in args.checkpoint], results))
    print(summary(results))


if __name__ == "__main__":
    main()
