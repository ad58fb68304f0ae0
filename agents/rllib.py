"""``rbenv train --engine rllib``: PPO on Ray RLlib's new API stack, in the SB3 run folder layout.

Each env runner steps the native rbenv vector env (``num_envs_per_env_runner`` satellites in
one NumPy call) through Gymnasium's vector entry point. Env runners are separate processes in
which the plain env id is unknown until ``rbenv`` is imported, so the env is registered with
Tune as a creator that imports rbenv itself (:func:`make_env`). Rewards are scaled in each
runner by a running estimate of the return's spread (Gymnasium's ``NormalizeReward``, as SB3's
VecNormalize does for ``rbenv train``); evaluation and reports use the raw env.

``env_runners=0`` samples in the driver process; ``N`` runs N runner processes on the local Ray
instance (all cores) or, with ``address``, on a running cluster. The run folder::

    config.json             resolved RLlibConfig ("engine": "rllib")
    run.lock                held by the live training process
    checkpoints/            ckpt_<steps>/ (RLlib's own checkpoint folders), latest.json
    eval/evaluations.npz    periodic evaluations (the SB3 format), kept across resumes
    policy/                 the final RLModule; load with RLlibPolicy(run folder, trust_pickle=True)
    training.json, report.md, evaluation.json, episode.png, training_curve.png

A checkpoint folder is written under a temporary name and renamed, and latest.json moves only
after that, so a killed run resumes (``resume=True``) from its last complete checkpoint.
"""

from __future__ import annotations

import argparse
import numbers
import platform
import shutil
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from rbenv.agents import runs
from rbenv.agents.ray_cluster import connect, require_ray, shutdown
from rbenv.agents.runs import RunFolderError, atomic_write, write_json
from rbenv.core.errors import InvalidParameterError

import rbenv

ENV_NAME = "rbenv-vector"  # the name the creator is registered under, in every Ray process
POLICY_DIR = "policy"
MODULE_PATH = Path("learner_group") / "learner" / "rl_module" / "default_policy"
RLLIB_HINT = ("Every RLlib run folder holds RLlib's pickles: pass the flag for runs you or your "
              "own cluster wrote")
# RLlib PPO settings matched to `rbenv train`'s SB3 PPO: 4096 steps per update in minibatches
# of 1024, 5 epochs, the same learning rate, discount, clipping and gradient-norm limit; the
# value loss unclipped.
DEFAULT_HYPERPARAMS = {"train_batch_size_per_learner": 4096, "minibatch_size": 1024,
                       "num_epochs": 5, "lr": 5e-4, "gamma": 0.99, "lambda_": 0.95,
                       "clip_param": 0.2, "vf_clip_param": 1e6, "entropy_coeff": 0.0,
                       "grad_clip": 0.5, "grad_clip_by": "global_norm"}
# Separate policy and value networks; a state-independent log std (set to log_std_init at the
# start, SB3's -1.0): with a state-dependent one the policy learns to act through its noise and
# its mean (the deterministic policy) fails.
DEFAULT_TIMESTEPS = 2_000_000
DEFAULT_MODEL = {"fcnet_hiddens": [128, 128], "fcnet_activation": "tanh",
                 "vf_share_layers": False, "free_log_std": True}


