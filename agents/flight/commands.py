"""The ``rbenv replay`` and ``rbenv identify`` commands (registered by :mod:`rbenv.agents.cli`).

    rbenv replay DIR --scene S --policy P --json OUT [--plot PNG] [--env-id ID]
                 [--env-kwargs JSON] [--seed N] [--trust-pickle]
    rbenv identify DIR --scene S [--policy P] [--out SCENE.toml] [--json OUT] [--draws N]
"""

from __future__ import annotations

import json

from rbenv.agents.flight import identify, replay

from rbenv.satellite.usage import InvalidChoiceError


def add_arguments(sub) -> None:
    """The two subcommands on the ``rbenv`` parser's subparsers ``sub``."""
    r = sub.add_parser("replay", help="fly a policy from each logged start of flight "
                                      "telemetry and compare with the flight",
                       description=replay.__doc__.split("\n\n")[0])
    r.add_argument("dir", metavar="DIR", help="telemetry folder (searched recursively for "
                                              "maneuver folders of four CSV files)")
    r.add_argument("--scene", required=True, help="scene name or .toml path")
    r.add_argument("--policy", required=True,
                   help="a baseline of the task (e.g. innocube-pd), a run folder or policy.pt")
    r.add_argument("--json", default=None, metavar="OUT", help="write the comparison here")
    r.add_argument("--plot", default=None, metavar="PNG",
                   help="flight against rbenv, one panel per sub-maneuver (matplotlib)")
    r.add_argument("--env-id", default=None,
                   help="the task (default: a run's own, else rbenv/SatelliteReorient-v1)")
    r.add_argument("--env-kwargs", type=_json_object, default={},
                   help='JSON of gym.make options over {"action_mode": "acceleration"}')
    r.add_argument("--seed", type=int, default=0,
                   help="seed of the scene's per-episode draws (e.g. a drawn deadband)")
    r.add_argument("--trust-pickle", action="store_true",
                   help="allow a pickle-based policy file (only from a source you trust)")
    i = sub.add_parser("identify", help="fit a scene's uncertain parameters to flight "
                                        "telemetry by least squares, and write the scene",
                       description=identify.__doc__.split("\n\n")[0])
    i.add_argument("dir", metavar="DIR", help="telemetry folder (as for replay)")
    i.add_argument("--scene", required=True, help="the scene to start from (name or .toml)")
    i.add_argument("--policy", default="innocube-pd",
                   help="the controller that flew the telemetry (default innocube-pd)")
    i.add_argument("--out", default=None, metavar="TOML",
                   help="identified scene file (default ./<scene>-identified.toml)")
    i.add_argument("--json", default=None, metavar="OUT", help="write the fit's report here")
    i.add_argument("--env-id", default=None)
    i.add_argument("--seed", type=int, default=0)
    i.add_argument("--draws", type=int, default=1,
                   help="fly each sub-maneuver this many times, the scene's ranges and sensor "
                        "noise drawn anew each time, and fit them all (default 1)")


def run_replay(args) -> int:
    if "scene" in args.env_kwargs:  # the scene replayed in is --scene, lengthened to the log
        raise InvalidChoiceError("env_kwargs", args.env_kwargs, (
            f"must not hold 'scene' (got {args.env_kwargs['scene']!r}): the scene replayed in "
            "is --scene"))
    result = replay.replay(args.dir, args.scene, args.policy, env_id=args.env_id,
                           env_kwargs=args.env_kwargs, seed=args.seed,
                           trust_pickle=args.trust_pickle)
    print(replay.format_table(result))
    if args.json:
        print(f"comparison: {replay.write_json(result, args.json)}")
    if args.plot:
        print(f"plot: {replay.plot(result, args.plot)}")
    return 0


def run_identify(args) -> int:
    fit = identify.identify(args.dir, args.scene, policy=args.policy, env_id=args.env_id,
                            seed=args.seed, draws=args.draws)
    print(identify.format_report(fit))
    out = args.out or f"{fit.scene_name}-identified.toml"
    print(f"scene: {identify.write_scene(fit, out)}")
    if args.json:
        print(f"report: {identify.write_json(fit, args.json)}")
    return 0


COMMANDS = {"replay": run_replay, "identify": run_identify}


def _json_object(text: str) -> dict:
    value = json.loads(text)
    if not isinstance(value, dict):
        raise ValueError(f"--env-kwargs must be a JSON object, got {text!r}")
    return value
