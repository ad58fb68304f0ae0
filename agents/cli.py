"""The ``rbenv`` command: train, evaluate and benchmark (also ``python -m rbenv.agents.cli``).

    rbenv train [--engine sb3|sbx|rllib|torchrl] [--algo ppo|sac|td3|tqc|crossq] [--timesteps N]
                [--scene NAME] [--env-id ID] [--out DIR] [--resume | --force] [--no-report]
                [...]   (one flag per field of rbenv.agents.training.config; see --help)
    rbenv evaluate --policy pd|bangbang|mpc|bdot|unload|zero|random|RUN_DIR|policy.pt --episodes N
                   [--seed S] [--scene NAME] [--env-kwargs JSON] [--json OUT] [--plot OUT.png]
                   [--video OUT.gif] [--out DIR] [--trust-pickle]
    rbenv export RUN_DIR|policy.pt --format c|onnx --out DIR [--trust-pickle]
    rbenv bench NAME [--out DIR]   (in a source checkout only: benchmarks/ is not installed)
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
from rbenv.agents.policies import compiled, runfolder
from rbenv.agents.policies.envcheck import check_env_options
from rbenv.agents.policies.evaluate import (
    check_policy,
    evaluate,
    format_table,
    plot_episodes,
    record_video,
    scripted,
    scripted_by_task,
    write_json,
)
from rbenv.agents.policies.sb3 import POLICY_ACTIONS
from rbenv.agents.policies.weights import ALGOS
from rbenv.agents.training import flags, rllib, suite, tune
from rbenv.agents.training.config import (
    ENGINES,
    RunConfig,
    SessionOptions,
    TorchRLRunConfig,
    TrainConfig,
)
from rbenv.agents.training.engine import add_run_arguments
from rbenv.agents.training.engine import run as engine_run
from rbenv.agents.training.rllib import RLlibConfig
from rbenv.core.errors import RbenvValueError

import rbenv
from rbenv.satellite import usage

BENCH_OUT = "bench-results"


CHECKOUT = Path(__file__).resolve().parent.parent  # the repository root, in a source checkout


NO_BENCH = ("rbenv bench runs the benchmarks of a source checkout, and this rbenv is an "
            "install without them (benchmarks/ is not in the wheel): clone the repository, "
            "install it with `pip install -e .` and run `python -m rbenv bench NAME` there "
            "(or `python -m benchmarks.NAME`)")


def benchmarks() -> list[str]:
    """Benchmark modules (each runnable as ``python -m benchmarks.NAME``) of a source checkout.

    benchmarks/ is not installed (other wheels, torchrl among them, install a top-level
    ``benchmarks``), so a wheel install lists none, and its command line has no ``bench``
    (:data:`NO_BENCH` says why). The modules are listed, not imported.
    """
    folder = CHECKOUT / "benchmarks"
    if not (folder / "__init__.py").is_file():
        return []
    return sorted(m.name for m in pkgutil.iter_modules([str(folder)])
                  if not m.name.startswith("_") and m.name != "common")


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Every option's help ends with its default, unless it states it already or is a switch."""

    def _get_help_string(self, action):
        help_text = action.help or ""
        if action.nargs == 0 or action.required or action.default is None \
                or "default" in help_text.lower():
            return help_text
        return super()._get_help_string(action)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit status 2, no usage dump) and a did-you-mean for a
    near miss of a choice or an option name."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def _check_value(self, action, value):
        if action.choices is not None and value not in action.choices:
            raise argparse.ArgumentError(action, usage.invalid_choice(
                action.dest, value, action.choices, what="one of").reason)

    def unknown(self, words: list[str]) -> str:
        """The error for unrecognised words, with a did-you-mean for an option name."""
        options = [o for a in self._actions for o in a.option_strings]
        shown = []
        for word in words:
            name = word.split("=", 1)[0]
            hint = usage.did_you_mean(name, options) if name.startswith("--") else ""
            shown.append(word + hint)
        return f"unrecognized arguments: {' '.join(shown)}"