@dataclass
class RLlibConfig:
    """Everything that defines an RLlib training run; saved as ``config.json``."""

    engine: str = "rllib"
    algo: str = "ppo"
    timesteps: int | None = None  # default DEFAULT_TIMESTEPS
    env_runners: int = 0  # runner processes; 0 samples in the driver
    envs_per_runner: int = 64  # satellites in each runner's native vector env
    seed: int = 0
    scene: str = "cubesat-12u"
    env_id: str = rbenv.ENV_ID
    out: str | None = None
    env_kwargs: dict = field(default_factory=dict)
    hyperparams: dict = field(default_factory=dict)
    model: dict = field(default_factory=dict)
    checkpoint_every: int = 200_000  # timesteps
    eval_every: int = 200_000  # timesteps
    eval_episodes: int = 100
    report_episodes: int = 500
    report_seed: int = 1_000_000
    threads: int = 1  # torch threads of the learner (the driver)
    log_std_init: float = -1.0  # initial log standard deviation of the Gaussian policy
    normalize_reward: bool = True  # scale rewards by the running spread of the return

    @property
    def n_envs(self) -> int:
        """Satellites stepped in parallel over all runners."""
        return max(self.env_runners, 1) * self.envs_per_runner

    def resolve(self) -> RLlibConfig:
        rbenv.registry.get(self.env_id)  # a named error for an id it does not hold
        if self.timesteps is None:
            self.timesteps = DEFAULT_TIMESTEPS
        if self.algo != "ppo":
            raise InvalidParameterError(f"algo must be 'ppo' with engine rllib, got "
                                        f"{self.algo!r}")
        for name in ("timesteps", "envs_per_runner", "threads", "checkpoint_every",
                     "eval_every", "eval_episodes", "report_episodes"):
            _check_count(name, getattr(self, name), minimum=1)
        _check_count("env_runners", self.env_runners, minimum=0)
        for name in ("env_kwargs", "hyperparams", "model"):
            if not isinstance(getattr(self, name), dict):
                raise InvalidParameterError(f"{name} must be a dict (a JSON object), got "
                                            f"{getattr(self, name)!r}")
        self.hyperparams = {**DEFAULT_HYPERPARAMS, **self.hyperparams}
        self.model = {**DEFAULT_MODEL, **self.model}
        self.out = self.out or f"runs/rllib-{self.algo}-{self.scene}-seed{self.seed}"
        return self


def _check_count(name: str, value, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InvalidParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")


# --- the env inside Ray processes --------------------------------------------------------------

def make_env(config: dict):
    """Env creator for Ray: imports rbenv (registering its ids) in whichever process runs it.

    RLlib calls it with ``num_envs`` for the vector entry point (the native vector env) and
    without it for a single env; ``env_id`` and the remaining keys are ``gym.make`` options.
    """
    import gymnasium as gym

    import rbenv

    options = dict(config)
    num_envs = options.pop("num_envs", None)
    env_id = options.pop("env_id", rbenv.ENV_ID)
    reward_gamma = options.pop("normalize_reward_gamma", None)
    if num_envs is None:
        return gym.make(env_id, **options)
    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        **options)
    if reward_gamma is not None:
        envs = gym.wrappers.vector.NormalizeReward(envs, gamma=reward_gamma)
    return envs


def register_env() -> None:
    from ray import tune

    tune.register_env(ENV_NAME, make_env)


