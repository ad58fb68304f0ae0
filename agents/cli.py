"""The ``rbenv`` command: train, evaluate and benchmark.

    rbenv train [--algo ppo|sac] [--timesteps N] [--n-envs K] [--seed S] [--scene NAME]
                [--out DIR] [--resume] [--checkpoint-every N] [--eval-every N]
                [--hyperparams JSON] [--env-kwargs JSON] [--no-report]
    rbenv evaluate --policy pd|bangbang|zero|random|PATH/TO/model.zip --episodes N --seed S
                   [--scene NAME] [--json OUT] [--plot OUT.png] [--video OUT.gif]
    rbenv bench accuracy|stability|speed|specialize|inertia
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

BENCHMARKS = ("accuracy", "stability", "speed", "specialize", "inertia")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rbenv", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train PPO or SAC, then report against the baselines")
    t.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    t.add_argument("--timesteps", type=int, default=None, help="default: ppo 2M, sac 200k")
    t.add_argument("--n-envs", type=int, default=None, help="default: ppo 64, sac 8")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--scene", default="cubesat-12u")
    t.add_argument("--out", default=None, help="run directory (default runs/ALGO-SCENE-seedS)")
    t.add_argument("--resume", action="store_true",
                   help="continue from the last checkpoint (--timesteps then sets a new total)")
    t.add_argument("--checkpoint-every", type=int, default=200_000, help="timesteps")
    t.add_argument("--eval-every", type=int, default=200_000, help="timesteps")
    t.add_argument("--hyperparams", type=json.loads, default={},
                   help='JSON overriding algorithm hyperparameters, e.g. \'{"n_steps": 128}\'')
    t.add_argument("--env-kwargs", type=json.loads, default={},
                   help='JSON of gym.make options, e.g. \'{"action_mode": "torque"}\'')
    t.add_argument("--no-report", action="store_true", help="skip the final evaluation report")
    e = sub.add_parser("evaluate", help="seeded evaluation of a policy")
    e.add_argument("--policy", required=True, help="pd, bangbang, zero, random or model.zip")
    e.add_argument("--episodes", type=int, default=100)
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--scene", default=None)
    e.add_argument("--json", default=None, help="write the summary as JSON here")
    e.add_argument("--plot", default="episodes.png", help="PNG of the first episode")
    e.add_argument("--video", default=None, help="render the first episode to a .gif/.mp4")
    b = sub.add_parser("bench", help="run a benchmark (writes benchmarks/results/NAME.*)")
    b.add_argument("name", choices=BENCHMARKS)
    return p


def _train(args) -> int:
    from agents.train import TrainConfig, train

    cfg = TrainConfig(algo=args.algo, timesteps=args.timesteps, n_envs=args.n_envs,
                      seed=args.seed, scene=args.scene, out=args.out,
                      checkpoint_every=args.checkpoint_every, eval_every=args.eval_every,
                      hyperparams=args.hyperparams, env_kwargs=args.env_kwargs)
    train(cfg, resume=args.resume, report=not args.no_report)
    return 0


def _evaluate(args) -> int:
    from agents.evaluate import evaluate, format_table, plot_episodes, record_video, write_json

    result = evaluate(args.policy, episodes=args.episodes, seed=args.seed, scene=args.scene)
    print(format_table([result]))
    if args.json:
        write_json([result], args.json)
    if args.plot:
        plot_episodes([result], args.plot)
    if args.video:
        print(f"video: {record_video(args.policy, args.video, seed=args.seed, scene=args.scene)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "train":
        return _train(args)
    if args.command == "evaluate":
        return _evaluate(args)
    importlib.import_module(f"benchmarks.{args.name}").main()
    return 0


if __name__ == "__main__":
    sys.exit(main())
