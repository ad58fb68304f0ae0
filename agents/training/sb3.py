"""The Stable-Baselines3 back end of the training engine: PPO, SAC, TD3, TQC or CrossQ on the
native vector env (``rbenv train``). Settings come from the training settings
(:mod:`rbenv.agents.settings`, RL Zoo's format; :class:`rbenv.agents.training.config.TrainConfig`).
With ``--engine sbx`` (:class:`SBXSession`) the same training runs SBX's SAC or TD3, in JAX (the
sbx extra).

The run folder, its lock, resume, summary and report are the engine's
(:mod:`rbenv.agents.training.engine`); this module builds the model, trains it with SB3's
callbacks, and writes and reads its checkpoints (pickle-free, :mod:`rbenv.agents.policies.weights`).
Importing it needs the train extra (SB3, torch, tqdm).

Training is reproducible given the seed, the torch thread count (``threads``, default 1, which
is also the fastest for these small MLPs) and the CPU kind.
"""

from __future__ import annotations

import copy
import inspect
import os
import shutil
import sys
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import ClassVar

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode
from rbenv.agents.policies import activations, runfolder, weights
from rbenv.agents.policies.runfolder import RunFolderError, atomic_write
from rbenv.agents.policies.sb3 import (
    RunPolicy,
    SB3Policy,
    check_model_file,
    load_model,
    load_stats,
)
from rbenv.agents.training import engine
from rbenv.agents.training.config import SessionOptions, TrainConfig
from rbenv.agents.training.report import Trained, write_report
from rbenv.agents.training.sb3_vec_env import SB3VecEnv
from rbenv.core.errors import InvalidParameterError
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.logger import configure
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize, sync_envs_normalization
from tqdm import tqdm

from rbenv.satellite import usage


@dataclass(frozen=True)
class SB3Session(SessionOptions):
    """The SB3 back end (:class:`rbenv.agents.training.engine.Backend`) with the options of one
    training session (``trust_pickle``: a resume may unpickle the checkpoints of a run folder
    written before rbenv's pickle-free format; never needed for runs written now, which hold no
    pickle)."""

    packages: ClassVar[tuple[str, ...]] = ("stable_baselines3", "torch")

    def check(self, cfg: TrainConfig) -> None:
        check_hyperparams(cfg)

    def fit(self, cfg: TrainConfig, out: Path, resume: bool) -> dict:
        return fit(cfg, out, resume, self)

    def report(self, out: Path, cfg: TrainConfig, summary: dict) -> Path:
        trained = summary.get("trained", True)
        if not trained:
            print(f"WARNING: {cfg.algo} took no gradient step; the report shows an untrained "
                  "policy")
        label = "trained" if trained else "UNTRAINED: no gradient step"
        return write_report(out, cfg, summary, Trained(
            SB3Policy(out), name=f"{cfg.algo} ({label})",
            title=f"{cfg.algo.upper()} on `{cfg.scene}`", setup=f"{cfg.n_envs} envs",
            load=f"`rbenv.agents.policies.load_policy({str(out)!r})`: it applies the "
                 "observation normalisation (`obs_stats.npz`) that the bare weights lack"))

    def load_hint(self, out: Path) -> str:
        return runfolder.LOAD_HINT.replace("PATH", repr(str(out)))


@dataclass(frozen=True)
class SBXSession(SB3Session):
    """The SBX back end (``--engine sbx``: :class:`rbenv.agents.training.config.TrainConfig`
    with ``engine="sbx"``): this module's training with SBX's SAC or TD3 (JAX) in place of
    SB3's. SBX keeps SB3's interface (``learn``, callbacks, VecNormalize, the replay buffer)
    and compiles each batch of gradient steps into one XLA call; its policies are saved as SB3
    policies (:mod:`rbenv.agents.policies.weights`)."""

    packages: ClassVar[tuple[str, ...]] = ("sbx", "jax", "stable_baselines3", "torch")


