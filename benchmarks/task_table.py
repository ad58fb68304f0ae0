"""Every shipped task against its scripted baseline: one table, a command per row.

    python -m benchmarks.task_table [--ids ID ...] [--seeds 0 1 2] [--runs DIR] [--jobs 2]
                                    [--episodes 500] [--seed 1000000] [--out DIR] [--quick]
    python -m benchmarks.task_table --table-only     # table.md from the folder's JSON files

For each id (default: the ids of :data:`OWN_IDS`) on its default scene (the task's
``default_scene``, else the package's, as ``gym.make(env_id)`` has it), trains PPO with the
shipped settings, ``rbenv train --env-id ID --scene SCENE --seed S --no-report --out
RUNS/<slug>-seedS``, for each seed (a finished run is reused, an unfinished one resumed, at
most ``--jobs`` at a time), then evaluates each policy and every scripted baseline of the id
that runs on the scene on the same held-out episodes (``--seed`` … ``--seed + --episodes - 1``)
with :func:`rbenv.agents.policies.evaluate.evaluate`, the function ``rbenv evaluate`` runs.
The scene is passed to ``rbenv train`` explicitly: its own default is cubesat-12u for every id,
where Desaturate (wheels) cannot run.

The measures, all read from :meth:`EvalResult.summary` (lower is better for both):

- time: the settle time median (s), when the hold that ended a successful episode began. A
  task whose success does not end the episode (Track: it runs to the scene's duration, and
  success is being on target for 90 % of its second half) has no time measure in ``rbenv
  evaluate``: its verdict is success and cost alone, and the row shows the final attitude
  error median (deg) beside them;
- cost: the propellant mean (g) where the scene has thrusters; else the electrical energy of
  wheels and rods, mean (J), the figure ``rbenv evaluate`` prints there.

The verdict, per training seed: the policy's success rate is at least the best baseline's, it
is strictly lower on one measure and not higher on the other. The best baseline is the one
with the highest success rate, ties broken by the lower time measure, then the lower cost. A
row passes when every seed passes.

Writes ``OUT/<task>.json`` (task: ``detumble`` of ``rbenv/SatelliteDetumble-v1``; rows of
other ids already in the file are kept) and ``OUT/table.md``, the table of every row of every
JSON in OUT (other benchmarks' rows too, such as reorient.json). ``--quick`` (the CI form):
one seed, 8192 training steps, 10 episodes, default OUT a temporary folder's.

Schema of ``<task>.json`` (the contract for every file of the folder):

.. code-block:: text

    {"benchmark": "task_table/<task>", "machine": {...},
     "rows": [{
       "env_id": "rbenv/SatelliteDetumble-v1", "scene": "cubesat-12u",
       "command": "python -m benchmarks.task_table --ids rbenv/SatelliteDetumble-v1",
       "episodes": 500, "seed": 1000000,          # held-out episodes seed .. seed+episodes-1
       "time_measure": "settle_time_median_s",    # or null (Track: no time measure)
       "cost_measure": "propellant_mean_g",       # or "energy_mean_J"
       "policy": {"algo": "ppo",
                  "runs": [{"seed": 0, "run": "RUNS/detumble-v1-cubesat-12u-seed0",
                            "timesteps": 300000, "training_cpu_s": 8.1,
                            "training_wall_s": 9.0, "load_average_1min": 1.9,
                            "success_rate": 1.0, "time": 14.0, "cost": 0.43,
                            "final_error_deg": 0.2}, ...]},
       "baselines": {"pd": {"success_rate": 1.0, "time": 20.0, "cost": 0.67,
                            "final_error_deg": 0.3}, ...},
       "best_baseline": "pd",
       "verdict": {"pass": true, "per_seed": [true, true, true], "text": "passes"}}]}

``time`` and ``cost`` are null where not measured (no successful episode: no settle time;
Track: no time measure); ``final_error_deg`` is the final attitude error median;
``training_cpu_s`` is training.json's ``session_cpu_time_s`` (the last session's, for a resumed
run) and ``training_wall_s`` its ``wall_time_s`` (every session's).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from rbenv.agents.baselines.controllers import applicable_baselines
from rbenv.agents.policies.evaluate import evaluate
from rbenv.agents.training.config import shipped_settings
from rbenv.core.errors import InvalidParameterError

import rbenv
from benchmarks import common

# The ids this benchmark trains by default; the Reorient ids' rows come from reorient.json.
OWN_IDS = ("rbenv/SatelliteDetumble-v0", "rbenv/SatelliteDetumble-v1", "rbenv/SatelliteTrack-v0",
           "rbenv/SatelliteTrack-v1", "rbenv/SatelliteDesaturate-v0",
           "rbenv/SatelliteDesaturate-v1")
SETTLE = "settle_time_median_s"
PROPELLANT, ENERGY = "propellant_mean_g", "energy_mean_J"
FIGURES = ("success_rate", "time", "cost", "final_error_deg")  # of a policy on the episodes
QUICK_TIMESTEPS, QUICK_EPISODES = 8192, 10
DEFAULT_OUT = common.RESULTS / "task_table"
# The run's final state: rbenv train writes it when the budget is reached.
FINISHED = "training.json"


def task_name(env_id: str) -> str:
    """``detumble`` of ``rbenv/SatelliteDetumble-v1``: the JSON file's name."""
    return env_id.split("/", 1)[-1].rsplit("-v", 1)[0].removeprefix("Satellite").lower()


