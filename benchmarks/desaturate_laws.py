"""Rod laws on Desaturate-v1's validation episodes: how far past ``unload`` a memoryless law of
the observation can go, the reference for the PPO sweep (docs/results.md).

    python -m benchmarks.desaturate_laws [--episodes 200] [--seed 5000000] [--out DIR]

Each law maps the stored wheel momentum h_w and the field B (read from the observation as
``unload`` reads them) to rod fractions μ; the env's inner loop holds the attitude:

- ``scaled K``: ``m = K (h_w × B)/|B|²`` to the rods by the pseudo-inverse, scaled down as a
  whole at a rod's limit (``unload`` is K = 0.003 1/s);
- ``clipped K``: the same dipole, each rod clipped to its limit on its own;
- ``lin c``: ``μ = clip(c · dump_B)`` (the observation's dump_B, Desaturate-v1);
- ``bang``: ``μ = sign(h_w × B)``, every rod at its limit.

Writes ``OUT/v1-laws.json`` (default ``benchmarks/results/desaturate``): success,
settle median (s) and energy mean (J) per law, on validation episodes (seeds 5,000,000 + i by
default; never the held-out ones).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines.controllers import Unload
from rbenv.agents.policies.evaluate import evaluate
from rbenv.core.vec import cross

from benchmarks import common
from rbenv.satellite.actuators.magnetorquers import FIELD_SCALE_T

ENV_ID = "rbenv/SatelliteDesaturate-v1"
LAWS = (("scaled", 0.001), ("scaled", 0.003), ("scaled", 0.005), ("scaled", 0.01),
        ("clipped", 0.002), ("clipped", 0.003), ("clipped", 0.004), ("clipped", 0.005),
        ("clipped", 0.01), ("lin", 2.0), ("lin", 4.0), ("lin", 8.0), ("bang", 0.0))


@dataclass(frozen=True, eq=False)
class RodLaw(Unload):
    """A rod law of the module docstring (``kind``, ``k``); the wheel entries stay zero (the
    env's inner loop drives the wheels)."""

    kind: str = "scaled"
    k: float = 0.003

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        h = self.wheel_momentum_B(obs)
        b = obs[:, self.slices["field_B"]] * FIELD_SCALE_T
        if self.kind == "lin":
            mu = np.clip(self.k * obs[:, self.slices["dump_B"]], -1.0, 1.0)
        elif self.kind == "bang":
            mu = np.sign(cross(h, b))
        else:
            mu = self.dipole_fractions(h, b, self.k)
            mu = np.clip(mu, -1.0, 1.0) if self.kind == "clipped" else \
                mu / np.maximum(np.abs(mu).max(axis=1, keepdims=True), 1.0)
        out = np.zeros((len(obs), self.plant.action_shape[0]), np.float32)
        out[:, self.plant.action_slices[self.plant.actuators.index(self.rods)]] = mu
        return (out[0], state) if single else (out, state)


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=200)
    p.add_argument("--seed", type=int, default=5_000_000)
    p.add_argument("--out", type=Path, default=common.RESULTS / "desaturate")
    a = p.parse_args(argv)
    env = gym.make(ENV_ID)
    rows, start = [], time.process_time()
    for kind, k in LAWS:
        name = kind if kind == "bang" else f"{kind} {k:g}"
        r = evaluate(RodLaw.from_env(env, kind=kind, k=k), episodes=a.episodes, seed=a.seed,
                     env_id=ENV_ID, record=0, name=name).summary()
        rows.append({"law": name, "success_rate": r["success_rate"],
                     "settle_time_median_s": r["settle_time_s"]["median"],
                     "energy_mean_J": round(r["energy"]["mean"], 1)})
        print(json.dumps(rows[-1]), flush=True)
    out = {"benchmark": "desaturate/v1-laws",
           "command": "python -m benchmarks.desaturate_laws",
           "episodes": a.episodes, "seed": a.seed, "env_id": ENV_ID, "scene": "cubesat-6u-rw",
           "cpu_s": round(time.process_time() - start, 1),
           "load_average_1min": os.getloadavg()[0], "rows": rows}
    a.out.mkdir(parents=True, exist_ok=True)
    text = json.dumps({k: v for k, v in out.items() if k != "rows"})[:-1]  # a row a line
    text += ', "rows": [\n' + ",\n".join(json.dumps(r) for r in rows) + "\n]}\n"
    (a.out / "v1-laws.json").write_text(text)
    return out


if __name__ == "__main__":
    main()
