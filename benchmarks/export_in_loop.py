"""An exported C policy flies the env as its run does: the same seeded episodes, compared.

For each ``--pair RUN DIR``: ``rbenv evaluate`` of the run folder (its Python policy) and of
``DIR/policy.c`` (compiled here, called through ctypes) on the same ``--episodes`` episodes from
``--seed``; per episode, the success, propellant, electrical energy and final error of the two
are compared. Writes ``export_in_loop.json``.

Run: ``python -m benchmarks.export_in_loop --pair runs/ppo-cubesat-12u-seed0
docs/export/ppo-reorient --episodes 500 --seed 1000000``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.common import write_json


def _rel(a: np.ndarray, b: np.ndarray) -> float | None:
    both = np.isfinite(a) & np.isfinite(b)
    if not both.any():
        return None
    scale = np.maximum(np.abs(b[both]), 1e-12)
    return float(np.max(np.abs(a[both] - b[both]) / scale))


def compare(run: str, folder: str, episodes: int, seed: int) -> dict:
    from rbenv.agents.policies.compiled import manifest
    from rbenv.agents.policies.evaluate import evaluate

    env_id = manifest(Path(folder))["env_id"]  # the run's task, as rbenv evaluate finds it
    python = evaluate(run, episodes=episodes, seed=seed, record=0, name="run (Python)",
                      env_id=env_id)
    flown = evaluate(str(Path(folder) / "policy.c"), episodes=episodes, seed=seed, record=0,
                     name="policy.c (ctypes)", env_id=env_id)
    return {
        "run": run, "export": folder, "env_id": env_id, "episodes": episodes, "seed": seed,
        "summaries": [python.summary(), flown.summary()],
        "success_equal_episodes": int(np.sum(python.success == flown.success)),
        "fuel_max_relative_difference": _rel(flown.fuel_kg, python.fuel_kg),
        "energy_max_relative_difference": _rel(flown.energy_J, python.energy_J),
        "final_error_max_abs_difference_deg": float(np.nanmax(np.abs(
            flown.final_error_deg - python.final_error_deg))),
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.export_in_loop",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--pair", nargs=2, action="append", required=True, metavar=("RUN", "DIR"),
                   help="a run folder and the folder rbenv export wrote from it")
    p.add_argument("--episodes", type=int, default=500)
    p.add_argument("--seed", type=int, default=1_000_000)
    args = p.parse_args(argv)
    results = [compare(run, folder, args.episodes, args.seed) for run, folder in args.pair]
    for r in results:
        py, c = r["summaries"]
        print(f"{r['export']}: success {100 * py['success_rate']:.1f} % (run) vs "
              f"{100 * c['success_rate']:.1f} % (C), same in {r['success_equal_episodes']} of "
              f"{r['episodes']} episodes; propellant {py['fuel']['mean'] * 1e3:.4f} g vs "
              f"{c['fuel']['mean'] * 1e3:.4f} g (largest relative difference per episode "
              f"{r['fuel_max_relative_difference']})")
    write_json("export_in_loop", {"results": results})


if __name__ == "__main__":
    main()
