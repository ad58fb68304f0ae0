"""The ``rbenv`` command: train, evaluate and benchmark (also ``python -m rbenv.agents.cli``).

    rbenv train [--algo ppo|sac|td3|tqc|crossq] [--timesteps N] [--n-envs K] [--seed S]
                [--scene NAME] [--out DIR] [--resume | --force] [--threads T] [--tensorboard DIR]
                [--checkpoint-every N] [--eval-every N] [--hyperparams JSON]
                [--env-kwargs JSON] [--no-report] [--no-progress] [--trust-pickle]
    rbenv evaluate --policy pd|bangbang|zero|random|RUN_DIR|policy.pt --episodes N --seed S
                   [--scene NAME] [--env-kwargs JSON] [--json OUT] [--plot OUT.png]
                   [--video OUT.gif] [--out DIR] [--trust-pickle]
    rbenv bench NAME [--out DIR]

Only what is asked for is written: evaluate prints its table and writes files only with
--json, --plot, --video or --out. Torch, Stable-Baselines3 and matplotlib are imported only
when a model is trained or loaded, or a plot is drawn.
"""

from __future__ import annotations

import argparse
import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

from rbenv.agents.policies import runfolder
from rbenv.agents.policies.evaluate import (
    SCRIPTED,
    evaluate,
    format_table,
    plot_episodes,
    record_video,
    write_json,
)
from rbenv.agents.training import rllib, suite, tune
from rbenv.agents.training.config import ALGOS, TrainConfig
from rbenv.core.errors import RbenvValueError

import rbenv

BENCH_OUT = "bench-results"


CHECKOUT = Path(__file__).resolve().parent.parent  # the repository root, in a source checkout


def benchmarks() -> list[str]:
    """Benchmark modules (each runnable as ``python -m benchmarks.NAME``) of a source checkout.

    benchmarks/ is not installed (other wheels, torchrl among them, install a top-level
    ``benchmarks``), so a wheel install lists none. The modules are listed, not imported.
    """
    folder = CHECKOUT / "benchmarks"
    if not (folder / "__init__.py").is_file():
        return []
    return sorted(m.name for m in pkgutil.iter_modules([str(folder)])
                  if not m.name.startswith("_") and m.name != "common")


def _json_arg(text: str):
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"not valid JSON ({e}): {text!r}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object, got {text!r}")
    return value


