"""The attitude estimator's validation numbers and its cost (docs/estimation.md).

    python -m benchmarks.estimation              # validation, then cost
    python -m benchmarks.estimation --no-cost    # validation only
    python -m benchmarks.estimation --cost-only  # cost only (--repeats 5 by default)

Validation: the Monte Carlo consistency of the MEKF (rbenv.satellite.estimation.monte_carlo,
300 runs × 300 steps: the run-averaged NEES of attitude and bias, their 95 % χ² band and the
share of steps inside it), the bias error in units of the filter's σ, the NEES computed from
``info`` alone over 200 seeded episodes of cubesat-12u with a star tracker, and the true
estimation error of docs/innocube/innocube-3u-mekf.toml (zero action, 20 episodes). Cost: one
single-env step and one vector-env step at N = 1024, cubesat-12u with and without the
estimator, in one run (the vector env also with the star tracker's fix steps spread over the
rows, as after autoresets): ``--repeats`` rounds, each timing all in turn, the median of each
and the ratio of the medians, with the 1-minute load average before and after (other
processes on a shared machine inflate single rounds).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from scipy.stats import chi2

import rbenv  # noqa: F401 (registers the ids)
from rbenv.satellite import sensors as sn
from rbenv.satellite.estimation import monte_carlo
from rbenv.satellite.scene import Scene, scene_table

V1 = "rbenv/SatelliteReorient-v1"
ROOT = Path(__file__).resolve().parents[1]


def star_scene() -> Scene:
    """cubesat-12u with a gyro, a default star tracker and the MEKF (as the tests use)."""
    data = scene_table("cubesat-12u")
    data["sensors"] = {"attitude": "estimator", "gyro_bias_sigma_dps": 0.05,
                       "gyro_bias_walk_dps_sqrt_s": 2e-4, "gyro_noise_dps": 0.01}
    data["estimator"] = {"initial_attitude_sigma_deg": 0.5}
    data["star_tracker"] = {}
    return Scene.from_dict(data, name="cubesat-12u-est")


def _info_error(info) -> np.ndarray:
    return np.concatenate((sn.qlog(sn.qmul(sn.qconj(info["q_est"]), info["q_true"])),
                           info["gyro_bias"] - info["gyro_bias_est"]), -1)


def validation() -> None:
    runs = 300
    lo, hi = chi2.ppf([0.025, 0.975], 3 * runs) / runs
    for sensors in (("star",), ("mag", "sun")):
        a, b, f, bias = monte_carlo(runs, 300, sensors)
        print(f"MC {'+'.join(sensors)}: band [{lo:.3f}, {hi:.3f}]; mean NEES attitude "
              f"{a.mean():.3f} (steps inside {np.mean((a > lo) & (a < hi)):.1%}), bias "
              f"{b.mean():.3f} (inside {np.mean((b > lo) & (b < hi)):.1%})")
    _, _, f, bias = monte_carlo(runs, 300, ("star",), seed=2)
    sigma = np.sqrt(np.diagonal(f.P, axis1=1, axis2=2)[:, 3:])
    z = np.abs(f.bias - bias) / sigma
    print(f"bias after 300 s: within 1σ {np.mean(z < 1):.1%}, within 3σ {np.mean(z < 3):.1%}; "
          f"σ {np.degrees(sigma.mean()) * 3600:.2f} °/h (prior 180 °/h)")
    env = gym.make(V1, scene=star_scene()).unwrapped
    nees, err = [], []
    for seed in range(200):
        env.reset(seed=seed)
        for _ in range(30):
            _, _, _, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
        e = _info_error(info)
        nees.append(e @ np.linalg.solve(info["estimate_cov"], e))
        err.append(math.degrees(np.linalg.norm(e[:3])) * 3600)
    lo6, hi6 = chi2.ppf([0.025, 0.975], 6 * 200) / 200
    print(f"env, from info, 200 episodes at step 30: mean NEES {np.mean(nees):.3f} (band "
          f"[{lo6:.3f}, {hi6:.3f}]); attitude error median {np.median(err):.1f} arcsec")
    env = gym.make(V1, scene=str(ROOT / "docs" / "innocube" / "innocube-3u-mekf.toml")).unwrapped
    err, sig = [], []
    for seed in range(20):
        env.reset(seed=seed)
        for _ in range(160):
            _, _, te, tr, info = env.step(np.zeros(env.action_space.shape, np.float32))
            if te or tr:
                break
        err.append(math.degrees(np.linalg.norm(_info_error(info)[:3])))
        sig.append(math.degrees(math.sqrt(np.trace(info["estimate_cov"][:3, :3]))))
    print(f"innocube-3u-mekf, zero action, 20 episodes, last step: true estimation error "
          f"mean {np.mean(err):.3f}°, median {np.median(err):.3f}°; filter σ (3 axes) "
          f"{np.mean(sig):.3f}°")


def _single(scene, n=2000) -> float:
    env = gym.make(V1, scene=scene).unwrapped
    env.reset(seed=0)
    a = np.zeros(env.action_space.shape, np.float32)
    for _ in range(50):
        env.step(a)
    t = time.perf_counter()
    for _ in range(n):
        _, _, te, tr, _ = env.step(a)
        if te or tr:
            env.reset()
    return (time.perf_counter() - t) / n


def _vector(scene, n=50, num_envs=1024, spread=False) -> float:
    """Seconds per vector-env step; spread: half the rows restarted one step later, so the
    star tracker's fix steps (every other step) fall on half the rows each step, as after
    autoresets."""
    envs = gym.make_vec(V1, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        scene=scene, autoreset_mode="Disabled" if spread else "NextStep")
    envs.reset(seed=0)
    a = np.zeros(envs.action_space.shape, np.float32)
    if spread:
        envs.step(a)
        envs.reset(options={"reset_mask": np.arange(num_envs) % 2 == 0})
    for _ in range(5):
        envs.step(a)
    t = time.perf_counter()
    for _ in range(n):
        envs.step(a)
    return (time.perf_counter() - t) / n


def cost(repeats: int = 5) -> None:
    est = star_scene()
    load = os.getloadavg()[0]
    rounds = np.array([(_single("cubesat-12u"), _single(est), _vector("cubesat-12u"),
                        _vector(est), _vector("cubesat-12u", spread=True),
                        _vector(est, spread=True)) for _ in range(repeats)])
    s0, s1, v0, v1, w0, w1 = np.median(rounds, axis=0)

    def ratios(i):
        return ", ".join(f"{r:.2f}" for r in rounds[:, i + 1] / rounds[:, i])

    print(f"single step: without {s0 * 1e6:.1f} µs, with the estimator {s1 * 1e6:.1f} µs, "
          f"ratio {s1 / s0:.2f} (median of {repeats}; rounds' ratios {ratios(0)})")
    print(f"vector step N = 1024: without {v0 * 1e3:.2f} ms, with {v1 * 1e3:.2f} ms, ratio "
          f"{v1 / v0:.2f} (rounds' ratios {ratios(2)})")
    print(f"vector step N = 1024, fixes spread over the rows: without {w0 * 1e3:.2f} ms, with "
          f"{w1 * 1e3:.2f} ms, ratio {w1 / w0:.2f} (rounds' ratios {ratios(4)})")
    print(f"1-minute load average: {load:.2f} before, {os.getloadavg()[0]:.2f} after "
          f"({os.cpu_count()} CPUs)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-cost", action="store_true", help="skip the timing")
    parser.add_argument("--cost-only", action="store_true", help="skip the validation")
    parser.add_argument("--repeats", type=int, default=5, help="timing rounds (median)")
    args = parser.parse_args()
    if not args.cost_only:
        validation()
    if not args.no_cost:
        cost(args.repeats)


if __name__ == "__main__":
    main()
