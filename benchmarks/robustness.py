"""Robustness: scripted and learned policies on the same perturbed episodes, against the size
of the domain randomization (reorientation task, scene cubesat-12u).

``python -m benchmarks.robustness [--quick] [--out DIR] [--seeds N] [--timesteps N [N ...]]``

A perturbation *size* s maps to every field of :class:`rbenv.satellite.randomization.Randomization`
(:func:`randomize_at`): principal second moments ``1 ± s`` and the mass distribution turned by
up to ``ROTATION_DEG_PER_SIZE · s``; the centre of mass anywhere within ``s`` times the body's
half-width (``HALF_WIDTH_M``); every thruster's force ``1 ± s`` and its nozzle tilted by up to
``MISALIGNMENT_DEG_PER_SIZE · s``; a one-step control delay in a fraction ``s`` of the episodes.
Conditions (:data:`CONDITIONS`): every kind at each size in :data:`SIZES`, then one kind at a
time at the largest trained size, plus two diagnostics (delay in every episode; every kind at
an extrapolated size beyond the trained range).

Policies: the PD (shipped tuning, and faster ones: :data:`PD_FREQUENCIES`) and bang-bang
baselines, all with the nominal model; PPO trained on the nominal scene and
on ``cubesat-12u-dr`` (the learning suite's runs, loaded as the suite does: the checkpoint it
selected on validation episodes, acting with the mean throttle); and PPO trained here with
randomization at the largest size (:data:`TRAIN_SIZE`), at each budget of ``--timesteps``
(a larger budget continues the same seed's run of the next smaller one). Every policy meets the
same episodes in every condition: episode i is seeded ``EVAL_SEED + i``, and the physics of an
episode is drawn from its own seed, so condition sizes scale one common set of draws.

Resumable: one JSON per finished training run (``OUT/train/``) and per evaluation
(``OUT/eval/<policy>/<condition>.json``); present files are not recomputed. Writes
``robustness.json``, ``robustness.md`` and ``robustness.png`` in OUT.
"""

from __future__ import annotations

import argparse
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rbenv.agents.policies.runfolder import RunFolderError, read_json, write_json
from rbenv.agents.training import suite

from benchmarks import common
from benchmarks.common import RESULTS

OUT = RESULTS / "robustness"
SUITE_OUT = RESULTS / "suite"
SCENE = "cubesat-12u"
ENV_ID = "rbenv/SatelliteReorient-v0"  # what the committed results measured
EVAL_SEED, EVAL_EPISODES = suite.EVAL_SEED, suite.EVAL_EPISODES
VALIDATION_SEED, VALIDATION_EPISODES = suite.VALIDATION_SEED, suite.VALIDATION_EPISODES
SIZES = (0.0, 0.1, 0.2, 0.3)
TRAIN_SIZE = 0.3
EXTRAPOLATED_SIZE = 0.5  # a diagnostic beyond the trained range
HALF_WIDTH_M = 0.11315  # m: half the 226.3 mm width of the 12U envelope (the scene's body)
ROTATION_DEG_PER_SIZE = 50.0  # mass distribution turned by up to 50° · s (10° at s = 0.2)
MISALIGNMENT_DEG_PER_SIZE = 30.0  # nozzles tilted by up to 30° · s (9° at s = 0.3)
# The perturbation kinds and the Randomization fields each one sets.
KINDS = {"inertia": ("inertia_scale", "inertia_rotation_deg"), "com": ("com_offset",),
         "force": ("force_scale",), "misalignment": ("misalignment_deg",),
         "delay": ("delay_probability",)}
# PPO's suite budget on the reorientation task, and three times it (validation success at
# s = 0.3 was still rising at 1 M steps).
TIMESTEPS = (1_000_000, 3_000_000)
QUICK = {"seeds": 1, "timesteps": (4096, 8192), "episodes": 20}
RESULT_VERSION = 1


def randomize_at(size: float, kinds=tuple(KINDS)) -> dict:
    """The ``randomize`` option of perturbation size ``size`` for ``kinds`` (others zero).

    Every field of :class:`rbenv.satellite.randomization.Randomization` that a thruster scene
    takes is present (the wheel and rod fields are refused on it), so the dict replaces (not
    merges with) whatever the scene has.
    """
    unknown = sorted(set(kinds) - set(KINDS))
    if unknown:
        raise ValueError(f"kinds must be among {sorted(KINDS)}, got {unknown}")
    s = float(size)
    full = {"inertia_scale": s, "inertia_rotation_deg": ROTATION_DEG_PER_SIZE * s,
            "com_offset": HALF_WIDTH_M * s, "force_scale": s,
            "misalignment_deg": MISALIGNMENT_DEG_PER_SIZE * s, "delay_probability": s}
    chosen = {f for k in kinds for f in KINDS[k]}
    return {f: (v if f in chosen else 0.0) for f, v in full.items()}