def _positive(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rbenv", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train PPO, SAC, TD3, TQC or CrossQ, then report against "
                                     "the baselines")
    t.add_argument("--algo", choices=ALGOS, default="ppo",
                   help="settings (hyperparameters, envs, budget, env options) come from "
                        "rbenv/hyperparams/ALGO.py, the file rl_zoo3 reads")
    t.add_argument("--timesteps", type=_positive, default=None,
                   help="default: the shipped n_timesteps (ppo 2M, tqc 200k, sac/td3/crossq "
                        "300k); with --resume, a new total")
    t.add_argument("--n-envs", type=_positive, default=None,
                   help="default: the shipped n_envs (ppo 64, off-policy 32)")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--scene", default="cubesat-12u")
    t.add_argument("--env-id", default=None,
                   help="the task, a registered id (default rbenv/SatelliteReorient-v0; "
                        "also rbenv/SatelliteDetumble-v0, rbenv/SatelliteTrack-v0)")
    t.add_argument("--out", default=None,
                   help="run folder (default ./runs/ALGO-SCENE-seedS); must be empty or new "
                        "unless --resume or --force")
    mode = t.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true",
                      help="continue the run in --out from its last complete checkpoint, with "
                           "its saved configuration (a finished run is left as it is)")
    t.add_argument("--trust-pickle", action="store_true",
                   help="let --resume unpickle a run folder written before rbenv's pickle-free "
                        "format (or an RLlib run's checkpoints); unpickling runs any code in "
                        "the files, so only for folders from a source you trust")
    mode.add_argument("--force", action="store_true",
                      help="start a new run in a non-empty --out, deleting the old run's files")
    t.add_argument("--threads", type=_positive, default=None,
                   help="torch threads (default 1: fastest for these small networks, and "
                        "robust to other busy processes); part of what makes a run repeatable")
    t.add_argument("--tensorboard", default=None, metavar="DIR",
                   help="also log training to TensorBoard under DIR/RUN_NAME")
    t.add_argument("--checkpoint-every", type=_positive, default=200_000, help="timesteps")
    t.add_argument("--eval-every", type=_positive, default=200_000, help="timesteps")
    t.add_argument("--hyperparams", type=_json_arg, default={},
                   help='JSON overriding algorithm hyperparameters, e.g. \'{"n_steps": 128}\'')
    t.add_argument("--env-kwargs", type=_json_arg, default={},
                   help='JSON of gym.make options, e.g. \'{"action_mode": "torque"}\'')
    t.add_argument("--no-report", action="store_true", help="skip the final evaluation report")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")
    t.add_argument("--engine", choices=("sb3", "rllib"), default="sb3",
                   help="sb3 (default) or rllib: PPO on Ray RLlib (needs the ray extra)")
    rllib.add_arguments(t)
    e = sub.add_parser("evaluate", help="seeded evaluation of a policy",
                       description="Seeded evaluation. Prints a table; writes files only when "
                                   "asked (--json, --plot, --video, --out).")
    e.add_argument("--policy", required=True,
                   help="pd, bangbang, zero, random, a run folder, its policy.pt or a "
                        "checkpoint policy_N.pt (a model is evaluated in its run's env options)")
    e.add_argument("--trust-pickle", action="store_true",
                   help="allow a pickle-based policy file (an older run's model.zip and "
                        "vecnormalize.pkl, a foreign SB3 .zip, an RLlib run); unpickling runs "
                        "any code in it, so only for files from a source you trust")
    e.add_argument("--episodes", type=_positive, default=100)
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--scene", default=None)
    e.add_argument("--env-id", default=None,
                   help="the task (default: a run's own, else rbenv/SatelliteReorient-v0)")
    e.add_argument("--env-kwargs", type=_json_arg, default={}, help="JSON of gym.make options")
    e.add_argument("--action", default="auto", choices=["auto", "mean_throttle", "mode"],
                   help="how a trained SB3 model acts: mean_throttle E[clip(mu + sigma eps, 0, "
                        "1)], mode (SB3's deterministic mu), auto (default): mean_throttle for "
                        "PPO/A2C in throttle mode, else mode")
    e.add_argument("--json", default=None, help="write the summary as JSON to this file")
    e.add_argument("--plot", default=None, metavar="PATH",
                   help="PNG of the first episode (no plot without it, or without --out)")
    e.add_argument("--video", default=None, help="render the first episode to a .gif/.mp4")
    e.add_argument("--out", default=None, metavar="DIR",
                   help="write evaluation.json and episodes.png into DIR (relative to the "
                        "current directory)")
    names = benchmarks()
    b = sub.add_parser("bench", help="run a benchmark, writing NAME.json and NAME.png")
    b.add_argument("name", choices=names or None, help=", ".join(names))
    b.add_argument("--out", default=BENCH_OUT, metavar="DIR",
                   help=f"results folder (default ./{BENCH_OUT} in the current directory; "
                        "pass benchmarks/results in a checkout to refresh the committed ones)")
    tune.add_arguments(suite.add_arguments(sub.add_parser(
        "suite", help="learning suite: algorithm x task x scene x seed beside the baselines")))
    return p


FIXED_BY_RUN = ("algo", "n_envs", "seed", "scene", "env_id", "checkpoint_every", "eval_every",
                "hyperparams", "env_kwargs")


