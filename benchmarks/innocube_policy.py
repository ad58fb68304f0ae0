"""A policy on innocube-3u with everything the data showed switched on, from random slews.

    python -m benchmarks.innocube_policy --policy innocube-pd [--policy docs/innocube/policy]
        [--episodes 500] [--seed 0] [--scene innocube-3u] [--env-kwargs JSON] [--plot PNG]

Each episode starts like the flight's slews: an attitude error of 100-180° about a random axis,
a body rate of 2-6 °/s in a random direction, wheel speeds uniform within ±500 rpm (the PD
set's carried-over speeds reach 300-620 rpm) and the wheels' start-up delay ahead, then runs
the scene's whole 160 s (success does not end it; an episode that loses control, |ω| above
the rate limit, counts as 180° from then on). Per episode, as ``rbenv replay`` measures
the telemetry: ``settle_1deg_s``, the first time after which the error stays below 1° to the
end (None: never), and ``steady_deg``, its mean over the last 20 s; both for the error the
satellite believes (the gyro-integrated attitude, what telemetry logs: ``sensed``) and the
true one. A run folder flies in its own env id and options (its ``config.json``: the action
mode it was trained in); a scripted policy in ``SatelliteReorient-v1`` with
``action_mode="acceleration"``, the flight's; ``--env-kwargs`` overrides both (e.g.
``'{"action_mode": "acceleration_lifted"}'``). On a scene with ``[estimator]`` "sensed" is
the MEKF's estimate. Targets (the learned policy's, docs/innocube/learned-policy.md): median
settle ≤ 60 s, mean steady ≤ 0.1°, ≥ 99 % settled.

Writes ``innocube_policy.json`` (one entry per policy); ``--plot`` draws the sensed error of
the first eight episodes against time, one panel per policy.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

from benchmarks import common

ENV_ID = "rbenv/SatelliteReorient-v1"
STEADY_S = 20.0


def random_starts(n: int, seed: int) -> list[dict]:
    """``n`` reset options: error 100-180°, rate 2-6 °/s, wheels ±500 rpm (rad/s)."""
    rng = np.random.default_rng(seed)

    def unit():
        v = rng.normal(size=3)
        return v / np.linalg.norm(v)

    out = []
    for _ in range(n):
        target = rng.normal(size=4)
        target /= np.linalg.norm(target)
        angle = math.radians(rng.uniform(100.0, 180.0))
        err = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * unit()])
        q = _qmul(target, err)
        out.append({"q_target": target, "q": q / np.linalg.norm(q),
                    "omega_B": math.radians(rng.uniform(2.0, 6.0)) * unit(),
                    "wheel_speed": rng.uniform(-500.0, 500.0, 3) * math.pi / 30.0})
    return out


def _qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def settle_time(t: np.ndarray, err: np.ndarray, limit: float = 1.0):
    """The first time after which ``err`` stays below ``limit`` to the end, or None."""
    above = np.flatnonzero(err >= limit)
    if len(above) == 0:
        return float(t[0])
    return None if above[-1] == len(err) - 1 else float(t[above[-1] + 1])


def run(policy_name: str, episodes: int, seed: int, scene: str,
        env_kwargs: dict | None = None) -> dict:
    """All episodes side by side in one native vector env (autoreset off: an episode that
    succeeds keeps flying to the scene's end)."""
    from gymnasium.vector import AutoresetMode
    from rbenv.agents.policies.evaluate import make_policy, scripted
    from rbenv.agents.policies.load import load_policy

    import rbenv

    # The whole episode is flown: a success hold as long as the episode never completes.
    flown = rbenv.scene_variant(scene, {"episode": {"hold_time": rbenv.load_scene(
        scene).episode.duration}})
    env_id, kwargs, policy = ENV_ID, {"action_mode": "acceleration"}, None
    if policy_name not in scripted() and Path(policy_name).exists():
        policy = load_policy(policy_name)
        env_id = policy.env_id
        kwargs.update(policy.env_kwargs)
    kwargs.update(env_kwargs or {})
    kwargs["scene"] = flown
    env = gym.make_vec(env_id, num_envs=episodes, vectorization_mode="vector_entry_point",
                       autoreset_mode=AutoresetMode.DISABLED, **kwargs)
    policy = policy or make_policy(policy_name, env)
    starts = random_starts(episodes, seed)
    options = {key: np.array([o[key] for o in starts]) for key in starts[0]}
    obs, _ = env.reset(seed=seed, options=options)
    # What the satellite believes: the MEKF's estimate on a scene with [estimator], else the
    # gyro-integrated attitude.
    sensed_key = ("estimated_attitude_error_deg" if env.unwrapped.plant.scene.estimator
                  is not None else "sensed_attitude_error_deg")
    t, true, sensed = [], [], []
    state, first = None, np.ones(episodes, bool)
    lost = np.zeros(episodes, bool)  # loss of control (|ω| > rate limit): never settles
    for _ in range(env.unwrapped.plant.scene.episode_steps):
        action, state = policy.predict(obs, state=state, episode_start=first,
                                       deterministic=True)
        first = np.zeros(episodes, bool)
        obs, _, term, _, info = env.step(np.asarray(action, np.float32))
        if term.any():
            lost |= term
            obs, _ = env.reset(options={"reset_mask": term})
        t.append(np.asarray(info["time_s"], float))
        true.append(np.asarray(info["attitude_error_deg"], float))
        sensed.append(np.asarray(info.get(sensed_key, info["attitude_error_deg"]), float))
    env.close()
    t, true, sensed = (np.array(x).T for x in (t, true, sensed))  # (episodes, steps)
    sensed[lost] = true[lost] = 180.0
    per = []
    for i in range(episodes):
        last = t[i] > t[i, -1] - STEADY_S
        per.append({"settle_1deg_s": settle_time(t[i], sensed[i]),
                    "steady_deg": float(sensed[i, last].mean()),
                    "true_settle_1deg_s": settle_time(t[i], true[i]),
                    "true_steady_deg": float(true[i, last].mean())})
    return {"policy": policy_name, "scene": scene, "env_id": env_id,
            "action_mode": kwargs.get("action_mode"), "episodes": episodes, "seed": seed,
            "summary": summarize(per), "episodes_detail": per,
            "trace": {"time_s": t[:PLOTTED], "sensed_deg": sensed[:PLOTTED]}}


PLOTTED = 8  # episodes drawn by --plot


def plot(results: list[dict], path: str) -> None:
    """Sensed error (log scale) against time, the first episodes of each policy."""
    plt = common.pyplot()
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.2), squeeze=False,
                             sharey=True)
    for ax, r in zip(axes[0], results, strict=True):
        trace = r["trace"]
        for t, e in zip(trace["time_s"], trace["sensed_deg"], strict=True):
            ax.semilogy(t, np.maximum(e, 1e-3), lw=0.9)
        ax.axhline(1.0, color="gray", ls=":", lw=0.8)
        ax.axhline(0.1, color="gray", ls="--", lw=0.8)
        s = r["summary"]
        ax.set_title(f"{Path(r['policy']).name}: settled {s['settled_fraction']:.0%}, "
                     f"{s['steady_deg_mean']:.3f}°", fontsize=8)
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylabel("sensed attitude error (deg)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def summarize(per: list[dict]) -> dict:
    out = {}
    for prefix in ("", "true_"):
        settle = [p[f"{prefix}settle_1deg_s"] for p in per]
        done = np.array([s for s in settle if s is not None])
        steady = np.array([p[f"{prefix}steady_deg"] for p in per])
        out[prefix + "settled_fraction"] = len(done) / len(per)
        out[prefix + "settle_1deg_s_median"] = float(np.median(done)) if len(done) else None
        out[prefix + "steady_deg_mean"] = float(steady.mean())
        out[prefix + "steady_deg_median"] = float(np.median(steady))
    return out


def main(argv=()) -> dict:
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--policy", action="append", required=True,
                   help="innocube-pd, pd, or a run folder (repeatable)")
    p.add_argument("--episodes", type=int, default=500)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scene", default="innocube-3u")
    p.add_argument("--env-kwargs", type=json.loads, default={},
                   help="JSON of gym.make options over each policy's own")
    p.add_argument("--out", default="innocube_policy", help="JSON name under results")
    p.add_argument("--plot", help="PNG of the first episodes' sensed error")
    p.add_argument("--detail", action="store_true",
                   help="also write every episode's figures (episodes_detail; about 130 bytes "
                        "an episode), not only their summary")
    args = p.parse_args(argv)
    results = [run(name, args.episodes, args.seed, args.scene, args.env_kwargs)
               for name in args.policy]
    rows = [{"policy": r["policy"], **{k: (round(v, 4) if isinstance(v, float) else v)
                                       for k, v in r["summary"].items()}} for r in results]
    print(common.table(rows, ["policy", "settled_fraction", "settle_1deg_s_median",
                              "steady_deg_mean", "true_steady_deg_mean"]))
    command = ("python -m benchmarks.innocube_policy " + " ".join(
        f"--policy {n}" for n in args.policy) + f" --episodes {args.episodes} --seed "
        f"{args.seed} --scene {args.scene}") + (
        f" --env-kwargs '{json.dumps(args.env_kwargs)}'" if args.env_kwargs else "")
    if args.plot:
        plot(results, args.plot)
    for r in results:
        r.pop("trace")
        if not args.detail:
            r.pop("episodes_detail")
    common.write_json(args.out, {"command": command, "load_average": os.getloadavg(),
                                 "results": results})
    return {r["policy"]: r["summary"] for r in results}


if __name__ == "__main__":
    main(sys.argv[1:])