def train(cfg: TrainConfig, *, resume: bool = False, force: bool = False,
          tensorboard: str | None = None, progress_bar: bool = True, report: bool = True,
          verbose: int = 0, trust_pickle: bool = False) -> Path:
    """Train (or resume) and save the run; returns the run directory (:func:`engine.run`)."""
    session = SB3Session(tensorboard=tensorboard, progress=progress_bar, verbose=verbose,
                         trust_pickle=trust_pickle)
    return engine.run(cfg, session, resume=resume, force=force, report=report)


def fit(cfg: TrainConfig, out: Path, resume: bool, session: SB3Session) -> dict:
    """Train under the engine's lock; save the final model; return the summary."""
    set_threads(cfg.threads)
    ckpt_dir = out / runfolder.CHECKPOINTS
    model, env, done, clock = _start(cfg, out, resume, session)
    if session.tensorboard:
        model.set_logger(configure(str(Path(session.tensorboard) / out.name),
                                   ["stdout", "tensorboard"] if session.verbose
                                   else ["tensorboard"]))
    eval_env = VecNormalize(make_vec_env(cfg, min(cfg.eval_episodes, 50), cfg.seed + 10_000),
                            training=False, norm_reward=False)
    # Evaluation before checkpoint: a checkpoint at step N implies the evaluation due at N is
    # logged, so a kill between the two never loses an entry of the history.
    evaluations = PeriodicEval(eval_env, out / runfolder.EVAL_LOG, cfg.eval_every,
                               cfg.eval_episodes, done, run_config=asdict(cfg),
                               best_dir=ckpt_dir if cfg.keep_best else None,
                               stop_success=cfg.stop_success or None)  # 0: never
    callbacks = [evaluations, AtomicCheckpoint(ckpt_dir, cfg.checkpoint_every, clock,
                                               cfg.save_replay_buffer)]
    limit = TimeLimit(clock, 60.0 * cfg.max_minutes) if cfg.max_minutes else None
    if limit is not None:
        callbacks.append(limit)
    if session.progress:
        callbacks.append(RateProgress())
    remaining = max(cfg.timesteps - done, 0)
    if remaining:
        model.learn(remaining, callback=CallbackList(callbacks), reset_num_timesteps=done == 0)
    steps = int(model.num_timesteps)
    latest = runfolder.latest_checkpoint(ckpt_dir)
    # A checkpoint that the callback wrote at the last step of this session holds the weights
    # from before the update that followed it (SB3 trains after a rollout's callbacks, at the
    # same num_timesteps), so it is written again: checkpoint <steps> is the final model, and
    # a longer resume continues from the trained weights.
    if remaining or latest is None or latest["timesteps"] != steps:
        save_checkpoint(model, ckpt_dir, steps, clock.total(), cfg.save_replay_buffer)
    if limit is not None and limit.stopped:
        print(limit.explain(steps, cfg, out))
    if evaluations.stopped is not None:
        print(f"stopped by --stop-success {cfg.stop_success:g} at {steps:,} of "
              f"{cfg.timesteps:,} timesteps: {100 * evaluations.stopped['success_rate']:.0f} % "
              f"of {cfg.eval_episodes} validation episodes; the policy evaluated then is the "
              "run's final one (--stop-success 0 trains on to the end)")
    weights.save_model(model, out / runfolder.FINAL_MODEL)
    atomic_write(out / runfolder.FINAL_STATS, lambda p: weights.save_stats(env, p))
    kept = evaluations.keep_best(steps, out) if cfg.keep_best else None
    env.close()
    eval_env.close()
    updates = int(getattr(model, "_n_updates", 0))
    if updates == 0:
        warnings.warn(f"{cfg.algo} took no gradient step in {steps} timesteps: the saved "
                      "policy is untrained", stacklevel=4)
    extra = {"stopped_by_time_limit": bool(limit and limit.stopped)} if limit else {}
    if kept is not None:
        extra["kept"] = kept
    if evaluations.stopped is not None:
        extra["stopped_at_success"] = evaluations.stopped
    return {**engine.session_summary(cfg, steps, done, clock), "gradient_updates": updates,
            "trained": updates > 0, **extra}


