"""How close to the limit: every reorientation policy as a ratio to per-episode lower bounds.

    python -m benchmarks.bounds [--quick] [--out DIR] [--episodes 500] [--seed 1000000]
                                [--optimal 3]
    python -m benchmarks.bounds --v1 [--suite DIR] [--run NAME=RUN_FOLDER ...]

On the default scene (cubesat-12u) and the held-out episodes ``seed + i``, computes for each
episode the lower bounds of :mod:`rbenv.agents.baselines.bounds` (settle time; propellant
for any successful
policy; propellant given the policy's own settle time), evaluates the PD and bang-bang
baselines and the suite's three PPO policies (``benchmarks/results/suite/cells/
ppo-reorient-cubesat-12u-seed{0,1,2}``, each as the suite evaluates it: the checkpoint the
suite selected, acting with its mean throttle) and reports achieved / bound per episode:
median and quartiles over successful episodes. A ratio below 1 would disprove a bound; the
minimum is reported. ``--optimal K`` also optimises open-loop trajectories (SciPy SLSQP,
:mod:`rbenv.agents.baselines.optimal`) for K episodes, replays them in the env, and compares them
with the
bounds. Writes ``bounds.json``, ``bounds.md`` and ``bounds.png`` to ``--out`` (default
``benchmarks/results/bounds``). ``--quick``: 20 episodes, PPO seed 0 only, one short
optimisation: a smoke test for CI.

``--v1``: the same ratios for the policies trained on ``rbenv/SatelliteReorient-v1`` (same
episodes for the same seed, checked): the v1 suite's PPO policies (``benchmarks/results/
suite_v1/cells/ppo-reorient_v1-cubesat-12u-seed{0,1,2}``, selected as the suite selects them)
and each ``--run NAME=FOLDER``, an ``rbenv train`` run folder evaluated with the policy it kept
(``policy.pt``; off-policy runs: the best validated one) in the env options it trained with.
Writes to ``benchmarks/results/bounds_v1`` by default; no trajectory optimisation (the
``--v0`` run has it; the bounds do not depend on the policy).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import common

SCENE = "cubesat-12u"
V0, V1 = "rbenv/SatelliteReorient-v0", "rbenv/SatelliteReorient-v1"
# Per env id: the suite folder of its PPO policies, their cell name, the default output.
SUITE = {V0: common.RESULTS / "suite", V1: common.RESULTS / "suite_v1"}
CELL = {V0: "ppo-reorient-cubesat-12u-seed{}", V1: "ppo-reorient_v1-cubesat-12u-seed{}"}
OUT = {V0: common.RESULTS / "bounds", V1: common.RESULTS / "bounds_v1"}
QUICK = {"episodes": 20, "ppo_seeds": (0,), "optimal": 1, "maxiter": 40}


def ppo_policy(seed: int, suite: Path | None = None, env_id: str = V0):
    """The suite's PPO policy for ``env_id``/cubesat-12u ``seed``, as the suite evaluates it:
    the checkpoint it selected on validation episodes, acting with its mean throttle.
    Returns (policy, facts, gym.make options of the env it trained in)."""
    from rbenv.agents.policies.runfolder import read_config, read_json
    from rbenv.agents.policies.sb3 import SB3Policy
    from rbenv.agents.training.suite import select_checkpoint

    folder = Path(suite or SUITE[env_id]) / "cells" / CELL[env_id].format(seed)
    result = read_json(folder / "result.json", "suite cell result")
    model, steps = select_checkpoint(folder / "run", result["learning_curve"])
    meta = {"model": model.name, "timesteps": steps,
            "suite_success_rate": result["policy"]["success_rate"],
            "suite_fuel_mean_g": 1000 * result["policy"]["fuel"]["mean"]}
    env_kwargs = dict(read_config(folder / "run").get("env_kwargs") or {})
    return SB3Policy(model, action="mean_throttle"), meta, env_kwargs


def trained_seeds(seeds, suite: Path | None = None, env_id: str = V0) -> list[int]:
    """The seeds of ``seeds`` whose suite run folder is present (trained models are not
    committed: a fresh clone has the suite's JSON, not its policies)."""
    suite = Path(suite or SUITE[env_id])
    cell = CELL[env_id]
    present = [s for s in seeds if (suite / "cells" / cell.format(s) / "run").is_dir()]
    task = cell.split("-")[1]
    for s in sorted(set(seeds) - set(present)):
        print(f"ppo seed {s}: no trained policy in {suite / 'cells' / cell.format(s)}; "
              f"skipped (train it with: python -m rbenv suite --tasks {task} --scenes "
              f"{SCENE} --out {suite})", flush=True)
    return present


def run_policy(name: str, folder) -> tuple:
    """An ``rbenv train`` run folder's kept policy (its ``policy.pt``), with facts from its
    ``training.json`` and the env options it trained with (its ``env_id`` must be v1)."""
    from rbenv.agents.policies.load import load_policy
    from rbenv.agents.policies.runfolder import read_json

    folder = Path(folder)
    if not (folder / "policy.pt").is_file():
        raise FileNotFoundError(f"--run {name}={folder}: no policy.pt in that folder (an "
                                "rbenv train run folder, trained to its end, is needed)")
    policy = load_policy(folder)
    if policy.env_id != V1:
        raise ValueError(f"--run {name}={folder}: trained on {policy.env_id!r}; --v1 "
                         f"compares policies of {V1!r}")
    summary = read_json(folder / "training.json", "training summary")
    kept = summary.get("kept") or {}
    meta = {"run": str(folder), "algo": policy.config.get("algo"),
            "timesteps": summary.get("timesteps"), "kept_timesteps": kept.get("timesteps"),
            "wall_time_s": summary.get("wall_time_s")}
    return policy, meta, dict(policy.env_kwargs)


def parse_runs(items) -> dict[str, Path]:
    """``NAME=FOLDER`` strings as {name: folder}; a malformed or repeated name is an error."""
    runs: dict[str, Path] = {}
    for item in items or ():
        name, sep, folder = item.partition("=")
        if not sep or not name or not folder:
            raise ValueError(f"--run must be NAME=RUN_FOLDER, got {item!r}")
        if name in runs or name in ("pd", "bangbang"):
            raise ValueError(f"--run name {name!r} is used twice (or is a baseline's name)")
        runs[name] = Path(folder)
    return runs


def quartiles(x) -> dict:
    """median, p25, p75, min, max and n of the finite values of x (None when there are none)."""
    v = np.asarray(x, float)
    v = v[np.isfinite(v)]
    if not len(v):
        return {"median": None, "p25": None, "p75": None, "min": None, "max": None, "n": 0}
    p25, med, p75 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "p25": float(p25), "p75": float(p75), "min": float(v.min()),
            "max": float(v.max()), "n": len(v)}