@dataclass(frozen=True)
class Condition:
    """One set of perturbed episodes: a name, its size and the randomize option."""

    name: str
    size: float
    kinds: str  # "all" or one kind
    randomize: dict

    @property
    def label(self) -> str:
        return f"{self.kinds}, s = {self.size:g}"


def conditions() -> list[Condition]:
    """Every kind at each size; each kind alone at TRAIN_SIZE; then the two diagnostics."""
    out = [Condition(f"all-{s:g}", s, "all", randomize_at(s)) for s in SIZES]
    out += [Condition(f"{k}-{TRAIN_SIZE:g}", TRAIN_SIZE, k, randomize_at(TRAIN_SIZE, (k,)))
            for k in KINDS]
    out.append(Condition("delay-always", TRAIN_SIZE, "delay (every episode)",
                         {**randomize_at(0.0), "delay_probability": 1.0}))
    out.append(Condition(f"all-{EXTRAPOLATED_SIZE:g}", EXTRAPOLATED_SIZE, "all (beyond training)",
                         randomize_at(EXTRAPOLATED_SIZE)))
    return out


CONDITIONS = conditions()


# --- policies ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class PolicySpec:
    """One evaluated policy: ``group`` (a table column), a seed for learned ones, and where its
    model is (``None`` for a scripted baseline: ``law``, default the group, a name in
    ``rbenv.agents.baselines.controllers.BASELINES["reorient"]``, built with ``options`` on the
    nominal
    scene).
    """

    group: str
    seed: int | None = None
    model: str | None = None
    timesteps: int | None = None  # the training step of the model (its identity in caches)
    law: str | None = None
    options: tuple = ()  # (name, value) pairs for the scripted controller

    @property
    def name(self) -> str:
        return self.group if self.seed is None else f"{self.group}-seed{self.seed}"


# The shipped PD has ωn = 0.3 rad/s; faster tunings of the same law show what its margin costs.
PD_FREQUENCIES = (0.5, 0.8)
GROUPS = {"pd": "PD, ωn 0.3 (shipped)",
          **{f"pd-wn{w:g}": f"PD, ωn {w:g}" for w in PD_FREQUENCIES},
          "bangbang": "bang-bang",
          "ppo-nominal": "PPO, trained nominal (1M)",
          "ppo-dr-scene": "PPO, trained on cubesat-12u-dr (1M)"}


def scripted_policies() -> list[PolicySpec]:
    """The shipped PD and bang-bang, and the PD at each of PD_FREQUENCIES."""
    return [PolicySpec("pd"),
            *(PolicySpec(f"pd-wn{w:g}", law="pd", options=(("natural_frequency", w),))
              for w in PD_FREQUENCIES),
            PolicySpec("bangbang")]


def scripted_controller(spec: PolicySpec):
    """``spec``'s scripted law with its options, from the nominal scene (its model)."""
    import gymnasium as gym
    from rbenv.agents.baselines.controllers import BASELINES

    env = gym.make(ENV_ID, scene=SCENE)
    return BASELINES["reorient"][spec.law or spec.group].from_env(env, **dict(spec.options))


def budget_label(timesteps: int) -> str:
    """``1M``, ``300k`` or the exact count."""
    t = int(timesteps)
    if t % 1_000_000 == 0:
        return f"{t // 1_000_000}M"
    return f"{t // 1000}k" if t % 1000 == 0 else str(t)


def randomized_group(timesteps: int) -> str:
    """Group id of the PPO trained here at TRAIN_SIZE with ``timesteps``."""
    return f"ppo-dr{round(100 * TRAIN_SIZE)}-{budget_label(timesteps)}"


def groups_for(budgets) -> dict:
    """Every group id and its column title, the randomized budgets last."""
    return {**GROUPS, **{randomized_group(t): f"PPO, trained at s = {TRAIN_SIZE:g} "
                         f"({budget_label(t)})" for t in budgets}}