def _start(cfg: TrainConfig, out: Path, resume: bool, session: SB3Session) -> tuple:
    """(model, env, steps done, clock): from the newest checkpoint that loads, else new."""
    ckpt_dir = out / runfolder.CHECKPOINTS
    base = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    loaded = load_checkpoint(cfg, ckpt_dir, base, session.trust_pickle) if resume else None
    if loaded is not None:
        model, env, ckpt = loaded
        done = int(model.num_timesteps)
        print(f"resuming {cfg.algo} in {str(out)!r} from {done} timesteps ({ckpt.model.name})")
        load_replay_buffer(model, ckpt_dir, done, session.trust_pickle)
        return model, env, done, engine.WallClock(ckpt.wall_time_s or 0.0)
    if resume:
        print(f"no checkpoint in {str(ckpt_dir)!r} yet; starting {str(out)!r} from 0 timesteps")
    env = VecNormalize(base, gamma=cfg.hyperparams.get("gamma", 0.99),
                       **(cfg.normalize or {"norm_obs": False, "norm_reward": False}))
    model = algo_class(cfg.algo, cfg.engine)("MlpPolicy", env, seed=cfg.seed, device="cpu",
                                             verbose=session.verbose, **model_kwargs(cfg, env))
    return model, env, 0, engine.WallClock()


# Keyword arguments of the model class that the engine itself passes.
_ENGINE_ARGS = ("self", "policy", "env", "seed", "device", "verbose", "_init_setup_model")
# RL Zoo's settings that are rbenv train's own flags (a key the error then names).
_OWN_FLAGS = {"n_envs": "--n-envs", "n_timesteps": "--timesteps", "normalize": "--normalize",
              "env_kwargs": "--env-kwargs"}


def check_hyperparams(cfg: TrainConfig) -> None:
    """Each key of ``cfg.hyperparams`` a keyword argument of the algorithm's model class (or RL
    Zoo's ``noise_type``/``noise_std``), and a schedule written as one (``"lin_X"``); else an
    error naming the keys and what is valid, before anything is written."""
    for key in SCHEDULES:
        if isinstance(cfg.hyperparams.get(key), str):
            linear_schedule(key, cfg.hyperparams[key])
    cls = algo_class(cfg.algo, cfg.engine)
    takes = set(inspect.signature(cls.__init__).parameters) - set(_ENGINE_ARGS)
    unknown = sorted(set(cfg.hyperparams) - takes - {"noise_type", "noise_std"})
    if unknown:
        own = [f"{k} is {_OWN_FLAGS[k]}" if k in _OWN_FLAGS else f"{k}: did you mean {near!r}?"
               for k in unknown
               if k in _OWN_FLAGS or (near := usage.suggestion(k, takes))]
        raise InvalidParameterError(
            f"hyperparams: {unknown} are not keyword arguments of {cls.__name__} ("
            + (f"{'; '.join(own)}; " if own else "")
            + f"it takes {', '.join(sorted(takes))})")


def set_threads(n: int) -> None:
    """torch intra-op threads for training (1 is fastest for small MLPs on a busy machine);
    with 1, XLA's CPU code (SBX) too, if JAX is not imported yet (it reads the flags once)."""
    torch.set_num_threads(int(n))
    flags = os.environ.get("XLA_FLAGS", "")
    if int(n) == 1 and "jax" not in sys.modules and "intra_op_parallelism" not in flags:
        os.environ["XLA_FLAGS"] = (f"{flags} --xla_cpu_multi_thread_eigen=false "
                                   "intra_op_parallelism_threads=1").strip()


def algo_class(name: str, engine: str = "sb3"):
    """The SB3 (or sb3-contrib) class of an algorithm name; SBX's with engine ``sbx``."""
    classes = weights.jax_model_classes() if engine == "sbx" else weights.model_classes()
    if name not in classes:
        raise InvalidParameterError(f"algo {name!r} needs sb3-contrib (the train extra); "
                                    f"installed: {sorted(classes)}")
    return classes[name]


def make_vec_env(cfg: TrainConfig, n_envs: int, seed: int) -> VecMonitor:
    """SB3 view of the native vector env (same-step autoreset), monitored."""
    venv = gym.make_vec(cfg.env_id, num_envs=n_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, scene=cfg.scene,
                        **cfg.env_kwargs)
    env = VecMonitor(SB3VecEnv(venv), info_keywords=("is_success",))
    env.seed(seed)
    return env


