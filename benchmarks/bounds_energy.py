"""The energy-rate bounds against optimised trajectories: wheel reorientation and detumbling.

    python -m benchmarks.bounds_energy [--quick] [--out DIR] [--seed 1000000] [--episodes 3]
                                       [--candidates 200] [--maxiter 150]

For each case, a few seeded episodes (the quartiles of the initial angle, or of the initial
rate for detumbling, among ``--candidates`` episodes from ``--seed``) get open-loop commands
optimised by :mod:`rbenv.agents.baselines.open_loop` (SciPy SLSQP) and replayed in the env
itself; the env's settle time and propellant are what count. Each is set beside the bounds of
:mod:`rbenv.agents.baselines.bounds` for that episode; a bound above an achieved value is a
bug and is
counted in ``violations``.

* ``reorient-wheels`` on cubesat-6u-rw and cubesat-12u-rw (Reorient, the default id): the
  earliest settle through the wheels alone (bisection on the settle step between the bound
  and the PD's settle step), wheel torque and speed limits honoured. Bounds: the energy-rate
  settle bound the evaluations report (every actuator of the scene may act), and the same
  bound for the wheels alone (``torque_limits(scene, used=("wheels",))``, the one that holds
  for a wheels-only manoeuvre; on cubesat-6u-rw the two are one).
* ``detumble-thrusters`` on cubesat-12u (Detumble): the earliest settle, and the least
  propellant settling at the PD's settle step (throttles held 1 s). Bounds: the settle bound,
  the propellant bound of any successful policy and at the trajectory's own settle time.
* ``detumble-wheels`` on cubesat-6u-rw (Detumble, 10 s steps): the earliest settle through the
  wheels alone (the rods idle).
* ``detumble-rods`` on cubesat-6u-rw: the earliest settle through the rods alone (dipoles held
  20 s; the optimiser models the orbit's field and gravity gradient), from the B-dot's
  commands and settle step.

The "PD" of each row is the warm start's controller (B-dot for the rods). The 12u-rw wheels
and the rods hold each command over 2 control steps (fewer unknowns, same settle steps).
Writes ``bounds_energy.json`` and ``bounds_energy.md`` to ``--out``
(default ``benchmarks/results/bounds``). ``--quick``: one episode per case (the smallest angle
or rate), one solve at the warm start's settle step (no bisection), 80 SLSQP iterations: a
smoke test for CI, about a minute.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import common

OUT = common.RESULTS / "bounds"
QUICK = {"episodes": 1, "maxiter": 80, "candidates": 40}


def cases() -> dict:
    import rbenv

    return {
        "reorient-wheels cubesat-6u-rw": {"env_id": rbenv.ENV_ID, "scene": "cubesat-6u-rw",
                                          "actuator": "wheels", "fuel": False},
        "reorient-wheels cubesat-12u-rw": {"env_id": rbenv.ENV_ID, "scene": "cubesat-12u-rw",
                                           "actuator": "wheels", "fuel": False, "block": 2},
        "detumble-thrusters cubesat-12u": {"env_id": rbenv.DETUMBLE_ID, "scene": "cubesat-12u",
                                           "actuator": "thrusters", "fuel": True},
        "detumble-wheels cubesat-6u-rw": {"env_id": rbenv.DETUMBLE_ID, "scene": "cubesat-6u-rw",
                                          "actuator": "wheels", "fuel": False},
        "detumble-rods cubesat-6u-rw": {"env_id": rbenv.DETUMBLE_ID, "scene": "cubesat-6u-rw",
                                        "actuator": "magnetorquers", "fuel": False,
                                        "warm": "bdot", "block": 2},
    }


def picks(key: np.ndarray, count: int, quick: bool) -> np.ndarray:
    """Indices of ``count`` episodes at evenly spaced quantiles (25 %…75 %) of ``key``; quick:
    the smallest (the shortest horizon)."""
    order = np.argsort(key)
    if quick:
        return order[:count]
    q = np.linspace(0.25, 0.75, count) if count > 1 else np.array([0.5])
    return order[np.rint(q * (len(order) - 1)).astype(int)]


def run_case(name: str, case: dict, seed: int, count: int, candidates: int, maxiter: int,
             quick: bool) -> list[dict]:
    """The rows of one case: per picked episode, its bounds, the PD and the optimised
    trajectories as the env replays them."""
    from rbenv.agents.baselines import bounds as rb
    from rbenv.agents.baselines import open_loop as ol
    from rbenv.agents.policies.optimality import episode_bounds

    env_id, scene, actuator = case["env_id"], case["scene"], case["actuator"]
    starts = rb.episode_starts(candidates, seed, scene, env_id=env_id)
    reorient = "angle" in starts
    key = starts["angle"] if reorient else np.linalg.norm(starts["omega_B"], axis=1)
    reported = episode_bounds(candidates, seed, env_id, {"scene": scene})
    task_scene = ol.Episode.from_seed(seed, env_id, scene, actuator).scene  # the task's physics
    used = rb.energy_settle_bound(rb.torque_limits(task_scene, used=(actuator,)),
                                  starts["omega_B"], starts.get("angle"),
                                  starts["bias_B"])["sampled"]
    rows = []
    for i in picks(key, count, quick):
        i = int(i)
        s = seed + i
        started = time.perf_counter()
        ep = ol.Episode.from_seed(s, env_id, scene, actuator)
        dt = ep.dt
        row = {"case": name, "seed": s, "scene": scene, "env_id": env_id,
               "actuator": actuator,
               ("angle_deg" if reorient else "rate0_dps"): float(np.degrees(key[i])),
               "settle_bound_s": float(reported.settle_s[i]),
               "settle_bound_used_s": float(used[i])}
        warm = case.get("warm", "pd")
        pd = ol.replay(warm, ep)
        row["pd"] = {"policy": warm, "success": pd["success"],
                     "settle_time_s": pd["settle_time_s"], "fuel_g": 1000 * pd["fuel_kg"]}
        if pd["success"] or not quick:
            # A failed warm start: from rest, with the latest settle step as the upper end.
            latest = ep.scene.episode_steps - ep.scene.hold_steps + 1
            hi = int(np.rint(pd["settle_time_s"] / dt)) if pd["success"] else latest
            guess = pd["commands"] if pd["success"] else None
            # quick: one solve at the warm start's step (a smoke test), no bisection
            lo = hi - 1 if quick else max(int(np.rint(used[i] / dt)) - 1, 0)
            sol = ol.time_optimal(ep, hi, guess, lo, maxiter=maxiter,
                                  block=case.get("block", 1))
            rep = ol.replay(sol.commands, ep)
            row["time_optimal"] = {"solver_feasible": sol.feasible, "success": rep["success"],
                                   "settle_time_s": rep["settle_time_s"],
                                   "fuel_g": 1000 * rep["fuel_kg"]}
            if case["fuel"]:
                sol = ol.fuel_optimal(ep, hi, guess, maxiter=maxiter)
                rep = ol.replay(sol.commands, ep)
                own = np.full(candidates, rep["settle_time_s"] if rep["success"] else math.nan)
                row["fuel_optimal"] = {"solver_feasible": sol.feasible,
                                       "success": rep["success"],
                                       "settle_time_s": rep["settle_time_s"],
                                       "fuel_g": 1000 * rep["fuel_kg"],
                                       "fuel_bound_own_time_g":
                                           1000 * float(reported.fuel_at(own)[i])}
        if reported.fuel_kg is not None:
            row["fuel_bound_g"] = 1000 * float(reported.fuel_kg[i])
        row["violations"] = violations(row)
        row["wall_s"] = time.perf_counter() - started
        print(f"  {name}, episode {s}: {json.dumps(row, default=float)}", flush=True)
        rows.append(row)
    return rows


def violations(row: dict) -> list[str]:
    """Every bound of ``row`` above a value the env achieved (each one a bug)."""
    out = []
    for key in ("time_optimal", "fuel_optimal", "pd"):
        r = row.get(key)
        if not r or not r["success"]:
            continue
        for bound in ("settle_bound_s", "settle_bound_used_s"):
            if bound == "settle_bound_used_s" and key == "pd":
                continue  # the PD may use every actuator; the restricted bound is not its
            if r["settle_time_s"] < row[bound] - 1e-9:
                out.append(f"{key} settles at {r['settle_time_s']} s < {bound} {row[bound]}")
        if "fuel_bound_g" in row and r["fuel_g"] < row["fuel_bound_g"] - 1e-12:
            out.append(f"{key} spends {r['fuel_g']} g < fuel_bound_g {row['fuel_bound_g']}")
        own = r.get("fuel_bound_own_time_g")
        if own is not None and r["fuel_g"] < own - 1e-12:
            out.append(f"{key} spends {r['fuel_g']} g < its own-time bound {own}")
    return out


def _f(x, spec=".1f"):
    if not isinstance(x, (int, float)) or not math.isfinite(x):  # None, NaN ("NaN" in JSON)
        return "—"
    return format(x, spec)


def markdown(data: dict) -> str:
    lines = [
        "Optimised open-loop trajectories (SciPy SLSQP, `rbenv.agents.baselines.open_loop`), "
        "replayed in the env on the same seeded episodes, beside the lower bounds of "
        "`rbenv.agents.baselines.bounds`. Settle bound: the one every evaluation reports "
        "(any actuator of "
        "the scene); own actuator: the bound for the optimised actuator alone. A bound above an "
        "achieved value would be a bug: "
        f"{data['violation_count']} found.", "",
        "| case | episode | angle or rate0 | settle bound (s) | own actuator (s) | "
        "time-optimised (s) | / bound | PD or B-dot (s) | fuel bound (g) | fuel-optimised (g) | "
        "own-time fuel bound (g) |",
        "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        t = r.get("time_optimal", {})
        f = r.get("fuel_optimal", {})
        start = (f"{r['angle_deg']:.1f}°" if "angle_deg" in r else f"{r['rate0_dps']:.2f}°/s")
        settle = t.get("settle_time_s") if t.get("success") else None
        ratio = settle / r["settle_bound_used_s"] if settle and r["settle_bound_used_s"] else None
        lines.append(
            f"| {r['case']} | {r['seed']} | {start} | {r['settle_bound_s']:.1f} | "
            f"{r['settle_bound_used_s']:.1f} | "
            f"{_f(settle) if t else '—'}{'' if not t or t['success'] else ' (failed)'} | "
            f"{_f(ratio, '.2f')} | {_f(r['pd']['settle_time_s'])} | "
            f"{_f(r.get('fuel_bound_g'), '.3f')} | "
            f"{_f(f.get('fuel_g'), '.3f') if f else '—'} | "
            f"{_f(f.get('fuel_bound_own_time_g'), '.3f') if f else '—'} |")
    return "\n".join(lines) + "\n"


def main(argv=()) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smoke form: " + json.dumps(QUICK))
    p.add_argument("--out", default=None, help=f"output folder (default {OUT})")
    p.add_argument("--seed", type=int, default=1_000_000)
    p.add_argument("--episodes", type=int, default=3, help="episodes per case")
    p.add_argument("--candidates", type=int, default=200,
                   help="episodes whose quartiles are picked")
    p.add_argument("--maxiter", type=int, default=150, help="SLSQP iterations per solve")
    p.add_argument("--case", action="append", default=[],
                   help="run only this case (repeatable; default all); without --quick, the "
                        "rows of the other cases in an existing bounds_energy.json of the same "
                        "settings are kept")
    args = p.parse_args(argv)
    from rbenv.agents.training.sb3 import set_threads

    set_threads(1)
    all_cases = cases()
    unknown = sorted(set(args.case) - set(all_cases))
    if unknown:
        p.error(f"--case {unknown[0]!r}: the cases are {sorted(all_cases)}")
    chosen = {k: v for k, v in all_cases.items() if not args.case or k in args.case}
    count, maxiter, candidates = ((QUICK["episodes"], QUICK["maxiter"], QUICK["candidates"])
                                  if args.quick else
                                  (args.episodes, args.maxiter, args.candidates))
    started = time.perf_counter()
    rows = []
    for name, case in chosen.items():
        rows += run_case(name, case, args.seed, count, candidates, maxiter, args.quick)
    data = {"seed": args.seed, "candidates": candidates, "episodes_per_case": count,
            "maxiter": maxiter, "quick": args.quick, "rows": rows,
            "violation_count": sum(len(r["violations"]) for r in rows),
            "command": " ".join(["python -m benchmarks.bounds_energy", *argv]),
            "wall_time_s": time.perf_counter() - started,
            "load_average_1min_at_end": os.getloadavg()[0], "machine": common.machine()}
    out = Path(args.out) if args.out else OUT
    out.mkdir(parents=True, exist_ok=True)
    old = out / "bounds_energy.json"
    if args.case and not args.quick and old.is_file():  # rerun cases: update their rows
        kept = json.loads(old.read_text())
        if (kept["seed"], kept["candidates"], kept["episodes_per_case"], kept["maxiter"]) == (
                args.seed, candidates, count, maxiter):
            order = list(all_cases)
            data["rows"] = sorted([r for r in kept["rows"] if r["case"] not in chosen] + rows,
                                  key=lambda r: order.index(r["case"]))
            data["violation_count"] = sum(len(r["violations"]) for r in data["rows"])
            data["command"] = kept.get("command", "") + "; then " + data["command"]
            data["wall_time_s"] += kept.get("wall_time_s", 0.0)
    (out / "bounds_energy.json").write_text(json.dumps(common._jsonable(data), indent=1) + "\n")
    table = markdown(data)
    (out / "bounds_energy.md").write_text(table)
    print(table)
    return data


if __name__ == "__main__":
    main(sys.argv[1:])