def suite_policies(suite_out: Path, scene: str, group: str, seeds) -> tuple[list, list]:
    """The suite's reorientation runs on ``scene``: (specs, missing cell names).

    Each is the checkpoint the suite selected on its validation episodes (the step its
    result.json records; the final model when no checkpoint was saved at that step). Only the
    result.json is needed to name it; the run folder is read when an evaluation is not cached.
    """
    from rbenv.agents.policies import runfolder as runs

    specs, missing = [], []
    for seed in seeds:
        cell = suite.Cell("ppo", ENV_ID, scene, seed, suite.default_timesteps("ppo", ENV_ID,
                                                                             scene))
        folder = suite.cell_dir(cell, suite_out)
        try:  # any complete result: only the selected step is read from it
            result = read_json(folder / "result.json", "cell result")
        except RunFolderError:
            result = None
        if result is None or not result.get("complete"):
            missing.append(cell.name)
            continue
        steps = int(result["policy"]["timesteps"])
        model = suite.checkpoint_at(folder / "run", steps) or folder / "run" / runs.FINAL_MODEL
        specs.append(PolicySpec(group, seed, str(model), steps))
    return specs, missing


# --- training ---------------------------------------------------------------------------------

def train_record(out: Path, seed: int, timesteps: int) -> Path:
    return Path(out) / "train" / f"{randomized_group(timesteps)}-seed{seed}.json"


def run_dir(out: Path, seed: int, timesteps: int) -> Path:
    return Path(out) / "runs" / f"{randomized_group(timesteps)}-seed{seed}"


def start_from_shorter_run(out: Path, seed: int, timesteps: int, shorter) -> Path | None:
    """Copy the longest finished run of ``seed`` among the ``shorter`` budgets into this
    budget's (absent) folder, so training continues it; returns the copied run or None."""
    from rbenv.agents.policies import runfolder as runs

    run = run_dir(out, seed, timesteps)
    if run.exists():
        return None
    for t in sorted((t for t in shorter if t < timesteps), reverse=True):
        source = run_dir(out, seed, t)
        if runs.is_finished(source):
            shutil.copytree(source, run, ignore=shutil.ignore_patterns(runs.LOCK, "*.tmp"))
            return source
    return None


def train_randomized(out: Path, seed: int, timesteps: int, validation_episodes: int,
                     threads: int = 1, shorter=()) -> dict:
    """PPO (shipped defaults) trained with randomization at TRAIN_SIZE; its record (cached).

    The run folder resumes from its checkpoints after a kill, and a new one starts from the
    finished run of the largest of the ``shorter`` budgets. The record names the checkpoint
    with the best validation success (the latest among equals), as the suite selects.
    """
    from rbenv.agents.policies import runfolder as runs
    from rbenv.agents.training.config import shipped_settings
    from rbenv.agents.training.sb3 import set_threads, train

    path = train_record(out, seed, timesteps)
    try:
        record = read_json(path, "training record")
        if record.get("version") == RESULT_VERSION and record["timesteps"] == timesteps:
            return record
    except RunFolderError:
        pass
    continued = start_from_shorter_run(out, seed, timesteps, shorter)
    run = run_dir(out, seed, timesteps)
    cell = suite.Cell("ppo", ENV_ID, SCENE, seed, timesteps)
    cfg = suite.train_config(cell, run, threads)
    # The suite's ten checkpoints per run, but never more often than once per rollout.
    ppo = shipped_settings("ppo")
    rollout = ppo["n_envs"] * ppo["n_steps"]
    cfg.eval_every = cfg.checkpoint_every = max(cfg.eval_every, rollout)
    randomize = randomize_at(TRAIN_SIZE)
    common.with_general_recipe(cfg)  # the recipe the committed results measured
    cfg.env_kwargs = {"randomize": randomize}
    resume = (run / runs.CONFIG).is_file()
    train(cfg, resume=resume, force=not resume, progress_bar=False, report=False)
    summary = read_json(run / runs.SUMMARY, "training summary")
    set_threads(threads)
    curve = suite.validation_curve(cell, run, validation_episodes, seed=VALIDATION_SEED,
                                   env_kwargs={"randomize": randomize})
    model, steps = suite.select_checkpoint(run, curve)
    record = {"version": RESULT_VERSION, "seed": seed, "timesteps": timesteps,
              "scene": SCENE, "env_id": ENV_ID, "randomize": randomize,
              "training": {k: summary.get(k) for k in ("timesteps", "wall_time_s", "threads",
                                                       "gradient_updates")},
              "validation": {"episodes": validation_episodes, "seed": VALIDATION_SEED,
                             "curve": curve},
              "selected_timesteps": steps,
              "continued_from": None if continued is None else continued.name,
              "model": str(Path(model).relative_to(Path(out)))}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


