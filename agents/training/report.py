"""report.md of a training run, whatever its back end: the trained policy beside the task's
scripted baselines on the same seeded episodes, the periodic evaluations as a curve."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rbenv.agents.baselines.controllers import applicable_baselines, env_parts
from rbenv.agents.policies import recorded
from rbenv.agents.policies.evaluate import evaluate, format_table, plot_episodes
from rbenv.agents.policies.runfolder import EVAL_LOG, atomic_write, write_json
from rbenv.agents.training.config import RunConfig


@dataclass(frozen=True)
class Trained:
    """What a back end tells the report about its trained policy."""

    policy: object  # anything with predict() (rbenv.agents.policies.Policy)
    name: str  # its row in the results table
    title: str  # the report's heading after "Training report: "
    setup: str  # how it was sampled, e.g. "64 envs"
    load: str  # how to load it, in Markdown


def write_report(run_dir, cfg: RunConfig, summary: dict, trained: Trained) -> Path:
    """Evaluate the trained policy and the task's scripted baselines on the same seeded
    episodes; write evaluation.json, episode.png, training_curve.png and report.md."""
    run_dir = Path(run_dir)
    kwargs = {"episodes": cfg.report_episodes, "seed": cfg.report_seed, "scene": cfg.scene,
              "env_kwargs": cfg.env_kwargs, "env_id": cfg.env_id}
    results = [evaluate(trained.policy, name=trained.name, **kwargs),
               *(evaluate(name, **kwargs) for name in applicable_baselines(
                   cfg.env_id, cfg.scene, cfg.env_kwargs))]
    mpc, notes = mpc_rows(cfg, kwargs)
    results += mpc
    table = "\n".join([format_table(results), *(f"\n{n}" for n in notes)])
    plot_episodes(results, run_dir / "episode.png")
    curve = plot_training_curve(run_dir, run_dir / "training_curve.png")
    write_json(run_dir / "evaluation.json", [r.summary() for r in results])
    lines = [
        f"# Training report: {trained.title}",
        "",
        f"- timesteps: {summary['timesteps']:,}; wall time: {duration(summary['wall_time_s'])} "
        f"({trained.setup}, seed {cfg.seed})"
        + (f"; resumed from {summary['resumed_from']:,}" if summary.get("resumed_from") else "")
        + ("; stopped by its time limit (--max-minutes)" if summary.get("stopped_by_time_limit")
           else "")
        + (f"; stopped when {100 * stop['success_rate']:.0f} % of {stop['episodes']} validation "
           "episodes succeeded (--stop-success)"
           if (stop := summary.get("stopped_at_success")) else ""),
        *kept_lines(summary.get("kept")),
        f"- evaluation: {cfg.report_episodes} episodes seeded from {cfg.report_seed}, the same "
        f"initial states for every policy; {success_rule(cfg)}",
        f"- load the policy with {trained.load}",
        "",
        table,
        "",
        "![episode](episode.png)",
    ]
    if curve:
        lines += ["", "![training curve](training_curve.png)"]
    path = run_dir / "report.md"
    atomic_write(path, lambda p: p.write_text("\n".join(lines) + "\n"))
    print(table)
    print(f"report: {path}")
    return path


def mpc_rows(cfg: RunConfig, kwargs: dict) -> tuple[list, list[str]]:
    """The MPC beside the policy: evaluated here with ``--report-mpc``, else its recorded
    results where they stand for the report's episodes (with the line that says so), else
    nothing."""
    if cfg.report_mpc:
        return [evaluate("mpc", **kwargs)], []
    rec = recorded.lookup("mpc", cfg.env_id, cfg.scene, cfg.env_kwargs,
                          cfg.report_episodes, cfg.report_seed)
    return ([rec.result], [rec.note]) if rec else ([], [])


def success_rule(cfg: RunConfig) -> str:
    """The success thresholds of the run's task on its scene, in words (the scene's own
    values: innocube-3u's are not cubesat-12u's)."""
    import gymnasium as gym

    env = gym.make(cfg.env_id, **{**cfg.env_kwargs,
                                  **({"scene": cfg.scene} if cfg.scene else {})})
    plant, task = env_parts(env)
    ep = plant.scene.episode
    env.close()
    return (f"success as task {task.name!r} defines it (docs/tasks.md), with the thresholds "
            f"of scene {plant.scene.name!r}: attitude error < {ep.success_angle_deg:g}°, "
            f"|ω| < {ep.success_rate:g} rad/s, held {ep.hold_time:g} s")


def duration(seconds: float) -> str:
    """A training time as the report writes it: seconds below two minutes, else minutes."""
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def kept_lines(kept: dict | None) -> list[str]:
    """The report's line on which evaluated policy the run kept (--keep-best)."""
    if not kept:
        return []
    last = kept["last"]
    return [f"- policy kept (--keep-best): the one evaluated at {kept['timesteps']:,} timesteps "
            f"({100 * kept['success_rate']:.0f} % success in {kept['episodes']} validation "
            f"episodes, mean return {kept['mean_return']:.3g}); at the last step, "
            f"{last['timesteps']:,}: {100 * last['success_rate']:.0f} %, "
            f"{last['mean_return']:.3g}"]


def plot_training_curve(run_dir: Path, path: Path) -> Path | None:
    """Success rate and mean reward of the periodic evaluations against timesteps."""
    log = run_dir / EVAL_LOG
    if not log.exists():
        return None
    try:
        with open(log, "rb") as f, np.load(f) as npz:  # closed also when the zip is torn
            data = dict(npz)
    except Exception as e:  # a torn file must not lose the report
        print(f"skipping the training curve: {str(log)!r} is unreadable ({e})")
        return None
    import matplotlib  # the train extra

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
