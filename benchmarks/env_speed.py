"""Env speed: the single env against Pendulum-v1, the native vector env, resets and memory.

Run ``rbenv bench env_speed`` (or ``python -m benchmarks.env_speed``). Every timing is the best
of interleaved rounds (shared machines are noisy), with actions generated beforehand and
episodes reset as they end, as a training loop would. Reported, each as a ratio taken in this
run:

* single env, µs per step through ``gym.make``, for every task, scene and action mode, and
  with ``compiled=True`` (numba, ``rbenv[fast]``; its compilation is paid before the timing
  and reported by ``rbenv bench speed``), as a ratio to ``Pendulum-v1``;
* native vector env, env-steps/s at N = 1024 and 4096 with random throttles, with all
  thrusters off (no episode ends) and with one fixed random throttle for every step
  (reset-heavy: a few percent of the sub-envs lose control and autoreset each step), the
  reset-heavy rate as a ratio to the no-reset rate, and the rate against Gymnasium's
  ``SyncVectorEnv`` over the single env;
* memory: peak RSS growth per sub-env of a vector env of N = 262 144 over a reset and ten steps,
  in a fresh interpreter.

Writes ``env_speed.json`` and ``env_speed.png`` to the results folder.
"""

from __future__ import annotations

import json
import subprocess
import sys

import gymnasium as gym
import numpy as np
from rbenv.core import compiled

import rbenv
from benchmarks.common import best_times, pyplot, save_figure, table, write_json

# The first release's id: the committed results (and the A/B against an older checkout)
# measured it; v1 has its episodes, with another observation and reward.
REORIENT_V0 = "rbenv/SatelliteReorient-v0"

ROUNDS = 5
N_ACTIONS = 1024
MEMORY_N = 262_144

# Peak RSS of this process in KiB. Linux's VmHWM belongs to the process image; ru_maxrss is
# carried across fork + exec, so a child of a large parent would start at the parent's peak
# and under-count its own growth (it read 400 B per sub-env inside `rbenv bench`, 920 alone).
_MEMORY_PROBE = r"""
import resource, sys
import gymnasium as gym, numpy as np
import rbenv

def peak_kib():
    try:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss

n = int(sys.argv[1])
a = np.random.default_rng(0).uniform(-1, 1, (n, 12)).astype(np.float32)
before = peak_kib()
env = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=n)
env.reset(seed=0)
for _ in range(10):
    env.step(a)
print((peak_kib() - before) * 1024 / n)
"""


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

    for _ in range(20):  # past the first episode ends
        step()
    return step