def _train(args) -> int:
    if args.engine == "rllib":
        rllib.train_from_args(args)
        return 0
    if args.address or args.env_runners:
        raise SystemExit("rbenv train: --address and --env-runners need --engine rllib")
    if args.resume:
        defaults = _parser().parse_args(["train"])
        ignored = [f"--{k.replace('_', '-')}" for k in FIXED_BY_RUN
                   if getattr(args, k) != getattr(defaults, k)]
        if ignored:
            print(f"--resume continues the run with its saved config.json; ignoring "
                  f"{', '.join(ignored)}")

    from rbenv.agents.training.sb3 import train  # the train extra (SB3, torch)

    cfg = TrainConfig(algo=args.algo, timesteps=args.timesteps, n_envs=args.n_envs,
                      seed=args.seed, scene=args.scene, out=args.out,
                      **({"env_id": args.env_id} if args.env_id else {}),
                      checkpoint_every=args.checkpoint_every, eval_every=args.eval_every,
                      hyperparams=args.hyperparams, env_kwargs=args.env_kwargs,
                      threads=args.threads or (None if args.resume else 1))
    train(cfg, resume=args.resume, force=args.force, tensorboard=args.tensorboard,
          progress_bar=not args.no_progress, report=not args.no_report,
          trust_pickle=args.trust_pickle)
    return 0


def _evaluate(args) -> int:
    result = evaluate(args.policy, episodes=args.episodes, seed=args.seed, scene=args.scene,
                      env_kwargs=args.env_kwargs, env_id=_env_id(args), action=args.action,
                      trust_pickle=args.trust_pickle)
    print(format_table([result]))
    json_path, plot_path = args.json, args.plot
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        json_path = json_path or Path(args.out) / "evaluation.json"
        plot_path = plot_path or Path(args.out) / "episodes.png"
    if json_path:
        print(f"summary: {write_json([result], json_path)}")
    if plot_path:
        print(f"plot: {plot_episodes([result], plot_path)}")
    if args.video:
        video = record_video(args.policy, args.video, seed=args.seed, scene=args.scene,
                             trust_pickle=args.trust_pickle)
        print(f"video: {video}")
    return 0


def _env_id(args) -> str:
    """--env-id, else the task a run folder was trained on, else reorientation."""
    if args.env_id:
        return args.env_id
    path = Path(args.policy)
    if args.policy not in SCRIPTED and path.exists():
        if path.is_dir() and (path / runfolder.CONFIG).is_file():  # a run folder, SB3 or RLlib
            config = runfolder.read_config(path)
        else:
            config = runfolder.locate(path).config or {}
        return config.get("env_id", rbenv.ENV_ID)
    return rbenv.ENV_ID


def _suite(args) -> int:
    if args.ray or args.address:
        tune.main(args)
        return 0
    suite.main(args)
    return 0


def _bench(args) -> int:
    """Run ``python -m benchmarks.NAME`` in the checkout, in a child process.

    The checkout goes first on the child's path, so its ``benchmarks`` wins over any installed
    package of that name; ``RBENV_BENCH_OUT`` tells it where to write (benchmarks.common).
    """
    out = Path(args.out).resolve()
    env = dict(os.environ, RBENV_BENCH_OUT=str(out),
               PYTHONPATH=os.pathsep.join(filter(None, [str(CHECKOUT),
                                                        os.environ.get("PYTHONPATH")])))
    print(f"results go to {out}")
    return subprocess.run([sys.executable, "-m", f"benchmarks.{args.name}"], env=env,
                          cwd=CHECKOUT, check=False).returncode


def main(argv: list[str] | None = None) -> int:
    """Run a command. From the command line (``argv`` None) a documented error (a
    ``ValueError`` subclass of :mod:`rbenv.core.errors`, such as a corrupt run file) is printed as
    ``rbenv: error: ...`` with exit status 2; called with ``argv`` it is raised."""
    args = _parser().parse_args(argv)
    command = {"train": _train, "evaluate": _evaluate, "bench": _bench,
               "suite": _suite}[args.command]
    if argv is not None:
        return command(args)
    try:
        return command(args)
    except RbenvValueError as e:
        print(f"rbenv: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