def ratios(result, bounds: dict, limits) -> dict:
    """Per-episode achieved / bound for one EvalResult, successful episodes only (the ratios
    of :func:`rbenv.agents.policies.optimality.ratios`, which every evaluation reports)."""
    from rbenv.agents.baselines.bounds import fuel_bound
    from rbenv.agents.policies.optimality import EpisodeBounds
    from rbenv.agents.policies.optimality import ratios as per_episode

    def fuel_at(t):  # propellant needed to settle by t (valid for each episode)
        return fuel_bound(limits, bounds["angle"], bounds["omega_B"], bounds["bias_B"],
                          time_s=t)["kg"]

    ok = np.asarray(result.success, bool)
    settle = np.where(ok, result.settle_time_s, np.nan)
    fuel = np.where(ok, result.fuel_kg, np.nan)
    r = per_episode(ok, result.settle_time_s, result.fuel_kg,
                    EpisodeBounds(bounds["settle_s"], bounds["fuel_kg"], fuel_at, "thrusters"))
    return {"success_rate": float(ok.mean()), "successes": int(ok.sum()),
            "settle_time_s": quartiles(settle), "fuel_g": quartiles(1000 * fuel),
            "settle_ratio": quartiles(r["settle_ratio"]), "fuel_ratio": quartiles(r["fuel_ratio"]),
            "fuel_ratio_own_time": quartiles(r["fuel_ratio_own_time"]),
            "per_episode": {"success": ok, "settle_time_s": settle, "fuel_g": 1000 * fuel,
                            "settle_ratio": r["settle_ratio"], "fuel_ratio": r["fuel_ratio"],
                            "fuel_ratio_own_time": r["fuel_ratio_own_time"]}}