def slug(env_id: str, scene: str) -> str:
    """``detumble-v1-cubesat-12u``: the run folders' prefix."""
    return f"{task_name(env_id)}-v{env_id.rsplit('-v', 1)[1]}-{scene}"


def measures(summary: dict, env_id: str) -> dict:
    """success_rate, time and cost of one :meth:`EvalResult.summary` of ``env_id``, with the
    measures' names (see the module docstring)."""
    settle = summary["settle_time_s"]["median"]
    fuel = summary["fuel"]["mean"]
    has_settle = rbenv.envs.registry.get(env_id).task.success_terminates
    return {"success_rate": summary["success_rate"],
            "time_measure": SETTLE if has_settle else None,
            "time": settle if has_settle else None,
            "final_error_deg": summary["final_error_deg"]["median"],
            "cost_measure": PROPELLANT if math.isfinite(fuel) else ENERGY,
            "cost": 1000 * fuel if math.isfinite(fuel) else summary["energy"]["mean"]}


def _key(figures: dict) -> tuple:
    """Sort key of "better": higher success, then lower time, then lower cost (None last)."""
    def low(x):
        return math.inf if x is None else x
    return (-figures["success_rate"], low(figures["time"]), low(figures["cost"]))


def best_baseline(baselines: dict) -> str:
    """The baseline with the highest success rate, ties by the lower time, then cost."""
    return min(baselines, key=lambda name: _key(baselines[name]))


def beats(policy: dict, baseline: dict) -> bool:
    """At least as successful, strictly lower on time or cost, not higher on the other (an
    unmeasured figure, None, is worse than any measured one)."""
    def lower(a, b):
        return a is not None and (b is None or a < b)

    def not_higher(a, b):
        return b is None or (a is not None and a <= b)
    p, b = policy, baseline
    return (p["success_rate"] >= b["success_rate"]
            and ((lower(p["time"], b["time"]) and not_higher(p["cost"], b["cost"]))
                 or (lower(p["cost"], b["cost"]) and not_higher(p["time"], b["time"]))))


def verdict(runs: list[dict], baselines: dict, best: str) -> dict:
    """The row's verdict against ``baselines[best]``: every seed must beat it."""
    b = baselines[best]
    per_seed = [beats(r, b) for r in runs]
    if all(per_seed):
        return {"pass": True, "per_seed": per_seed, "text": "passes"}
    missing = []
    for r, ok in zip(runs, per_seed, strict=True):
        if ok:
            continue
        why = []
        if r["success_rate"] < b["success_rate"]:
            why.append(f"success {100 * r['success_rate']:.1f} % < {100 * b['success_rate']:.1f} %")
        for m in ("time", "cost"):
            if (r[m] is None and b[m] is not None) or (None not in (r[m], b[m]) and r[m] > b[m]):
                why.append(f"{m} {common.fmt(r[m], '.4g')} > {common.fmt(b[m], '.4g')}")
        if not why:
            why.append("equal to the baseline on both measures")
        missing.append(f"seed {r['seed']}: {', '.join(why)}")
    return {"pass": False, "per_seed": per_seed,
            "text": f"fails against {best} ({'; '.join(missing)})"}


def train_command(env_id: str, scene: str, seed: int, out: Path,
                  timesteps: int | None = None) -> list[str]:
    """The ``rbenv train`` command of one seed's run; ``--resume`` when the folder exists."""
    cmd = [sys.executable, "-m", "rbenv", "train", "--env-id", env_id, "--scene", scene,
           "--seed", str(seed), "--no-report", "--no-progress", "--out", str(out)]
    if timesteps is not None:
        cmd += ["--timesteps", str(timesteps)]
    if (out / "config.json").is_file():
        cmd.append("--resume")
    return cmd


