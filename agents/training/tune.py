"""``rbenv suite --ray``: the learning suite's grid on Ray Tune, one trial per cell.

Each trial calls :func:`rbenv.agents.training.suite.run_cell` for its cell, so a trial writes
exactly what the serial suite writes (``OUT/cells/<name>/run`` and ``result.json``), and the
driver then calls :func:`rbenv.agents.training.suite.aggregate` on every trial's result: the same
``suite.json``, ``suite.md`` and curves as ``run_serial``. Trials are spread over every core of
this machine, or of a cluster (``address``); each asks for ``cpus_per_trial`` CPUs.

A trial whose process dies is retried up to ``max_failures`` times (Tune's
``FailureConfig``); the retry resumes the cell's training run from its last checkpoint, which
``run_cell`` finds in the run folder. On a cluster, OUT must be a folder every node sees at the
same path (a shared file system); the results themselves come back to the driver through Tune,
which writes any ``result.json`` missing on its side before aggregating.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import asdict
from pathlib import Path

from rbenv.agents.policies.runfolder import write_json
from rbenv.agents.training import suite
from rbenv.agents.training.ray_cluster import connect, shutdown

TRIAL_RECORD = "tune_trial.json"  # in the cell's folder: pid, node and attempt of its trial


def _trial(config: dict) -> None:
    """One Tune trial: run (or resume) one cell, report its whole result to the driver."""
    import ray  # the ray extra
    from ray import tune

    cell = suite.Cell(**config["cell"])
    out = Path(config["out"])
    folder = suite.cell_dir(cell, out)
    folder.mkdir(parents=True, exist_ok=True)
    record = folder / TRIAL_RECORD
    attempts = 0
    if record.is_file():
        try:
            attempts = int(json.loads(record.read_text()).get("attempt", 0))
        except (ValueError, OSError):
            attempts = 0
    node_ip = ray.util.get_node_ip_address()
    write_json(record, {"pid": os.getpid(), "node_ip": node_ip, "attempt": attempts + 1,
                        "started": time.time()})
    result = suite.run_cell(cell, out, eval_episodes=config["eval_episodes"],
                            eval_seed=config["eval_seed"], threads=config["threads"])
    tune.report({"success_rate": result["policy"]["success_rate"], "node_ip": node_ip,
                 "pid": os.getpid(), "attempt": attempts + 1, "result_json": json.dumps(result)})


def run_tune(cells: list, out: Path, *, eval_episodes: int, eval_seed: int, threads: int = 1,
             address: str | None = None, cpus_per_trial: float = 1, max_failures: int = 2,
             num_cpus: int | None = None) -> dict:
    """Run every cell as a Tune trial, then aggregate at the driver; returns suite.json's data.

    ``address``: None for a private Ray instance on this machine (``num_cpus`` caps it),
    ``"auto"`` or ``HOST:PORT`` for a running cluster.
    """
    out = Path(out).resolve()
    started = connect(address, num_cpus=num_cpus, feature="--ray")  # before ray is imported
    out.mkdir(parents=True, exist_ok=True)
    try:
        from ray import tune  # the ray extra, imported once connect() has set Ray up

        trainable = tune.with_resources(_trial, {"cpu": cpus_per_trial})
        space = {"cell": tune.grid_search([asdict(c) for c in cells]), "out": str(out),
                 "eval_episodes": eval_episodes, "eval_seed": eval_seed, "threads": threads}
        run_config = tune.RunConfig(
            name=f"suite-{time.strftime('%Y%m%d-%H%M%S')}", storage_path=str(out / "tune"),
            failure_config=tune.FailureConfig(max_failures=max_failures), verbose=1)
        grid = tune.Tuner(trainable, param_space=space, run_config=run_config).fit()
        results, placement = [], {}
        for r in grid:
            if r.metrics and "result_json" in r.metrics:
                result = json.loads(r.metrics["result_json"])
                results.append(result)
                placement[result["name"]] = {k: r.metrics[k] for k in ("node_ip", "pid",
                                                                        "attempt")}
                path = suite.cell_dir(suite.Cell(**result["cell"]), out) / "result.json"
                if suite.read_result(path) is None:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    write_json(path, result)
            elif r.error is not None:
                print(f"trial {r.config['cell']} failed: {r.error}")
        write_json(out / "tune_placement.json", placement)
    finally:
        shutdown(started)
    return suite.aggregate(results, out, expected=cells)


def main(args) -> dict:
    """``rbenv suite --ray``: the suite's arguments plus ``--address``, ``--cpus-per-trial``."""
    out = Path(args.out or ("runs/suite-quick" if args.quick else "runs/suite"))
    episodes = args.episodes or (suite.QUICK["episodes"] if args.quick else suite.EVAL_EPISODES)
    cells = suite.cells_from_args(args)
    started = time.perf_counter()
    data = run_tune(cells, out, eval_episodes=episodes, eval_seed=args.eval_seed,
                    threads=args.threads, address=getattr(args, "address", None),
                    cpus_per_trial=getattr(args, "cpus_per_trial", 1),
                    max_failures=getattr(args, "max_failures", 2))
    print(f"suite of {len(cells)} cells on Ray Tune: "
          f"{(time.perf_counter() - started) / 60:.1f} min")
    print((out / "suite.md").read_text())
    print(f"written: {out / 'suite.json'}, {out / 'suite.md'}, {out / 'learning_curves.png'}")
    return data


def add_arguments(p):
    """The Ray flags of ``rbenv suite``."""
    p.add_argument("--ray", action="store_true",
                   help="run the grid on Ray Tune, one trial per cell (needs the ray extra)")
    p.add_argument("--address", default=None,
                   help="with --ray: a running cluster, 'auto' or HOST:PORT of its head "
                        "(default: a private Ray instance on this machine, 127.0.0.1)")
    p.add_argument("--cpus-per-trial", type=float, default=1.0)
    p.add_argument("--max-failures", type=int, default=2,
                   help="retries of a trial whose process died (it resumes from its last "
                        "checkpoint)")
    return p


if __name__ == "__main__":
    parser = add_arguments(suite.add_arguments(argparse.ArgumentParser(
        prog="python -m rbenv.agents.training.tune", description=__doc__.split("\n")[0])))
    main(parser.parse_args())
