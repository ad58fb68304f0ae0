"""``rbenv suite``: the learning suite, algorithm × task × scene × seed, with reference results.

Each cell of the grid is one training run (:mod:`rbenv.agents.training.sb3`, resumable) in
``OUT/cells/<cell.name>/run``, then one held-out evaluation: the trained policy and every
scripted baseline of the task on the same seeded episodes (episode i seeded ``eval_seed + i``).
The cell's outcome is written atomically to ``OUT/cells/<cell.name>/result.json``; a cell whose
result is complete is not trained again, so a killed suite resumes where it stopped.
:func:`aggregate` turns the results into ``suite.json``, ``suite.md`` (mean ± spread over seeds
beside the baselines) and ``learning_curves.png``.

The grid API (:class:`Cell`, :func:`grid`, :func:`run_cell`, :func:`aggregate`) is what any
runner uses: :func:`run_serial` here, or a runner that places cells on other processes.
"""

from __future__ import annotations

import argparse
import math
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from rbenv.agents import settings
from rbenv.agents.baselines.controllers import applicable_baselines
from rbenv.agents.policies import runfolder
from rbenv.agents.policies.evaluate import evaluate
from rbenv.agents.policies.runfolder import RunFolderError, read_json, write_json
from rbenv.agents.policies.sb3 import SB3Policy
from rbenv.agents.training.config import TrainConfig

import rbenv

RESULT_VERSION = 3  # 3: mean-throttle action, checkpoints selected on validation episodes
# The grid's tasks come from the env registry (rbenv.envs.registry), their budgets from the
# training settings (rbenv.agents.settings).
EVAL_EPISODES, EVAL_SEED = 500, 1_000_000
VALIDATION_EPISODES, VALIDATION_SEED = 100, 2_000_000  # checkpoint selection, not held out
CURVE_POINTS = 10  # periodic evaluations per training run (the learning curve)
CURVE_EPISODES = 50
QUICK = {"algos": ["ppo"], "tasks": ["detumble", "reorient"], "scenes": ["cubesat-12u"],
         "seeds": 1, "timesteps": 8192, "episodes": 20}


def task_of(env_id: str) -> str:
    """Short name of a registered id ("reorient", "detumble", "track")."""
    if env_id in tasks().values():
        return rbenv.envs.registry.get(env_id).name
    return re.sub(r"[^a-z0-9]+", "-", env_id.lower()).strip("-")


@dataclass(frozen=True)
class Cell:
    """One training run of the grid."""

    algo: str
    env_id: str
    scene: str
    seed: int
    timesteps: int

    @property
    def task(self) -> str:
        return task_of(self.env_id)

    @property
    def name(self) -> str:
        """Folder name, stable across runs: ``<algo>-<task>-<scene>-seed<seed>``.

        The budget is not part of it: a cell given a larger budget resumes its run there and
        trains on to the new total.
        """
        return f"{self.algo}-{self.task}-{self.scene}-seed{self.seed}"


def tasks() -> dict:
    """Short task name → env id, for every registered task."""
    return {spec.name: spec.env_id for spec in rbenv.envs.registry.specs()}


def default_timesteps(algo: str, env_id: str, scene: str) -> int:
    """The full suite's budget for ``algo`` on ``env_id`` and ``scene``: the ``n_timesteps`` of
    its recipe for SB3 on that scene (rbenv.agents.settings), as ``rbenv train`` trains."""
    return settings.get(env_id).recipe(algo, "sb3", scene)["n_timesteps"]


def grid(algos: Iterable[str], env_ids: Iterable[str], scenes: Iterable[str],
         seeds: Iterable[int], timesteps_for: Callable[[str, str, str], int] | int
         ) -> list[Cell]:
    """Every cell, seed-major (all of seed 0 first, so a partial run covers the grid once).

    ``timesteps_for(algo, env_id, scene)`` gives each cell's budget (or one int for all).
    """
    budget = timesteps_for if callable(timesteps_for) else (lambda *_: int(timesteps_for))
    scenes = list(scenes)
    return [Cell(algo, env_id, scene, int(seed), int(budget(algo, env_id, scene)))
            for seed in seeds for env_id in env_ids for scene in scenes for algo in algos
            if rbenv.envs.registry.get(env_id).runs_on(scene)]  # desaturation needs wheels


# --- one cell ---------------------------------------------------------------------------------

def cell_dir(cell: Cell, out: Path) -> Path:
    return Path(out) / "cells" / cell.name