def train(env_id: str, scene: str, seed: int, out: Path, timesteps: int | None) -> dict:
    """Train (or resume) one seed's run, unless finished; its training.json."""
    if not (out / FINISHED).is_file():
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out.parent / f"{out.name}.log", "a") as log:
            done = subprocess.run(["nice", *train_command(env_id, scene, seed, out, timesteps)],
                                  stdout=log, stderr=subprocess.STDOUT, check=False)
        if done.returncode != 0 or not (out / FINISHED).is_file():
            raise RuntimeError(f"rbenv train of {env_id} seed {seed} failed (exit "
                               f"{done.returncode}); its log: {out.parent / (out.name + '.log')}")
    return json.loads((out / FINISHED).read_text())


def row(env_id: str, seeds, runs_dir: Path, episodes: int, seed: int, jobs: int,
        timesteps: int | None = None, command: str | None = None) -> dict:
    """One row of the table (the module docstring's schema)."""
    scene = rbenv.envs.registry.get(env_id).scene
    shipped_settings("ppo", env_id, None, scene)  # a named error for an id without settings
    folders = {s: runs_dir / f"{slug(env_id, scene)}-seed{s}" for s in seeds}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        trained = dict(zip(seeds, pool.map(
            lambda s: train(env_id, scene, s, folders[s], timesteps), seeds), strict=True))
    runs = []
    for s in seeds:
        t = trained[s]
        m = measures(evaluate(str(folders[s]), episodes=episodes, seed=seed, env_id=env_id,
                              record=0).summary(), env_id)
        runs.append({"seed": s, "run": str(folders[s]), "timesteps": t["timesteps"],
                     "training_cpu_s": t.get("session_cpu_time_s"),
                     "training_wall_s": t.get("wall_time_s"),
                     "load_average_1min": t.get("load_average_1min"),
                     **{k: m[k] for k in FIGURES}})
        kinds = (m["time_measure"], m["cost_measure"])
    baselines = {}
    for name in applicable_baselines(env_id, scene):
        m = measures(evaluate(name, episodes=episodes, seed=seed, scene=scene, env_id=env_id,
                              record=0).summary(), env_id)
        baselines[name] = {k: m[k] for k in FIGURES}
    if not baselines:
        raise InvalidParameterError(f"env_id {env_id!r}: no scripted baseline runs on its "
                                    f"default scene {scene!r}")
    best = best_baseline(baselines)
    return {"env_id": env_id, "scene": scene,
            "command": command or f"python -m benchmarks.task_table --ids {env_id}",
            "episodes": episodes, "seed": seed,
            "time_measure": kinds[0], "cost_measure": kinds[1],
            "policy": {"algo": "ppo", "runs": runs}, "baselines": baselines,
            "best_baseline": best, "verdict": verdict(runs, baselines, best)}


def write_rows(out: Path, rows: list[dict]) -> list[Path]:
    """Each row into ``out/<task>.json``, over the rows of the same id already there."""
    written = []
    for task in dict.fromkeys(task_name(r["env_id"]) for r in rows):
        path = out / f"{task}.json"
        kept = json.loads(path.read_text())["rows"] if path.is_file() else []
        new = [r for r in rows if task_name(r["env_id"]) == task]
        ids = {r["env_id"] for r in new}
        merged = sorted([r for r in kept if r["env_id"] not in ids] + new,
                        key=lambda r: r["env_id"])
        out.mkdir(parents=True, exist_ok=True)
        payload = {"benchmark": f"task_table/{task}", "machine": common.machine(),
                   "rows": merged}
        path.write_text(common.dumps(common._jsonable(payload)) + "\n")
        written.append(path)
    return written


UNITS = {SETTLE: ("settle", "s", ".1f"), None: ("final error, no time measure", "°", ".3g"),
         PROPELLANT: ("propellant", "g", ".2f"), ENERGY: ("energy", "J", ".0f")}


def _span(values, spec: str, unit: str = "") -> str:
    """``1.2–1.5 unit`` over seeds (one value when they agree), ``—`` where none measured."""
    if any(v is None for v in values):
        shown = [common.fmt(v, spec) for v in values]
        return " / ".join(shown) + (f" {unit}" if unit else "")
    lo, hi = format(min(values), spec), format(max(values), spec)
    return (lo if lo == hi else f"{lo}–{hi}") + (f" {unit}" if unit else "")