def algorithm_config(cfg: RLlibConfig):
    """The RLlib ``PPOConfig`` of a run."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    env_config = {"env_id": cfg.env_id, "scene": cfg.scene, **cfg.env_kwargs}
    if cfg.normalize_reward:
        env_config["normalize_reward_gamma"] = cfg.hyperparams["gamma"]
    return (PPOConfig()
            .environment(ENV_NAME, env_config=env_config)
            .env_runners(num_env_runners=cfg.env_runners,
                         num_envs_per_env_runner=cfg.envs_per_runner,
                         gym_env_vectorize_mode="vector_entry_point")
            .training(**cfg.hyperparams)
            .rl_module(model_config=DefaultModelConfig(**cfg.model))
            .reporting(metrics_num_episodes_for_smoothing=100)
            .debugging(seed=cfg.seed, log_level="WARN"))


# --- the predict() adapter -----------------------------------------------------------------------

class RLlibPolicy:
    """A trained RLlib RLModule behind SB3's ``predict`` interface (for agents.evaluate).

    ``path``: a run folder (its final ``policy/``, else its latest checkpoint), a checkpoint
    folder ``ckpt_<N>``, or an RLModule folder. Observations are the raw env ones (the run
    adds no observation filter); deterministic actions are the Gaussian's mean, clipped.

    RLlib's checkpoint format pickles (``class_and_ctor_args.pkl``, the module state), so
    loading runs code from the folder: it is refused unless ``trust_pickle=True``
    (``rbenv evaluate --trust-pickle``).
    """

    def __init__(self, path, *, trust_pickle: bool = False):
        self.source = module_dir(Path(path))
        runs.require_trust(self.source, "an RLlib checkpoint (RLlib pickles its modules)",
                           trust_pickle, RLLIB_HINT)
        import torch
        from ray.rllib.core.rl_module.rl_module import RLModule

        self.module = RLModule.from_checkpoint(self.source)
        self.module.eval()
        self._dist = self.module.get_inference_action_dist_cls()
        space = self.module.action_space
        self.low, self.high = space.low, space.high
        self._torch = torch

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        torch = self._torch
        obs = np.asarray(observation, np.float32)
        single = obs.ndim == 1
        batch = torch.from_numpy(obs[None] if single else obs)
        with torch.no_grad():
            out = self.module.forward_inference({"obs": batch})
            dist = self._dist.from_logits(out["action_dist_inputs"])
            action = (dist.to_deterministic() if deterministic else dist).sample().numpy()
        action = np.clip(action, self.low, self.high)
        return (action[0] if single else action), state


def module_dir(path: Path) -> Path:
    """The RLModule folder of a run folder, a checkpoint folder or a module folder."""
    path = Path(path)
    if (path / runs.CONFIG).is_file():  # a run folder
        if (path / POLICY_DIR).is_dir():
            return path / POLICY_DIR
        ckpt = latest(path / runs.CHECKPOINTS)
        if ckpt is None:
            raise RunFolderError(f"run folder {str(path)!r} has no {POLICY_DIR}/ and no "
                                 "checkpoint yet")
        return ckpt[1] / MODULE_PATH
    if (path / MODULE_PATH).is_dir():
        return path / MODULE_PATH
    if (path / "module_state.pkl").is_file() or (path / "metadata.json").is_file():
        return path
    raise RunFolderError(f"{str(path)!r} is not an RLlib run folder, checkpoint or module")


# --- checkpoints ---------------------------------------------------------------------------------

def save_checkpoint(algo, directory: Path, steps: int, wall_time_s: float) -> Path:
    """``algo.save_to_path`` into ``ckpt_<steps>`` via a temporary folder; then latest.json."""
    directory.mkdir(parents=True, exist_ok=True)
    final = directory / f"ckpt_{steps}"
    tmp = directory / f".ckpt_{steps}.{time.time_ns()}.tmpdir"
    algo.save_to_path(str(tmp.resolve()))
    if final.exists():
        shutil.rmtree(final)
    tmp.rename(final)
    write_json(directory / runs.LATEST, {"timesteps": steps, "checkpoint": final.name,
                                         "wall_time_s": wall_time_s})
    return final


def latest(directory: Path) -> tuple[int, Path, float] | None:
    """``(steps, folder, wall_time_s)`` of the newest complete checkpoint, or None.

    latest.json's record first; if it is unusable, the highest ``ckpt_<N>`` on disk.
    """
    directory = Path(directory)
    try:
        info = runs.read_json(directory / runs.LATEST, "checkpoint pointer")
        folder = runs.confined(directory, info.get("checkpoint"), "checkpoint")
        if (folder / "rllib_checkpoint.json").is_file():
            return int(info["timesteps"]), folder, float(info.get("wall_time_s") or 0.0)
    except (RunFolderError, KeyError, TypeError, ValueError):
        pass
    found = sorted((int(p.name.split("_")[1]), p) for p in directory.glob("ckpt_*")
                   if p.name.split("_")[1].isdigit() and (p / "rllib_checkpoint.json").is_file())
    return (found[-1][0], found[-1][1], 0.0) if found else None


def remove_temporaries(out: Path) -> list[Path]:
    stale = list((out / runs.CHECKPOINTS).glob(".ckpt_*.tmpdir"))
    for p in stale:
        shutil.rmtree(p, ignore_errors=True)
    return stale + runs.remove_temporaries(out)


# --- periodic evaluation -------------------------------------------------------------------------

def rollout(policy, cfg: RLlibConfig, episodes: int, seed: int) -> dict:
    """Returns, lengths and successes of ``episodes`` seeded episodes (deterministic policy)."""
    envs = gym.make_vec(cfg.env_id, num_envs=episodes, vectorization_mode="vector_entry_point",
                        scene=cfg.scene, **cfg.env_kwargs)
    obs, _ = envs.reset(seed=seed)
    alive = np.ones(episodes, bool)
    returns, lengths = np.zeros(episodes), np.zeros(episodes, int)
    success = np.zeros(episodes, bool)
    while alive.any():
        action, _ = policy.predict(obs)
        obs, reward, term, trunc, info = envs.step(action)
        returns[alive] += reward[alive]
        lengths[alive] += 1
        done = (term | trunc) & alive
        success[done] = np.asarray(info["is_success"])[done]
        alive &= ~done
    envs.close()
    return {"results": returns.tolist(), "ep_lengths": lengths.tolist(),
            "successes": success.tolist()}


def record_evaluation(log: Path, history: dict, steps: int, outcome: dict) -> None:
    history["timesteps"].append(steps)
    for key in ("results", "ep_lengths", "successes"):
        history[key].append(outcome[key])
    log.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(log, lambda p: _savez(p, history))


def _savez(path: Path, history: dict) -> None:
    with open(path, "wb") as f:
        np.savez(f, **{k: np.asarray(v) for k, v in history.items()})


# --- the run -------------------------------------------------------------------------------------

def _versions() -> dict:
    import ray
    import torch

    return {"python": platform.python_version(), "numpy": np.__version__,
            "gymnasium": gym.__version__, "ray": ray.__version__, "torch": torch.__version__}


def resumed_config(out: Path, timesteps: int | None) -> RLlibConfig:
    saved = runs.read_config(out)
    if saved.get("engine") != "rllib":
        raise RunFolderError(f"run folder {str(out)!r} was not trained with --engine rllib "
                             f"(its config.json has engine {saved.get('engine', 'sb3')!r})")
    known = RLlibConfig.__dataclass_fields__
    cfg = RLlibConfig(**{k: v for k, v in saved.items() if k in known})
    cfg.out, cfg.timesteps = str(out), timesteps or cfg.timesteps
    return cfg.resolve()


def train(cfg: RLlibConfig, *, resume: bool = False, force: bool = False,
          address: str | None = None, report: bool = True, progress: bool = True,
          trust_pickle: bool = False) -> Path:
    """Train (or resume) PPO with RLlib into ``cfg.out``; returns the run folder.

    ``address``: None for a private Ray instance on this machine, ``"auto"`` or ``HOST:PORT``
    for a running cluster (env runners are placed on its nodes). ``resume`` restores RLlib's
    own checkpoint, which is pickle-based, so it needs ``trust_pickle=True``
    (``--trust-pickle``); without it the resume is refused before anything is loaded.
    """
    if resume and not trust_pickle:
        runs.require_trust(Path(cfg.out) / runs.CHECKPOINTS,
                           "an RLlib run's checkpoint folder (RLlib pickles its state)", False,
                           RLLIB_HINT)
    require_ray("--engine rllib")
    cfg = resumed_config(Path(cfg.out), cfg.timesteps) if resume else cfg.resolve()
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    with runs.RunLock(out):
        if resume:
            for p in remove_temporaries(out):
                print(f"removed {str(p)!r}, left by a killed writer")
            finished = runs.read_json(out / runs.SUMMARY, "summary") if (
                out / runs.SUMMARY).is_file() and (out / POLICY_DIR).is_dir() else None
            if finished and int(finished.get("timesteps", 0)) >= cfg.timesteps:
                print(f"run {str(out)!r} is already finished ({finished['timesteps']} "
                      "timesteps); nothing to do")
                return out
        else:
            runs.prepare_new_run(out, force)
            shutil.rmtree(out / POLICY_DIR, ignore_errors=True)
            write_json(out / runs.CONFIG, {**asdict(cfg), "versions": _versions()})
        started = connect(address, feature="--engine rllib")
        try:
            summary = _train_locked(cfg, out, resume, progress)
        finally:
            shutdown(started)
    if report:
        write_report(out, cfg, summary)
    print(f"run saved in {out}; load the policy with agents.rllib.RLlibPolicy({str(out)!r}, "
          "trust_pickle=True) (RLlib checkpoints are pickles)")
    return out


def _train_locked(cfg: RLlibConfig, out: Path, resume: bool, progress: bool) -> dict:
    import torch

    torch.set_num_threads(cfg.threads)
    register_env()
    algo = algorithm_config(cfg).build_algo()
    ckpt_dir, log = out / runs.CHECKPOINTS, out / runs.EVAL_LOG
    found = latest(ckpt_dir) if resume else None
    done, before = 0, 0.0
    if found is not None:
        done, folder, before = found
        algo.restore_from_path(str(folder.resolve()))
        print(f"resuming rllib ppo in {str(out)!r} from {done} timesteps ({folder.name})")
    else:
        set_log_std(algo, cfg.log_std_init)
    from rbenv.agents.train import load_eval_history

    history = load_eval_history(log, done)
    start, start_steps = time.perf_counter(), done
    next_ckpt = (done // cfg.checkpoint_every + 1) * cfg.checkpoint_every
    next_eval = (done // cfg.eval_every + 1) * cfg.eval_every
    try:
        while done < cfg.timesteps:
            result = algo.train()
            done += int(result["env_runners"]["num_env_steps_sampled"])
            wall = before + time.perf_counter() - start
            if progress:
                ret = result["env_runners"].get("episode_return_mean", float("nan"))
                print(f"  {done:>10,} steps  {wall:7.1f} s  "
                      f"{(done - start_steps) / (time.perf_counter() - start):7.0f} steps/s  "
                      f"return {ret:8.2f}", flush=True)
            if done >= next_eval or done >= cfg.timesteps:
                outcome = rollout(_LivePolicy(algo), cfg, min(cfg.eval_episodes, 50),
                                  cfg.seed + 10_000)
                record_evaluation(log, history, done, outcome)
                next_eval = (done // cfg.eval_every + 1) * cfg.eval_every
                if progress:
                    print(f"  eval at {done:,}: success {np.mean(outcome['successes']):.1%}")
            if done >= next_ckpt or done >= cfg.timesteps:
                save_checkpoint(algo, ckpt_dir, done, wall)
                next_ckpt = (done // cfg.checkpoint_every + 1) * cfg.checkpoint_every
        final = latest(ckpt_dir)
        if final is None or final[0] != done:
            save_checkpoint(algo, ckpt_dir, done, before + time.perf_counter() - start)
            final = latest(ckpt_dir)
    finally:
        algo.stop()
    session = time.perf_counter() - start
    tmp = out / f".{POLICY_DIR}.tmpdir"
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(final[1] / MODULE_PATH, tmp)
    shutil.rmtree(out / POLICY_DIR, ignore_errors=True)
    tmp.rename(out / POLICY_DIR)
    summary = {"engine": "rllib", "timesteps": done, "wall_time_s": before + session,
               "session_wall_time_s": session,
               "session_steps_per_s": (done - start_steps) / max(session, 1e-9),
               "resumed_from": start_steps or None, "threads": cfg.threads,
               "env_runners": cfg.env_runners, "envs_per_runner": cfg.envs_per_runner,
               "trained": done > 0}
    write_json(out / runs.SUMMARY, summary)
    return summary


def set_log_std(algo, value: float) -> None:
    """Set the policy's free log std parameter in the learner, then sync it to the runners."""
    import torch

    def fill(learner):
        for name, param in learner.module["default_policy"].named_parameters():
            if name.endswith("log_std"):
                with torch.no_grad():
                    param.fill_(float(value))

    algo.learner_group.foreach_learner(fill)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group,
                                       inference_only=True, timeout_seconds=60.0)


