"""The speed/accuracy trade for learned policies: train PPO on cheap physics, test on exact physics.

Run ``python -m benchmarks.fidelity`` (``--quick`` for a smoke form). For each physics setting a
user might pick for speed (integrator × substeps per 0.5 s control step), PPO is trained with
the shipped defaults (:func:`rbenv.agents.training.suite.train_config`,
:func:`rbenv.agents.training.sb3.train`) on
the default reorientation task, scene cubesat-12u, with only ``integrator`` and ``substeps``
changed. Every policy is then evaluated, with the learning suite's mean-throttle action
(``action="mean_throttle"`` of :class:`rbenv.agents.policies.sb3.RunPolicy`), on the suite's 500
held-out
episodes (seed 1,000,000 + i):

- on **reference physics** (:data:`REFERENCE`, RK4 with 16 substeps), checked to be converged by
  evaluating the PD, the bang-bang and every policy again on RK4 with 32 substeps;
- on its **own training physics**, the number the user would have seen.

The checkpoint is selected as the suite does, by success on 100 validation episodes (seed
2,000,000 + i), but on the training physics: the user has nothing else. The scripted baselines
run on every setting and on the reference, and the vector env's env-steps/s of every setting is
measured in one run (CPU time, interleaved rounds, 64 sub-envs as in training).

Resumable: each finished (setting, seed) run is written to ``OUT/runs/<setting>-seed<k>.json``
and skipped when present; the training folders (models, checkpoints) are in ``--runs-dir``
(default ``runs/fidelity``, or ``OUT/train`` with ``--quick``), and a killed training resumes
from its last checkpoint. The aggregate is ``OUT/fidelity.json``, ``fidelity.md`` and
``fidelity.png`` (success on the reference against training time, one point per setting).
``OUT`` defaults to ``benchmarks/results/fidelity``, and to ``runs/fidelity-quick`` with
``--quick`` so that the smoke form never overwrites the committed results.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from rbenv.agents.policies.runfolder import RunFolderError, read_json, write_json
from rbenv.agents.training import suite

from benchmarks import common

# The first release's id: the committed results (and the A/B against an older checkout)
# measured it; v1 has its episodes, with another observation and reward.
REORIENT_V0 = "rbenv/SatelliteReorient-v0"

RESULT_VERSION = 1
SCENE = "cubesat-12u"
N_ENVS = 64  # PPO's default (its shipped n_envs), also used for the speed figure
LARGE_N_ENVS = 4096  # a second speed figure where the physics, not per-call overhead, dominates


@dataclass(frozen=True)
class Setting:
    """A physics setting: integrator and substeps per control step (control_dt stays 0.5 s)."""

    integrator: str
    substeps: int

    @property
    def name(self) -> str:
        return f"{self.integrator}x{self.substeps}"

    @property
    def env_kwargs(self) -> dict:
        return {"integrator": self.integrator, "substeps": self.substeps}


REFERENCE = Setting("rk4", 16)
CHECK = Setting("rk4", 32)  # the reference is converged if everyone scores the same here
SETTINGS = (Setting("euler_seed", 1), Setting("euler", 1), Setting("euler", 4),
            Setting("euler", 8), Setting("semi_implicit", 1), Setting("midpoint", 1),
            Setting("splitting", 1), Setting("rk4", 1), Setting("rk4", 4), REFERENCE)
DEFAULT = Setting("rk4", 1)  # the scene's own physics
TIMESTEPS = 600_000
QUICK = {"settings": [Setting("euler_seed", 1), DEFAULT], "timesteps": 4096, "episodes": 20,
         "seeds": 1}
BASELINES = ("pd", "bangbang")
CONVERGED_FUEL_RTOL = 1e-3  # reference vs check: same success, fuel within 0.1 %


def parse_setting(text: str) -> Setting:
    """``"rk4x16"`` -> Setting("rk4", 16); a named error otherwise."""
    integrator, sep, substeps = text.rpartition("x")
    if not sep or not substeps.isdigit() or int(substeps) < 1:
        raise argparse.ArgumentTypeError(f"setting must be INTEGRATORxSUBSTEPS (e.g. rk4x4), "
                                         f"got {text!r}")
    return Setting(integrator, int(substeps))


# --- one run: train on a setting, evaluate on the reference and on the setting ----------------

def _evaluate(policy, setting: Setting, episodes: int, seed: int) -> dict:
    from rbenv.agents.policies.evaluate import evaluate

    name = policy if isinstance(policy, str) else "ppo"
    return evaluate(policy, name=name, episodes=episodes, seed=seed, scene=SCENE, record=0,
                    env_id=REORIENT_V0, env_kwargs=setting.env_kwargs).summary()


def train_setting(setting: Setting, seed: int, timesteps: int, run: Path, threads: int
                  ) -> dict:
    """Train PPO (Reorient-v0's general recipe, :func:`benchmarks.common.with_general_recipe`)
    on ``setting``; training.json plus this process's CPU time.

    ``cpu_time_s`` is the CPU time of this process during :func:`rbenv.agents.training.sb3.train`
    (one
    torch thread), None when the run was resumed from a checkpoint written by another process.
    """
    from rbenv.agents.policies import runfolder as runs
    from rbenv.agents.training.sb3 import train

    cell = suite.Cell("ppo", REORIENT_V0, SCENE, seed, timesteps)
    cfg = common.with_general_recipe(suite.train_config(cell, run, threads))
    cfg.env_kwargs = setting.env_kwargs
    resume = (run / runs.CONFIG).is_file()
    cpu = time.process_time()
    train(cfg, resume=resume, force=not resume, progress_bar=False, report=False)
    cpu = time.process_time() - cpu
    summary = read_json(run / runs.SUMMARY, "training summary")
    fresh = not resume and not summary.get("resumed_from")
    return {**{k: summary.get(k) for k in ("timesteps", "wall_time_s", "threads",
                                          "gradient_updates")},
            "cpu_time_s": cpu if fresh else None, "n_envs": cfg.n_envs,
            "steps_per_s_wall": summary["timesteps"] / summary["wall_time_s"]}


def result_path(out: Path, setting: Setting, seed: int) -> Path:
    return Path(out) / "runs" / f"{setting.name}-seed{seed}.json"


def read_run(path: Path, expect: dict) -> dict | None:
    """A complete run result at ``path`` matching ``expect`` (setting, seed, budget), or None."""
    try:
        data = read_json(path, "fidelity run")
    except RunFolderError:
        return None
    if data.get("version") != RESULT_VERSION or not data.get("complete"):
        return None
    return data if all(data.get(k) == v for k, v in expect.items()) else None


def collect(out: Path, settings: list[Setting], timesteps: int, episodes: int) -> list[dict]:
    """Every finished run in ``out/runs`` of ``settings`` with this budget, whatever its seed."""
    found = []
    for s in settings:
        for path in sorted((Path(out) / "runs").glob(f"{s.name}-seed*.json")):
            run = read_run(path, {"setting": asdict(s), "timesteps": timesteps,
                                  "eval": {"episodes": episodes, "seed": suite.EVAL_SEED}})
            found += [run] if run else []
    return sorted(found, key=lambda r: (r["seed"], r["name"]))


def run_setting(setting: Setting, seed: int, *, out: Path, runs_dir: Path, timesteps: int,
                episodes: int, threads: int = 1) -> dict:
    """Train on ``setting`` and evaluate on reference, check and own physics; cached as JSON."""
    from rbenv.agents.policies.sb3 import SB3Policy
    from rbenv.agents.training.sb3 import set_threads

    path = result_path(out, setting, seed)
    expect = {"setting": asdict(setting), "seed": seed, "timesteps": timesteps,
              "eval": {"episodes": episodes, "seed": suite.EVAL_SEED}}
    done = read_run(path, expect)
    if done is not None:
        return done
    run = Path(runs_dir) / f"{setting.name}-seed{seed}"
    training = train_setting(setting, seed, timesteps, run, threads)
    set_threads(threads)
    cell = suite.Cell("ppo", REORIENT_V0, SCENE, seed, timesteps)
    curve = suite.validation_curve(cell, run, min(episodes, suite.VALIDATION_EPISODES),
                                   env_kwargs=setting.env_kwargs)
    model, steps = suite.select_checkpoint(run, curve)
    selected = SB3Policy(model, action="mean_throttle")
    final = SB3Policy(run, action="mean_throttle")
    evals = {"reference": _evaluate(selected, REFERENCE, episodes, suite.EVAL_SEED),
             "check": _evaluate(selected, CHECK, episodes, suite.EVAL_SEED),
             "own": _evaluate(selected, setting, episodes, suite.EVAL_SEED),
             "final_reference": _evaluate(final, REFERENCE, episodes, suite.EVAL_SEED),
             "final_own": _evaluate(final, setting, episodes, suite.EVAL_SEED)}
    result = {"version": RESULT_VERSION, "complete": True, **expect, "name": setting.name,
              "run_dir": str(run), "selected_timesteps": steps, "validation_curve": curve,
              "training": training, **evals}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, result)
    return result


# --- per setting: scripted baselines and env speed --------------------------------------------

def baselines(settings: list[Setting], episodes: int) -> dict:
    """Summary of every scripted baseline on every setting (same held-out episodes)."""
    return {s.name: {b: _evaluate(b, s, episodes, suite.EVAL_SEED) for b in BASELINES}
            for s in settings}


def reference_check(table: dict, runs: list[dict]) -> dict:
    """Is the reference converged? Baselines and policies on REFERENCE vs CHECK."""
    rows = [{"policy": b, "reference": _metrics(table[REFERENCE.name][b]),
             "check": _metrics(table[CHECK.name][b])} for b in BASELINES]
    rows += [{"policy": f"ppo {r['name']} seed {r['seed']}", "reference":
              _metrics(r["reference"]), "check": _metrics(r["check"])} for r in runs]
    for row in rows:
        ref, chk = row["reference"], row["check"]
        row["success_diff"] = abs(ref["success_rate"] - chk["success_rate"])
        row["fuel_rel_diff"] = abs(ref["fuel_g"] - chk["fuel_g"]) / max(chk["fuel_g"], 1e-12)
    worst_fuel = max(r["fuel_rel_diff"] for r in rows)
    worst_success = max(r["success_diff"] for r in rows)
    return {"reference": asdict(REFERENCE), "check": asdict(CHECK), "rows": rows,
            "max_success_diff": worst_success, "max_fuel_rel_diff": worst_fuel,
            "converged": bool(worst_success == 0.0 and worst_fuel <= CONVERGED_FUEL_RTOL)}


def env_speed(settings: list[Setting], *, num_envs: int = N_ENVS, rounds: int = 7,
              steps: int = 8) -> dict:
    """Env-steps/s of the vector env (``num_envs`` sub-envs, same-step autoreset as in training)
    for every setting: CPU time, minimum over interleaved rounds; random actions, resets
    included."""
    import gymnasium as gym
    from gymnasium.vector import AutoresetMode

    from benchmarks.common import best_times

    fns, envs = {}, []
    for s in settings:
        env = gym.make_vec(REORIENT_V0, num_envs=num_envs, vectorization_mode="vector_entry_point",
                           autoreset_mode=AutoresetMode.SAME_STEP, scene=SCENE, **s.env_kwargs)
        env.reset(seed=0)
        actions = np.random.default_rng(0).uniform(-1, 1, (steps, *env.action_space.shape))

        def fn(env=env, actions=actions):
            for a in actions:
                env.step(a)

        fns[s.name] = fn
        envs.append(env)
    seconds = best_times(fns, rounds=rounds)
    for env in envs:
        env.close()
    return {name: num_envs * steps / t for name, t in seconds.items()}


def open_loop_divergence(settings: list[Setting], *, episodes: int = 100,
                         duration_s: float = 30.0) -> dict:
    """How far each setting's physics drifts from the reference under the same thrust.

    The PD flies ``episodes`` held-out episodes on the reference physics for ``duration_s``
    (the slew, before it settles); its throttle sequence is then replayed open-loop on each
    setting. Reported: the largest difference of the attitude error (deg) and of the rate
    (deg/s) between the two over the replay, median and max over episodes. A lower bound on
    the model error a policy trained on the setting meets on the reference, before feedback.
    """
    import gymnasium as gym
    from rbenv.agents.baselines.controllers import baseline

    def make(setting):
        env = gym.make_vec(REORIENT_V0, num_envs=episodes, scene=SCENE,
                           vectorization_mode="vector_entry_point", **setting.env_kwargs)
        obs, _ = env.reset(seed=suite.EVAL_SEED)
        return env, obs

    def fly(env, obs, actions=None, policy=None):
        alive = np.ones(episodes, bool)
        trace, taken = [], []
        for k in range(n_steps):
            a = actions[k] if actions is not None else policy.predict(obs)[0]
            obs, _, term, trunc, info = env.step(a)
            taken.append(np.asarray(a, float).copy())
            trace.append((np.where(alive, info["attitude_error_deg"], np.nan),
                          np.where(alive, info["rate_dps"], np.nan)))
            alive &= ~(term | trunc)
        env.close()
        return np.array(trace), taken

    ref_env, obs = make(REFERENCE)
    n_steps = round(duration_s / ref_env.unwrapped.plant.control_dt)
    ref, actions = fly(ref_env, obs, policy=baseline(ref_env, "pd"))
    out = {}
    for s in settings:
        trace, _ = fly(*make(s), actions=actions)
        diff = np.nanmax(np.abs(trace - ref), axis=0)  # (2, episodes): error, rate
        out[s.name] = {"attitude_error_deg": {"median": float(np.median(diff[0])),
                                              "max": float(np.max(diff[0]))},
                       "rate_dps": {"median": float(np.median(diff[1])),
                                    "max": float(np.max(diff[1]))}}
    return {"episodes": episodes, "duration_s": duration_s, "settings": out}


# --- aggregate --------------------------------------------------------------------------------

def _metrics(summary: dict) -> dict:
    return {"success_rate": summary["success_rate"], "fuel_g": 1000 * summary["fuel"]["mean"],
            "settle_median_s": summary["settle_time_s"]["median"]}


def _stats(values) -> dict:
    return suite._stats(list(values))


def setting_rows(settings: list[Setting], runs: list[dict], table: dict, speed: dict,
                 timesteps: int, large: dict) -> list:
    """One row per setting: the policies' stats over seeds, baselines, speed (and the CPU time
    the env alone would take for ``timesteps`` steps at that speed)."""
    rows = []
    base_speed = speed.get(DEFAULT.name)
    for s in settings:
        rs = sorted((r for r in runs if r["name"] == s.name), key=lambda r: r["seed"])
        row = {"setting": s.name, **asdict(s), "seeds": [r["seed"] for r in rs],
               "env_steps_per_s": speed.get(s.name),
               "env_cost_vs_default": (base_speed / speed[s.name]
                                       if base_speed and s.name in speed else None),
               "env_cpu_s_per_run": (timesteps / speed[s.name] if s.name in speed else None),
               "env_steps_per_s_large": large.get(s.name),
               "env_cost_vs_default_large": (large[DEFAULT.name] / large[s.name]
                                             if s.name in large else None),
               "baselines_own": {b: _metrics(table[s.name][b]) for b in BASELINES}}
        for key in ("reference", "own", "final_reference", "final_own"):
            per = [_metrics(r[key]) for r in rs]
            row[key] = {m: _stats(p[m] for p in per) for m in
                        ("success_rate", "fuel_g", "settle_median_s")}
        row["train_wall_time_s"] = _stats(r["training"]["wall_time_s"] for r in rs)
        row["train_cpu_time_s"] = _stats(r["training"]["cpu_time_s"] for r in rs)
        row["selected_timesteps"] = [r["selected_timesteps"] for r in rs]
        rows.append(row)
    return rows


def _pct(s: dict) -> str:
    if s["mean"] is None:
        return "—"
    spread = f" ± {100 * s['std']:.1f}" if s["n"] > 1 else ""
    return f"{100 * s['mean']:.1f}{spread} %"


def _num(s: dict, spec: str, scale: float = 1.0) -> str:
    if s["mean"] is None:
        return "—"
    spread = f" ± {format(s['std'] * scale, spec)}" if s["n"] > 1 else ""
    return f"{format(s['mean'] * scale, spec)}{spread}"


def _drift(row: dict) -> str:
    d = row["open_loop_divergence"]["attitude_error_deg"]
    return f"{d['median']:.2g} ({d['max']:.2g})"


def format_markdown(data: dict) -> str:
    info, check = data["info"], data["reference_check"]
    ref = data["baselines"][REFERENCE.name]
    lines = [
        f"PPO ({info['timesteps']:,} timesteps, shipped defaults, {N_ENVS} envs, 1 torch "
        f"thread) trained on each physics setting of `{SCENE}` (control step 0.5 s; setting = "
        f"integrator × substeps), evaluated with its mean throttle on the same "
        f"{info['episodes']} held-out episodes (seed {suite.EVAL_SEED:,} + i) on the reference "
        f"physics {REFERENCE.name} and on its own training physics. Checkpoint chosen on "
        f"{suite.VALIDATION_EPISODES} validation episodes of the training physics. Mean ± std "
        "over seeds. Training time: wall time of the run on a shared 2-core machine (CPU "
        "time of the process beside it). env-steps/s: the vector env alone, "
        f"{N_ENVS} sub-envs (as in training), CPU time, measured in one run; its cost "
        f"relative to rk4x1 also at {LARGE_N_ENVS} sub-envs, where the physics dominates; env "
        f"CPU per run: the CPU time those env steps take over {info['timesteps']:,} timesteps "
        "(the rest of training is the network). Open-loop drift: the PD's thrust sequence "
        f"from {data['open_loop_divergence']['episodes']} reference episodes replayed on the "
        "setting; largest difference of the attitude error over the first 30 s, median "
        "(max) over episodes: the model error a policy meets, before feedback corrects it. "
        "PD/bang-bang own: the scripted baselines on "
        "the same episodes of that setting's physics (success / propellant).", "",
        f"| setting | env-steps/s | env cost vs rk4x1 ({N_ENVS} / {LARGE_N_ENVS} envs) | "
        "env CPU per run (s) | open-loop drift, 30 s (deg) | seeds | "
        "success on reference | "
        "success on own physics | fuel on reference (g) | settle median on reference (s) | "
        "training wall (min) | training CPU (min) | PD own | bang-bang own |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in data["rows"]:
        sps = "—" if row["env_steps_per_s"] is None else f"{row['env_steps_per_s']:,.0f}"
        cost = "—" if row["env_cost_vs_default"] is None else (
            f"{row['env_cost_vs_default']:.2f}× / {row['env_cost_vs_default_large']:.2f}×")
        env_s = "—" if row["env_cpu_s_per_run"] is None else f"{row['env_cpu_s_per_run']:.1f}"
        pd, bb = row["baselines_own"]["pd"], row["baselines_own"]["bangbang"]
        lines.append(
            f"| {row['setting']} | {sps} | {cost} | {env_s} | {_drift(row)} | "
            f"{len(row['seeds'])} | "
            f"**{_pct(row['reference']['success_rate'])}** | {_pct(row['own']['success_rate'])}"
            f" | {_num(row['reference']['fuel_g'], '.2f')} | "
            f"{_num(row['reference']['settle_median_s'], '.1f')} | "
            f"{_num(row['train_wall_time_s'], '.1f', 1 / 60)} | "
            f"{_num(row['train_cpu_time_s'], '.1f', 1 / 60)} | "
            f"{100 * pd['success_rate']:.1f} % / {pd['fuel_g']:.2f} g | "
            f"{100 * bb['success_rate']:.1f} % / {bb['fuel_g']:.2f} g |")
    lines += ["", "Scripted baselines on the reference physics: " + "; ".join(
        f"{b} {100 * ref[b]['success_rate']:.1f} %, {1000 * ref[b]['fuel']['mean']:.2f} g, "
        f"settle median {ref[b]['settle_time_s']['median']:.1f} s" for b in BASELINES) + ".",
        "", f"Reference converged ({REFERENCE.name} vs {CHECK.name}, every baseline and "
        f"policy): {'yes' if check['converged'] else '**NO**'} (largest success difference "
        f"{100 * check['max_success_diff']:.2f} points, largest fuel difference "
        f"{100 * check['max_fuel_rel_diff']:.3f} %)."]
    gap = data["gap_own_minus_reference"]
    if gap["n"]:
        lines += ["", f"Success on own physics minus success on the reference, over all "
                  f"{gap['n']} policies: mean {100 * gap['mean']:+.2f} points, largest "
                  f"{100 * gap['largest_abs']:.1f} points."]
    if data["missing"]:
        lines += ["", "**Missing runs** (not run or not finished): "
                  + ", ".join(data["missing"]) + "."]
    return "\n".join(lines) + "\n"


def _training_time(row: dict) -> tuple[dict, str]:
    """The x axis: CPU time of training where every run has it (a quieter measure on a shared
    machine than wall time), else wall time."""
    cpu = row["train_cpu_time_s"]
    if cpu["n"] and cpu["n"] == len(row["seeds"]):
        return cpu, "CPU"
    return row["train_wall_time_s"], "wall"


def plot(data: dict, path: Path) -> Path:
    """Success on the reference (filled) and on the training physics (open) against training
    time, one point per setting (mean over seeds; bars: min to max)."""
    from benchmarks.common import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.8))
    kinds = set()
    for row in data["rows"]:
        (time_s, kind), ref = _training_time(row), row["reference"]["success_rate"]
        own = row["own"]["success_rate"]
        if time_s["mean"] is None:
            continue
        kinds.add(kind)
        x = time_s["mean"] / 60
        (pt,) = ax.plot([x], [100 * ref["mean"]], "o", ms=7, label=row["setting"])
        ax.errorbar([x], [100 * ref["mean"]], yerr=[[100 * (ref["mean"] - ref["min"])],
                                                    [100 * (ref["max"] - ref["mean"])]],
                    color=pt.get_color(), capsize=3, lw=1)
        ax.plot([x, x], [100 * own["mean"], 100 * ref["mean"]], color=pt.get_color(), lw=0.8,
                ls=":")
        ax.plot([x], [100 * own["mean"]], "o", mfc="none", color=pt.get_color(), ms=7)
    ref_base = data["baselines"][REFERENCE.name]
    for b, ls in zip(BASELINES, ("--", "-."), strict=True):
        ax.axhline(100 * ref_base[b]["success_rate"], color="k", ls=ls, lw=0.8,
                   label=f"{b} on reference")
    what = " or ".join(sorted(kinds)) or "CPU"
    ax.set_xlabel(f"PPO training time, {what} (min, 1 torch thread, shared 2-core machine)")
    ax.set_ylabel(f"success on reference physics {REFERENCE.name} (%)")
    ax.set_title(f"PPO on {SCENE}, {data['info']['timesteps']:,} steps: trained on each "
                 "setting, tested on the reference\n(filled: mean over seeds on the reference, "
                 "bars min to max; open: mean on its own physics)", fontsize=8)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def aggregate(settings: list[Setting], runs: list[dict], out: Path, *, episodes: int,
              timesteps: int, seeds: list[int], speed_rounds: int = 7) -> dict:
    """Baselines, reference check and env speed, then fidelity.json/.md/.png in ``out``."""
    from benchmarks.common import machine

    table = baselines(list(dict.fromkeys([*settings, REFERENCE, CHECK])), episodes)
    timed = list(dict.fromkeys([*settings, DEFAULT]))
    speed = env_speed(timed, rounds=speed_rounds)
    large = env_speed(timed, num_envs=LARGE_N_ENVS, rounds=speed_rounds, steps=2)
    drift = open_loop_divergence(settings, episodes=min(episodes, 100))
    have = {(r["name"], r["seed"]) for r in runs}
    missing = [f"{s.name} seed {k}" for k in seeds for s in settings if (s.name, k) not in have]
    rows = setting_rows(settings, runs, table, speed, timesteps, large)
    for row in rows:
        row["open_loop_divergence"] = drift["settings"][row["setting"]]
    gaps = [r["own"]["success_rate"] - r["reference"]["success_rate"] for r in runs]
    data = {"version": RESULT_VERSION, "benchmark": "fidelity", "machine": machine(),
            "gap_own_minus_reference": {**_stats(gaps),
                                        "largest_abs": max(map(abs, gaps), default=None)},
            "info": {"scene": SCENE, "episodes": episodes, "eval_seed": suite.EVAL_SEED,
                     "timesteps": timesteps, "seeds": seeds, "n_envs": N_ENVS,
                     "reference": REFERENCE.name, "check": CHECK.name},
            "reference_check": reference_check(table, runs),
            "rows": rows,
            "env_steps_per_s": speed, "env_steps_per_s_large": large,
            "open_loop_divergence": drift,
            "baselines": table, "missing": missing,
            "runs": [{k: r[k] for k in ("name", "seed", "setting", "timesteps",
                                        "selected_timesteps", "training", "validation_curve",
                                        "reference", "check", "own", "final_reference",
                                        "final_own")} for r in runs]}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "fidelity.json", data)
    (out / "fidelity.md").write_text(format_markdown(data))
    plot(data, out / "fidelity.png")
    return data


# --- command line -----------------------------------------------------------------------------

def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m benchmarks.fidelity",
                                description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true",
                   help=f"smoke form: {[s.name for s in QUICK['settings']]}, "
                   f"{QUICK['timesteps']} timesteps, {QUICK['episodes']} episodes")
    p.add_argument("--out", default=None,
                   help="results folder (default benchmarks/results/fidelity; "
                   "runs/fidelity-quick with --quick)")
    p.add_argument("--runs-dir", default=None,
                   help="training folders (default runs/fidelity; OUT/train with --quick)")
    p.add_argument("--settings", nargs="+", type=parse_setting, default=None,
                   help="e.g. euler_seedx1 rk4x4 (default: every setting of SETTINGS)")
    p.add_argument("--seeds", type=int, default=None, help="seeds 0..N-1 (default 1)")
    p.add_argument("--timesteps", type=int, default=None, help=f"default {TIMESTEPS:,}")
    p.add_argument("--episodes", type=int, default=None,
                   help=f"held-out episodes (default {suite.EVAL_EPISODES})")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--aggregate-only", action="store_true",
                   help="write the tables from every finished run present in OUT (any seed; "
                   "--seeds N only sets which are listed as missing); train nothing")
    return p.parse_args(argv)


def main(argv=None) -> dict:
    args = parse_args(argv)
    quick = QUICK if args.quick else {}
    from benchmarks.common import RESULTS

    out = Path(args.out or ("runs/fidelity-quick" if args.quick else RESULTS / "fidelity"))
    runs_dir = Path(args.runs_dir or (out / "train" if args.quick else "runs/fidelity"))
    settings = list(args.settings or quick.get("settings", SETTINGS))
    seeds = list(range(args.seeds if args.seeds is not None else quick.get("seeds", 1)))
    timesteps = args.timesteps or quick.get("timesteps", TIMESTEPS)
    episodes = args.episodes or quick.get("episodes", suite.EVAL_EPISODES)
    kw = {"out": out, "runs_dir": runs_dir, "timesteps": timesteps, "episodes": episodes,
          "threads": args.threads}
    runs = []
    for seed in [] if args.aggregate_only else seeds:  # seed-major: covers every setting once
        for s in settings:
            started = time.perf_counter()
            print(f"{s.name} seed {seed}: training {timesteps:,} timesteps", flush=True)
            r = run_setting(s, seed, **kw)
            print(f"    success on reference {100 * r['reference']['success_rate']:.1f} %, "
                  f"own {100 * r['own']['success_rate']:.1f} % "
                  f"({time.perf_counter() - started:.0f} s)", flush=True)
            runs.append(r)
    if args.aggregate_only:
        runs = collect(out, settings, timesteps, episodes)
    data = aggregate(settings, runs, out, episodes=episodes, timesteps=timesteps, seeds=seeds,
                     speed_rounds=3 if args.quick else 7)
    print((out / "fidelity.md").read_text())
    return data


if __name__ == "__main__":
    main()