def _time(figures: dict, row: dict):
    """The time cell's figure: the time measure, or the final error where there is none."""
    return figures["time"] if row["time_measure"] else figures.get("final_error_deg")


def markdown(rows: list[dict]) -> str:
    """The table: one line per row, the policy's figures as ranges over its seeds."""
    lines = ["| task | scene | measures | policy (PPO, seeds) success | time | cost "
             "| best baseline | its success | time | cost | verdict | command |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: r["env_id"]):
        (tname, tunit, tspec), (cname, cunit, cspec) = UNITS[r["time_measure"]], \
            UNITS[r["cost_measure"]]
        runs, b = r["policy"]["runs"], r["baselines"][r["best_baseline"]]
        seeds = ",".join(str(x["seed"]) for x in runs)
        verdict_cell = "passes" if r["verdict"]["pass"] else \
            f"**fails** ({sum(r['verdict']['per_seed'])}/{len(runs)} seeds pass)"
        lines.append(
            f"| {r['env_id'].split('/')[-1]} | {r['scene']} | {tname} ({tunit}), "
            f"{cname} ({cunit}) | {_span([100 * x['success_rate'] for x in runs], '.1f', '%')} "
            f"({seeds}) | {_span([_time(x, r) for x in runs], tspec)} "
            f"| {_span([x['cost'] for x in runs], cspec)} | {r['best_baseline']} "
            f"| {100 * b['success_rate']:.1f} % | {common.fmt(_time(b, r), tspec)} "
            f"| {common.fmt(b['cost'], cspec)} | {verdict_cell} | `{r['command']}` |")
    return "\n".join(lines) + "\n"


def merged_rows(out: Path) -> list[dict]:
    """Every row of every JSON in ``out``."""
    return [r for path in sorted(out.glob("*.json"))
            for r in json.loads(path.read_text())["rows"]]


def main(argv=None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--ids", nargs="+", default=list(OWN_IDS), metavar="ID",
                   help="env ids to train and evaluate (default: %(default)s)")
    p.add_argument("--seeds", nargs="+", type=int, default=None,
                   help="training seeds (default: 0 1 2; --quick: 0)")
    p.add_argument("--runs", type=Path, default=None,
                   help="folder of the run folders (default: runs/task_table; --quick: a "
                        "temporary folder)")
    p.add_argument("--jobs", type=int, default=2, help="trainings at a time")
    p.add_argument("--episodes", type=int, default=None,
                   help=f"held-out episodes (default 500; --quick {QUICK_EPISODES})")
    p.add_argument("--seed", type=int, default=1_000_000, help="seed of the first episode")
    p.add_argument("--out", type=Path, default=None,
                   help=f"where the JSON and table.md go (default {DEFAULT_OUT}; --quick: a "
                        "temporary folder)")
    p.add_argument("--table-only", action="store_true",
                   help="train and evaluate nothing: rebuild OUT/table.md from the JSON files "
                        "in OUT (after another benchmark's file, such as reorient.json, lands)")
    p.add_argument("--quick", action="store_true",
                   help=f"CI form: one seed, {QUICK_TIMESTEPS} steps, {QUICK_EPISODES} episodes")
    args = p.parse_args(argv)
    for env_id in args.ids:
        rbenv.envs.registry.get(env_id)  # a named error for an unknown id, before training
    if args.jobs < 1:
        p.error(f"--jobs must be at least 1, got {args.jobs}")
    tmp = tempfile.mkdtemp(prefix="task_table-") if args.quick else None
    seeds = args.seeds or ([0] if args.quick else [0, 1, 2])
    episodes = args.episodes or (QUICK_EPISODES if args.quick else 500)
    runs_dir = args.runs or (Path(tmp) / "runs" if args.quick else Path("runs/task_table"))
    out = args.out or (Path(tmp) if args.quick else DEFAULT_OUT)
    rows = []
    for env_id in [] if args.table_only else args.ids:
        r = row(env_id, seeds, runs_dir, episodes, args.seed, args.jobs,
                QUICK_TIMESTEPS if args.quick else None)
        rows.append(r)
        print(f"{env_id}: {r['verdict']['text']}", flush=True)
        write_rows(out, [r])  # each row as it is done
    table = markdown(merged_rows(out))
    (out / "table.md").write_text(table)
    print(table)
    print(f"results: {out}")
    return rows


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
