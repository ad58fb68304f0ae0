"""Digests of seeded episodes, to show that a refactor changes no episode by a single bit.

    python -m benchmarks.episode_digest --baseline /path/to/old/checkout [--quick]

Each case runs seeded episodes with fixed random actions through ``gym.make`` (single env) or
``gym.make_vec`` (native vector env, N = 1, 7 and 40 000) and hashes, step by step, the raw
bytes of every observation, reward, termination and truncation flag and every info value
(keys sorted). The cases cover every shipped id (v0, v1 and v2), scene, action mode, allocator and
integrator, with and without the compiled kernels, in all three autoreset modes, and the torch
vector env (CPU, float64) in its two. A case that raises (a task on a scene it cannot run on)
digests its error message. The probe runs in a fresh
interpreter per source tree (``PYTHONPATH`` set to it); the two trees' digests must be equal.

Writes ``<out>/episode_digest.json`` (default ``benchmarks/results``) with the digest of every
case for both trees and the list of cases that differ.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmarks import common

PROBE = r"""
import hashlib, json, sys, warnings
import gymnasium as gym
import numpy as np
import rbenv
from gymnasium.vector import AutoresetMode

warnings.simplefilter("ignore")
QUICK = sys.argv[1] == "1"
IDS = {"reorient": "rbenv/SatelliteReorient-v0", "detumble": "rbenv/SatelliteDetumble-v0",
       "track": "rbenv/SatelliteTrack-v0", "desaturate": "rbenv/SatelliteDesaturate-v0",
       "reorient_v1": "rbenv/SatelliteReorient-v1", "detumble_v1": "rbenv/SatelliteDetumble-v1",
       "track_v1": "rbenv/SatelliteTrack-v1", "reorient_v2": "rbenv/SatelliteReorient-v2",
       "desaturate_v1": "rbenv/SatelliteDesaturate-v1"}
INTEGRATORS = ("euler_seed", "euler", "semi_implicit", "rk4", "midpoint", "splitting")


def feed(h, value):
    if isinstance(value, dict):
        for key in sorted(value):
            h.update(key.encode())
            feed(h, value[key])
    elif isinstance(value, (tuple, list)) or (isinstance(value, np.ndarray)
                                               and value.dtype == object):
        for v in value:
            feed(h, v)
    elif value is None:
        h.update(b"None")
    elif hasattr(value, "detach"):  # a torch tensor: its values, as NumPy
        feed(h, value.detach().cpu().numpy())
    else:
        arr = np.asarray(value)
        h.update(str(arr.dtype).encode())
        h.update(np.ascontiguousarray(arr).tobytes())


def single(task, kw, steps):
    env = gym.make(IDS[task], **kw)
    h = hashlib.sha256()
    rng = np.random.default_rng(7)
    feed(h, env.reset(seed=11))
    for _ in range(steps):
        out = env.step(rng.uniform(-1.2, 1.2, env.action_space.shape).astype(np.float32))
        feed(h, out)
        if out[2] or out[3]:
            feed(h, env.reset())
    return h.hexdigest()


def vector(task, kw, n, steps, mode):
    env = gym.make_vec(IDS[task], num_envs=n, autoreset_mode=mode, **kw)
    h = hashlib.sha256()
    rng = np.random.default_rng(7)
    feed(h, env.reset(seed=11))
    for _ in range(steps):
        out = env.step(rng.uniform(-1.2, 1.2, env.action_space.shape).astype(np.float32))
        feed(h, out)
        if mode is AutoresetMode.DISABLED:
            done = out[2] | out[3]
            if done.any():
                feed(h, env.reset(options={"reset_mask": done}))
    return h.hexdigest()


def torch_vector(task, kw, n, steps, mode):
    import torch

    torch.set_num_threads(1)
    env = gym.make_vec(IDS[task], num_envs=n, backend="torch", autoreset_mode=mode, **kw)
    h = hashlib.sha256()
    rng = np.random.default_rng(7)
    feed(h, env.reset(seed=11))
    for _ in range(steps):
        out = env.step(torch.as_tensor(rng.uniform(-1.2, 1.2, env.action_space.shape)))
        feed(h, out)
        if mode is AutoresetMode.DISABLED:
            done = out[2] | out[3]
            if bool(done.any()):
                feed(h, env.reset(options={"reset_mask": done}))
    return h.hexdigest()