class _LivePolicy(RLlibPolicy):
    """The algorithm's current module behind ``predict`` (periodic evaluation)."""

    def __init__(self, algo):
        import torch

        self.module = algo.get_module()
        self._dist = self.module.get_inference_action_dist_cls()
        space = self.module.action_space
        self.low, self.high = space.low, space.high
        self._torch, self.source = torch, "live"


# --- report ---------------------------------------------------------------------------------

def write_report(out: Path, cfg: RLlibConfig, summary: dict) -> Path:
    """The trained policy and the task's scripted baselines on the same seeded episodes."""
    from rbenv.agents.controllers import applicable_baselines
    from rbenv.agents.evaluate import evaluate, format_table, plot_episodes
    from rbenv.agents.evaluate import write_json as write_results
    from rbenv.agents.report import finish_report, plot_training_curve

    kwargs = {"episodes": cfg.report_episodes, "seed": cfg.report_seed, "scene": cfg.scene,
              "env_kwargs": cfg.env_kwargs, "env_id": cfg.env_id}
    # The run this process just wrote: its pickles are our own.
    results = [evaluate(RLlibPolicy(out, trust_pickle=True), name="ppo (RLlib, trained)",
                        **kwargs),
               *(evaluate(name, **kwargs) for name in applicable_baselines(
                   cfg.env_id, cfg.scene, cfg.env_kwargs))]
    table = format_table(results)
    plot_episodes(results, out / "episode.png")
    curve = plot_training_curve(out, out / "training_curve.png")
    write_results(results, out / "evaluation.json")
    runners = (f"{cfg.env_runners} env runners × {cfg.envs_per_runner} envs" if cfg.env_runners
               else f"{cfg.envs_per_runner} envs sampled in the driver")
    lines = [
        f"# Training report: PPO (Ray RLlib) on `{cfg.scene}`",
        "",
        f"- timesteps: {summary['timesteps']:,}; wall time: {summary['wall_time_s'] / 60:.1f} "
        f"min ({runners}, seed {cfg.seed})"
        + (f"; resumed from {summary['resumed_from']:,}" if summary.get("resumed_from") else ""),
        f"- evaluation: {cfg.report_episodes} episodes seeded from {cfg.report_seed}, the same "
        "initial states for every policy",
        f"- load the policy with `rbenv.agents.rllib.RLlibPolicy({str(out)!r}, trust_pickle=True)` "
        "(SB3-style `predict`; RLlib checkpoints are pickles)",
    ]
    return finish_report(out, lines, table, curve)


