"""The Ray RLlib back end of the training engine: PPO on RLlib's new API stack
(``rbenv train --engine rllib``), in the same run folder as the SB3 back end.

Each env runner steps the native rbenv vector env (``num_envs_per_env_runner`` satellites in
one NumPy call) through Gymnasium's vector entry point. Env runners are separate processes in
which the plain env id is unknown until ``rbenv`` is imported, so the env is registered with
Tune as a creator that imports rbenv itself (:func:`make_env`). Rewards are scaled in each
runner by a running estimate of the return's spread (Gymnasium's ``NormalizeReward``, as SB3's
VecNormalize does for ``rbenv train``); evaluation and reports use the raw env.

``env_runners=0`` samples in the driver process; ``N`` runs N runner processes on the local Ray
instance (all cores) or, with ``address``, on a running cluster. The run folder is the engine's
(:mod:`rbenv.agents.training.engine`), with RLlib's own checkpoints::

    config.json             resolved RLlibConfig ("engine": "rllib")
    checkpoints/            ckpt_<steps>/ (RLlib's own checkpoint folders), latest.json
    policy/                 the final RLModule; load with RLlibPolicy(run folder, trust_pickle=True)

A checkpoint folder is written under a temporary name and renamed, and latest.json moves only
after that, so a killed run resumes (``resume=True``) from its last complete checkpoint.
Importing this module needs no Ray; training does (the ray extra).
"""

from __future__ import annotations

import argparse
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import gymnasium as gym
import numpy as np
from rbenv.agents.policies import runfolder
from rbenv.agents.policies.rllib import MODULE_PATH, RLLIB_HINT, RLlibPolicy, latest
from rbenv.agents.settings import rllib as _rllib
from rbenv.agents.training import engine, flags
from rbenv.agents.training.config import (
    Engine,
    RunConfig,
    SessionOptions,
    apply_run_defaults,
    shipped_settings,
)
from rbenv.agents.training.engine import add_run_arguments
from rbenv.agents.training.ray_cluster import connect, require_ray, shutdown
from rbenv.agents.training.report import Trained, write_report
from rbenv.core.errors import InvalidParameterError

import rbenv

ENV_NAME = "rbenv-vector"  # the name the creator is registered under, in every Ray process
# RLlib PPO settings: the id's shipped PPO settings (rbenv.agents.settings, the one
# source) in RLlib's names (rbenv.agents.settings.rllib), so both engines train with one set.


@dataclass
class RLlibConfig(RunConfig):
    """A run of the RLlib back end; saved as ``config.json``."""

    # Folders written before this engine took the recipe's env options resume without them.
    LEGACY_DEFAULTS: ClassVar[dict] = {**RunConfig.LEGACY_DEFAULTS, "recipe_env_kwargs": False}

    engine: Engine = "rllib"
    env_runners: int = 0
    """RLlib env runner processes; 0 samples in the driver."""
    envs_per_runner: int = 64
    """Satellites in each runner's native vector env."""
    model: dict = field(default_factory=dict)
    """RLlib DefaultModelConfig options as a JSON object, over the shipped PPO network's."""
    log_std_init: float | None = None
    """Initial log standard deviation of the Gaussian policy (None: the shipped PPO's)."""
    normalize_reward: bool = True
    """Scale rewards by the running spread of the return (as SB3's VecNormalize does)."""

    @property
    def n_envs(self) -> int:
        """Satellites stepped in parallel over all runners."""
        return max(self.env_runners, 1) * self.envs_per_runner

    def default_out(self) -> str:
        return f"runs/rllib-{self.algo}-{self.scene}-seed{self.seed}"

    def resolve(self) -> RLlibConfig:
        if self.algo != "ppo":
            raise InvalidParameterError(f"algo must be 'ppo' with engine rllib, got "
                                        f"{self.algo!r}")
        # The task's PPO recipe for this engine and scene (a named error for an id without
        # one), its env options under the caller's.
        shipped = shipped_settings(self.algo, self.env_id, self.engine, self.scene)
        if self.timesteps is None:
            self.timesteps = shipped["n_timesteps"]
        if self.log_std_init is None:
            self.log_std_init = _rllib.ppo_log_std_init(shipped)
        apply_run_defaults(self, shipped)  # the periodic evaluation's (no stop_success here)
        self.check_counts(("envs_per_runner",))
        self.check_counts(("env_runners",), minimum=0)
        self.check_dicts(("model",))
        super().resolve()
        self.apply_recipe_env_kwargs(shipped)
        self.hyperparams = {**_rllib.ppo(shipped), **self.hyperparams}
        self.model = {**_rllib.ppo_model(shipped), **self.model}
        return self