def _actions(space, count, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(space.low, space.high, (count, *space.shape)).astype(np.float32)


def single_env() -> list[dict]:
    """µs per step through gym.make, as a ratio to Pendulum-v1 measured in the same rounds."""
    pend = gym.make("Pendulum-v1")
    cases = {"Pendulum-v1": _single_stepper(pend, _actions(pend.action_space, N_ACTIONS))}
    for env_id in rbenv.ENV_IDS:
        spec = rbenv.envs.registry.get(env_id)
        scenes = rbenv.list_scenes() if env_id == REORIENT_V0 else \
            [spec.scene]
        for scene in scenes:
            env = gym.make(env_id, scene=scene)
            cases[f"{env_id} {scene}"] = _single_stepper(env, _actions(env.action_space,
                                                                       N_ACTIONS))
    env = gym.make(REORIENT_V0, action_mode="torque")
    cases[f"{REORIENT_V0} cubesat-12u torque"] = _single_stepper(
        env, _actions(env.action_space, N_ACTIONS))
    if compiled.available():
        env = gym.make(REORIENT_V0, compiled=True)
        env.reset(seed=0)
        env.step(env.action_space.sample())  # the JIT compilation, outside the timing
        cases[f"{REORIENT_V0} cubesat-12u compiled"] = _single_stepper(
            env, _actions(env.action_space, N_ACTIONS))
    best = best_times(cases, rounds=ROUNDS, min_time=0.05)
    ref = best["Pendulum-v1"]
    return [{"env": name, "us_per_step": t * 1e6, "ratio_to_pendulum": t / ref}
            for name, t in best.items()]


def _vector_cases(n: int) -> dict:
    envs = [gym.make_vec(REORIENT_V0, num_envs=n) for _ in range(3)]
    shape = envs[0].action_space.shape
    fixed = np.random.default_rng(2).uniform(-1, 1, shape[1:]).astype(np.float32)
    return {
        f"random N={n}": _vector_stepper(envs[0], _actions(envs[0].action_space, 64)),
        f"zero action N={n}": _vector_stepper(envs[1], -np.ones((4, *shape), np.float32)),
        f"reset-heavy N={n}": _vector_stepper(envs[2], np.broadcast_to(fixed, (4, *shape))),
    }


def vector_env(sizes=(1024, 4096)) -> list[dict]:
    """Env-steps/s of the native vector env (default scene) and of SyncVectorEnv."""
    cases, sizes_of = {}, {}
    for n in sizes:
        for name, fn in _vector_cases(n).items():
            cases[name], sizes_of[name] = fn, n
    n_sync = 64
    sync = gym.make_vec(REORIENT_V0, num_envs=n_sync, vectorization_mode="sync")
    cases[f"SyncVectorEnv random N={n_sync}"] = _vector_stepper(
        sync, _actions(sync.action_space, 64))
    sizes_of[f"SyncVectorEnv random N={n_sync}"] = n_sync
    best = best_times(cases, rounds=ROUNDS, min_time=0.2)
    rate = {name: sizes_of[name] / t for name, t in best.items()}
    sync_rate = rate[f"SyncVectorEnv random N={n_sync}"]
    rows = [{"env": name, "env_steps_per_s": r, "us_per_env_step": 1e6 / r,
             "ratio_to_sync": r / sync_rate} for name, r in rate.items()]
    for n in sizes:
        rows.append({"env": f"reset-heavy / zero action N={n}",
                     "ratio": rate[f"reset-heavy N={n}"] / rate[f"zero action N={n}"]})
    return rows


def memory(n: int = MEMORY_N) -> dict:
    """Peak RSS growth per sub-env over reset + 10 steps, measured in a fresh interpreter."""
    out = subprocess.run([sys.executable, "-c", _MEMORY_PROBE, str(n)], check=True,
                         capture_output=True, text=True)
    return {"num_envs": n, "bytes_per_sub_env": float(out.stdout.strip().splitlines()[-1])}


def plot(single: list[dict], vector: list[dict]):
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(14, 5))
    rows = [r for r in single if r["env"] != "Pendulum-v1"]
    a.barh([r["env"].replace("rbenv/", "") for r in rows],
           [r["ratio_to_pendulum"] for r in rows], color="tab:blue")
    a.axvline(1.0, color="k", lw=0.8)
    a.axvline(1.2, color="tab:red", ls=":", lw=1, label="target 1.2×")
    a.set_xlabel("time per step / Pendulum-v1's (gym.make, same run)")
    a.legend()
    rates = [r for r in vector if "env_steps_per_s" in r]
    b.barh([r["env"] for r in rates], [r["env_steps_per_s"] / 1e6 for r in rates],
           color="tab:green")
    b.axvline(3.0, color="tab:red", ls=":", lw=1, label="target 3 M/s at N = 4096")
    b.set_xlabel("million env-steps per second, one core")
    b.legend()
    fig.suptitle("rbenv env speed (best of interleaved rounds, one run)")
    fig.tight_layout()
    return save_figure(fig, "env_speed")


def main() -> dict:
    """Measure, print the tables and write ``env_speed.json`` and ``env_speed.png``."""
    single = single_env()
    print(table(single, ["env", "us_per_step", "ratio_to_pendulum"]))
    print()
    vector = vector_env()
    print(table([r for r in vector if "env_steps_per_s" in r],
                ["env", "env_steps_per_s", "us_per_env_step", "ratio_to_sync"]))
    print(table([r for r in vector if "ratio" in r], ["env", "ratio"]))
    mem = memory()
    print(f"\nmemory: {mem['bytes_per_sub_env']:.0f} bytes per sub-env at N = {mem['num_envs']}")
    data = {"single_env": single, "vector_env": vector, "memory": mem, "rounds": ROUNDS,
            "notes": "best of interleaved rounds; actions pre-generated; resets included"}
    path = write_json("env_speed", data)
    plot(single, vector)
    print(f"\nwrote {path}")
    return json.loads(path.read_text())


if __name__ == "__main__":
    if "--backend" in sys.argv[1:]:  # rbenv bench env_speed --backend torch ...
        from benchmarks import torch_env_speed

        torch_env_speed.main(sys.argv[1:])
    else:
        from benchmarks.common import no_options

        no_options(__doc__)
        main()
