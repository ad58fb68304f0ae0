"""Shared benchmark plumbing: timing by ratio within one run, machine record, JSON/PNG output."""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from rbenv.core import kernels

# Where write_json and save_figure put files: benchmarks/results, or the folder that
# `rbenv bench NAME --out DIR` passes in RBENV_BENCH_OUT.
RESULTS = Path(os.environ.get("RBENV_BENCH_OUT") or Path(__file__).resolve().parent / "results")


def best_time(fn: Callable[[], object], *, repeats: int = 5, min_time: float = 0.05) -> float:
    """Seconds per call of ``fn``: the minimum over ``repeats`` batches of auto-sized loops.

    The minimum is the least noisy estimate on a shared machine; compare results as ratios
    measured in the same run.
    """
    fn()  # warm caches and lazy imports
    loops = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(loops):
            fn()
        elapsed = time.perf_counter() - t0
        if elapsed >= min_time:
            break
        loops *= 2
    best = elapsed / loops
    for _ in range(repeats - 1):
        t0 = time.perf_counter()
        for _ in range(loops):
            fn()
        best = min(best, (time.perf_counter() - t0) / loops)
    return best


def _loops_for(fn: Callable[[], object], min_time: float) -> int:
    loops = 1
    while True:
        t0 = time.process_time()
        for _ in range(loops):
            fn()
        if time.process_time() - t0 >= min_time:
            return loops
        loops *= 2


def best_times(fns: dict[str, Callable[[], object]], *, rounds: int = 9,
               min_time: float = 0.02) -> dict[str, float]:
    """CPU seconds per call of each function: the minimum over ``rounds`` interleaved rounds.

    Each round times every function once (a batch of calls lasting at least ``min_time``), so a
    burst of load on a shared machine hits all of them alike; ratios between the results of
    one call are the figures to quote. The clock is this process's CPU time: on a busy machine
    the scheduler takes the core away for whole time slices, and wall time would count that
    wait (the functions timed here are single-threaded).
    """
    loops = {}
    for name, fn in fns.items():
        fn()  # warm caches, lazy imports and JIT compilation
        loops[name] = _loops_for(fn, min_time)
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(rounds):
        for name, fn in fns.items():
            n = loops[name]
            t0 = time.process_time()
            for _ in range(n):
                fn()
            best[name] = min(best[name], (time.process_time() - t0) / n)
    return best


def single_env_loop(env_id: str, steps: int, **make_kwargs) -> tuple[Callable[[], None], int]:
    """A timing loop over one env of ``gym.make(env_id, **make_kwargs)``: ``steps`` steps of 64
    seeded random actions, resets inline. Returns ``(run, steps)``, for :func:`best_times`."""
    import gymnasium as gym

    env = gym.make(env_id, **make_kwargs)
    env.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (64, *env.action_space.shape))
    acts = acts.astype(np.float32)

    def run():
        for i in range(steps):
            _, _, te, tr, _ = env.step(acts[i % 64])
            if te or tr:
                env.reset()
    return run, steps


def vector_env_loop(env_id: str, n: int, steps: int = 4,
                    **make_kwargs) -> tuple[Callable[[], None], int]:
    """A timing loop over the native vector env of ``n`` sub-envs: ``steps`` steps of 8 seeded
    random action batches. Returns ``(run, steps * n)``: per sub-env step, for
    :func:`best_times`."""
    import gymnasium as gym

    env = gym.make_vec(env_id, num_envs=n, **make_kwargs)
    env.reset(seed=0)
    acts = np.random.default_rng(1).uniform(-1, 1, (8, *env.action_space.shape))
    acts = acts.astype(np.float32)

    def run():
        for i in range(steps):
            env.step(acts[i % 8])
    return run, steps * n