# --- the env inside Ray processes --------------------------------------------------------------

def make_env(config: dict):
    """Env creator for Ray: imports rbenv (registering its ids) in whichever process runs it.

    RLlib calls it with ``num_envs`` for the vector entry point (the native vector env) and
    without it for a single env; ``env_id`` and the remaining keys are ``gym.make`` options.
    """
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
    from ray import tune  # the ray extra

    tune.register_env(ENV_NAME, make_env)


def algorithm_config(cfg: RLlibConfig):
    """The RLlib ``PPOConfig`` of a run."""
    from ray.rllib.algorithms.ppo import PPOConfig  # the ray extra
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
    engine.point_latest(directory, steps, wall_time_s, checkpoint=final.name)
    return final


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


# --- the back end --------------------------------------------------------------------------------

@dataclass(frozen=True)
class RLlibSession(SessionOptions):
    """The RLlib back end (:class:`rbenv.agents.training.engine.Backend`) with the options of
    one training session."""

    packages: ClassVar[tuple[str, ...]] = ("ray", "torch")

    def check(self, cfg: RLlibConfig) -> None:
        """Nothing beyond :meth:`RLlibConfig.resolve`: RLlib checks its own settings when it
        builds the algorithm."""

    def fit(self, cfg: RLlibConfig, out: Path, resume: bool) -> dict:
        started = connect(self.address, feature="--engine rllib")
        try:
            return fit(cfg, out, resume, self.progress)
        finally:
            shutdown(started)

    def report(self, out: Path, cfg: RLlibConfig, summary: dict) -> Path:
        runners = (f"{cfg.env_runners} env runners × {cfg.envs_per_runner} envs"
                   if cfg.env_runners else f"{cfg.envs_per_runner} envs sampled in the driver")
        # The run this process just wrote: its pickles are our own.
        return write_report(out, cfg, summary, Trained(
            RLlibPolicy(out, trust_pickle=True), name="ppo (RLlib, trained)",
            title=f"PPO (Ray RLlib) on `{cfg.scene}`", setup=runners,
            load=f"`rbenv.agents.policies.load_policy({str(out)!r}, trust_pickle=True)` "
                 "(SB3-style `predict`; RLlib checkpoints are pickles)"))

    def load_hint(self, out: Path) -> str:
        return (f"load the policy with rbenv.agents.policies.load_policy({str(out)!r}, "
                "trust_pickle=True) (RLlib checkpoints are pickles)")


def train(cfg: RLlibConfig, *, resume: bool = False, force: bool = False,
          address: str | None = None, report: bool = True, progress: bool = True,
          trust_pickle: bool = False) -> Path:
    """Train (or resume) PPO with RLlib into ``cfg.out``; returns the run folder.

    ``address``: None for a private Ray instance on this machine, ``"auto"`` or ``HOST:PORT``
    for a running cluster (env runners are placed on its nodes). ``resume`` restores RLlib's
    own checkpoint, which is pickle-based, so it needs ``trust_pickle=True``
    (``--trust-pickle``); without it the resume is refused before anything is loaded.
    """
    session = RLlibSession(address=address, progress=progress, trust_pickle=trust_pickle)
    return run(cfg, session, resume=resume, force=force, report=report)


def run(cfg: RLlibConfig, session: RLlibSession, *, resume: bool = False, force: bool = False,
        report: bool = True, dry_run: bool = False) -> Path:
    """:func:`train` with the session's options in one object (the command line's way)."""
    if resume and not session.trust_pickle:
        runfolder.require_trust(Path(cfg.out or cfg.default_out()) / runfolder.CHECKPOINTS,
                                "an RLlib run's checkpoint folder (RLlib pickles its state)",
                                False, RLLIB_HINT)
    require_ray("--engine rllib")
    return engine.run(cfg, session, resume=resume, force=force, report=report, dry_run=dry_run)