# --engine torchrl --quick: CI's smoke run, where the caller does not set these.
QUICK_TORCHRL_TIMESTEPS, QUICK_REPORT_EPISODES = 16_384, 50
# The option groups of `rbenv train`: the run's fields every engine reads, then each engine's
# config class; the session's options (SessionOptions) go with the engines that read them.
COMMON = (RunConfig, SessionOptions)
ENGINE_GROUPS = (
    ("sb3", "sb3 options (--engine sb3, the default: Stable-Baselines3; the train extra; "
            "--engine sbx, SAC and TD3 in JAX with SBX, reads the same options; the sbx extra)",
     TrainConfig),
    ("rllib", "rllib options (--engine rllib: PPO on Ray RLlib; the ray extra)", RLlibConfig),
    ("torchrl", "torchrl options (--engine torchrl: TorchRL's PPO on the torch env, env and "
                "learner on --device; the ecosystem extra). It reads every common option and "
                "--stop-success; "
                "its --hyperparams are the learner's, in RL Zoo's names (rbenv.agents.training."
                "config.TORCHRL_HYPERPARAMS)",
     TorchRLRunConfig),
)
# The config class each engine takes its run's fields from.
ENGINE_CONFIGS = {"sb3": TrainConfig, "sbx": TrainConfig, "rllib": RLlibConfig,
                  "torchrl": TorchRLRunConfig}


def _reads(engine: str) -> set[str]:
    """The flags (field names) ``engine`` reads: its config's and its session options."""
    return ({f.name for f in dataclasses.fields(ENGINE_CONFIGS[engine])}
            | set(SessionOptions.read_by(engine)))


