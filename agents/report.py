"""report.md for a training run: the trained policy beside the scripted baselines."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from agents.evaluate import SB3Policy, evaluate, format_table, plot_episodes


def plot_training_curve(run_dir: Path, path: Path) -> Path | None:
    """Success rate and mean reward of the periodic evaluations against timesteps."""
    log = run_dir / "eval" / "evaluations.npz"
    if not log.exists():
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = np.load(log)
    steps = data["timesteps"]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    if "successes" in data and data["successes"].size:
        ax.plot(steps, 100 * data["successes"].mean(axis=1), "o-", label="success rate (%)")
    ax.set_xlabel("timesteps")
    ax.set_ylabel("success rate (%)")
    ax.set_ylim(-2, 102)
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(steps, data["results"].mean(axis=1), "s--", color="C1", label="mean return")
    ax2.set_ylabel("mean return", color="C1")
    ax.set_title("Periodic evaluation during training (deterministic policy)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_report(run_dir, cfg, summary: dict) -> Path:
    """Evaluate model.zip, PD and bang-bang on the same seeded episodes; write report.md."""
    run_dir = Path(run_dir)
    trained = SB3Policy(run_dir / "model.zip", run_dir / "vecnormalize.pkl")
    kwargs = {"episodes": cfg.report_episodes, "seed": cfg.report_seed, "scene": cfg.scene,
              "env_kwargs": cfg.env_kwargs}
    results = [evaluate(trained, name=f"{cfg.algo} (trained)", **kwargs),
               evaluate("pd", **kwargs), evaluate("bangbang", **kwargs)]
    table = format_table(results)
    plot_episodes(results, run_dir / "episode.png")
    curve = plot_training_curve(run_dir, run_dir / "training_curve.png")
    (run_dir / "evaluation.json").write_text(
        json.dumps([r.summary() for r in results], indent=2) + "\n")
    minutes = summary["wall_time_s"] / 60
    lines = [
        f"# Training report: {cfg.algo.upper()} on `{cfg.scene}`",
        "",
        f"- timesteps: {summary['timesteps']:,}; wall time: {minutes:.1f} min "
        f"({cfg.n_envs} envs, seed {cfg.seed})"
        + (f"; resumed from {summary['resumed_from']:,}" if summary.get("resumed_from") else ""),
        f"- evaluation: {cfg.report_episodes} episodes seeded from {cfg.report_seed}, the same "
        "initial states for every policy; success = error < 1° and |ω| < 0.01 rad/s held "
        "for the scene's hold time",
        "",
        table,
        "",
        "![episode](episode.png)",
    ]
    if curve:
        lines += ["", "![training curve](training_curve.png)"]
    path = run_dir / "report.md"
    path.write_text("\n".join(lines) + "\n")
    print(table)
    print(f"report: {path}")
    return path
