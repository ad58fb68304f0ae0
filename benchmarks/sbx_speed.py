"""SBX (JAX) against SB3 (torch): off-policy env-steps/s with the settings rbenv ships.

SBX (``sbx-rl``) is an optional extra because it measurably wins. This measures
whether it does, in one run on one machine: each algorithm's shipped settings
(``agents/zoo/<algo>.py``: 32 native sub-envs, 8 gradient steps per vector step, batch
512, [256, 256]) built once with SB3 (as ``rbenv train`` does, :mod:`benchmarks.train_speed`) and
once with SBX's class of the same name and the same arguments, then ``learn`` timed end to end
(collection, replay sampling, updates) over 160 gradient updates after a prefilled buffer, the
configurations interleaved over 2 rounds, median kept. SBX rows with smaller networks show how
far the update cost falls. One torch thread; JAX limited to one intra-op thread.

SBX pins nothing of ours but pulls JAX: install it in its own venv, torch pinned so pip keeps
the CPU build::

    python -m venv .venv-sbx && .venv-sbx/bin/pip install torch==2.13.0 sbx-rl \\
        -e ".[train,bench]"
    XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1" \\
        .venv-sbx/bin/python -m benchmarks.sbx_speed     # benchmarks/results/sbx_speed.*

``--quick``: SAC only, 16 updates, one round (a smoke test).
"""

from __future__ import annotations

import argparse
import inspect
import os
import sys

import numpy as np

from benchmarks.common import pyplot, save_figure, table, write_json
from benchmarks.train_speed import (
    OFF_POLICY,
    TARGET_STEPS_PER_S,
    TARGET_UPDATES_PER_STEP,
    _off_policy_model,
    _timed_learn,
    meets_target,
)

UPDATES, ROUNDS = 160, 2
# SB3 model attributes passed to SBX's class as they are (train_freq and policy_kwargs are
# rebuilt; the rest are SB3-only options such as monitor_kwargs).
SBX_ARGS = ("learning_rate", "buffer_size", "learning_starts", "batch_size", "tau", "gamma",
            "gradient_steps", "action_noise")


def configs(quick: bool) -> list[dict]:
    """(engine, algo, changes) per row: every algorithm on both engines, then SBX SAC with
    smaller networks."""
    algos = ("sac",) if quick else OFF_POLICY
    rows = [{"engine": e, "algo": a, "changes": {}} for a in algos for e in ("sb3", "sbx")]
    if not quick:
        rows += [{"engine": "sbx", "algo": "sac",
                  "changes": {"policy_kwargs": {"net_arch": arch}}}
                 for arch in ([128, 128], [64, 64])]
    return rows


def _sbx_model(sb3_model, algo: str):
    """SBX's ``algo`` on the SB3 model's env, with the SB3 model's arguments."""
    import sbx

    cls = {"sac": sbx.SAC, "td3": sbx.TD3, "tqc": sbx.TQC, "crossq": sbx.CrossQ}[algo]
    accepted = inspect.signature(cls).parameters  # SBX's CrossQ, as sb3-contrib's, has no tau
    kwargs = {k: getattr(sb3_model, k) for k in SBX_ARGS
              if k in accepted and hasattr(sb3_model, k)}
    kwargs["train_freq"] = sb3_model.train_freq.frequency
    kwargs["policy_kwargs"] = {"net_arch": sb3_model.policy_kwargs["net_arch"]}
    return cls("MlpPolicy", sb3_model.get_env(), seed=0, **kwargs)


def build(spec: dict):
    model, cfg = _off_policy_model({"algo": spec["algo"], "changes": spec["changes"]})
    if spec["engine"] == "sbx":
        model = _sbx_model(model, spec["algo"])
    return model, cfg


def name(spec: dict) -> str:
    arch = spec["changes"].get("policy_kwargs", {}).get("net_arch")
    return f"{spec['engine']} {spec['algo']}" + (f" {arch[0]}x{arch[1]}" if arch else "")