# --- callbacks --------------------------------------------------------------------------------

class _Every(BaseCallback):
    """Base: fire ``_fire()`` each time num_timesteps passes a multiple of ``every``."""

    def __init__(self, every: int):
        super().__init__()
        self.every, self._next = int(every), None

    def _on_training_start(self) -> None:
        self._next = engine.next_multiple(self.num_timesteps, self.every)

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self._fire()
            self._next = engine.next_multiple(self.num_timesteps, self.every)
        return True

    def _fire(self) -> None:
        raise NotImplementedError


class AtomicCheckpoint(_Every):
    """Every ``every`` timesteps save model + statistics atomically and update latest.json."""

    def __init__(self, directory: Path, every: int, clock: engine.WallClock,
                 replay_buffer: bool = False):
        super().__init__(every)
        self.directory, self.clock, self.replay_buffer = Path(directory), clock, replay_buffer

    def _fire(self) -> None:
        save_checkpoint(self.model, self.directory, self.num_timesteps, self.clock.total(),
                        self.replay_buffer)


class TimeLimit(BaseCallback):
    """Stop ``learn()`` once the run's training wall time reaches ``seconds`` (--max-minutes);
    the run then ends as at its last timestep: final model, summary, report."""

    def __init__(self, clock: engine.WallClock, seconds: float):
        super().__init__()
        self.clock, self.seconds, self.stopped = clock, float(seconds), False

    def _on_step(self) -> bool:
        self.stopped = self.clock.total() >= self.seconds
        return not self.stopped

    def explain(self, steps: int, cfg: TrainConfig, out: Path) -> str:
        """What the console says when the limit stopped the run: when, why, where, and how
        to train on."""
        return (f"stopped by --max-minutes {cfg.max_minutes:g}: {self.clock.total() / 60:.1f} "
                f"min of training wall time (all sessions of the run) at {steps:,} of "
                f"{cfg.timesteps:,} timesteps ({100 * steps / cfg.timesteps:.0f} %); the policy "
                f"as it is then is the run's final one, in {str(out)!r}; to train on: rbenv "
                f"train --out {out} --resume --max-minutes M, with M > {cfg.max_minutes:g}")