# --- command line ---------------------------------------------------------------------------

def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The flags of ``rbenv train --engine rllib`` that the SB3 path lacks."""
    p.add_argument("--env-runners", type=int, default=0,
                   help="RLlib env runner processes (0: sample in the driver)")
    p.add_argument("--envs-per-runner", type=int, default=64,
                   help="satellites in each runner's native vector env")
    p.add_argument("--address", default=None,
                   help="a running Ray cluster: 'auto' (started on this machine with ray "
                        "start) or HOST:PORT of its head; default: a private Ray on 127.0.0.1")
    return p


def config_from_args(args) -> RLlibConfig:
    return RLlibConfig(algo=getattr(args, "algo", "ppo"), timesteps=args.timesteps,
                       env_runners=args.env_runners, envs_per_runner=args.envs_per_runner,
                       seed=args.seed, scene=args.scene, env_id=getattr(args, "env_id", None)
                       or rbenv.ENV_ID, out=args.out,
                       env_kwargs=args.env_kwargs, hyperparams=args.hyperparams,
                       checkpoint_every=args.checkpoint_every, eval_every=args.eval_every,
                       threads=args.threads or 1)


def train_from_args(args) -> Path:
    """``rbenv train --engine rllib``: the train command's arguments plus add_arguments'."""
    cfg = config_from_args(args)
    return train(cfg, resume=args.resume, force=args.force, address=args.address,
                 report=not args.no_report, progress=not getattr(args, "no_progress", False),
                 trust_pickle=getattr(args, "trust_pickle", False))


def main(argv: list[str] | None = None) -> Path:
    """``python -m rbenv.agents.rllib``: the same flags as ``rbenv train --engine rllib``."""
    import json

    p = argparse.ArgumentParser(prog="python -m rbenv.agents.rllib",
                                description=__doc__.split("\n")[0])
    p.add_argument("--timesteps", type=int, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scene", default="cubesat-12u")
    p.add_argument("--env-id", default=rbenv.ENV_ID)
    p.add_argument("--out", default=None)
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true")
    mode.add_argument("--force", action="store_true")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--checkpoint-every", type=int, default=200_000)
    p.add_argument("--eval-every", type=int, default=200_000)
    p.add_argument("--hyperparams", type=json.loads, default={})
    p.add_argument("--env-kwargs", type=json.loads, default={})
    p.add_argument("--report-episodes", type=int, default=500)
    p.add_argument("--no-report", action="store_true")
    p.add_argument("--trust-pickle", action="store_true",
                   help="let --resume load RLlib's pickle-based checkpoint")
    add_arguments(p)
    args = p.parse_args(argv)
    cfg = config_from_args(args)
    cfg.report_episodes = args.report_episodes
    return train(cfg, resume=args.resume, force=args.force, address=args.address,
                 report=not args.no_report, trust_pickle=args.trust_pickle)


if __name__ == "__main__":
    main()
