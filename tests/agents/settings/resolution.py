"""What every training combination resolves to: id x algorithm x engine x scene.

:func:`resolve_all` makes each engine's run configuration (``TrainConfig`` for sb3
and sbx, ``RLlibConfig``, ``TorchRLRunConfig``) with only the combination given and calls
``.resolve()``, as ``rbenv train`` does, and adds the learning suite's budget and RL Zoo's
table, so that a change of the settings' shape can be checked to keep every number.
``python -m tests.agents.settings.resolution OUT.json`` writes the dump
(data/resolution_8ef0698.json is main's, before the recipes).
"""

from __future__ import annotations

import dataclasses
import json
import sys

from rbenv.agents import settings
from rbenv.agents.training import config, suite
from rbenv.agents.training.rllib import RLlibConfig

import rbenv

ALGOS = ("ppo", "sac", "td3", "tqc", "crossq")
ENGINES = {"sb3": ALGOS, "sbx": ("sac", "td3"), "rllib": ("ppo",), "torchrl": ("ppo",)}
CONFIGS = {"sb3": config.TrainConfig, "sbx": config.TrainConfig, "rllib": RLlibConfig,
           "torchrl": config.TorchRLRunConfig}
RUN = ("timesteps", "eval_every", "eval_episodes", "stop_success", "keep_best")


def _plain(value):
    """JSON's view of ``value`` (tuples become lists)."""
    return json.loads(json.dumps(value))


def resolve_one(engine: str, algo: str, env_id: str, scene: str) -> dict:
    """The numbers a run of ``engine``/``algo`` on ``env_id``/``scene`` starts with."""
    cfg = CONFIGS[engine](engine=engine, algo=algo, env_id=env_id, scene=scene).resolve()
    out = {k: getattr(cfg, k) for k in RUN if hasattr(cfg, k)}
    out["env_kwargs"] = cfg.env_kwargs
    if engine == "torchrl":  # the learner's own fields, whatever names the run keeps
        learner = dataclasses.asdict(cfg.learner("cpu"))
        for k in ("env_id", "scene", "device", "seed", "threads"):
            learner.pop(k)
        out["learner"] = learner
    else:
        out["hyperparams"] = cfg.hyperparams
    for name in ("n_envs", "normalize", "model", "log_std_init", "envs_per_runner"):
        if hasattr(cfg, name):
            out[name] = getattr(cfg, name)
    return _plain(out)


def resolve_all() -> dict:
    """Every combination, keyed ``engine/algo/env_id/scene`` (``suite/...`` for the suite's
    budget, ``zoo/<algo>`` for RL Zoo's table)."""
    out = {}
    for entry in settings.entries():
        env_id = entry.env_id
        spec = rbenv.envs.registry.get(env_id)
        for scene in rbenv.list_scenes():
            if not spec.runs_on(scene):
                continue
            for engine, algos in ENGINES.items():
                for algo in algos:
                    out[f"{engine}/{algo}/{env_id}/{scene}"] = resolve_one(engine, algo, env_id,
                                                                          scene)
            for algo in ALGOS:
                out[f"suite/{algo}/{env_id}/{scene}"] = suite.default_timesteps(algo, env_id,
                                                                                scene)
    for algo in ALGOS:
        out[f"zoo/{algo}"] = _plain(settings.zoo_hyperparams(algo))
    return out


def dumps(table: dict) -> str:
    """``table`` as JSON, one combination a line (sorted), so a diff names the combination."""
    lines = [f"{json.dumps(k)}: {json.dumps(v, sort_keys=True)}" for k, v in sorted(table.items())]
    return "{\n" + ",\n".join(lines) + "\n}\n"


if __name__ == "__main__":
    with open(sys.argv[1], "w") as f:
        f.write(dumps(resolve_all()))