def fit(cfg: RLlibConfig, out: Path, resume: bool, progress: bool) -> dict:
    """Train under the engine's lock; copy the final module to policy/; return the summary."""
    import torch  # the ray extra installs it

    torch.set_num_threads(cfg.threads)
    register_env()
    algo = algorithm_config(cfg).build_algo()
    ckpt_dir = out / runfolder.CHECKPOINTS
    found = latest(ckpt_dir) if resume else None
    done, clock = 0, engine.WallClock()
    if found is not None:
        done, folder, before = found
        clock = engine.WallClock(before)
        algo.restore_from_path(str(folder.resolve()))
        print(f"resuming rllib ppo in {str(out)!r} from {done} timesteps ({folder.name})")
    else:
        set_log_std(algo, cfg.log_std_init)
    start_steps = done
    try:
        done = _learn(algo, cfg, out, done, clock, progress)
    finally:
        algo.stop()
    _publish_module(out, latest(ckpt_dir)[1])
    return {**engine.session_summary(cfg, done, start_steps, clock),
            "env_runners": cfg.env_runners, "envs_per_runner": cfg.envs_per_runner,
            "trained": done > 0}


def _learn(algo, cfg: RLlibConfig, out: Path, done: int, clock: engine.WallClock,
           progress: bool) -> int:
    """Train to ``cfg.timesteps`` with periodic evaluation and checkpoints; the steps done."""
    ckpt_dir, log = out / runfolder.CHECKPOINTS, out / runfolder.EVAL_LOG
    history = engine.load_eval_history(log, done)
    start_steps = done
    next_ckpt = engine.next_multiple(done, cfg.checkpoint_every)
    next_eval = engine.next_multiple(done, cfg.eval_every)
    while done < cfg.timesteps:
        result = algo.train()
        done += int(result["env_runners"]["num_env_steps_sampled"])
        if progress:
            ret = result["env_runners"].get("episode_return_mean", float("nan"))
            print(f"  {done:>10,} steps  {clock.total():7.1f} s  "
                  f"{(done - start_steps) / clock.session():7.0f} steps/s  "
                  f"return {ret:8.2f}", flush=True)
        if done >= next_eval or done >= cfg.timesteps:
            outcome = rollout(RLlibPolicy.live(algo), cfg, min(cfg.eval_episodes, 50),
                              cfg.seed + 10_000)
            engine.record_evaluation(log, history, done, outcome)
            next_eval = engine.next_multiple(done, cfg.eval_every)
            if progress:
                print(f"  eval at {done:,}: success {np.mean(outcome['successes']):.1%}")
        if done >= next_ckpt or done >= cfg.timesteps:
            save_checkpoint(algo, ckpt_dir, done, clock.total())
            next_ckpt = engine.next_multiple(done, cfg.checkpoint_every)
    final = latest(ckpt_dir)
    if final is None or final[0] != done:
        save_checkpoint(algo, ckpt_dir, done, clock.total())
    return done


def _publish_module(out: Path, checkpoint: Path) -> None:
    """Copy the final checkpoint's RLModule to ``out/policy`` (via a temporary folder)."""
    tmp = out / f".{runfolder.POLICY_DIR}.tmpdir"
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(checkpoint / MODULE_PATH, tmp)
    shutil.rmtree(out / runfolder.POLICY_DIR, ignore_errors=True)
    tmp.rename(out / runfolder.POLICY_DIR)


def set_log_std(algo, value: float) -> None:
    """Set the policy's free log std parameter in the learner, then sync it to the runners."""
    import torch  # the ray extra installs it

    def fill(learner):
        for name, param in learner.module["default_policy"].named_parameters():
            if name.endswith("log_std"):
                with torch.no_grad():
                    param.fill_(float(value))

    algo.learner_group.foreach_learner(fill)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group,
                                       inference_only=True, timeout_seconds=60.0)


# --- command line ---------------------------------------------------------------------------

def main(argv: list[str] | None = None) -> Path:
    """``python -m rbenv.agents.training.rllib``: the flags of ``rbenv train --engine rllib``."""
    p = argparse.ArgumentParser(prog="python -m rbenv.agents.training.rllib",
                                description=__doc__.split("\n")[0])
    flags.add_fields(p, RLlibConfig, skip=("engine",))
    flags.add_fields(p, RLlibSession, skip=RLlibSession.ignored_by("rllib"))
    add_run_arguments(p)
    args = p.parse_args(argv)
    cfg = RLlibConfig(**flags.given(args, RLlibConfig))
    return run(cfg, RLlibSession(**flags.given(args, RLlibSession)), resume=args.resume,
               force=args.force, report=not args.no_report, dry_run=args.dry_run)


if __name__ == "__main__":
    main()
