"""Env speed: single-env step vs Pendulum-v1, native vector throughput, vs SyncVectorEnv.

Run ``python -m benchmarks.env_speed``. Every timing is the best of several interleaved
rounds (shared machines are noisy), with random actions generated beforehand and episodes
reset as they end, as a training loop would. Results: a table on stdout and
``benchmarks/results/env_speed.json``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import rbenv
from benchmarks.common import best_time, table, write_json

ROUNDS = 5
N_ACTIONS = 1024


def _single_stepper(env, actions):
    """A no-argument callable: one env step with the next pre-generated action (resets inline)."""
    env.reset(seed=0)
    state = {"i": 0}

    def step():
        i = state["i"] = (state["i"] + 1) % len(actions)
        _, _, terminated, truncated, _ = env.step(actions[i])
        if terminated or truncated:
            env.reset()

    return step


def _vector_stepper(envs, actions):
    envs.reset(seed=0)
    state = {"i": 0}

    def step():
        i = state["i"] = (state["i"] + 1) % len(actions)
        envs.step(actions[i])

    return step


def _actions(space, count, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(space.low, space.high, (count, *space.shape)).astype(np.float32)


def single_env() -> list[dict]:
    """µs per step through gym.make, as a ratio to Pendulum-v1 measured in the same rounds."""
    pend = gym.make("Pendulum-v1")
    cases = {"Pendulum-v1": _single_stepper(pend, _actions(pend.action_space, N_ACTIONS))}
    for scene in rbenv.list_scenes():
        for mode in ("throttle", "torque"):
            env = gym.make(rbenv.ENV_ID, scene=scene, action_mode=mode)
            cases[f"{scene} {mode}"] = _single_stepper(env, _actions(env.action_space, N_ACTIONS))
    raw = rbenv.SatelliteReorientEnv()
    cases["cubesat-12u throttle (unwrapped)"] = _single_stepper(
        raw, _actions(raw.action_space, N_ACTIONS))
    best = {name: np.inf for name in cases}
    for _ in range(ROUNDS):
        for name, fn in cases.items():
            best[name] = min(best[name], best_time(fn, repeats=3, min_time=0.05))
    ref = best["Pendulum-v1"]
    return [{"env": name, "us_per_step": t * 1e6, "ratio_to_pendulum": t / ref}
            for name, t in best.items()]


def vector_env(sizes=(1024, 4096)) -> list[dict]:
    """Env-steps/s of the native vector env (default scene), and of SyncVectorEnv over the
    single env, with random actions (so sub-envs lose control and autoreset now and then)."""
    rows = []
    best_native = {}
    for n in sizes:
        envs = gym.make_vec(rbenv.ENV_ID, num_envs=n)
        fn = _vector_stepper(envs, _actions(envs.action_space, 64))
        t = min(best_time(fn, repeats=3, min_time=0.2) for _ in range(ROUNDS))
        best_native[n] = n / t
        rows.append({"env": f"native vector N={n}", "env_steps_per_s": n / t,
                     "us_per_env_step": t / n * 1e6})
    n_sync = 64
    sync = gym.make_vec(rbenv.ENV_ID, num_envs=n_sync, vectorization_mode="sync")
    fn = _vector_stepper(sync, _actions(sync.action_space, 64))
    t = min(best_time(fn, repeats=3, min_time=0.2) for _ in range(ROUNDS))
    sync_rate = n_sync / t
    rows.append({"env": f"SyncVectorEnv N={n_sync}", "env_steps_per_s": sync_rate,
                 "us_per_env_step": t / n_sync * 1e6})
    for row in rows:
        row["ratio_to_sync"] = row["env_steps_per_s"] / sync_rate
    return rows


def main() -> dict:
    """Measure, print two tables and write ``benchmarks/results/env_speed.json``."""
    single = single_env()
    print(table(single, ["env", "us_per_step", "ratio_to_pendulum"]))
    print()
    vector = vector_env()
    print(table(vector, ["env", "env_steps_per_s", "us_per_env_step", "ratio_to_sync"]))
    data = {"single_env": single, "vector_env": vector, "rounds": ROUNDS,
            "notes": "best of interleaved rounds; random actions pre-generated; resets included"}
    path = write_json("env_speed", data)
    print(f"\nwrote {path}")
    return data


if __name__ == "__main__":
    main()
