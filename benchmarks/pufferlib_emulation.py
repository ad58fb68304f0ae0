"""What PufferLib's emulation costs over rbenv's native vector env (Reorient-v1, 256 envs).

Run ``python -m benchmarks.pufferlib_emulation``. PufferLib is in no extra of rbenv: 3.0.0 is
an sdist whose build downloads raylib, and the 2.0.2 wheel pins numpy 1.23 and gymnasium
<= 0.29, so it was measured installed beside the project's packages without its pins
(``pip install --no-deps --target DIR pufferlib==2.0.2 gym==0.23.1``, then ``PYTHONPATH=DIR``).
PufferLib wraps each single env (``emulation.GymnasiumPufferEnv``) and steps them in one
process (``vector.Serial``); rbenv's vector env steps the 256 satellites as arrays. Both take
the same random actions; the figure is process CPU milliseconds per vector step.
Results: ``benchmarks/results/pufferlib_emulation.json``.
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np

from benchmarks.common import write_json

ENV_ID = "rbenv/SatelliteReorient-v1"


def cpu_ms_per_step(step, actions: np.ndarray) -> float:
    """Process CPU milliseconds per call of ``step`` over the rows of ``actions``."""
    c0 = time.process_time()
    for a in actions:
        step(a)
    return 1e3 * (time.process_time() - c0) / len(actions)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--envs", type=int, default=256)
    p.add_argument("--steps", type=int, default=200)
    args = p.parse_args(argv)
    try:
        import pufferlib
        import pufferlib.emulation
        import pufferlib.vector
    except ImportError:
        raise SystemExit("this benchmark needs PufferLib, in no extra of rbenv (see the "
                         "module's doc for how 2.0.2 was installed)") from None
    import rbenv  # noqa: F401 (registers the ids)

    actions = np.random.default_rng(0).uniform(-1, 1, (args.steps, args.envs, 12))
    load0 = os.getloadavg()[0]
    puffer = pufferlib.vector.make(
        lambda: pufferlib.emulation.GymnasiumPufferEnv(env_creator=lambda: gym.make(ENV_ID)),
        num_envs=args.envs, backend=pufferlib.vector.Serial)
    puffer.reset(seed=0)
    puffer_ms = cpu_ms_per_step(puffer.step, actions.astype(np.float32))
    native = gym.make_vec(ENV_ID, num_envs=args.envs)
    native.reset(seed=0)
    native_ms = cpu_ms_per_step(native.step, actions)
    result = {"env_id": ENV_ID, "envs": args.envs, "steps": args.steps,
              "pufferlib": getattr(pufferlib, "__version__", None),
              "puffer_serial_cpu_ms_per_step": puffer_ms,
              "native_vector_cpu_ms_per_step": native_ms, "ratio": puffer_ms / native_ms,
              "load_before": round(load0, 2), "load_after": round(os.getloadavg()[0], 2)}
    write_json("pufferlib_emulation", result)
    print(result)


if __name__ == "__main__":
    main()