def measure(quick: bool = False) -> list[dict]:
    updates, rounds = (16, 1) if quick else (UPDATES, ROUNDS)
    built = []
    for spec in configs(quick):
        model, cfg = build(spec)
        _timed_learn(model, cfg.hyperparams["learning_starts"] + 4 * cfg.n_envs, 1)  # prefill
        built.append((spec, model, cfg))
    samples: dict[str, list[float]] = {name(s): [] for s, _, _ in built}
    cpu_samples: dict[str, list[float]] = {name(s): [] for s, _, _ in built}
    for _ in range(rounds):
        for spec, model, cfg in built:
            steps = max(updates // cfg.hyperparams["gradient_steps"], 2) * cfg.n_envs
            timing = _timed_learn(model, steps, 1)
            samples[name(spec)].append(steps / timing.wall_s)
            cpu_samples[name(spec)].append(steps / timing.cpu_s)
    rows = []
    for spec, model, cfg in built:
        rate = float(np.median(samples[name(spec)]))
        cpu_rate = float(np.median(cpu_samples[name(spec)]))
        per_step = cfg.hyperparams["gradient_steps"] / cfg.n_envs
        rows.append({"name": name(spec), "engine": spec["engine"], "algo": spec["algo"],
                     "net_arch": spec["changes"].get("policy_kwargs", {}).get(
                         "net_arch", cfg.hyperparams["policy_kwargs"]["net_arch"]),
                     "updates_per_env_step": per_step, "env_steps_per_s": rate,
                     "samples": samples[name(spec)],
                     "meets_target": meets_target(rate, per_step),
                     "env_steps_per_cpu_s": cpu_rate, "cpu_samples": cpu_samples[name(spec)],
                     "meets_target_per_cpu_s": meets_target(cpu_rate, per_step)})
        model.get_env().close()
    sb3 = {r["algo"]: r["env_steps_per_s"] for r in rows if r["engine"] == "sb3"}
    for r in rows:
        r["over_sb3_shipped"] = r["env_steps_per_s"] / sb3[r["algo"]]
    return rows


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="SAC only, 16 updates, 1 round")
    quick = parser.parse_args(sys.argv[1:] if argv is None else argv).quick
    import sbx  # noqa: F401  (fail before building anything when SBX is not installed)
    import torch

    torch.set_num_threads(1)
    load_before = os.getloadavg()
    rows = measure(quick)
    columns = ["name", "updates_per_env_step", "env_steps_per_s", "env_steps_per_cpu_s",
               "over_sb3_shipped", "meets_target", "meets_target_per_cpu_s"]
    print(table([{k: r[k] for k in columns} for r in rows], columns))
    out = "sbx_speed_quick" if quick else "sbx_speed"
    from rbenv.agents.training.engine import versions

    write_json(out, {"command": "python -m benchmarks.sbx_speed" + (" --quick" if quick else ""),
                     "xla_flags": os.environ.get("XLA_FLAGS"),
                     "versions": versions(("sbx", "jax", "torch", "stable_baselines3")),
                     "updates_per_measurement": 16 if quick else UPDATES,
                     "rounds": 1 if quick else ROUNDS, "load_average_before": load_before,
                     "load_average_after": os.getloadavg(), "rows": rows})
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 0.45 * len(rows) + 1.5))
    y = np.arange(len(rows))[::-1]
    ax.barh(y, [r["env_steps_per_s"] for r in rows],
            color=["C1" if r["engine"] == "sbx" else "C0" for r in rows])
    ax.set_yticks(y, [r["name"] for r in rows], fontsize=8)
    for yi, r in zip(y, rows, strict=True):
        ax.text(r["env_steps_per_s"], yi, f" {r['env_steps_per_s']:,.0f} "
                f"({r['over_sb3_shipped']:.1f}x)", va="center", fontsize=8)
    ax.plot([r["env_steps_per_cpu_s"] for r in rows], y, "k|", markersize=12,
            label="per CPU-second of the process (a core of its own)")
    ax.axvline(TARGET_STEPS_PER_S, color="C3", ls="--", lw=1, label="target")
    ax.set_xlabel(f"env-steps/s at {TARGET_UPDATES_PER_STEP} updates per env step, learn() "
                  "end to end (1 thread)")
    ax.set_title(f"SBX (orange) against SB3 (blue), shipped settings; load "
                 f"{load_before[0]:.1f} before", fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    save_figure(fig, out)
    return {"rows": rows}


if __name__ == "__main__":
    main()