def spot_checks(seed: int, count: int, maxiter: int, quick: bool,
                candidates: int = 500) -> list[dict]:
    """Optimised trajectories for ``count`` episodes (replayed in the env) beside the bounds.

    Episodes, among ``seed … seed + candidates − 1``: the quartiles of the initial angle,
    evenly spaced (quick: the smallest angle, the shortest horizon). Time: the earliest settle
    step SLSQP reaches, by bisection between the bound (infeasible below it) and the bang-bang
    controller's settle step, warm-started from the bang-bang throttles. Propellant: least
    propellant settling by the last admissible step, throttles held 2 s, warm-started from the
    PD's throttles (skipped with --quick).
    """
    from rbenv.agents.baselines import bounds as rb
    from rbenv.agents.baselines import optimal

    limits = rb.scene_limits(SCENE)
    starts = rb.episode_starts(candidates, seed, SCENE)
    order = np.argsort(starts["angle"])
    picks = order[:1] if quick else order[np.linspace(len(order) // 4, 3 * len(order) // 4,
                                                      count).astype(int)]
    rows = []
    for i in picks[:count]:
        s = seed + int(i)
        one = {k: v[i:i + 1] for k, v in starts.items()}
        settle_bound = float(rb.settle_time_bound(limits, one["angle"], one["omega_B"],
                                                  one["bias_B"])["sampled"][0])
        fuel_bound = float(rb.fuel_bound(limits, one["angle"], one["omega_B"],
                                         one["bias_B"])["kg"][0])
        problem = optimal.Problem.from_seed(s, SCENE)
        started = time.perf_counter()
        bang = optimal.replay("bangbang", s, SCENE)
        pd = optimal.replay("pd", s, SCENE)
        dt = limits.control_dt
        row = {"seed": s, "angle_deg": math.degrees(one["angle"][0]),
               "rate0": float(np.linalg.norm(one["omega_B"][0])),
               "settle_bound_s": settle_bound, "fuel_bound_g": 1000 * fuel_bound,
               "bangbang": {k: bang[k] for k in ("success", "settle_time_s")}
               | {"fuel_g": 1000 * bang["fuel_kg"]},
               "pd": {k: pd[k] for k in ("success", "settle_time_s")}
               | {"fuel_g": 1000 * pd["fuel_kg"]}}
        if bang["success"]:
            lo = int(np.rint(settle_bound / dt)) - 1
            sol = optimal.time_optimal(problem, int(np.rint(bang["settle_time_s"] / dt)),
                                       bang["throttles"], lo, maxiter=maxiter)
            rep = optimal.replay(sol.throttles, s, SCENE)
            row["time_optimal"] = {"solver_feasible": sol.feasible, "success": rep["success"],
                                   "settle_time_s": rep["settle_time_s"],
                                   "fuel_g": 1000 * rep["fuel_kg"]}
        if not quick and pd["success"]:
            sol = optimal.fuel_optimal(problem, pd["throttles"], maxiter=maxiter)
            rep = optimal.replay(sol.throttles, s, SCENE)
            row["fuel_optimal"] = {"solver_feasible": sol.feasible, "success": rep["success"],
                                   "settle_time_s": rep["settle_time_s"],
                                   "fuel_g": 1000 * rep["fuel_kg"]}
        row["wall_s"] = time.perf_counter() - started
        print(f"  optimal, episode {s}: {json.dumps(row, default=float)}", flush=True)
        rows.append(row)
    return rows


def _cell(s: dict, spec: str = ".2f") -> str:
    if s["median"] is None:
        return "—"
    return (f"{format(s['median'], spec)} [{format(s['p25'], spec)}, "
            f"{format(s['p75'], spec)}]")


