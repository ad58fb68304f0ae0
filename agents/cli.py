"""The ``rbenv`` command: train, evaluate and benchmark (also ``python -m rbenv.agents.cli``).

    rbenv train [--engine sb3|rllib|torchrl] [--algo ppo|sac|td3|tqc|crossq] [--timesteps N]
                [--scene NAME] [--env-id ID] [--out DIR] [--resume | --force] [--no-report]
                [...]   (one flag per field of rbenv.agents.training.config; see --help)
    rbenv evaluate --policy pd|bangbang|zero|random|RUN_DIR|policy.pt --episodes N --seed S
                   [--scene NAME] [--env-kwargs JSON] [--json OUT] [--plot OUT.png]
                   [--video OUT.gif] [--out DIR] [--trust-pickle]
    rbenv bench NAME [--out DIR]
    rbenv replay DIR --scene S --policy P [--json OUT] [--plot PNG]   (flight telemetry)
    rbenv identify DIR --scene S [--out SCENE.toml]

Only what is asked for is written: evaluate prints its table and writes files only with
--json, --plot, --video or --out. Torch, Stable-Baselines3 and matplotlib are imported only
when a model is trained or loaded, or a plot is drawn.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

from rbenv.agents.flight import commands as flight
from rbenv.agents.policies import runfolder
from rbenv.agents.policies.evaluate import (
    SCRIPTED,
    evaluate,
    format_table,
    plot_episodes,
    record_video,
    write_json,
)
from rbenv.agents.training import flags, rllib, suite, tune
from rbenv.agents.training.config import (
    RLlibOptions,
    RunConfig,
    SB3Options,
    TorchRLOptions,
    TrainConfig,
)
from rbenv.agents.training.engine import add_run_arguments
from rbenv.agents.training.engine import run as engine_run
from rbenv.agents.training.rllib import RLlibConfig
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


def _positive(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rbenv", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train PPO, SAC, TD3, TQC or CrossQ, then report against "
                                     "the baselines",
                       description="Every flag but --resume, --force and --no-report is a field "
                                   "of the run's configuration (rbenv.agents.training.config), "
                                   "and its help is that field's docstring.")
    seen: set[str] = set()
    for fields in (TrainConfig, RLlibConfig, SB3Options, RLlibOptions, TorchRLOptions):
        flags.add_fields(t, fields, seen=seen)
    add_run_arguments(t)
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
    e.add_argument("--env-kwargs", type=flags.json_object, default={},
                   help="JSON of gym.make options")
    e.add_argument("--action", default="auto", choices=["auto", "mean_throttle", "mode"],
                   help="how a trained SB3 model acts: mean_throttle E[clip(mu + sigma eps, "
                        "low, high)] with the env's clip bounds (thrusters 0..1, wheels and "
                        "rods -1..1), mode (SB3's deterministic mu), auto (default): "
                        "mean_throttle for PPO/A2C in throttle mode on a scene with thrusters, "
                        "else mode")
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
    flight.add_arguments(sub)  # replay, identify: flight telemetry
    return p


# What a resumed run takes from the command line; the rest comes from its config.json.
RESUME_OVERRIDES = ("out", "timesteps", "threads", "engine")


def _train(args) -> int:
    """``rbenv train``: the given fields make the config of the chosen back end."""
    engine = getattr(args, "engine", "sb3")
    config, options = {"sb3": (TrainConfig, SB3Options), "rllib": (RLlibConfig, RLlibOptions),
                       "torchrl": (RunConfig, TorchRLOptions)}[engine]
    known = {f.name for cls in (config, options) for f in dataclasses.fields(cls)}
    wrong = [flags.flag(k) for cls in (TrainConfig, RLlibConfig, SB3Options, RLlibOptions,
                                       TorchRLOptions)
             for k in flags.given(args, cls) if k not in known]
    if wrong:
        raise SystemExit(f"rbenv train: {', '.join(sorted(set(wrong)))} not for --engine "
                         f"{engine}")
    cfg_fields = flags.given(args, config)
    if args.resume:
        ignored = [flags.flag(k) for k in cfg_fields if k not in RESUME_OVERRIDES]
        if ignored:
            print(f"--resume continues the run with its saved config.json; ignoring "
                  f"{', '.join(ignored)}")
    cfg = config(**cfg_fields)
    if engine == "torchrl":
        from rbenv.agents.training import torchrl  # the ecosystem extra (torch, TorchRL)

        return torchrl.train_from_config(cfg, TorchRLOptions(**flags.given(args, options)))
    if engine == "rllib":
        rllib.run(cfg, rllib.RLlibSession(**flags.given(args, options)), resume=args.resume,
                  force=args.force, report=not args.no_report)
        return 0
    from rbenv.agents.training import sb3  # the train extra (SB3, torch)

    engine_run(cfg, sb3.SB3Session(**flags.given(args, options)), resume=args.resume,
               force=args.force, report=not args.no_report)
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
    return subprocess.run([sys.executable, "-m", f"benchmarks.{args.name}", *args.extra],
                          env=env, cwd=CHECKOUT, check=False).returncode


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line's arguments; ``rbenv bench NAME ARGS...`` keeps ARGS for the benchmark
    (``args.extra``), any other command refuses unknown arguments."""
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    if extra and args.command != "bench":
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    args.extra = extra
    return args


def main(argv: list[str] | None = None) -> int:
    """Run a command. From the command line (``argv`` None) a documented error (a
    ``ValueError`` subclass of :mod:`rbenv.core.errors`, such as a corrupt run file) is printed as
    ``rbenv: error: ...`` with exit status 2; called with ``argv`` it is raised."""
    args = parse(argv)
    command = {"train": _train, "evaluate": _evaluate, "bench": _bench,
               "suite": _suite, **flight.COMMANDS}[args.command]
    if argv is not None:
        return command(args)
    try:
        return command(args)
    except RbenvValueError as e:
        print(f"rbenv: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