class PeriodicEval(_Every):
    """Deterministic evaluation every ``every`` timesteps, logged to ``eval/evaluations.npz``.

    The policy acts as a loaded one does (:class:`rbenv.agents.policies.sb3.RunPolicy` with
    ``action="auto"``: the mean throttle for PPO in throttle mode), so the training curve
    shows the controller that ``rbenv evaluate`` and the report measure. ``run_config``: the
    run's configuration (its ``env_kwargs`` name the action mode). The history is loaded from
    the file on resume (entries after the resumed checkpoint are dropped, since those steps are
    trained again) and rewritten atomically after each evaluation, in the format of SB3's
    ``EvalCallback``.

    With ``stop_success`` (--stop-success), an evaluation whose success rate reaches it ends
    ``learn()`` at once: the callback runs after the env step and before the rollout's update,
    so the policy evaluated is the model's final one; :attr:`stopped` records the step.

    With ``best_dir`` (--keep-best), the policy of the best evaluation of this session (highest
    success rate, then mean return; the earlier at a tie) is saved there as ``best_policy.pt``,
    ``.json`` and ``best_obs_stats.npz``, pickle-free like a checkpoint, and :meth:`keep_best`
    makes it the run's final policy.
    """

    BEST_MODEL, BEST_STATS = "best_policy.pt", "best_obs_stats.npz"

    def __init__(self, eval_env, log: Path, every: int, episodes: int, resumed_at: int,
                 run_config: dict | None = None, best_dir: Path | None = None,
                 stop_success: float | None = None):
        super().__init__(every)
        self.stop_success, self.stopped = stop_success, None
        self.eval_env, self.log, self.episodes = eval_env, Path(log), episodes
        self.run_config = run_config
        self.history = engine.load_eval_history(self.log, resumed_at)
        self.best_dir = None if best_dir is None else Path(best_dir)
        self.best: dict | None = None

    def policy(self) -> RunPolicy:
        """The model being trained, acting as a loaded policy would. The eval env normalises
        observations itself, so the policy carries no statistics."""
        return RunPolicy(self.model, None, self.run_config, source="training model")

    def _on_step(self) -> bool:
        super()._on_step()
        return self.stopped is None

    def _fire(self) -> None:
        sync_envs_normalization(self.training_env, self.eval_env)
        successes: list[bool] = []

        def record(locals_, _globals):
            if locals_["done"] and "is_success" in locals_["info"]:
                successes.append(bool(locals_["info"]["is_success"]))

        rewards, lengths = evaluate_policy(self.policy(), self.eval_env, self.episodes,
                                           deterministic=True, return_episode_rewards=True,
                                           warn=False, callback=record)
        engine.record_evaluation(self.log, self.history, self.num_timesteps, {
            "results": rewards[:self.episodes], "ep_lengths": lengths[:self.episodes],
            "successes": successes[:self.episodes]})
        rate = float(np.mean(successes[:self.episodes])) if successes else 0.0
        mean_return = float(np.mean(rewards[:self.episodes]))
        self.logger.record("eval/mean_reward", mean_return)
        self.logger.record("eval/success_rate", rate)
        if self.stop_success is not None and rate >= self.stop_success:
            self.stopped = {"timesteps": int(self.num_timesteps), "success_rate": rate,
                            "episodes": self.episodes}
        if self.best_dir is not None and (
                self.best is None
                or (rate, mean_return) > (self.best["success_rate"], self.best["mean_return"])):
            self.best_dir.mkdir(parents=True, exist_ok=True)
            weights.save_model(self.model, self.best_dir / self.BEST_MODEL)
            atomic_write(self.best_dir / self.BEST_STATS,
                         lambda p: weights.save_stats(self.model.get_vec_normalize_env(), p))
            self.best = {"timesteps": int(self.num_timesteps), "success_rate": rate,
                         "mean_return": mean_return}

    def keep_best(self, steps: int, out: Path) -> dict | None:
        """Make the best evaluated policy the run's final one (``out``'s policy.pt, .json and
        obs_stats.npz), after evaluating the final model too if no evaluation fell on its
        step. Returns what was kept (its timesteps and validation scores, and the final
        model's), or None if nothing was evaluated in this session."""
        if self.history["timesteps"][-1:] != [steps]:
            self.num_timesteps = steps
            self._fire()
        if self.best is None:
            return None
        last = {"timesteps": steps, "success_rate": float(np.mean(self.history["successes"][-1]))
                if len(self.history["successes"][-1]) else 0.0,
                "mean_return": float(np.mean(self.history["results"][-1]))}
        # Copied even when the best is at the last step: an evaluation that the callback ran at
        # that step saw the weights from before the update that followed it.
        config = weights.config_path(Path(self.BEST_MODEL)).name
        pairs = [(self.BEST_MODEL, runfolder.FINAL_MODEL), (config, runfolder.FINAL_CONFIG),
                 (self.BEST_STATS, runfolder.FINAL_STATS)]
        jax_state = weights.jax_state_path(Path(self.BEST_MODEL)).name
        if (self.best_dir / jax_state).is_file():  # an SBX model's training state
            pairs.append((jax_state, runfolder.FINAL_JAX_STATE))
        for src, dst in pairs:
            atomic_write(out / dst,
                         lambda p, src=src: shutil.copyfile(self.best_dir / src, p))
        return {**self.best, "episodes": self.episodes, "last": last}


class RateProgress(BaseCallback):
    """A tqdm bar over the timesteps of this session showing the true average rate.

    SB3's own bar shows tqdm's smoothed instantaneous rate, which reads the fast rollout phase
    and misses the gradient updates; here the rate is steps done / wall time since the start.
    """

    def _on_training_start(self) -> None:
        total = self.locals["total_timesteps"] - self.model.num_timesteps
        self.pbar = tqdm(total=total, unit="step", unit_scale=True, smoothing=0.0,
                         dynamic_ncols=True)

    def _on_step(self) -> bool:
        self.pbar.update(self.training_env.num_envs)
        return True

    def _on_training_end(self) -> None:
        self.pbar.close()