def markdown(data: dict) -> str:
    b = data["bounds"]
    lines = [
        f"Scene {data['scene']}, {data['episodes']} held-out episodes (seed {data['seed']} + i). "
        "Ratios are achieved / lower bound per episode, over each policy's **successful "
        "episodes only**: median [25th, 75th percentile]. Fuel / bound (any policy): against "
        "the least propellant any policy needs to succeed within the episode; fuel / bound "
        "(own time): against the least propellant needed to settle as early as this policy "
        "did in that episode. Episodes whose propellant bound is 0 (small angles with a "
        f"helpful initial rate: {b['fuel_zero']}) have no fuel ratio. PPO: the suite's policies "
        "(selected checkpoint, mean throttle).", "",
        f"Bounds over the episodes: settle time {_cell(b['settle_s'], '.1f')} s; propellant "
        f"{_cell(b['fuel_g'], '.3f')} g.", "",
        *([f"Policies of {data['env_id']} (the same episodes as {V0}'s for the same seeds, "
           "checked). PPO rows: the v1 suite's; the other learned rows: `rbenv train` runs "
           "with the policy each kept (the best validated one for off-policy learners), "
           "acting deterministically in the env options they trained with (torque actions, "
           "pinv allocation).", ""] if data.get("env_id", V0) != V0 else []),
        "| policy | success | settle time (s) | settle / bound | fuel (g) | fuel / bound (any "
        "policy) | fuel / bound (own time) | least ratio (settle, fuel) |",
        "|---|---|---|---|---|---|---|---|"]
    for name, r in data["policies"].items():
        least = (f"{r['settle_ratio']['min']:.2f}, {r['fuel_ratio']['min']:.2f}"
                 if r["settle_ratio"]["min"] is not None else "—")
        lines.append(f"| {name} | {100 * r['success_rate']:.1f} % | "
                     f"{_cell(r['settle_time_s'], '.1f')} | {_cell(r['settle_ratio'])} | "
                     f"{_cell(r['fuel_g'])} | {_cell(r['fuel_ratio'], '.1f')} | "
                     f"{_cell(r['fuel_ratio_own_time'], '.1f')} | {least} |")
    if data["optimal"]:
        lines += ["", "Optimised open-loop trajectories (SLSQP, replayed in the env), beside "
                  "the bounds and the baselines on the same episodes:", "",
                  "| episode | angle (deg) | settle bound (s) | time-optimised settle (s) | "
                  "bang-bang settle (s) | fuel bound (g) | fuel-optimised (g) | PD fuel (g) |"
                  " optimised / bound (time, fuel) |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for o in data["optimal"]:
            t = o.get("time_optimal", {})
            f = o.get("fuel_optimal", {})
            def show(d, key, spec):
                if not d:
                    return "—"
                return format(d[key], spec) + ("" if d["success"] else " (failed)")

            def ratio(d):
                return "—" if not d or d.get("ratio_to_bound") is None \
                    else f"{d['ratio_to_bound']:.2f}"
            lines.append(f"| {o['seed']} | {o['angle_deg']:.1f} | {o['settle_bound_s']:.1f} | "
                         f"{show(t, 'settle_time_s', '.1f')} | "
                         f"{o['bangbang']['settle_time_s']:.1f} | {o['fuel_bound_g']:.3f} | "
                         f"{show(f, 'fuel_g', '.3f')} | {o['pd']['fuel_g']:.3f} | "
                         f"{ratio(t)}, {ratio(f)} |")
    return "\n".join(lines) + "\n"


def plot(data: dict, per_episode: dict, path: Path) -> Path:
    """Box plots of the per-episode ratios (whiskers 5-95 %), one panel per ratio; crosses:
    the optimised trajectories of the spot checks."""
    plt = common.pyplot()
    names = list(per_episode)
    spots = {"settle_ratio": [o["time_optimal"]["ratio_to_bound"] for o in data["optimal"]
                              if "time_optimal" in o],
             "fuel_ratio": [o["fuel_optimal"]["ratio_to_bound"] for o in data["optimal"]
                            if o.get("fuel_optimal", {}).get("ratio_to_bound")]}
    panels = (("settle_ratio", "settle time / bound"),
              ("fuel_ratio", "propellant / bound (any policy)"),
              ("fuel_ratio_own_time", "propellant / bound at its own settle time"))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    for ax, (key, title) in zip(axes, panels, strict=True):
        values = [np.asarray(per_episode[n][key], float) for n in names]
        values = [v[np.isfinite(v)] for v in values]
        labels = list(names)
        ax.boxplot(values, whis=(5, 95), showfliers=False)
        if spots.get(key):
            x = len(values) + 1
            ax.plot([x] * len(spots[key]), spots[key], "x", color="tab:red", ms=8)
            labels.append("optimised\n(spot checks)")
        ax.set_xticks(range(1, len(labels) + 1), labels, rotation=20, fontsize=8)
        ax.axhline(1.0, color="k", ls=":", lw=0.8)
        ax.set_yscale("log")
        ax.set_title(title, fontsize=10)
        ax.grid(True, axis="y", which="both", alpha=0.3)
    axes[0].set_ylabel("achieved / lower bound")
    fig.suptitle(f"How close to the limit: {data['scene']}, {data['episodes']} held-out "
                 "episodes, successful ones (boxes: quartiles, whiskers: 5-95 %; dotted: the "
                 "bound)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def run(episodes: int, seed: int, ppo_seeds, optimal_count: int, maxiter: int,
        quick: bool = False, env_id: str = V0, suite: Path | None = None,
        runs: dict[str, Path] | None = None) -> tuple[dict, dict]:
    from rbenv.agents.baselines import bounds as rb
    from rbenv.agents.policies.evaluate import evaluate
    from rbenv.agents.training.sb3 import set_threads

    set_threads(1)
    limits = rb.scene_limits(SCENE)
    starts = rb.episode_starts(episodes, seed, SCENE)
    if env_id != V0:
        check_same_episodes(starts, rb.episode_starts(episodes, seed, SCENE, env_id=env_id),
                            env_id)
    settle = rb.settle_time_bound(limits, starts["angle"], starts["omega_B"], starts["bias_B"])
    fuel = rb.fuel_bound(limits, starts["angle"], starts["omega_B"], starts["bias_B"])
    bounds = {**starts, "settle_s": settle["sampled"], "settle_continuous_s":
              settle["continuous"], "fuel_kg": fuel["kg"], "kappa": fuel["kappa"]}
    policies: dict = {"pd": ("pd", {}, {}), "bangbang": ("bangbang", {}, {})}
    trained = trained_seeds(ppo_seeds, suite, env_id)
    missing = sorted(set(ppo_seeds) - set(trained))
    ppo_seeds = trained
    for s in ppo_seeds:
        policies[f"ppo seed {s}"] = ppo_policy(s, suite, env_id)
    for name, folder in (runs or {}).items():
        policies[name] = run_policy(name, folder)
    results, per_episode = {}, {}
    for name, (policy, meta, env_kwargs) in policies.items():
        started = time.perf_counter()
        ev = evaluate(policy, episodes=episodes, seed=seed, scene=SCENE, name=name, record=0,
                      env_id=env_id, env_kwargs=env_kwargs)
        r = ratios(ev, bounds, limits)
        per_episode[name] = r.pop("per_episode")
        results[name] = {**r, **meta, "eval_wall_s": time.perf_counter() - started}
        print(f"{name}: success {100 * r['success_rate']:.1f} %, settle/bound "
              f"{_cell(r['settle_ratio'])}, fuel/bound {_cell(r['fuel_ratio'], '.1f')}",
              flush=True)
    if len(ppo_seeds) > 1:  # the seeds pooled: every successful episode of every seed
        pooled = {k: np.concatenate([per_episode[f"ppo seed {s}"][k] for s in ppo_seeds])
                  for k in per_episode[f"ppo seed {ppo_seeds[0]}"]}
        results["ppo (seeds pooled)"] = {
            "success_rate": float(np.mean(pooled["success"])),
            "successes": int(np.sum(pooled["success"])),
            **{k: quartiles(pooled[k]) for k in ("settle_time_s", "fuel_g", "settle_ratio",
                                                   "fuel_ratio", "fuel_ratio_own_time")}}
        per_episode["ppo (seeds pooled)"] = pooled
    optimal = spot_checks(seed, optimal_count, maxiter, quick) if optimal_count else []
    violations = {name: {"settle": int(np.sum(per_episode[name]["settle_ratio"] < 1.0)),
                         "fuel": int(np.sum(per_episode[name]["fuel_ratio"] < 1.0)),
                         "fuel_own_time": int(np.sum(per_episode[name]["fuel_ratio_own_time"]
                                                     < 1.0))}
                  for name in per_episode}
    for o in optimal:
        for key, achieved, bound in (("time_optimal", "settle_time_s", "settle_bound_s"),
                                     ("fuel_optimal", "fuel_g", "fuel_bound_g")):
            if key in o:
                o[key]["ratio_to_bound"] = o[key][achieved] / o[bound] if o[bound] else None
    data = {"env_id": env_id, "scene": SCENE, "episodes": episodes, "seed": seed,
            "limits": limits.summary(),
            "bounds": {"settle_s": quartiles(bounds["settle_s"]),
                       "settle_continuous_s": quartiles(bounds["settle_continuous_s"]),
                       "fuel_g": quartiles(1000 * bounds["fuel_kg"]),
                       "fuel_zero": int(np.sum(bounds["fuel_kg"] <= 0)),
                       "kappa_lambda_max": quartiles(bounds["kappa"] * limits.inertia_max)},
            "policies": results, "missing_ppo_seeds": missing, "violations": violations,
            "optimal": optimal,
            "per_episode": _rounded({"angle_deg": np.degrees(bounds["angle"]),
                                     "rate0": np.linalg.norm(bounds["omega_B"], axis=1),
                                     "settle_bound_s": bounds["settle_s"],
                                     "fuel_bound_g": 1000 * bounds["fuel_kg"],
                                     "policies": per_episode})}
    return data, per_episode


def check_same_episodes(v0: dict, other: dict, env_id: str) -> None:
    """Refuse to compare with the bounds of v0's episodes unless ``env_id`` starts the same
    episodes for the same seeds (attitude, target, rate and bias, to the bit)."""
    for key, value in v0.items():
        if not np.array_equal(value, other[key]):
            raise ValueError(f"{env_id} starts other episodes than {V0} for the same seeds "
                             f"({key} differs): its policies cannot use these bounds")


def _rounded(tree):
    """Arrays in a nested dict as lists of floats to 5 significant digits (NaN: None)."""
    if isinstance(tree, dict):
        return {k: _rounded(v) for k, v in tree.items()}
    arr = np.asarray(tree)
    if arr.dtype == bool:
        return arr.tolist()
    return [float(f"{x:.5g}") if np.isfinite(x) else None for x in arr.astype(float)]


def main(argv=()) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smoke form: " + json.dumps(QUICK))
    p.add_argument("--v1", action="store_true",
                   help=f"the policies of {V1} (the suite's PPO and --run folders)")
    p.add_argument("--suite", default=None,
                   help="the suite folder with the PPO run folders (default: the committed "
                        f"suite's, {SUITE[V0]} or with --v1 {SUITE[V1]})")
    p.add_argument("--run", action="append", default=[], metavar="NAME=RUN_FOLDER",
                   help="with --v1: an rbenv train run folder to evaluate (repeatable)")
    p.add_argument("--out", default=None, help=f"output folder (default {OUT[V0]} or with "
                                               f"--v1 {OUT[V1]})")
    p.add_argument("--episodes", type=int, default=500)
    p.add_argument("--seed", type=int, default=1_000_000)
    p.add_argument("--optimal", type=int, default=None,
                   help="episodes to optimise trajectories for (0: none; default 3, quick 1, "
                        "--v1 0)")
    p.add_argument("--maxiter", type=int, default=150, help="SLSQP iterations per solve")
    args = p.parse_args(argv)
    env_id = V1 if args.v1 else V0
    if args.run and not args.v1:
        p.error("--run needs --v1 (v0's learned rows are the suite's PPO policies)")
    try:
        runs = parse_runs(args.run)
    except ValueError as exc:
        p.error(str(exc))
    started = time.perf_counter()
    common_args = {"env_id": env_id, "suite": args.suite, "runs": runs}
    if args.quick:
        count = QUICK["optimal"] if args.optimal is None else args.optimal
        data, per_episode = run(QUICK["episodes"], args.seed, QUICK["ppo_seeds"],
                                0 if args.v1 else count, QUICK["maxiter"], quick=True,
                                **common_args)
    else:
        count = (0 if args.v1 else 3) if args.optimal is None else args.optimal
        data, per_episode = run(args.episodes, args.seed, (0, 1, 2), count, args.maxiter,
                                **common_args)
    data["command"] = " ".join(["python -m benchmarks.bounds", *argv])
    data["wall_time_s"] = time.perf_counter() - started
    data["machine"] = common.machine()
    out = Path(args.out) if args.out else OUT[env_id]
    out.mkdir(parents=True, exist_ok=True)
    (out / "bounds.json").write_text(common.dumps(common._jsonable(data)) + "\n")
    table = markdown(data)
    (out / "bounds.md").write_text(table)
    plot(data, per_episode, out / "bounds.png")
    print(table)
    return data


if __name__ == "__main__":
    main(sys.argv[1:])
