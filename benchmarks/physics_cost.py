"""What the new physics costs: reaction wheels, magnetorquers and orbit torques, per env step.

    python -m benchmarks.physics_cost [--instructions]    (or: rbenv bench physics_cost)

Times one env step of ``SatelliteReorient-v0`` (random actions, resets inline) through
``gym.make`` and, per sub-env, through the native vector env at N = 4096, for the thruster
scene ``cubesat-12u`` (the reference) and for ``cubesat-6u-rw`` with its models switched on one
at a time: wheels only; wheels and magnetorquers with Earth's field; and the whole scene
(wheels, rods, field and gravity gradient). All in one run, interleaved (process CPU time,
best of rounds), so the ratios to ``cubesat-12u`` are what a user pays for each model. Target:
the whole ``cubesat-6u-rw`` within 1.5x of ``cubesat-12u`` per env step.

With ``--instructions`` (needs valgrind) it also counts the instructions of one single-env
step of each variant with callgrind: a ratio that does not move with the machine's load.

Writes ``physics_cost.json`` and ``physics_cost.png``.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

import rbenv
from benchmarks import common

N_VECTOR = 4096


def _variants() -> dict:
    """Scene name → Scene: the reference, then the 6U scene with models added one by one."""
    full = rbenv.load_scene("cubesat-6u-rw")
    orbit_off = dataclasses.replace(full.orbit, model="none", gravity_gradient=False,
                                    magnetic_field=False)
    wheels_only = dataclasses.replace(full, orbit=orbit_off,
                                      actuators={"wheels": full.actuators["wheels"]})
    field_only = dataclasses.replace(full, orbit=dataclasses.replace(
        full.orbit, gravity_gradient=False))
    return {"cubesat-12u (thrusters)": rbenv.load_scene("cubesat-12u"),
            "6u: wheels": wheels_only,
            "6u: wheels + rods + field": field_only,
            "6u: all (+ gravity gradient)": full}


def _single(scene, steps: int = 400):
    return common.single_env_loop(rbenv.ENV_ID, steps, scene=scene)


def measure(rounds: int = 7) -> dict:
    kwargs = {name: {"scene": scene} for name, scene in _variants().items()}
    return common.variant_costs(rbenv.ENV_ID, kwargs, "cubesat-12u (thrusters)",
                                single_steps=400, n_vector=N_VECTOR, rounds=rounds,
                                ratio_key="12u")


# One variant's single env under callgrind: its name and the step count come as arguments.
COUNT = """
import sys
from benchmarks.physics_cost import _single, _variants
run, _ = _single(_variants()[sys.argv[1]], steps=int(sys.argv[2]))
run()
"""


def add_instructions(rows: dict, steps: int = 2000) -> None:
    """Instructions per single-env step of each variant, and their ratio to cubesat-12u."""
    for name, row in rows.items():
        low, high = (common.instructions(COUNT, name, str(n)) for n in (0, steps))
        row["single_instructions"] = (high - low) / steps
    ref = rows["cubesat-12u (thrusters)"]["single_instructions"]
    for row in rows.values():
        row["instructions_vs_12u"] = row["single_instructions"] / ref


def plot(rows: dict):
    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    names = list(rows)
    x = np.arange(len(names))
    ax.bar(x - 0.2, [rows[n]["single_vs_12u"] for n in names], 0.4, label="single env")
    ax.bar(x + 0.2, [rows[n]["vector_vs_12u"] for n in names], 0.4,
           label=f"vector env, per sub-env (N = {N_VECTOR})")
    ax.axhline(1.5, color="k", ls="--", lw=0.8, label="target 1.5x")
    ax.set_xticks(x, names, rotation=12, fontsize=8)
    ax.set_ylabel("cost per env step / cubesat-12u")
    ax.set_title("What each model costs (SatelliteReorient-v0, one run)")
    ax.legend(fontsize=8)
    return fig


def main(argv=()) -> dict:
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--instructions", action="store_true",
                   help="also count single-env instructions with valgrind (minutes)")
    counted = p.parse_args(argv).instructions
    rows = measure()
    if counted:
        add_instructions(rows)
    columns = ["scene", "single_us", "vector_us", "single_vs_12u", "vector_vs_12u"]
    print(common.table([{"scene": n, **{k: round(v, 3) for k, v in r.items()}}
                        for n, r in rows.items()],
                       columns + (["instructions_vs_12u"] if counted else [])))
    command = "python -m benchmarks.physics_cost" + (" --instructions" if counted else "")
    common.write_json("physics_cost", {"rows": rows, "n_vector": N_VECTOR,
                                       "command": command})
    common.save_figure(plot(rows), "physics_cost")
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
