"""The env driven where it breaks: every case must end in a clear error or a clean stop.

Used by ``benchmarks.stability``. A case passes when each episode either ends
(terminated/truncated) with finite observations and rewards, or raises an rbenv error whose
message says what went wrong; a NaN anywhere is a failure of the case.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines.controllers import QuaternionPD

import rbenv
from rbenv.satellite.scene import Faults

# The first release's id: the committed results (and the A/B against an older checkout)
# measured it; v1 has its episodes, with another observation and reward.
REORIENT_V0 = "rbenv/SatelliteReorient-v0"


def _episode(env, policy, seed: int, options=None) -> dict:
    obs, _ = env.reset(seed=seed, options=options)
    state, finite = None, bool(np.isfinite(obs).all())
    while True:
        action = policy(obs, state)
        if isinstance(action, tuple):
            action, state = action
        try:
            obs, reward, term, trunc, info = env.step(action)
        except ValueError as exc:  # rbenv errors are ValueError subclasses
            return {"outcome": f"error: {type(exc).__name__}", "detail": str(exc)[:160],
                    "finite": finite}
        finite &= bool(np.isfinite(obs).all() and np.isfinite(reward))
        if term or trunc:
            kind = "success" if info["is_success"] else ("terminated" if term else "truncated")
            return {"outcome": kind, "detail": f"error {info['attitude_error_deg']:.3g} deg, "
                    f"rate {info['rate_dps']:.3g} deg/s", "finite": finite}


def _summary(case: str, episodes: list[dict]) -> dict:
    outcomes = sorted({e["outcome"] for e in episodes})
    counts = {o: sum(e["outcome"] == o for e in episodes) for o in outcomes}
    return {"case": case, "outcome": ", ".join(f"{o} ×{n}" for o, n in counts.items()),
            "detail": episodes[-1]["detail"], "all_finite": all(e["finite"] for e in episodes),
            "episodes": len(episodes)}


def cases(episodes: int = 20) -> list[dict]:
    rows = []
    rng = np.random.default_rng(0)

    def random_policy(obs, state):
        return rng.uniform(-1, 1, 12).astype(np.float32)

    # 1. Fast tumble: start at 99 % of the rate limit and fire at random.
    env = gym.make(REORIENT_V0, max_initial_rate=0.99 * 0.1745)
    rows.append(_summary("fast tumble, random thrusters",
                         [_episode(env, random_policy, s) for s in range(episodes)]))
    # 2. Tumbling far beyond the limit from the start: loss of control on the first step.
    spin = {"omega_B": np.array([3.0, -2.0, 1.0])}
    rows.append(_summary("start at 3.7 rad/s (21x the limit)",
                         [_episode(env, random_policy, s, spin) for s in range(episodes)]))
    # 3. An explicit integrator pushed past its stability limit: a clear error, not a NaN.
    hot = gym.make(REORIENT_V0, integrator="semi_implicit", control_dt=20.0,
                   max_episode_steps=50)
    spin_hot = {"omega_B": np.array([0.17, 0.0, 0.01])}
    rows.append(_summary("semi_implicit, dt = 20 s, h·|ω| = 3.4",
                         [_episode(hot, random_policy, s, spin_hot) for s in range(3)]))
    # 4. ... and diverging inside one control step (100 substeps at h·|ω| = 100): the env raises.
    blow = gym.make(REORIENT_V0, integrator="semi_implicit", control_dt=10.0, substeps=100)
    spin_blow = {"omega_B": np.array([1000.0, 0.0, 30.0])}
    rows.append(_summary("semi_implicit, 1000 rad/s, h·|ω| = 100",
                         [_episode(blow, random_policy, s, spin_blow) for s in range(3)]))
    # 5. The boom scene (inertia ratio 186:1, faults, noise) under PD and at random.
    boom = gym.make(REORIENT_V0, scene="boom-sat")
    pd = QuaternionPD.from_env(boom)
    rows.append(_summary("boom-sat, PD", [_episode(boom, lambda o, s: pd.predict(o, s), k)
                                          for k in range(episodes)]))
    rows.append(_summary("boom-sat, random", [_episode(boom, random_policy, k)
                                              for k in range(episodes)]))
    # 6. Thruster failures on the CubeSat: half the thrusters stuck off at reset.
    scene = dataclasses.replace(rbenv.load_scene("cubesat-12u"),
                                faults=Faults(model="random", p_reset=0.5))
    broken = gym.make(REORIENT_V0, scene=scene)
    pd = QuaternionPD.from_env(broken)
    rows.append(_summary("cubesat-12u, 50 % thrusters failed, PD",
                         [_episode(broken, lambda o, s: pd.predict(o, s), k)
                          for k in range(episodes)]))
    return rows


if __name__ == "__main__":
    from benchmarks.common import no_options, table

    no_options(__doc__)
    print(table(cases(), ["case", "outcome", "all_finite", "detail"]))