# --- checkpoints ------------------------------------------------------------------------------

def save_checkpoint(model, directory: Path, steps: int, wall_time_s: float | None = None,
                    replay_buffer: bool = False) -> None:
    """Write policy_<steps>.pt/.json and obs_stats_<steps>.npz (and, with ``replay_buffer``, an
    off-policy model's replay_buffer_<steps>.npz), then point latest.json at them. No file is a
    pickle; only the latest replay buffer is kept."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    model_path = directory / f"policy_{steps}.pt"
    stats_path = directory / f"obs_stats_{steps}.npz"
    weights.save_model(model, model_path)
    atomic_write(stats_path, lambda p: weights.save_stats(model.get_vec_normalize_env(), p))
    buffer = directory / f"replay_buffer_{steps}.npz"
    keep = replay_buffer and getattr(model, "replay_buffer", None) is not None
    if keep:  # off-policy, asked for: keep the latest only
        atomic_write(buffer, lambda p: weights.save_replay_buffer(model, p))
    engine.point_latest(directory, steps, wall_time_s, model=model_path.name,
                        stats=stats_path.name)
    for old in directory.glob("replay_buffer_*.*"):
        if old != buffer or not keep:
            old.unlink(missing_ok=True)


def load_replay_buffer(model, directory: Path, steps: int, trust_pickle: bool = False) -> None:
    """Restore an off-policy model's replay buffer saved with checkpoint ``steps``, if any:
    ``replay_buffer_<steps>.npz``, or an older run's ``.pkl`` only with ``trust_pickle``."""
    if getattr(model, "replay_buffer", None) is None:
        return
    path = Path(directory) / f"replay_buffer_{steps}.npz"
    legacy = path.with_suffix(".pkl")
    try:
        if path.is_file():
            size = weights.load_replay_buffer(model, path)
        elif legacy.is_file():
            runfolder.require_trust(legacy, "a pickled replay buffer", trust_pickle)
            model.load_replay_buffer(str(legacy))
            path, size = legacy, model.replay_buffer.size()
        else:
            print(f"no replay buffer saved with checkpoint {steps} (--save-replay-buffer "
                  f"keeps it); {type(model).__name__} starts with an empty buffer and trains "
                  "at once on the transitions the resumed policy collects (SB3 does not wait "
                  "for learning_starts again)")
            return
    except Exception as e:  # refused, torn or foreign: train on, say what was lost
        print(f"replay buffer not restored ({type(e).__name__}: {e}); "
              f"{type(model).__name__} refills it from the resumed policy")
        return
    n_envs = model.replay_buffer.n_envs  # SB3's size() counts vector steps, not transitions
    print(f"replay buffer restored: {size * n_envs} transitions, {size} vector steps of "
          f"{n_envs} envs ({path.name})")


def load_checkpoint(cfg: TrainConfig, directory: Path, base, trust_pickle: bool = False):
    """(model, env, checkpoint) from the newest checkpoint that loads, or None if none exists.

    A checkpoint that fails (missing or corrupt file, a pickle without ``trust_pickle``, or a
    claimed step count that its model contradicts) is reported, naming the file, and the next
    older one is tried. The model's own ``num_timesteps`` is the truth; the returned
    checkpoint carries it. Raises :class:`RunFolderError` if complete checkpoints exist but
    none loads; only incomplete ones (a kill during the first checkpoint) mean starting from 0.
    """
    tried, incomplete, untrusted = [], [], False
    for ckpt in runfolder.checkpoints(directory):
        missing = _missing_file(ckpt)
        if missing is not None:
            # A kill between the writes of a checkpoint; never pointed to by latest.json.
            print(f"checkpoint at {ckpt.steps} timesteps is incomplete ({str(missing)!r} is "
                  "missing); skipping it")
            incomplete.append(ckpt.model.name)
            continue
        try:
            model, env = _load_pair(cfg, ckpt, base, trust_pickle)
        except RunFolderError as e:
            print(f"checkpoint at {ckpt.steps} timesteps is unusable: {e}")
            tried.append(ckpt.model.name)
            untrusted |= isinstance(e, runfolder.UntrustedPickleError)
            continue
        if tried or incomplete:
            print(f"falling back to the last complete checkpoint: {ckpt.model} "
                  f"({ckpt.steps} timesteps)")
        return model, env, ckpt
    if tried:
        hint = (f"; they are pickles of an older run: pass {runfolder.TRUST_FLAG} if you trust "
                "them" if untrusted else "")
        raise RunFolderError(f"no usable checkpoint in {str(directory)!r} (tried "
                             f"{', '.join(tried)}){hint}; pass --force without --resume to "
                             "start over")
    return None


