"""What each as-flown effect of innocube-3u costs per env step, against the scene without it.

    python -m benchmarks.innocube_cost [--quick]

Times one env step of ``SatelliteReorient-v1`` with ``action_mode="acceleration"`` (random
actions, resets inline) through ``gym.make`` and, per sub-env, through the native vector env
at N = 1024, for ``innocube-3u`` with every as-flown effect off (ideal wheels, true attitude,
no residual dipole: the reference), each effect switched on alone, and the shipped scene (all
on). All in one run, interleaved (process CPU time, best of rounds), so each ratio to the
reference is what a user pays for that effect ("model only what a scene requires").

Writes ``innocube_cost.json``.
"""

from __future__ import annotations

import sys

import rbenv
from benchmarks import common

N_VECTOR = 1024
ENV_ID = "rbenv/SatelliteReorient-v1"
WHEEL_KEYS = ("deadband_rpm_s", "realized_gain", "startup_delay_s", "speed_quantization_rpm")


def variants() -> dict:
    """Label → Scene: the reference (all off), each effect alone, the shipped scene."""
    from rbenv.satellite.scene import scene_table

    shipped = scene_table("innocube-3u")
    wheels, sensors = shipped["wheels"], shipped["sensors"]
    dipole = shipped["orbit"]["residual_dipole"]
    off = {"wheels": dict.fromkeys(WHEEL_KEYS), "sensors": None,
           "orbit": {"residual_dipole": None}}

    def alone(label, wheel_keys=(), sensor_keys=None, with_dipole=False):
        over = {"wheels": {k: (wheels[k] if k in wheel_keys else None) for k in WHEEL_KEYS},
                "sensors": None if sensor_keys is None else
                {k: sensors[k] for k in sensor_keys},
                "orbit": {"residual_dipole": dipole if with_dipole else None}}
        return rbenv.scene_variant("innocube-3u", over, name=label)

    return {
        "reference (all off)": rbenv.scene_variant("innocube-3u", off, name="reference"),
        "+ deadband, gain, start-up delay": alone(
            "command", ("deadband_rpm_s", "realized_gain", "startup_delay_s")),
        "+ speed quantization": alone("quantization", ("speed_quantization_rpm",)),
        "+ gyro attitude (bias, walk, noise)": alone(
            "gyro", sensor_keys=("attitude", "gyro_bias_sigma_dps",
                                 "gyro_bias_walk_dps_sqrt_s", "gyro_noise_dps")),
        "+ one-step observation delay": alone("delay", sensor_keys=("delay_steps",)),
        "+ residual dipole (m x B at every stage)": alone("dipole", with_dipole=True),
        "innocube-3u (all on)": rbenv.load_scene("innocube-3u"),
    }


def measure(rounds: int = 7, n_vector: int = N_VECTOR) -> dict:
    kwargs = {name: {"scene": scene, "action_mode": "acceleration"}
              for name, scene in variants().items()}
    return common.variant_costs(ENV_ID, kwargs, "reference (all off)", single_steps=320,
                                n_vector=n_vector, rounds=rounds, ratio_key="reference")


def main(argv=()) -> dict:
    import argparse
    import os

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="3 rounds, N = 64 (CI's form)")
    quick = p.parse_args(argv).quick
    n_vector = 64 if quick else N_VECTOR
    rows = measure(rounds=3 if quick else 7, n_vector=n_vector)
    columns = ["effect", "single_us", "vector_us", "single_vs_reference",
               "vector_vs_reference"]
    print(common.table([{"effect": n, **{k: round(v, 3) for k, v in r.items()}}
                        for n, r in rows.items()], columns))
    if not quick:
        common.write_json("innocube_cost", {
            "rows": rows, "n_vector": n_vector, "env_id": ENV_ID,
            "action_mode": "acceleration", "load_average": os.getloadavg(),
            "command": "python -m benchmarks.innocube_cost"})
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