# --- evaluation -------------------------------------------------------------------------------

def evaluate_policy(spec: PolicySpec, condition: Condition, episodes: int, seed: int,
                    randomize=None):
    """:class:`rbenv.agents.policies.evaluate.EvalResult` of ``spec`` on ``condition``'s
    episodes."""
    from rbenv.agents.policies.evaluate import evaluate
    from rbenv.agents.policies.sb3 import SB3Policy

    if spec.model is not None:
        policy = SB3Policy(spec.model, action="mean_throttle")
    else:
        policy = scripted_controller(spec) if spec.options else spec.law or spec.group
    kwargs = {"randomize": condition.randomize if randomize is None else randomize}
    return evaluate(policy, name=spec.name, episodes=episodes, seed=seed, scene=SCENE,
                    env_id=ENV_ID, record=0, env_kwargs=kwargs)


def eval_record(out: Path, spec: PolicySpec, condition: Condition) -> Path:
    return Path(out) / "eval" / spec.name / f"{condition.name}.json"


def evaluate_cached(out: Path, spec: PolicySpec, condition: Condition, episodes: int,
                    seed: int) -> dict:
    """The summary of ``spec`` on ``condition`` (read from its JSON when it matches)."""
    path = eval_record(out, spec, condition)
    key = {"episodes": episodes, "seed": seed, "randomize": condition.randomize,
           "timesteps": spec.timesteps, **({"options": dict(spec.options)} if spec.options
                                           else {})}
    try:
        record = read_json(path, "evaluation")
        if record.get("version") == RESULT_VERSION and record.get("key") == key:
            return record
    except RunFolderError:
        pass
    result = evaluate_policy(spec, condition, episodes, seed)
    s = result.summary()
    record = {"version": RESULT_VERSION, "key": key, "policy": spec.name, "group": spec.group,
              "seed": spec.seed, "condition": condition.name, "size": condition.size,
              "kinds": condition.kinds, "success_rate": s["success_rate"],
              "fuel_g": 1000 * s["fuel"]["mean"], "settle_time_s": s["settle_time_s"],
              "final_error_deg_median": s["final_error_deg"]["median"],
              "success": "".join("1" if x else "0" for x in result.success)}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


# --- aggregate --------------------------------------------------------------------------------

def aggregate(records: list[dict], out: Path, info: dict) -> dict:
    """``robustness.json``, ``.md`` and ``.png`` from the evaluation records; returns the JSON.

    info: the run's settings, with ``groups`` (id → column title, in column order).
    """
    out = Path(out)
    table = {}
    for c in CONDITIONS:
        row = {}
        for group in info["groups"]:
            rs = [r for r in records if r["group"] == group and r["condition"] == c.name]
            if rs:
                row[group] = {"success_rate": suite._stats([r["success_rate"] for r in rs]),
                              "fuel_g": suite._stats([r["fuel_g"] for r in rs]),
                              "settle_median_s": suite._stats(
                                  [r["settle_time_s"]["median"] for r in rs]),
                              "seeds": sorted(r["seed"] for r in rs if r["seed"] is not None)}
        table[c.name] = {"size": c.size, "kinds": c.kinds, "label": c.label,
                         "randomize": c.randomize, "policies": row}
    data = {"version": RESULT_VERSION, **info, "conditions": table,
            "evaluations": sorted(({k: r[k] for k in ("policy", "group", "seed", "condition",
                                                      "success_rate", "fuel_g")}
                                   for r in records),
                                  key=lambda r: (r["group"], r["policy"], r["condition"]))}
    write_json(out / "robustness.json", data)
    (out / "robustness.md").write_text(format_markdown(data))
    plot(data, out / "robustness.png")
    return data


def _cell(stats: dict | None, key: str, scale: float, spec: str, unit: str) -> str:
    if stats is None:
        return "—"
    s = stats[key]
    if s["mean"] is None:
        return "—"
    spread = f" ± {format(scale * s['std'], spec)}" if s["n"] > 1 else ""
    return f"{format(scale * s['mean'], spec)}{spread}{unit}"