def read_result(path: Path, cell: Cell | None = None) -> dict | None:
    """A complete result.json (for ``cell`` if given), else None."""
    try:
        data = read_json(path, "cell result")
    except RunFolderError:
        return None
    if not data.get("complete") or data.get("version") != RESULT_VERSION:
        return None
    if cell is not None and data.get("cell") != asdict(cell):
        return None
    return data


def train_config(cell: Cell, run: Path, threads: int):
    """The TrainConfig of ``cell``: the algorithm's shipped defaults, periodic evaluations."""
    every = max(cell.timesteps // CURVE_POINTS, 1)
    return TrainConfig(algo=cell.algo, env_id=cell.env_id, scene=cell.scene, seed=cell.seed,
                       timesteps=cell.timesteps, out=str(run), threads=threads,
                       eval_every=every, checkpoint_every=every,
                       eval_episodes=CURVE_EPISODES, keep_best=False,  # select_checkpoint
                       stop_success=0.0,  # a cell trains its whole budget
                       # a cell given a larger budget resumes as if never stopped
                       save_replay_buffer=True)


def train_cell(cell: Cell, run: Path, threads: int) -> dict:
    """Train ``cell`` in ``run`` (resuming what is there); returns training.json."""
    from rbenv.agents.training.sb3 import train  # the train extra (SB3, torch)

    cfg = train_config(cell, run, threads)
    resume = (run / runfolder.CONFIG).is_file()
    train(cfg, resume=resume, force=not resume, progress_bar=False, report=False)
    return read_json(run / runfolder.SUMMARY, "training summary")


def _settings(run: Path) -> dict:
    """What the run was trained with (from its config.json): n_envs and hyperparameters."""
    config = runfolder.read_config(run)
    return {"n_envs": config.get("n_envs"), "hyperparams": config.get("hyperparams")}


def learning_curve(run: Path) -> dict:
    """Periodic evaluations of the run: timesteps and success rate at each."""
    log = run / runfolder.EVAL_LOG
    if not log.is_file():
        return {"timesteps": [], "success_rate": []}
    with np.load(log) as data:
        steps = data["timesteps"].tolist()
        success = [float(np.mean(s)) if len(s) else 0.0 for s in data["successes"]]
    return {"timesteps": steps, "success_rate": success}


def checkpoint_at(run: Path, steps: int) -> Path | None:
    """The model file of the run's checkpoint at ``steps``, in any format the run folder holds
    (policy_<N>.pt; an older run's model_<N>.zip), pickle-free first; None if there is none."""
    for ckpt in runfolder.checkpoints(run / runfolder.CHECKPOINTS, report=lambda _: None):
        if ckpt.steps == steps and ckpt.model.is_file():
            return ckpt.model
    return None


def select_checkpoint(run: Path, curve: dict) -> tuple[Path, int]:
    """The checkpoint with the best validation success in ``curve``, the latest among equals.

    The validation episodes (:func:`validation_curve`) are never the held-out ones, so this is
    model selection on a validation set. Without a checkpoint at that step, the final model.
    """
    if curve["success_rate"]:
        best = max(curve["success_rate"])
        steps = max(t for t, x in zip(curve["timesteps"], curve["success_rate"], strict=True)
                    if x == best)
        model = checkpoint_at(run, steps)
        if model is not None:
            return model, steps
    summary = read_json(run / runfolder.SUMMARY, "summary")
    return run / runfolder.FINAL_MODEL, int(summary["timesteps"])


def run_env_kwargs(run: Path) -> dict:
    """The gym.make options the run trained with (its config.json), which its policies are
    evaluated in: they fix the action space (the off-policy recipe's ``action_mode="torque"``)
    as ``rbenv train``'s own report does."""
    return dict(runfolder.read_config(run).get("env_kwargs") or {})


def validation_curve(cell: Cell, run: Path, episodes: int, seed: int = VALIDATION_SEED,
                     env_kwargs: dict | None = None) -> dict:
    """Success of every checkpoint (:class:`SB3Policy`'s "auto" action) on ``episodes``
    validation episodes of the cell's task and scene; ``env_kwargs``: further gym.make
    options of the env the run trained in (physics setting, randomization)."""
    ckpts = sorted(runfolder.checkpoints(run / runfolder.CHECKPOINTS, report=lambda _: None),
                   key=lambda c: c.steps)
    curve = {"timesteps": [], "success_rate": []}
    for ckpt in ckpts:
        s = evaluate(SB3Policy(ckpt.model, action="auto"), episodes=episodes,
                     seed=seed, scene=cell.scene, env_id=cell.env_id, record=0,
                     env_kwargs=env_kwargs).summary()
        curve["timesteps"].append(ckpt.steps)
        curve["success_rate"].append(s["success_rate"])
    return curve


def evaluate_cell(cell: Cell, run: Path, episodes: int, seed: int) -> dict:
    """On the same held-out episodes: the checkpoint selected on validation episodes and the
    final model (both with "auto": the mean action on a scene with thrusters, μ on wheels and
    rods alone), the final model with SB3's deterministic action μ (the env clips it), and
    every scripted baseline of the task."""
    common = {"episodes": episodes, "seed": seed, "scene": cell.scene, "env_id": cell.env_id,
              "record": 0}
    trained_in = {**common, "env_kwargs": run_env_kwargs(run)}
    curve = validation_curve(cell, run, min(episodes, VALIDATION_EPISODES),
                             env_kwargs=trained_in["env_kwargs"])
    model, steps = select_checkpoint(run, curve)
    policy = evaluate(SB3Policy(model, action="auto"), name=cell.algo,
                      **trained_in).summary()
    final = evaluate(SB3Policy(run, action="auto"), name=f"{cell.algo} (final)",
                     **trained_in).summary()
    clip_mean = evaluate(SB3Policy(run, action="mode"), name=f"{cell.algo} (final, clip(mean))",
                         **trained_in).summary()
    baselines = {name: evaluate(name, **common).summary()
                 for name in applicable_baselines(cell.env_id, cell.scene)}
    return {"policy": {**policy, "timesteps": steps}, "final": final,
            "final_clip_mean": clip_mean, "baselines": baselines, "learning_curve": curve}


def checkpoint_progress(cell: Cell, out: Path, *, episodes: int = 200,
                        seed: int = EVAL_SEED) -> list[dict]:
    """Held-out success and median final error of every checkpoint ("auto" action).

    The evidence for a cell that misses its target: whether the policy was still improving
    when its budget ran out, and how far from the success thresholds it ends.
    """
    rows = []
    run = cell_dir(cell, out) / "run"
    env_kwargs = run_env_kwargs(run)
    ckpts = sorted(runfolder.checkpoints(run / runfolder.CHECKPOINTS, report=lambda _: None),
                   key=lambda c: c.steps)
    for ckpt in ckpts:
        s = evaluate(SB3Policy(ckpt.model, action="auto"), episodes=episodes,
                     seed=seed, scene=cell.scene, env_id=cell.env_id, record=0,
                     env_kwargs=env_kwargs).summary()
        rows.append({"timesteps": ckpt.steps, "success_rate": s["success_rate"],
                     "final_error_deg_median": s["final_error_deg"]["median"],
                     "fuel_g": 1000 * s["fuel"]["mean"]})
    return rows


def run_cell(cell: Cell, out: Path, *, eval_episodes: int, eval_seed: int,
             threads: int = 1) -> dict:
    """Train, evaluate beside the baselines, write ``cells/<name>/result.json``; return it.

    A complete result.json for the same cell is returned as is (nothing is retrained).
    """
    from rbenv.agents.training.sb3 import set_threads  # the train extra (torch)

    folder = cell_dir(cell, out)
    path = folder / "result.json"
    done = read_result(path, cell)
    if done is not None and done["eval"] == {"episodes": eval_episodes, "seed": eval_seed}:
        return done
    folder.mkdir(parents=True, exist_ok=True)
    run = folder / "run"
    summary = train_cell(cell, run, threads)
    set_threads(threads)
    started = time.perf_counter()
    evaluation = evaluate_cell(cell, run, eval_episodes, eval_seed)
    result = {"version": RESULT_VERSION, "complete": True, "cell": asdict(cell),
              "name": cell.name, "task": cell.task,
              "eval": {"episodes": eval_episodes, "seed": eval_seed},
              "training": {**{k: summary.get(k) for k in ("timesteps", "wall_time_s",
                                                          "gradient_updates", "threads")},
                           **_settings(run)},
              "eval_wall_time_s": time.perf_counter() - started,
              "training_curve": learning_curve(run), **evaluation}
    write_json(path, result)
    return result


# --- aggregate --------------------------------------------------------------------------------

def _stats(values: list[float]) -> dict:
    """mean, std (population), min, max and n of finite values (None when there are none)."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], float)
    if not len(v):
        return {"mean": None, "std": None, "min": None, "max": None, "n": 0}
    return {"mean": float(v.mean()), "std": float(v.std()), "min": float(v.min()),
            "max": float(v.max()), "n": len(v)}


def _metrics(summary: dict) -> dict:
    return {"success_rate": summary["success_rate"], "fuel_g": 1000 * summary["fuel"]["mean"],
            "settle_median_s": summary["settle_time_s"]["median"]}


def group_results(results: list[dict]) -> list[dict]:
    """One row per algorithm × task × scene: stats over seeds, and the task's baselines."""
    groups: dict[tuple, list[dict]] = {}
    for r in results:
        c = r["cell"]
        groups.setdefault((c["algo"], r["task"], c["scene"]), []).append(r)
    rows = []
    for (algo, task, scene), rs in sorted(groups.items(), key=lambda kv: (kv[0][1], kv[0][2],
                                                                           kv[0][0])):
        per_seed = [_metrics(r["policy"]) for r in rs]
        stats = {k: _stats([m[k] for m in per_seed]) for k in per_seed[0]}
        baselines = {}
        for name in rs[0]["baselines"]:
            # Every seed's cell evaluated the baseline itself: identical unless the episodes
            # (or the env's code) differed between them.
            seen = [_metrics(r["baselines"][name]) for r in rs]
            baselines[name] = {**seen[0], "identical_in_every_seed": all(m == seen[0]
                                                                         for m in seen)}
        best = max(b["success_rate"] for b in baselines.values())
        rows.append({"algo": algo, "task": task, "scene": scene,
                     "seeds": sorted(r["cell"]["seed"] for r in rs),
                     "timesteps": sorted({r["training"]["timesteps"] for r in rs}),
                     "train_wall_time_s": _stats([r["training"]["wall_time_s"] for r in rs]),
                     **stats, "final_success_rate": _stats([r["final"]["success_rate"]
                                                             for r in rs]),
                     "final_clip_mean_success_rate": _stats(
                         [r["final_clip_mean"]["success_rate"] for r in rs]),
                     "selected_timesteps": [r["policy"]["timesteps"] for r in rs],
                     "baselines": baselines, "best_baseline_success": best,
                     "target": _target(stats["success_rate"]["mean"], best)})
    return rows


def _target(success: float, best_baseline: float) -> dict:
    """The suite's target: ≥ 95 %, or at least the best scripted baseline where it is < 95 %."""
    goal = min(0.95, best_baseline)
    return {"goal": goal, "met": bool(success >= goal)}


def _pct(s: dict) -> str:
    if s["mean"] is None:
        return "—"
    spread = f" ± {100 * s['std']:.1f}" if s["n"] > 1 else ""
    return f"{100 * s['mean']:.1f}{spread} %"


def _num(s: dict, spec: str = ".2f") -> str:
    if s["mean"] is None:
        return "—"
    spread = f" ± {format(s['std'], spec)}" if s["n"] > 1 else ""
    return f"{format(s['mean'], spec)}{spread}"


def format_markdown(rows: list[dict], missing: list[str], info: dict) -> str:
    lines = [f"Held-out evaluation: {info['episodes']} episodes seeded {info['seed']} + i, the "
             "same episodes for every policy; learned policies deterministic. Learned rows: "
             "mean ± standard deviation over seeds. On a scene with thrusters the learned "
             "policy acts with its mean action E[clip(μ + σε, low, high)] (thrusters 0..1, "
             "wheels -1..1), on wheels and rods alone with μ; its row is the checkpoint with "
             "the best success "
             f"on {VALIDATION_EPISODES} validation episodes (seeded {VALIDATION_SEED} + i, not "
             "the held-out ones). Last columns: the final model's held-out success with the "
             "same action and with SB3's deterministic action μ (clipped by the env).", "",
             "| task | scene | policy | seeds | timesteps | success | fuel (g) | "
             "settle median (s) | train (min) | target | final model | final, clip(μ) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        goal = row["target"]
        mark = ("met" if goal["met"] else "**missed**") + f" (≥ {100 * goal['goal']:.1f} %)"
        wall = row["train_wall_time_s"]
        minutes = {k: (v / 60 if isinstance(v, float) else v) for k, v in wall.items()}
        steps = "/".join(f"{t:,}" for t in row["timesteps"]) + " (selected: " + ", ".join(
            f"{t / 1000:.0f}k" for t in row["selected_timesteps"]) + ")"
        lines.append(f"| {row['task']} | {row['scene']} | **{row['algo']}** | "
                     f"{len(row['seeds'])} | {steps} | {_pct(row['success_rate'])} | "
                     f"{_num(row['fuel_g'])} | {_num(row['settle_median_s'], '.1f')} | "
                     f"{_num(minutes, '.1f')} | {mark} | "
                     f"{_pct(row['final_success_rate'])} | "
                     f"{_pct(row['final_clip_mean_success_rate'])} |")
        for name, b in row["baselines"].items():
            settle = "—" if b["settle_median_s"] is None else f"{b['settle_median_s']:.1f}"
            fuel = "—" if not math.isfinite(b["fuel_g"]) else f"{b['fuel_g']:.2f}"  # no thrusters
            lines.append(f"| {row['task']} | {row['scene']} | {name} (scripted) | | | "
                         f"{100 * b['success_rate']:.1f} % | {fuel} | {settle} | | "
                         "| | |")
    if missing:
        lines += ["", f"**Missing cells** ({info['missing']}, not run or not finished): "
                  + "; ".join(missing) + "."]
    return "\n".join(lines) + "\n"


def plot_curves(results: list[dict], rows: list[dict], path: Path) -> Path | None:
    """Success rate of the periodic (validation) evaluations against timesteps, one panel per
    task × scene; a star marks the selected checkpoint's held-out success."""
    import matplotlib  # the train extra

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = sorted({(r["task"], r["cell"]["scene"]) for r in results})
    if not panels:
        return None
    tasks = sorted({t for t, _ in panels})
    scenes = sorted({s for _, s in panels})
    fig, axes = plt.subplots(len(tasks), len(scenes), figsize=(3.6 * len(scenes),
                                                              2.8 * len(tasks)),
                             squeeze=False, sharey=True)
    best = {(row["task"], row["scene"]): row["best_baseline_success"] for row in rows}
    for r in results:
        ax = axes[tasks.index(r["task"])][scenes.index(r["cell"]["scene"])]
        curve = r["learning_curve"]
        (line,) = ax.plot(curve["timesteps"], curve["success_rate"], marker=".", lw=1,
                          label=f"{r['cell']['algo']} seed {r['cell']['seed']}")
        ax.plot([r["policy"]["timesteps"]], [r["policy"]["success_rate"]], marker="*", ms=9,
                color=line.get_color(), ls="none")
    for i, task in enumerate(tasks):
        for j, scene in enumerate(scenes):
            ax = axes[i][j]
            if (task, scene) in best:
                ax.axhline(best[(task, scene)], color="k", ls="--", lw=0.8,
                           label="best scripted")
                ax.legend(fontsize=6, loc="lower right")
            ax.set_title(f"{task} · {scene}", fontsize=9)
            ax.set_ylim(-0.02, 1.02)
            if j == 0:
                ax.set_ylabel("success rate")
            if i == len(tasks) - 1:
                ax.set_xlabel("timesteps")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)


def aggregate(results: list[dict], out: Path, *, expected: Iterable[Cell] | None = None
              ) -> dict:
    """Write ``suite.json``, ``suite.md`` and ``learning_curves.png`` in ``out``; return the
    JSON's data, with each cell's summary and curves in ``cells`` where the file has its name.

    ``expected``: the whole grid, so that cells without a result are listed as missing.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results = sorted(results, key=lambda r: r["name"])
    have = {r["name"] for r in results}
    missing = [c for c in (expected or []) if c.name not in have]
    by_group: dict[str, list[int]] = {}
    for c in missing:
        by_group.setdefault(f"{c.algo} {c.task} {c.scene}", []).append(c.seed)
    missing_md = [f"{k} seed{'s' if len(v) > 1 else ''} {', '.join(map(str, sorted(v)))}"
                  for k, v in sorted(by_group.items())]
    missing = sorted(c.name for c in missing)
    evals = sorted({(r["eval"]["episodes"], r["eval"]["seed"]) for r in results})
    info = ({"episodes": evals[0][0], "seed": evals[0][1]} if len(evals) == 1
            else {"episodes": "/".join(str(e) for e, _ in evals) or "—",
                  "seed": "/".join(str(s) for _, s in evals) or "—"})
    rows = group_results(results)
    data = {"version": RESULT_VERSION, "eval": info, "rows": rows, "missing": missing,
            "cells": [{k: r[k] for k in ("name", "cell", "task", "eval", "training",
                                         "policy", "final", "final_clip_mean", "baselines",
                                         "learning_curve", "training_curve")}
                      for r in results]}
    # The file names the cells; each cell's figures are in cells/<name>/result.json already.
    write_json(out / "suite.json", {**data, "cells": [r["name"] for r in results]})
    (out / "suite.md").write_text(format_markdown(rows, missing_md,
                                                  {**info, "missing": len(missing)}))
    plot_curves(results, rows, out / "learning_curves.png")
    return data


def collect(out: Path) -> list[dict]:
    """Every complete result.json under ``out/cells``."""
    found = [read_result(p) for p in sorted((Path(out) / "cells").glob("*/result.json"))]
    return [r for r in found if r is not None]


def run_serial(cells: list[Cell], out: Path, **kw) -> dict:
    """:func:`run_cell` for each cell in order, then :func:`aggregate` over all of them."""
    results = []
    for i, cell in enumerate(cells):
        print(f"[{i + 1}/{len(cells)}] {cell.name}", flush=True)
        started = time.perf_counter()
        result = run_cell(cell, out, **kw)
        pol = result["policy"]
        print(f"    {cell.algo} success {100 * pol['success_rate']:.1f} % "
              f"({time.perf_counter() - started:.0f} s)", flush=True)
        results.append(result)
    return aggregate(results, out, expected=cells)


# --- command line -----------------------------------------------------------------------------

def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    p.add_argument("--quick", action="store_true",
                   help=f"smoke form for CI: {QUICK['tasks']} on {QUICK['scenes']}, "
                   f"{QUICK['timesteps']} timesteps, {QUICK['episodes']} episodes")
    p.add_argument("--out", default=None, help="output folder (default runs/suite, "
                   "runs/suite-quick with --quick)")
    p.add_argument("--algos", nargs="+", default=None, help="default: ppo")
    p.add_argument("--tasks", nargs="+", default=None, choices=sorted(tasks()),
                   help="default: every task")
    p.add_argument("--scenes", nargs="+", default=None, help="default: every shipped scene")
    p.add_argument("--seeds", type=int, default=None, help="seeds 0..N-1 (default 3)")
    p.add_argument("--timesteps", type=int, default=None,
                   help="one budget for every cell (default: per cell, the n_timesteps of "
                   "its recipe, rbenv.agents.settings)")
    p.add_argument("--episodes", type=int, default=None,
                   help=f"held-out episodes (default {EVAL_EPISODES})")
    p.add_argument("--eval-seed", type=int, default=EVAL_SEED)
    p.add_argument("--threads", type=int, default=1, help="torch threads per training run")
    p.add_argument("--aggregate-only", action="store_true",
                   help="write the tables from the results present; train nothing")
    return p


def cells_from_args(args) -> list[Cell]:
    quick = QUICK if args.quick else {}
    algos = args.algos or quick.get("algos", ["ppo"])
    names = args.tasks or quick.get("tasks", list(tasks()))
    scenes = args.scenes or quick.get("scenes", rbenv.list_scenes())
    seeds = args.seeds if args.seeds is not None else quick.get("seeds", 3)
    budget = args.timesteps or quick.get("timesteps") or default_timesteps
    return grid(algos, [tasks()[t] for t in names], scenes, range(seeds), budget)


def main(args) -> dict:
    out = Path(args.out or ("runs/suite-quick" if args.quick else "runs/suite"))
    episodes = args.episodes or (QUICK["episodes"] if args.quick else EVAL_EPISODES)
    cells = cells_from_args(args)
    if args.aggregate_only:
        data = aggregate(collect(out), out, expected=cells)
    else:
        started = time.perf_counter()
        data = run_serial(cells, out, eval_episodes=episodes, eval_seed=args.eval_seed,
                          threads=args.threads)
        print(f"suite of {len(cells)} cells: {(time.perf_counter() - started) / 60:.1f} min")
    print((out / "suite.md").read_text())
    print(f"written: {out / 'suite.json'}, {out / 'suite.md'}, {out / 'learning_curves.png'}")
    return data


if __name__ == "__main__":
    main(add_arguments(argparse.ArgumentParser(prog="python -m rbenv.agents.training.suite",
                                               description=__doc__.split("\n")[0])).parse_args())
