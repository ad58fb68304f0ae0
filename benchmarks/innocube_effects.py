"""How much of the flight behaviour each modelled effect explains: the flight PD replayed from
every logged start of InnoCube telemetry, with innocube-3u's effects switched on one by one.

    python -m benchmarks.innocube_effects DIR [--identified SCENE.toml] [--out FOLDER]

DIR is a telemetry folder (e.g. ``lelar-in-orbit-data/maneuver_data/pd``; the data is not in
this repository). Rows, each with everything of the row above: ideal wheels and the true
attitude; + the command deadband; + the realized gain; + the start-up delay; + the wheel-speed
quantization; + the sensors as flown (gyro-integrated attitude, one-step delay) = innocube-3u
as shipped; and, with ``--identified``, an identified scene. Ranges of the scene are drawn per
episode from seed 0. Per row: the median |error(rbenv) − error(flight)| over every logged
sample, the mean and median steady error (last 20 s), the median settle time below 1°.

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
from rbenv.scene import scene_table

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
    for label, keys in ROWS:
        over = {"wheels": {k: (wheels[k] if k in keys else None) for k in WHEEL_KEYS},
                "sensors": None}
        out[label] = rbenv.scene_variant("innocube-3u", over, name="innocube-3u")
    out["+ sensors as flown (gyro attitude, delay) = innocube-3u"] = "innocube-3u"
    if identified:
        out[f"identified ({Path(identified).name})"] = identified
    return out


def row(result: dict) -> dict:
    steady = [m["sim"]["steady_deg"] for m in result["maneuvers"]]
    s = result["summary"]
    return {"median_abs_error_diff_deg": s["median_abs_error_diff_deg"],
            "sim_steady_deg_mean": s["sim_steady_deg_mean"],
            "sim_steady_deg_median": float(np.median(steady)),
            "sim_settle_1deg_s_median": s["sim_settle_1deg_s_median"]}


def table(rows: dict, flight: dict) -> str:
    def fmt(x, spec=".2f"):
        return "—" if x is None else format(x, spec)
    lines = ["| effects switched on | median \\|diff\\| (deg) | steady mean (deg) "
             "| steady median (deg) | settle < 1° median (s) |", "|---|---|---|---|---|"]
    lines.append(f"| flight (telemetry) | — | {fmt(flight['steady_mean'])} "
                 f"| {fmt(flight['steady_median'])} | {fmt(flight['settle_median'], '.0f')} |")
    for label, r in rows.items():
        lines.append(f"| {label} | {fmt(r['median_abs_error_diff_deg'])} "
                     f"| {fmt(r['sim_steady_deg_mean'])} | {fmt(r['sim_steady_deg_median'])} "
                     f"| {fmt(r['sim_settle_1deg_s_median'], '.0f')} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir", help="telemetry folder")
    p.add_argument("--identified", default=None, help="an identified scene file, as a row")
    p.add_argument("--out", default="docs/innocube", help="output folder")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, shipped, identified = {}, None, {}
    for label, scene in variants(args.identified).items():
        result = replay.replay(args.dir, scene, POLICY)
        rows[label] = row(result)
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
        {"telemetry": Path(args.dir).name, "policy": POLICY, "seed": 0, "flight": flight,
         "rows": rows}, indent=2) + "\n")
    (out / "innocube_effects.md").write_text(table(rows, flight) + "\n")
    replay.plot(shipped, out / "replay_pd.png", others=identified)
    print(table(rows, flight))


if __name__ == "__main__":
    main()
