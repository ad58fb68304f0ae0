"""Record the MPC's evaluation on the report's default episodes, for ``rbenv train``'s report.

``python -m benchmarks.mpc_record`` evaluates :class:`rbenv.agents.baselines.mpc.ModelPredictive`
(the ``mpc`` extra) on the 500 episodes every ``rbenv train`` report uses by default (seeds
1,000,000 + i, cubesat-12u, Reorient-v2; Reorient-v1 shares those episodes) and writes, per
episode, what the report needs to ``agents/policies/records/mpc-<scene>.json``
(:mod:`rbenv.agents.policies.recorded`; the schema is there). A few minutes on one core.
``tests/agents/policies/test_recorded.py`` reruns the first episodes against the record.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import time
from pathlib import Path

from rbenv.agents.policies import recorded

from benchmarks import common

ENV_IDS = ("rbenv/SatelliteReorient-v2", "rbenv/SatelliteReorient-v1")


def record(episodes: int, seed: int, scene: str, out: Path | None = None) -> Path:
    """Evaluate the MPC and write its record; returns the file."""
    from rbenv.agents.policies.evaluate import evaluate

    t0 = time.perf_counter()
    r = evaluate("mpc", episodes=episodes, seed=seed, scene=scene, env_id=ENV_IDS[0],
                 record=0)
    def values(a):
        return [None if math.isnan(v) else float(v) for v in a.tolist()]
    data = {
        "policy": "mpc", "env_ids": list(ENV_IDS), "scene": scene, "seed": seed,
        "episodes": episodes,
        "command": "python -m benchmarks.mpc_record"
                   + (f" --episodes {episodes}" if episodes != 500 else "")
                   + (f" --seed {seed}" if seed != 1_000_000 else "")
                   + (f" --scene {scene}" if scene != "cubesat-12u" else ""),
        "recorded": f"{datetime.date.today().isoformat()}, commit "
                    f"{common.commit(Path(__file__).parent) or 'unknown'}",
        "wall_s": round(time.perf_counter() - t0, 1),
        "per_episode": {"success": [bool(v) for v in r.success],
                        **{k: values(getattr(r, k)) for k in recorded.PER_EPISODE[1:]}},
    }
    path = out or recorded.record_path("mpc", scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, separators=(",", ":")) + "\n")
    tmp.replace(path)
    recorded.read_record(path)  # what the report will read back
    s = r.summary()
    print(f"{path}: {100 * s['success_rate']:.1f} %, settle median "
          f"{s['settle_time_s']['median']} s, fuel mean {1000 * s['fuel']['mean']:.2f} g, "
          f"{data['wall_s']} s")
    return path


def main(argv=None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1_000_000)
    ap.add_argument("--scene", default="cubesat-12u")
    ap.add_argument("--out", type=Path, default=None, help="another file than the package's")
    a = ap.parse_args(argv)
    return record(a.episodes, a.seed, a.scene, a.out)


if __name__ == "__main__":
    main()
