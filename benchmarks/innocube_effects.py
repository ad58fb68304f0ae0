"""How much of the flight behaviour each modelled effect explains: the flight PD replayed from
every logged start of InnoCube telemetry, with innocube-3u's effects switched on one by one.

    python -m benchmarks.innocube_effects DIR [--identified SCENE.toml] [--out FOLDER]

DIR is a telemetry folder (e.g. ``lelar-in-orbit-data/maneuver_data/pd``; the data is not in
this repository). Rows, each with everything of the row above: ideal wheels and the true
attitude; + the command deadband; + the realized gain; + the start-up delay; + the wheel-speed
quantization; + the sensors as flown (gyro-integrated attitude, one-step delay); + the residual
magnetic dipole = innocube-3u as shipped; and, with ``--identified``, an identified scene.
Ranges of the scene (and the gyro's noise) are drawn per episode from each seed 0..N-1
(``--seeds``, default 5). Per row, as the mean over the seeds (with their range): the median
|error(rbenv) − error(flight)| over every logged sample, the mean of the sub-maneuvers' steady
errors (last 20 s); and the mean over the seeds of the median steady error and of the median
settle time below 1°. The figure is seed 0's.

Writes ``innocube_effects.json``, ``innocube_effects.md`` (the table) and ``replay_pd.png``
(flight against innocube-3u as shipped, and the identified scene) into FOLDER (default
``docs/innocube``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from rbenv.agents.flight import replay

import rbenv
from rbenv.satellite.scene import scene_table

POLICY = "innocube-pd"
WHEEL_KEYS = ("deadband_rpm_s", "realized_gain", "startup_delay_s", "speed_quantization_rpm")
ROWS = (("ideal wheels, true attitude", ()),
        ("+ deadband", ("deadband_rpm_s",)),
        ("+ realized gain", ("deadband_rpm_s", "realized_gain")),
        ("+ start-up delay", ("deadband_rpm_s", "realized_gain", "startup_delay_s")),
        ("+ speed quantization", WHEEL_KEYS))


def variants(identified: str | None) -> dict:
    """Row label → scene (a Scene, or a name/path)."""
    out, wheels = {}, scene_table("innocube-3u")["wheels"]
    no_dipole = {"orbit": {"residual_dipole": None}}
    for label, keys in ROWS:
        over = {"wheels": {k: (wheels[k] if k in keys else None) for k in WHEEL_KEYS},
                "sensors": None, **no_dipole}
        out[label] = rbenv.scene_variant("innocube-3u", over, name="innocube-3u")
    out["+ sensors as flown (gyro attitude, delay)"] = rbenv.scene_variant(
        "innocube-3u", no_dipole, name="innocube-3u")
    out["+ residual dipole = innocube-3u"] = "innocube-3u"
    if identified:
        out[f"identified ({Path(identified).name})"] = identified
    return out


def row(results: list[dict]) -> dict:
    """One row from the replays of several seeds: each metric's mean over the seeds, and the
    lowest and highest of the two the targets read."""
    per_seed = [{"median_abs_error_diff_deg": r["summary"]["median_abs_error_diff_deg"],
                 "sim_steady_deg_mean": r["summary"]["sim_steady_deg_mean"],
                 "sim_steady_deg_median": float(np.median(
                     [m["sim"]["steady_deg"] for m in r["maneuvers"]])),
                 "sim_settle_1deg_s_median": r["summary"]["sim_settle_1deg_s_median"]}
                for r in results]
    out = {}
    for key in per_seed[0]:
        values = [p[key] for p in per_seed if p[key] is not None]
        out[key] = float(np.mean(values)) if values else None
        if key in ("median_abs_error_diff_deg", "sim_steady_deg_mean"):
            out[key + "_range"] = [float(min(values)), float(max(values))]
    out["per_seed"] = per_seed
    return out


def table(rows: dict, flight: dict, seeds: int) -> str:
    def fmt(x, spec=".2f"):
        return "—" if x is None else format(x, spec)

    def spread(r, key):
        low, high = r[key + "_range"]
        return f"{fmt(r[key])} ({fmt(low)}–{fmt(high)})"
    lines = [f"| effects switched on | median \\|diff\\| (deg), mean of {seeds} seeds (range) "
             "| steady mean (deg) (range) | steady median (deg) | settle < 1° median (s) |",
             "|---|---|---|---|---|"]
    lines.append(f"| flight (telemetry) | — | {fmt(flight['steady_mean'])} "
                 f"| {fmt(flight['steady_median'])} | {fmt(flight['settle_median'], '.0f')} |")
    for label, r in rows.items():
        lines.append(f"| {label} | {spread(r, 'median_abs_error_diff_deg')} "
                     f"| {spread(r, 'sim_steady_deg_mean')} | {fmt(r['sim_steady_deg_median'])} "
                     f"| {fmt(r['sim_settle_1deg_s_median'], '.0f')} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir", help="telemetry folder")
    p.add_argument("--identified", default=None, help="an identified scene file, as a row")
    p.add_argument("--out", default="docs/innocube", help="output folder")
    p.add_argument("--seeds", type=int, default=5,
                   help="seeds 0..N-1 of the scene's per-episode draws (default 5)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, shipped, identified = {}, None, {}
    for label, scene in variants(args.identified).items():
        results = [replay.replay(args.dir, scene, POLICY, seed=seed)
                   for seed in range(args.seeds)]
        result = results[0]  # the figure's: seed 0
        rows[label] = row(results)
        print(f"{label}: {rows[label]}", flush=True)
        if scene == "innocube-3u":
            shipped = result
        elif scene == args.identified:
            identified = {"identified": result}
    steady = [m["flight"]["steady_deg"] for m in shipped["maneuvers"]]
    flight = {"steady_mean": shipped["summary"]["flight_steady_deg_mean"],
              "steady_median": float(np.median(steady)),
              "settle_median": shipped["summary"]["flight_settle_1deg_s_median"]}
    (out / "innocube_effects.json").write_text(json.dumps(
        {"telemetry": Path(args.dir).name, "policy": POLICY, "seeds": args.seeds,
         "flight": flight,
         "rows": rows}, indent=2) + "\n")
    (out / "innocube_effects.md").write_text(table(rows, flight, args.seeds) + "\n")
    replay.plot(shipped, out / "replay_pd.png", others=identified)
    print(table(rows, flight, args.seeds))


if __name__ == "__main__":
    main()