def format_markdown(data: dict) -> str:
    titles = data["groups"]
    groups = [g for g in titles if any(g in c["policies"] for c in data["conditions"].values())]
    head = ("| perturbation | " + " | ".join(titles[g] for g in groups) + " |\n"
            + "|---|" + "---|" * len(groups))
    lines = [f"Reorientation on {SCENE}: {data['episodes']} held-out episodes per condition "
             f"(seeded {data['eval_seed']} + i), the same episodes and the same physics draws "
             "for every policy. Learned policies: mean ± standard deviation over training "
             "seeds (" + ", ".join(f"{titles[g]}: {n}" for g, n in data["seeds"].items())
             + "), acting with the mean throttle. Scripted policies (the quaternion PD at natural "
             "frequency ωn rad/s, the eigenaxis bang-bang) use the nominal model.",
             "", "Size s: principal moments of inertia 1 ± s and the mass distribution turned by "
             f"up to {ROTATION_DEG_PER_SIZE:g}°·s; centre of mass within s × {HALF_WIDTH_M} m "
             "(the body's half-width); thrust 1 ± s per thruster; nozzles tilted by up to "
             f"{MISALIGNMENT_DEG_PER_SIZE:g}°·s; a one-step (0.5 s) control delay in a fraction s "
             f"of the episodes. PPO (s = {TRAIN_SIZE:g}) trains on every kind at s = "
             f"{TRAIN_SIZE:g} (a larger budget continues the same seed's run); cubesat-12u-dr "
             "is inertia ±0.2, 10°, CoM 1 cm, thrust ±0.1, 2°, delay in half of the episodes.",
             "", "**Success rate**", "", head]
    for c in data["conditions"].values():
        lines.append(f"| {c['label']} | " + " | ".join(
            _cell(c["policies"].get(g), "success_rate", 100, ".1f", " %") for g in groups)
            + " |")
    lines += ["", "**Propellant per episode, mean over all episodes (g)**", "", head]
    for c in data["conditions"].values():
        lines.append(f"| {c['label']} | " + " | ".join(
            _cell(c["policies"].get(g), "fuel_g", 1, ".2f", "") for g in groups) + " |")
    lines += ["", "**Settle time, median over successful episodes (s)**", "", head]
    for c in data["conditions"].values():
        lines.append(f"| {c['label']} | " + " | ".join(
            _cell(c["policies"].get(g), "settle_median_s", 1, ".1f", "") for g in groups)
            + " |")
    if data.get("missing"):
        lines += ["", "**Missing** (not run or not found): " + ", ".join(data["missing"]) + "."]
    return "\n".join(lines) + "\n"