def _parser() -> Parser:
    p = Parser(prog="rbenv", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    t = sub.add_parser("train", help="train PPO, SAC, TD3, TQC or CrossQ, then report against "
                                     "the baselines",
                       description="Every flag but --resume, --force, --no-report and "
                                   "--dry-run is a field of the run's configuration "
                                   "(rbenv.agents.training.config), and its help is that "
                                   "field's docstring. Every argument is checked (and the env "
                                   "made once) before anything is written; --dry-run stops "
                                   "there.")
    seen: set[str] = set()
    common = t.add_argument_group("common options (every engine)")
    flags.add_fields(common, RunConfig, seen=seen)
    flags.add_fields(common, SessionOptions, seen=seen, skip=[
        n for n in SessionOptions.READ_BY if set(SessionOptions.READ_BY[n]) != set(ENGINES)])
    add_run_arguments(common)
    for engine, title, cls in ENGINE_GROUPS:
        group = t.add_argument_group(title)
        flags.add_fields(group, cls, seen=seen)
        flags.add_fields(group, SessionOptions, seen=seen,
                         skip=SessionOptions.ignored_by(engine))
    e = sub.add_parser("evaluate", help="seeded evaluation of a policy",
                       description="Seeded evaluation. Prints a table; writes files only when "
                                   "asked (--json, --plot, --video, --out).")
    e.add_argument("--policy", required=True,
                   help=f"a scripted policy: {scripted_by_task()}; or a run folder, its "
                        "policy.pt or a checkpoint policy_N.pt (a model is evaluated in its "
                        "run's env options)")
    e.add_argument("--trust-pickle", action="store_true",
                   help="allow a pickle-based policy file (an older run's model.zip and "
                        "vecnormalize.pkl, a foreign SB3 .zip, an RLlib run); unpickling runs "
                        "any code in it, so only for files from a source you trust")
    e.add_argument("--episodes", type=_positive, default=100,
                   help="episodes, run side by side; episode i is seeded --seed + i")
    e.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    e.add_argument("--scene", default=None,
                   help="a shipped scene or a scene TOML file (default: a run's own, else the "
                        "task's default scene)")
    e.add_argument("--env-id", default=None,
                   help=f"the task (default: a run's own, else {rbenv.ENV_ID})")
    e.add_argument("--env-kwargs", type=flags.json_object, default={}, metavar="JSON",
                   help="JSON of gym.make options (docs/api.md lists them)")
    e.add_argument("--action", default="auto", choices=POLICY_ACTIONS,
                   help="how a trained SB3 model acts: mean_throttle E[clip(mu + sigma eps, "
                        "low, high)] with the env's clip bounds (thrusters 0..1, wheels and "
                        "rods -1..1), mode (SB3's deterministic mu), auto (default): the run's "
                        "own policy_action (its config.json) where it names one, else "
                        "mean_throttle for PPO/A2C in throttle mode on a scene with thrusters, "
                        "else mode")
    e.add_argument("--json", default=None, help="write the summary as JSON to this file")
    e.add_argument("--plot", default=None, metavar="PATH",
                   help="PNG of the first episode (no plot without it, or without --out)")
    e.add_argument("--video", default=None, metavar="PATH",
                   help="render the first episode to a .gif or .mp4 (the render extra)")
    e.add_argument("--out", default=None, metavar="DIR",
                   help="write evaluation.json and episodes.png into DIR (relative to the "
                        "current directory)")
    x = sub.add_parser("export", help="a trained policy as C99 or ONNX flight code, checked "
                                      "against the run (docs/export.md)")
    x.add_argument("run", help="a run folder, its policy.pt or a checkpoint policy_N.pt")
    x.add_argument("--format", action="append", choices=["c", "onnx"], default=None,
                   help="c: policy.h + policy.c; onnx: policy.onnx (repeat for both; "
                        "default c)")
    x.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    x.add_argument("--trust-pickle", action="store_true",
                   help="allow an RLlib run (RLlib pickles its modules): only one you trust")
    x.add_argument("--precision", choices=["float32", "int8"], default="float32",
                   help="int8: dense weights as int8 with a scale per row (4x less flash; "
                        "its difference from the run is measured and printed)")
    names = benchmarks()
    if names:  # a source checkout; an install has no benchmarks to run (NO_BENCH)
        b = sub.add_parser("bench", help="run a benchmark of this checkout, writing NAME.json "
                                         "and NAME.png")
        b.add_argument("name", choices=names, help=", ".join(names))
        b.add_argument("--out", default=BENCH_OUT, metavar="DIR",
                       help=f"results folder (default ./{BENCH_OUT} in the current directory; "
                            "pass benchmarks/results to refresh the committed ones)")
    tune.add_arguments(suite.add_arguments(sub.add_parser(
        "suite", help="learning suite: algorithm x task x scene x seed beside the baselines")))
    flight.add_arguments(sub)  # replay, identify: flight telemetry
    return p


# --- checks: every argument, before anything is written ---------------------------------------

def _check_train(args) -> tuple[type, type]:
    """The engine's (config, options) classes, once every given flag is one the engine reads."""
    engine = getattr(args, "engine", "sb3")
    reads = _reads(engine)
    owners: dict[str, list[str]] = {}
    for name, _, _ in ENGINE_GROUPS:
        for field in sorted(_reads(name)):
            owners.setdefault(field, []).append(name)
    for cls in (*COMMON, *(c for _, _, c in ENGINE_GROUPS)):
        for name in flags.given(args, cls):
            if name not in reads:
                engines = " and ".join(f"--engine {o}" for o in owners[name])
                raise usage.InvalidChoiceError(name, getattr(args, name), (
                    f"belongs to {engines}, not to --engine {engine}"))
    if engine == "torchrl" and getattr(args, "quick", False) and args.resume:
        raise usage.InvalidChoiceError("quick", True, "a new run's smoke form, not one of "
                                       "--resume, which continues the run as it was saved")
    return ENGINE_CONFIGS[engine], SessionOptions


def _train(args) -> int:
    """``rbenv train``: the given fields make the config of the chosen back end."""
    engine = getattr(args, "engine", "sb3")
    config, options = _check_train(args)
    cfg_fields = flags.given(args, config)
    if args.resume:
        keep = ("out", "engine", *config.RESUME_OVERRIDES)
        ignored = [flags.flag(k) for k in cfg_fields if k not in keep]
        if ignored:
            print(f"--resume continues the run with its saved config.json; ignoring "
                  f"{', '.join(ignored)}")
    cfg = config(**cfg_fields)
    if engine == "torchrl":
        if cfg.algo != "ppo":
            raise usage.invalid_choice("algo", cfg.algo, ["ppo"],
                                       what="one of --engine torchrl's algorithms:")
        from rbenv.agents.training import torchrl  # the ecosystem extra (torch, TorchRL)

        session = torchrl.TorchRLSession(**flags.given(args, options))
        if session.quick:  # a new run's smoke form: what the caller did not set
            cfg.timesteps = QUICK_TORCHRL_TIMESTEPS if cfg.timesteps is None else cfg.timesteps
            cfg.report_episodes = cfg_fields.get("report_episodes", QUICK_REPORT_EPISODES)
        engine_run(cfg, session, resume=args.resume, force=args.force,
                   report=not args.no_report, dry_run=args.dry_run)
        return 0
    if engine == "rllib":
        rllib.run(cfg, rllib.RLlibSession(**flags.given(args, options)), resume=args.resume,
                  force=args.force, report=not args.no_report, dry_run=args.dry_run)
        return 0
    from rbenv.agents.training import sb3  # the train extra (SB3, torch)

    if engine == "sbx":  # before anything is written
        usage.require("sbx", "rbenv train --engine sbx")
    session = sb3.SBXSession if engine == "sbx" else sb3.SB3Session
    engine_run(cfg, session(**flags.given(args, options)), resume=args.resume,
               force=args.force, report=not args.no_report, dry_run=args.dry_run)
    return 0


def _check_evaluate(args) -> None:
    """Every argument of ``rbenv evaluate``, before an episode runs or a file is written: the
    task, the policy, the scene and env options (the env is made once), the baseline on that
    scene, the output folders and the extras that --plot and --video need."""
    env_id = _env_id(args)
    usage.check_choice("env_id", env_id, [s.env_id for s in rbenv.envs.registry.specs()],
                       what="a registered rbenv task:")
    check_policy(args.policy, env_id)  # its name; the scene it runs on once that is known
    options = dict(args.env_kwargs)
    if Path(args.policy).exists():
        options = {**runfolder.env_kwargs_of(_run_config(args.policy)), **options}
    if args.scene is not None:
        options["scene"] = args.scene
    check_env_options(env_id, options)
    check_policy(args.policy, env_id, options)  # a baseline the scene cannot run: where it can
    for name in ("json", "plot", "video"):
        path = getattr(args, name)
        if path is not None and not Path(path).resolve().parent.is_dir():
            raise usage.InvalidChoiceError(name, path, (
                f"the folder of {path!r} does not exist"))
    if args.video is not None:
        usage.check_choice("video", Path(args.video).suffix, [".gif", ".mp4"],
                           what="a video file suffix:")
        for module in ("pygame", "imageio"):
            usage.require(module, "rbenv evaluate --video")
    if args.plot is not None or args.out is not None:
        usage.require("matplotlib", "rbenv evaluate --plot/--out")


def _evaluate(args) -> int:
    _check_evaluate(args)
    env_id = _env_id(args)
    result = evaluate(args.policy, episodes=args.episodes, seed=args.seed, scene=args.scene,
                      env_kwargs=args.env_kwargs, env_id=env_id, action=args.action,
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
                             env_kwargs=args.env_kwargs, env_id=env_id,
                             trust_pickle=args.trust_pickle)
        print(f"video: {video}")
    return 0


def _export(args) -> int:
    from rbenv.agents.policies import export  # torch, and onnx for --format onnx

    done = export.export(args.run, args.format or ["c"], args.out,
                         trust_pickle=args.trust_pickle, precision=args.precision)
    print(export.format_footprint(done.footprint))
    print("agreement with the run's predict (fraction of the action range): "
          + ", ".join(f"{k} {v:.2g}" for k, v in done.errors.items()))
    print("wrote " + ", ".join(str(f) for f in done.files))
    return 0


def _env_id(args) -> str:
    """--env-id, else the task a run folder was trained on, else :data:`rbenv.ENV_ID`."""
    if args.env_id:
        return args.env_id
    if args.policy not in scripted() and Path(args.policy).exists():
        return _run_config(args.policy).get("env_id", rbenv.ENV_ID)
    return rbenv.ENV_ID


def _run_config(policy: str) -> dict:
    """The config.json of the run a policy path belongs to ({} for a bare model file; the
    export.json manifest for an exported policy.c or .so)."""
    path = Path(policy)
    if compiled.is_exported(path):
        return compiled.manifest(path)
    if path.is_dir() and (path / runfolder.CONFIG).is_file():  # a run folder, SB3 or RLlib
        return runfolder.read_config(path)
    return runfolder.locate(path).config or {}


def _suite(args) -> int:
    for algo in args.algos or ():
        usage.check_choice("algos", algo, ALGOS, what="one of")
    for scene in args.scenes or ():
        try:
            rbenv.load_scene(scene)
        except usage.InvalidChoiceError as e:  # named for the flag, with its did-you-mean
            raise usage.InvalidChoiceError("scenes", scene, e.reason) from None
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


def parse(argv: list[str] | None = None, parser: Parser | None = None) -> argparse.Namespace:
    """The command line's arguments; ``rbenv bench NAME ARGS...`` keeps ARGS for the benchmark
    (``args.extra``), any other command refuses unknown arguments (one line, exit status 2,
    with a did-you-mean for a misspelt option)."""
    parser = parser or _parser()
    commands = parser._subparsers._group_actions[0].choices
    words = list(sys.argv[1:] if argv is None else argv)
    name = next((w for w in words if not w.startswith("-")), None)
    if name == "bench" and name not in commands:
        parser.error(NO_BENCH)
    if name in commands and name != "bench":  # a misspelt option first, before what it hides
        command = commands[name]
        options = [o for a in command._actions for o in a.option_strings]
        for word in words[words.index(name) + 1:]:
            flag = word.split("=", 1)[0]
            if flag.startswith("--") and not any(o.startswith(flag) for o in options):
                command.error(command.unknown([flag]))
    args, extra = parser.parse_known_args(argv)
    if extra and args.command != "bench":
        command = commands[args.command]
        command.error(command.unknown(extra))
    args.extra = extra
    return args


COMMANDS = {"train": _train, "evaluate": _evaluate, "bench": _bench, "suite": _suite,
            "export": _export, **flight.COMMANDS}


def _feature(args) -> str:
    """What the command line asked for, as a missing extra's message names it."""
    engine = getattr(args, "engine", None) if args.command == "train" else None
    return f"rbenv {args.command}" + (f" --engine {engine}" if engine else "")


def _one_line(args, parser: Parser, error: Exception) -> str:
    """``rbenv COMMAND: error: ...`` in one line; an input error whose field is a flag of the
    command names the flag (``argument --scene: ...``) where the flag gave the value (not
    where ``--env-kwargs`` did)."""
    text = " ".join(str(error).split())
    if isinstance(error, usage.InvalidChoiceError):
        command = parser._subparsers._group_actions[0].choices[args.command]
        dests = {a.dest: a.option_strings[0] for a in command._actions if a.option_strings}
        if error.field in dests and getattr(args, error.field, None) is not None:
            text = f"argument {dests[error.field]}: {' '.join(error.reason.split())}"
    return f"rbenv {args.command}: error: {text}"


def console(argv: list[str]) -> int:
    """Run a command as the command line does: a user's mistake (a named ``ValueError`` of
    :mod:`rbenv.core.errors`: a bad value, a missing or corrupt run file, a missing extra) is
    printed as one line on stderr with exit status 2, never a traceback; anything else is a bug
    and keeps its traceback."""
    parser = _parser()
    args = parse(argv, parser)
    try:
        return COMMANDS[args.command](args)
    except RbenvValueError as e:
        error = e
    except ModuleNotFoundError as e:
        error = usage.missing_extra(e, _feature(args))
        if error is None:
            raise
    print(_one_line(args, parser, error), file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """Run a command. From the command line (``argv`` None) as :func:`console` does; called
    with ``argv`` (tests, scripts) a documented error is raised, a missing extra as
    :class:`rbenv.satellite.usage.MissingExtraError`."""
    if argv is None:
        return console(sys.argv[1:])
    args = parse(argv)
    try:
        return COMMANDS[args.command](args)
    except ModuleNotFoundError as e:
        error = usage.missing_extra(e, _feature(args))
        if error is None:
            raise
        raise error from None


if __name__ == "__main__":
    sys.exit(main())
