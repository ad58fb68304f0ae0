"""report.md for a training run: the trained policy beside the scripted baselines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rbenv.agents.controllers import applicable_baselines
from rbenv.agents.evaluate import SB3Policy, evaluate, format_table, plot_episodes
from rbenv.agents.runs import atomic_write, write_json

import rbenv


def plot_training_curve(run_dir: Path, path: Path) -> Path | None:
    """Success rate and mean reward of the periodic evaluations against timesteps."""
    log = run_dir / "eval" / "evaluations.npz"
    if not log.exists():
        return None
    try:
        data = dict(np.load(log))
    except Exception as e:  # a torn file must not lose the report
        print(f"skipping the training curve: {str(log)!r} is unreadable ({e})")
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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


def task_name(env_id: str) -> str:
    """The task of a registered rbenv id ("reorient", "detumble", "track"): BASELINES' key."""
    import gymnasium as gym

    env = gym.make(env_id)
    try:
        return env.unwrapped.task.name
    finally:
        env.close()


def write_report(run_dir, cfg, summary: dict) -> Path:
    """Evaluate the final policy and the task's scripted baselines on the same seeded episodes;
    write report.md."""
    run_dir = Path(run_dir)
    trained = SB3Policy(run_dir)
    env_id = getattr(cfg, "env_id", rbenv.ENV_ID)
    kwargs = {"episodes": cfg.report_episodes, "seed": cfg.report_seed, "scene": cfg.scene,
              "env_kwargs": cfg.env_kwargs, "env_id": env_id}
    label = "trained" if summary.get("trained", True) else "UNTRAINED: no gradient step"
    results = [evaluate(trained, name=f"{cfg.algo} ({label})", **kwargs),
               *(evaluate(name, **kwargs) for name in applicable_baselines(
                   env_id, cfg.scene, cfg.env_kwargs))]
    table = format_table(results)
    plot_episodes(results, run_dir / "episode.png")
    curve = plot_training_curve(run_dir, run_dir / "training_curve.png")
    write_json(run_dir / "evaluation.json", [r.summary() for r in results])
    minutes = summary["wall_time_s"] / 60
    if not summary.get("trained", True):
        print(f"WARNING: {cfg.algo} took no gradient step; the report shows an untrained policy")
    lines = [
        f"# Training report: {cfg.algo.upper()} on `{cfg.scene}`",
        "",
        f"- timesteps: {summary['timesteps']:,}; wall time: {minutes:.1f} min "
        f"({cfg.n_envs} envs, seed {cfg.seed})"
        + (f"; resumed from {summary['resumed_from']:,}" if summary.get("resumed_from") else ""),
        f"- evaluation: {cfg.report_episodes} episodes seeded from {cfg.report_seed}, the same "
        "initial states for every policy; success = error < 1° and |ω| < 0.01 rad/s held "
        "for the scene's hold time",
        f"- load the policy with `rbenv.agents.runs.load_policy({str(run_dir)!r})`: it applies the "
        "observation normalisation (`obs_stats.npz`) that the bare weights lack",
    ]
    return finish_report(run_dir, lines, table, curve)


def finish_report(run_dir: Path, lines: list[str], table: str, curve) -> Path:
    """Append the results table and the plots to ``lines``; write ``report.md`` atomically."""
    lines = [*lines, "", table, "", "![episode](episode.png)"]
    if curve:
        lines += ["", "![training curve](training_curve.png)"]
    path = Path(run_dir) / "report.md"
    atomic_write(path, lambda p: p.write_text("\n".join(lines) + "\n"))
    print(table)
    print(f"report: {path}")
    return path