def cases():
    scenes = rbenv.list_scenes()
    steps = 120 if QUICK else 400
    for task in IDS:
        for scene in scenes:
            for mode in ("throttle", "on_off", "torque"):
                yield f"single/{task}/{scene}/{mode}", single, (task, {"scene": scene, "action_mode": mode}, steps)
            for integ in INTEGRATORS:
                if scene == "cubesat-12u-dr" and integ == "splitting":
                    continue
                yield f"single/{task}/{scene}/{integ}", single, (task, {"scene": scene, "integrator": integ}, steps // 2)
            for mode in AutoresetMode:
                yield f"vector7/{task}/{scene}/{mode.value}", vector, (task, {"scene": scene}, 7, steps, mode)
        for alloc in ("nnls", "lp"):
            yield f"single/{task}/alloc-{alloc}", single, (task, {"action_mode": "torque", "allocator": alloc}, steps // 2)
            yield f"vector7/{task}/alloc-{alloc}", vector, (task, {"action_mode": "torque", "allocator": alloc}, 7, steps // 4, AutoresetMode.NEXT_STEP)
        yield f"vector1/{task}", vector, (task, {}, 1, steps, AutoresetMode.NEXT_STEP)
        yield f"vector7/{task}/midpoint", vector, (task, {"integrator": "midpoint"}, 7, steps, AutoresetMode.SAME_STEP)
        yield f"vector7/{task}/torque", vector, (task, {"action_mode": "torque"}, 7, steps, AutoresetMode.SAME_STEP)
        yield f"vector40000/{task}", vector, (task, {}, 40_000, 3 if QUICK else 12, AutoresetMode.NEXT_STEP)
        yield f"vector40000/{task}/dr", vector, (task, {"scene": "cubesat-12u-dr"}, 40_000, 3 if QUICK else 8, AutoresetMode.SAME_STEP)
        for mode in (AutoresetMode.SAME_STEP, AutoresetMode.DISABLED):
            yield f"torch7/{task}/{mode.value}", torch_vector, (task, {"integrator": "rk4"}, 7, steps, mode)
        try:
            import numba  # noqa: F401
        except ImportError:
            continue
        yield f"single/{task}/compiled", single, (task, {"compiled": True}, steps)
        yield f"vector7/{task}/compiled", vector, (task, {"compiled": True}, 7, steps, AutoresetMode.NEXT_STEP)


out = {}
for name, fn, args in cases():
    try:
        out[name] = fn(*args)
    except Exception as exc:  # a case that raises is part of the behaviour
        out[name] = f"raised {type(exc).__name__}: {exc}"
print(json.dumps(out))
"""


def probe(tree: Path, quick: bool) -> dict:
    """Digest of every case, run in a fresh interpreter on the source tree ``tree``."""
    return common.run_in_tree(tree, PROBE, "1" if quick else "0")


def main(argv=()) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--baseline", required=True, help="source tree of the old revision")
    p.add_argument("--new", default=str(Path(__file__).resolve().parents[1]),
                   help="source tree of the new revision (default: this one)")
    p.add_argument("--quick", action="store_true", help="shorter episodes (CI form)")
    p.add_argument("--out", default=None,
                   help="folder for episode_digest.json (default: the benchmark results folder)")
    args = p.parse_args(argv)
    trees = {"old": Path(args.baseline).resolve(), "new": Path(args.new).resolve()}
    digests = {name: probe(tree, args.quick) for name, tree in trees.items()}
    differ = sorted(k for k in digests["old"] if digests["old"][k] != digests["new"].get(k))
    data = {"trees": {k: str(v) for k, v in trees.items()}, "quick": args.quick,
            "cases": len(digests["old"]), "differ": differ, "digests": digests}
    out = Path(args.out) if args.out else common.RESULTS
    out.mkdir(parents=True, exist_ok=True)
    (out / "episode_digest.json").write_text(json.dumps(data, indent=2) + "\n")
    print(f"{len(digests['old'])} cases, {len(differ)} differ" +
          "".join(f"\n  {k}: {digests['old'][k][:60]} != {digests['new'].get(k, '')[:60]}"
                  for k in differ))
    return data


if __name__ == "__main__":
    main(sys.argv[1:])