def _missing_file(ckpt: runfolder.Checkpoint) -> Path | None:
    needed = [ckpt.model, ckpt.stats]
    if ckpt.model.suffix == ".pt":
        needed.append(weights.config_path(ckpt.model))
    return next((p for p in needed if not p.is_file()), None)


def _load_pair(cfg: TrainConfig, ckpt: runfolder.Checkpoint, base, trust_pickle: bool) -> tuple:
    """(model, VecNormalize env) of one checkpoint; RunFolderError if it is unusable,
    including when its model's own num_timesteps is not the count claimed for it."""
    check_model_file(ckpt.model)
    env = load_stats(ckpt.stats, base, trust_pickle=trust_pickle)
    model = load_model(ckpt.model, cfg.algo, env=env, hyperparams=model_kwargs(cfg, env),
                       seed=cfg.seed, trust_pickle=trust_pickle)
    own = int(model.num_timesteps)
    if own != ckpt.steps:
        claim = ckpt.source or ckpt.model
        raise RunFolderError(f"{str(claim)!r} claims {ckpt.steps} timesteps but the model "
                             f"{str(ckpt.model)!r} holds {own}; the checkpoint is the truth")
    return model, env


# Hyperparameters RL Zoo writes as schedules ("lin_X"): linear_schedule turns them into one.
SCHEDULES = ("learning_rate", "clip_range")


def linear_schedule(name: str, spec: str):
    """RL Zoo's ``"lin_X"``: a value falling linearly from X at the start of training to 0 at
    its end (SB3 calls it with the remaining fraction, 1 → 0; below 0 when the last rollout
    overshoots the budget, where the rate stays 0 rather than turning negative)."""
    try:
        prefix, value = spec.split("_", 1)
        start = float(value)
    except ValueError:
        prefix, start = "", float("nan")
    if prefix != "lin" or not 0 < start < float("inf"):
        raise InvalidParameterError(f"{name} must be a number or 'lin_X' with X > 0 (RL "
                                    f"Zoo's linear schedule), got {spec!r}")

    def schedule(remaining: float) -> float:
        return max(remaining, 0.0) * start

    return schedule


def model_kwargs(cfg: TrainConfig, env) -> dict:
    """The model's keyword arguments from ``cfg.hyperparams``: the zoo's ``noise_type`` and
    ``noise_std`` become an ``action_noise`` (as rl_zoo3 builds it), an activation's name in
    ``policy_kwargs`` its class (:mod:`rbenv.agents.policies.activations`); the rest pass
    through."""
    hp = copy.deepcopy(cfg.hyperparams)  # SB3 writes into policy_kwargs
    if "policy_kwargs" in hp:
        if cfg.engine == "sbx" and "activation_fn" in hp["policy_kwargs"]:
            raise InvalidParameterError(
                "policy_kwargs activation_fn is not supported by --engine sbx (its networks "
                f"use ReLU), got {hp['policy_kwargs']['activation_fn']!r}")
        hp["policy_kwargs"] = activations.to_classes(hp["policy_kwargs"])
    for key in SCHEDULES:
        if isinstance(hp.get(key), str):
            hp[key] = linear_schedule(key, hp[key])
    noise_type, noise_std = hp.pop("noise_type", None), hp.pop("noise_std", None)
    if noise_type is not None:
        if noise_type != "normal":
            raise InvalidParameterError(f"noise_type must be 'normal', got {noise_type!r}")
        dim = env.action_space.shape[0]
        hp["action_noise"] = NormalActionNoise(np.zeros(dim), float(noise_std) * np.ones(dim))
    return hp