def variant_costs(env_id: str, variants: dict[str, dict], reference: str, *, single_steps: int,
                  n_vector: int, rounds: int, ratio_key: str) -> dict[str, dict]:
    """µs per env step of each variant (its ``gym.make`` keyword arguments), one env and the
    native vector env of ``n_vector``, timed in one interleaved :func:`best_times` call, with
    each figure's ratio to the ``reference`` variant's (keys ``single_vs_<ratio_key>``,
    ``vector_vs_<ratio_key>``)."""
    fns, per = {}, {}
    for name, kwargs in variants.items():
        loops = {"single": single_env_loop(env_id, single_steps, **kwargs),
                 "vector": vector_env_loop(env_id, n_vector, **kwargs)}
        for kind, (fn, count) in loops.items():
            fns[(name, kind)] = fn
            per[(name, kind)] = count
    times = best_times(fns, rounds=rounds)
    out = {}
    for (name, kind), t in times.items():
        out.setdefault(name, {})[f"{kind}_us"] = 1e6 * t / per[(name, kind)]
    ref = out[reference]
    for row in out.values():
        row[f"single_vs_{ratio_key}"] = row["single_us"] / ref["single_us"]
        row[f"vector_vs_{ratio_key}"] = row["vector_us"] / ref["vector_us"]
    return out

# What every A/B probe (a program run by :func:`run_in_tree` in a fresh interpreter on each
# source tree) starts with: the imports, the best-of-rounds CPU timer, and the single-env loop.
PROBE_PRELUDE = r"""
import json, time, warnings
import gymnasium as gym
import numpy as np
import rbenv

def best(fn, n, rounds=3):
    out = []
    for _ in range(rounds):
        t = time.process_time(); fn(n); out.append((time.process_time() - t) / n)
    return min(out)

def single(env, steps, scale=1.0):  # CPU s per step, 256 seeded random actions, resets inline
    env.reset(seed=0)
    shape = (256, *env.action_space.shape)
    acts = scale * np.random.default_rng(0).uniform(-1, 1, shape).astype(np.float32)
    def run(n):
        for i in range(n):
            _, _, te, tr, _ = env.step(acts[i % 256])
            if te or tr:
                env.reset()
    return best(run, steps)
"""


def components(arr) -> tuple:
    """Kernel components of an array: floats for a (k,) vector, contiguous (N,) arrays for (N, k).

    The form :mod:`rbenv.core.kernels` and the integrators take (one body runs on Python floats).
    """
    parts = kernels.unpack(np.asarray(arr, dtype=float))
    return parts if isinstance(parts[0], float) else tuple(np.ascontiguousarray(p) for p in parts)


def with_general_recipe(cfg):
    """``cfg`` (a ``TrainConfig``) set to its task's general recipe for its algorithm: the
    hyperparameters and envs of ``shipped_settings(algo, env_id)`` with no scene's, none of a
    recipe's env options, and the auto action. What the committed results of
    ``benchmarks.robustness`` and ``benchmarks.fidelity`` measured on Reorient-v0 and
    cubesat-12u, before that scene had its own SB3 recipe; returns ``cfg``."""
    from rbenv.agents.training.config import ZOO_KEYS, shipped_settings

    general = shipped_settings(cfg.algo, cfg.env_id)
    cfg.hyperparams = {k: v for k, v in general.items() if k not in ZOO_KEYS}
    cfg.n_envs, cfg.recipe_env_kwargs, cfg.policy_action = general["n_envs"], False, "auto"
    return cfg


def machine() -> dict:
    """Machine and library versions to store beside every result."""
    info = {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "numpy": np.__version__,
    }
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    for lib in ("scipy", "gymnasium", "mujoco"):
        try:
            info[lib] = __import__(lib).__version__
        except ImportError:
            pass
    return info


def commit(tree: Path) -> str | None:
    """The commit checked out in ``tree``, short, plus "+changes" when tracked files differ
    from it; None outside git (or without git)."""
    import subprocess

    def git(*args):
        return subprocess.run(["git", "-C", str(tree), *args], capture_output=True,
                              text=True).stdout.strip()

    try:
        head = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no") if head else ""
    except OSError:
        return None
    return (head + ("+changes" if dirty else "")) if head else None


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return str(obj)
    return obj


