"""Where a reorientation's propellant goes: spin-up, cruise and capture, per policy.

Run ``python -m benchmarks.propellant_phases --policy P [--policy P ...] [--episodes 200]
[--seed 5000000] [--out NAME]``. P is a scripted policy of Reorient-v2 (``pd``, ``bangbang``,
``mpc``) or a run folder, optionally ``RUN@ACTION`` with ACTION ``mode`` or ``mean_throttle``
(how a trained PPO model acts: :class:`rbenv.agents.policies.sb3.RunPolicy`; default ``auto``).
The default seed is the validation episodes' (never the report's held-out ones). Results:
``benchmarks/results/<NAME>.json`` (default ``propellant_phases``) and a table on stdout.

Each episode (cubesat-12u, Reorient-v2, run until it ends) is cut at two instants: the step of
its peak body rate, and the first step from which the attitude error stays below 10°. The
propellant spent before the peak is the spin-up, between the two the cruise (and the turn's
braking down to 10°), after the second the capture (the last 10°, the stop and the hold).
Propellant is ``info["fuel_kg"]`` (cumulative), so the three parts add up to the episode's.
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from benchmarks.common import table, write_json

ENV_ID = "rbenv/SatelliteReorient-v2"
CAPTURE_DEG = 10.0


def _policy(spec: str, env):
    from rbenv.agents.policies.evaluate import make_policy, scripted
    from rbenv.agents.policies.load import load_policy

    name, _, action = spec.partition("@")
    if name in scripted(ENV_ID):
        return make_policy(name, env)
    return load_policy(name, action or "auto")


def phases(spec: str, episodes: int, seed: int) -> dict:
    """The propellant (g, means over episodes) of each phase, the peak rate (°/s, median) and
    the capture's length (control steps, median), with success and settle time."""
    import gymnasium as gym

    env = gym.make_vec(ENV_ID, num_envs=episodes, vectorization_mode="vector_entry_point")
    policy = _policy(spec, env)
    obs, _ = env.reset(seed=seed)
    alive, first, state = np.ones(episodes, bool), np.ones(episodes, bool), None
    rate, err, fuel, success = [], [], [], np.zeros(episodes, bool)
    for _ in range(env.unwrapped.plant.scene.episode_steps):
        action, state = policy.predict(obs, state=state, episode_start=first,
                                       deterministic=True)
        first[:] = False
        obs, _, term, trunc, info = env.step(action)
        rate.append(np.where(alive, info["rate_dps"], np.nan))
        err.append(np.where(alive, info["attitude_error_deg"], np.nan))
        fuel.append(np.where(alive, info["fuel_kg"], np.nan))
        success |= alive & np.asarray(info["is_success"], bool)
        alive &= ~(term | trunc)
        if not alive.any():
            break
    env.close()
    rate, err, fuel = (np.array(x) for x in (rate, err, fuel))  # (steps, episodes)
    steps = np.isfinite(err).sum(axis=0)
    cols = np.arange(episodes)
    total = fuel[steps - 1, cols]
    peak = np.nanargmax(rate, axis=0)
    above = np.where(np.isfinite(err), err >= CAPTURE_DEG, False)
    last_above = np.where(above.any(axis=0), len(err) - 1 - np.argmax(above[::-1], axis=0), -1)
    capture = np.maximum(last_above + 1, peak)  # the first step of the capture phase
    fuel0 = np.vstack([np.zeros(episodes), fuel])  # fuel spent before step k: fuel0[k]
    spin, cruise = fuel0[peak, cols], fuel0[capture, cols] - fuel0[peak, cols]
    g = 1000.0
    return {"policy": spec, "episodes": episodes, "seed": seed,
            "success_rate": float(success.mean()),
            "episode_steps_median": float(np.median(steps)),
            "peak_rate_dps_median": float(np.median(np.nanmax(rate, axis=0))),
            "propellant_g": {"total": g * float(total.mean()), "spin_up": g * float(spin.mean()),
                             "cruise": g * float(cruise.mean()),
                             "capture": g * float((total - fuel0[capture, cols]).mean())},
            "capture_steps_median": float(np.median(steps - capture))}


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", action="append", required=True)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=5_000_000)
    parser.add_argument("--out", default="propellant_phases")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    rows = [phases(p, args.episodes, args.seed) for p in args.policy]
    write_json(args.out, {"env_id": ENV_ID, "scene": "cubesat-12u", "rows": rows,
                          "command": "python -m benchmarks.propellant_phases "
                          + " ".join(argv if argv is not None else sys.argv[1:])})
    flat = [{"policy": r["policy"], "success": f"{100 * r['success_rate']:.1f} %",
             "peak °/s": f"{r['peak_rate_dps_median']:.2f}",
             **{k: f"{v:.3f}" for k, v in r["propellant_g"].items()},
             "capture steps": f"{r['capture_steps_median']:.0f}"} for r in rows]
    print(table(flat, list(flat[0])))
    return rows


if __name__ == "__main__":
    main()