def plot(data: dict, path: Path) -> Path:
    """Success and propellant against size (every kind), and success per kind alone."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conds = data["conditions"]
    sweep = [n for n, c in conds.items() if c["kinds"].startswith("all")]
    single = [n for n, c in conds.items() if not c["kinds"].startswith("all")]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    titles = data["groups"]
    for i, group in enumerate(titles):
        pts = [(conds[n]["size"], conds[n]["policies"][group]) for n in sweep
               if group in conds[n]["policies"]]
        if not pts:
            continue
        x = [p[0] for p in pts]
        for ax, key, scale in ((axes[0], "success_rate", 100), (axes[1], "fuel_g", 1)):
            y = [scale * p[1][key]["mean"] for p in pts]
            err = [scale * (p[1][key]["std"] or 0) for p in pts]
            ax.errorbar(x, y, yerr=err, marker="o", capsize=3, label=titles[group],
                        ls="-" if group.startswith("ppo") else "--")  # dashed: scripted
        ys = [100 * conds[n]["policies"][group]["success_rate"]["mean"]
              if group in conds[n]["policies"] else np.nan for n in single]
        width = 0.8 / len(titles)
        axes[2].bar(np.arange(len(single)) + (i - (len(titles) - 1) / 2) * width, ys, width,
                    label=titles[group])
    for ax in axes[:2]:
        ax.axvspan(TRAIN_SIZE, EXTRAPOLATED_SIZE, color="0.92", zorder=0,
                   label="beyond the training range")
        ax.set_xlabel("perturbation size s (every kind at once)")
    axes[0].set_ylabel("success rate (%)")
    axes[0].set_title("success vs perturbation size")
    axes[1].set_ylabel("propellant per episode (g)")
    axes[1].set_title("propellant vs perturbation size")
    axes[0].legend(fontsize=7, loc="lower left")
    axes[2].set_xticks(range(len(single)), [conds[n]["kinds"] for n in single], rotation=20,
                       fontsize=7)
    axes[2].set_ylabel("success rate (%)")
    axes[2].set_title(f"one kind at s = {TRAIN_SIZE:g}")
    fig.suptitle(f"Robustness on {SCENE} reorientation ({data['episodes']} episodes per point)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)


# --- the run ----------------------------------------------------------------------------------

def run(out: Path, *, seeds: int, timesteps, episodes: int, suite_out: Path,
        validation_episodes: int = VALIDATION_EPISODES, threads: int = 1,
        eval_seed: int = EVAL_SEED) -> dict:
    """Train what is missing, evaluate what is missing, aggregate.

    timesteps: the PPO budgets to train at TRAIN_SIZE (one group each).
    """
    from rbenv.agents.training.sb3 import set_threads

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    specs = scripted_policies()
    missing = []
    for scene, group in ((SCENE, "ppo-nominal"), ("cubesat-12u-dr", "ppo-dr-scene")):
        found, lost = suite_policies(suite_out, scene, group, range(seeds))
        specs += found
        missing += lost
    budgets = sorted(int(t) for t in timesteps)
    for t in budgets:  # every seed at one budget before the next budget
        group = randomized_group(t)
        for seed in range(seeds):
            started = time.perf_counter()
            record = train_randomized(out, seed, t, validation_episodes, threads, budgets)
            print(f"{group} seed {seed}: selected {record['selected_timesteps']} steps "
                  f"({time.perf_counter() - started:.0f} s)", flush=True)
            specs.append(PolicySpec(group, seed, str(out / record["model"]),
                                    record["selected_timesteps"]))
    set_threads(threads)
    records = []
    for spec in specs:
        started = time.perf_counter()
        records += [evaluate_cached(out, spec, c, episodes, eval_seed) for c in CONDITIONS]
        print(f"evaluated {spec.name} ({time.perf_counter() - started:.0f} s)", flush=True)
    groups = groups_for(budgets)
    count = {g: len({s.seed for s in specs if s.group == g}) for g in groups
             if g.startswith("ppo")}
    info = {"scene": SCENE, "env_id": ENV_ID, "episodes": episodes, "eval_seed": eval_seed,
            "timesteps": budgets, "groups": groups, "train_size": TRAIN_SIZE, "seeds": count,
            "missing": missing, "sizes": list(SIZES),
            "size_map": {"inertia_rotation_deg_per_size": ROTATION_DEG_PER_SIZE,
                         "com_offset_m_per_size": HALF_WIDTH_M,
                         "misalignment_deg_per_size": MISALIGNMENT_DEG_PER_SIZE,
                         "delay_probability_per_size": 1.0}}
    return aggregate(records, out, info)


def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    p.add_argument("--quick", action="store_true",
                   help=f"smoke form: {QUICK['timesteps']} timesteps, {QUICK['seeds']} seed, "
                   f"{QUICK['episodes']} episodes")
    p.add_argument("--out", default=None, help=f"output folder (default {OUT}; "
                   "runs/robustness-quick with --quick)")
    p.add_argument("--seeds", type=int, default=None, help="training seeds 0..N-1 (default 3)")
    p.add_argument("--timesteps", type=int, nargs="+", default=None,
                   help="PPO budgets per seed, each a group; a larger one continues the run of "
                   f"the next smaller one (default {' '.join(map(str, TIMESTEPS))})")
    p.add_argument("--episodes", type=int, default=None,
                   help=f"held-out episodes per condition (default {EVAL_EPISODES})")
    p.add_argument("--suite", default=str(SUITE_OUT),
                   help="the learning suite's output folder, for its trained runs")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    return p


def main(args) -> dict:
    quick = QUICK if args.quick else {}
    out = Path(args.out or ("runs/robustness-quick" if args.quick else OUT))
    seeds = args.seeds if args.seeds is not None else quick.get("seeds", 3)
    timesteps = args.timesteps or quick.get("timesteps", TIMESTEPS)
    episodes = args.episodes or quick.get("episodes", EVAL_EPISODES)
    validation = min(episodes, VALIDATION_EPISODES)
    started = time.perf_counter()
    data = run(out, seeds=seeds, timesteps=timesteps, episodes=episodes,
               suite_out=Path(args.suite), validation_episodes=validation,
               threads=args.threads)
    print((out / "robustness.md").read_text())
    print(f"written: {out / 'robustness.json'}, {out / 'robustness.md'}, "
          f"{out / 'robustness.png'} ({(time.perf_counter() - started) / 60:.1f} min)")
    return data


if __name__ == "__main__":
    main(add_arguments(argparse.ArgumentParser(
        prog="python -m benchmarks.robustness",
        description=__doc__.split("\n")[0])).parse_args())