def run_in_tree(tree: Path, program: str, *args: str) -> dict:
    """Run ``program`` (Python source) in a fresh interpreter on source tree ``tree``
    (``PYTHONPATH`` set to it, one BLAS thread) and parse its last stdout line as JSON: the
    way A/B benchmarks compare two revisions in one run."""
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", program, *args], env=env, cwd=tree,
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def instructions(program: str, *args: str, tree: Path | None = None) -> int:
    """Instructions that ``python -c program *args`` executes, counted by valgrind's callgrind
    (hash seed and BLAS threads fixed, so a count repeats exactly and does not move with the
    machine's load). ``tree``: the source tree on ``PYTHONPATH`` (default: this checkout)."""
    import re
    import subprocess
    import sys
    import tempfile

    tree = Path(tree or Path(__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONHASHSEED": "0",
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run(["valgrind", "--tool=callgrind",
                               f"--callgrind-out-file={tmp}/cg.out", sys.executable, "-c",
                               program, *args], env=env, cwd=tree, check=True,
                              capture_output=True, text=True)
    return int(re.search(r"Collected : (\d+)", done.stderr).group(1))


def dumps(obj, indent: int = 1, level: int = 0) -> str:
    """JSON text with dicts and lists of containers indented, and a list of numbers or strings
    on one line: a curve of 500 points takes one line instead of 500 (committed results stay
    small and their diffs short)."""
    pad, end = " " * (indent * (level + 1)), " " * (indent * level)
    if isinstance(obj, dict) and obj:
        items = (f"{pad}{json.dumps(k)}: {dumps(v, indent, level + 1)}" for k, v in obj.items())
        return "{\n" + ",\n".join(items) + "\n" + end + "}"
    if isinstance(obj, list) and any(isinstance(x, dict | list) for x in obj):
        items = (pad + dumps(x, indent, level + 1) for x in obj)
        return "[\n" + ",\n".join(items) + "\n" + end + "]"
    if isinstance(obj, list):
        return "[" + ", ".join(json.dumps(x) for x in obj) + "]"
    return json.dumps(obj)


def write_json(name: str, data: dict) -> Path:
    """Write ``data`` plus the machine record to ``benchmarks/results/<name>.json``
    (:func:`dumps`)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    payload = {"benchmark": name, "machine": machine(), **data}
    path.write_text(dumps(_jsonable(payload)) + "\n")
    return path


def pyplot():
    """Matplotlib's pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, name: str) -> Path:
    """Save a matplotlib figure to ``benchmarks/results/<name>.png`` (:func:`small_png`)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    small_png(path)
    return path


def small_png(path: Path) -> None:
    """Re-save an opaque plot as a 256-colour palette PNG, about a third of the bytes: a line
    plot's few colours come through exactly, only antialiasing shades move (by a few levels).
    An image with transparency is left as it is."""
    from PIL import Image  # matplotlib's own dependency

    with Image.open(path) as im:
        im.load()
    if im.mode == "RGBA" and im.getchannel("A").getextrema()[0] < 255:
        return
    im.convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT,
                               dither=Image.Dither.NONE).save(path, optimize=True)


def fit_order(x, y) -> float:
    """Least-squares slope of log y against log x (a convergence order)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(y)
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def fmt(value, spec: str, missing: str = "—") -> str:
    """``format(value, spec)``, or ``missing`` for a value that was not measured (None)."""
    return missing if value is None else format(value, spec)


def table(rows: list[dict], columns: list[str]) -> str:
    """A Markdown table of ``rows`` restricted to ``columns``."""
    def cell(v):
        if isinstance(v, float):
            return f"{v:.3g}"
        return str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(r.get(c, "")) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def no_options(doc: str | None, argv=None) -> None:
    """The command line of a benchmark that takes no options: ``--help`` prints its docstring
    and an unknown argument is an error (exit 2), instead of a full run that rewrites the
    committed results."""
    import argparse
    import sys

    parser = argparse.ArgumentParser(description=(doc or "").split("\n\n")[0])
    parser.parse_args(sys.argv[1:] if argv is None else argv)

