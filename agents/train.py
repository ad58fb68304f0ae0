"""``rbenv train``: PPO, SAC, TD3, TQC or CrossQ on the native vector env, with checkpoints,
resume and a report. Settings come from ``rbenv/hyperparams/<algo>.py`` (RL Zoo's format).

The run folder layout, its lock and the loader are in :mod:`rbenv.agents.runs`. A run is safe to
kill, corrupt and share:

- every file is written to a unique temporary name and renamed, and ``latest.json`` moves
  only after both files of a checkpoint exist, so ``kill -9`` at any moment leaves the last
  complete checkpoint;
- ``--resume DIR`` continues DIR (never the folder recorded in its config.json), falling
  back past a corrupt or missing checkpoint to the newest complete one, and says which;
- an exclusive lock refuses a second live run on the folder; a lock left by a killed run is
  recognised as stale;
- a new run into a non-empty folder needs ``force``; a finished run resumes as a no-op.

Training is reproducible given the seed, the torch thread count (``threads``, default 1, which
is also the fastest for these small MLPs) and the CPU kind.
"""

from __future__ import annotations

import copy
import numbers
import platform
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from rbenv.agents import runs
from rbenv.agents.runs import RunFolderError, atomic_write, write_json
from rbenv.agents.sb3 import SB3VecEnv
from rbenv.core.errors import InvalidParameterError
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize, sync_envs_normalization

import rbenv

ALGOS = ("ppo", "sac", "td3", "tqc", "crossq")
OFF_POLICY = ("sac", "td3", "tqc", "crossq")
# Keys of a zoo settings dict that are not model keyword arguments: rbenv train reads them into
# TrainConfig's own fields (rl_zoo3's ExpManager does the same).
ZOO_KEYS = ("policy", "n_envs", "n_timesteps", "normalize", "env_kwargs", "monitor_kwargs")


def shipped_settings(algo: str, env_id: str = rbenv.ENV_ID) -> dict:
    """The settings shipped for ``algo`` on ``env_id``, in RL Zoo's format: its task registry
    entry's (rbenv.registry; the dicts live in rbenv.hyperparams.tuned).

    This is the one source of ``rbenv train``'s defaults; ``rl_zoo3 --conf-file
    rbenv.hyperparams.<algo>`` reads the same dict. Returns a deep copy.
    """
    if algo not in ALGOS:
        raise InvalidParameterError(f"algo must be one of {', '.join(ALGOS)}, got {algo!r}")
    table = rbenv.registry.get(env_id).hyperparams  # the task registry: one source
    if algo not in table:
        raise InvalidParameterError(f"the task entry of {env_id!r} has no {algo} settings; "
                                    f"it has {sorted(table)}")
    return copy.deepcopy(dict(table[algo]))


def normalize_kwargs(setting) -> dict | None:
    """VecNormalize keyword arguments from the zoo's ``normalize`` (bool or dict)."""
    if setting is True:
        return {"norm_obs": True, "norm_reward": True}
    if not setting:
        return None
    return dict(setting)


@dataclass
class TrainConfig:
    """Everything that defines a training run; saved as ``config.json`` in the run directory."""

    algo: str = "ppo"
    timesteps: int | None = None
    n_envs: int | None = None
    seed: int = 0
    scene: str = "cubesat-12u"
    env_id: str = rbenv.ENV_ID  # the task: any id of the task registry (rbenv.registry)
    out: str | None = None
    env_kwargs: dict = field(default_factory=dict)
    hyperparams: dict = field(default_factory=dict)
    checkpoint_every: int = 200_000  # timesteps
    eval_every: int = 200_000  # timesteps
    eval_episodes: int = 100
    report_episodes: int = 500
    report_seed: int = 1_000_000
    threads: int = 1  # torch intra-op threads; part of what makes a run reproducible
    # VecNormalize's keyword arguments (None: no normalisation); default: the shipped settings
    normalize: dict | None = None

    def resolve(self) -> TrainConfig:
        """Fill defaults that depend on the algorithm; validate names and counts."""
        shipped = shipped_settings(self.algo, self.env_id)
        if self.timesteps is None:
            self.timesteps = shipped["n_timesteps"]
        if self.n_envs is None:
            self.n_envs = shipped["n_envs"]
        if self.normalize is None:
            self.normalize = normalize_kwargs(shipped.get("normalize", False))
        for name in ("timesteps", "n_envs", "threads", "checkpoint_every", "eval_every"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value <= 0:
                raise InvalidParameterError(f"{name} must be a positive integer, got {value!r}")
            setattr(self, name, int(value))
        for name in ("env_kwargs", "hyperparams"):
            if not isinstance(getattr(self, name), dict):
                raise InvalidParameterError(f"{name} must be a dict (a JSON object), got "
                                            f"{getattr(self, name)!r}")
        # Shipped settings first, then the caller's overrides (a resumed run's are complete).
        self.hyperparams = {**{k: v for k, v in shipped.items() if k not in ZOO_KEYS},
                            **self.hyperparams}
        self.env_kwargs = {**shipped.get("env_kwargs", {}), **self.env_kwargs}
        self.out = self.out or f"runs/{self.algo}-{self.scene}-seed{self.seed}"
        starts = self.hyperparams.get("learning_starts", 0)
        if self.algo in OFF_POLICY and self.timesteps <= starts:
            raise InvalidParameterError(
                f"timesteps must exceed {self.algo}'s learning_starts ({starts}) or no gradient "
                f"step is taken, got timesteps={self.timesteps}; raise --timesteps or pass "
                "--hyperparams '{\"learning_starts\": N}'")
        return self


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
        self._next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self._fire()
            self._next = (self.num_timesteps // self.every + 1) * self.every
        return True

    def _fire(self) -> None:
        raise NotImplementedError


class AtomicCheckpoint(_Every):
    """Every ``every`` timesteps save model + statistics atomically and update latest.json."""

    def __init__(self, directory: Path, every: int, clock: WallClock):
        super().__init__(every)
        self.directory, self.clock = Path(directory), clock

    def _fire(self) -> None:
        save_checkpoint(self.model, self.directory, self.num_timesteps, self.clock.total())


class PeriodicEval(_Every):
    """Deterministic evaluation every ``every`` timesteps, logged to ``eval/evaluations.npz``.

    The policy acts as a loaded one does (:class:`rbenv.agents.runs.RunPolicy` with
    ``action="auto"``: the mean throttle for PPO in throttle mode), so the training curve
    shows the controller that ``rbenv evaluate`` and the report measure. ``run_config``: the
    run's configuration (its ``env_kwargs`` name the action mode). The history is loaded from
    the file on resume (entries after the resumed checkpoint are dropped, since those steps are
    trained again) and rewritten atomically after each evaluation, in the format of SB3's
    ``EvalCallback``.
    """

    def __init__(self, eval_env, log: Path, every: int, episodes: int, resumed_at: int,
                 run_config: dict | None = None):
        super().__init__(every)
        self.eval_env, self.log, self.episodes = eval_env, Path(log), episodes
        self.run_config = run_config
        self.history = load_eval_history(self.log, resumed_at)

    def policy(self) -> runs.RunPolicy:
        """The model being trained, acting as a loaded policy would. The eval env normalises
        observations itself, so the policy carries no statistics."""
        return runs.RunPolicy(self.model, None, self.run_config, source="training model")

    def _fire(self) -> None:
        sync_envs_normalization(self.training_env, self.eval_env)
        successes: list[bool] = []

        def record(locals_, _globals):
            if locals_["done"] and "is_success" in locals_["info"]:
                successes.append(bool(locals_["info"]["is_success"]))

        rewards, lengths = evaluate_policy(self.policy(), self.eval_env, self.episodes,
                                           deterministic=True, return_episode_rewards=True,
                                           warn=False, callback=record)
        h = self.history
        h["timesteps"].append(self.num_timesteps)
        h["results"].append(rewards[:self.episodes])
        h["ep_lengths"].append(lengths[:self.episodes])
        h["successes"].append(successes[:self.episodes])
        self.log.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(self.log, lambda p: _savez(p, h))
        self.logger.record("eval/mean_reward", float(np.mean(rewards)))
        self.logger.record("eval/success_rate", float(np.mean(successes)) if successes else 0.0)


def _savez(path: Path, history: dict) -> None:
    with open(path, "wb") as f:  # np.savez on a name would append ".npz"
        np.savez(f, **{k: np.asarray(v) for k, v in history.items()})


def load_eval_history(log: Path, upto: int) -> dict:
    """Evaluations at timesteps <= ``upto`` from ``log`` (empty if absent; warns if corrupt)."""
    keys = ("timesteps", "results", "ep_lengths", "successes")
    history = {k: [] for k in keys}
    if upto <= 0 or not log.exists():
        return history
    try:
        with np.load(log) as data:
            loaded = {k: data[k].tolist() for k in keys}
    except Exception as e:  # a torn or foreign file: keep training, say what was lost
        warnings.warn(f"evaluation history {str(log)!r} is unreadable ({type(e).__name__}: "
                      f"{e}); starting a new one", stacklevel=2)
        return history
    keep = [i for i, t in enumerate(loaded["timesteps"]) if t <= upto]
    return {k: [loaded[k][i] for i in keep] for k in keys}


class RateProgress(BaseCallback):
    """A tqdm bar over the timesteps of this session showing the true average rate.

    SB3's own bar shows tqdm's smoothed instantaneous rate, which reads the fast rollout phase
    and misses the gradient updates; here the rate is steps done / wall time since the start.
    """

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        total = self.locals["total_timesteps"] - self.model.num_timesteps
        self.pbar = tqdm(total=total, unit="step", unit_scale=True, smoothing=0.0,
                         dynamic_ncols=True)

    def _on_step(self) -> bool:
        self.pbar.update(self.training_env.num_envs)
        return True

    def _on_training_end(self) -> None:
        self.pbar.close()


class WallClock:
    """Training wall time accumulated over every session of a run (kept in checkpoints)."""

    def __init__(self, before: float = 0.0):
        self.before, self.start = float(before), time.perf_counter()

    def session(self) -> float:
        return time.perf_counter() - self.start

    def total(self) -> float:
        return self.before + self.session()


# --- checkpoints ------------------------------------------------------------------------------

def save_checkpoint(model, directory: Path, steps: int, wall_time_s: float | None = None) -> None:
    """Write policy_<steps>.pt/.json and obs_stats_<steps>.npz (and an off-policy model's
    replay_buffer_<steps>.npz), then point latest.json at them. No file is a pickle."""
    from rbenv.agents import weights

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    model_path = directory / f"policy_{steps}.pt"
    stats_path = directory / f"obs_stats_{steps}.npz"
    weights.save_model(model, model_path)
    atomic_write(stats_path, lambda p: weights.save_stats(model.get_vec_normalize_env(), p))
    buffer = directory / f"replay_buffer_{steps}.npz"
    if getattr(model, "replay_buffer", None) is not None:  # off-policy: keep the latest only
        atomic_write(buffer, lambda p: weights.save_replay_buffer(model, p))
    write_json(directory / runs.LATEST, {"timesteps": steps, "model": model_path.name,
                                         "stats": stats_path.name,
                                         "wall_time_s": wall_time_s})
    for old in directory.glob("replay_buffer_*.*"):
        if old != buffer:
            old.unlink(missing_ok=True)


def load_replay_buffer(model, directory: Path, steps: int, trust_pickle: bool = False) -> None:
    """Restore an off-policy model's replay buffer saved with checkpoint ``steps``, if any:
    ``replay_buffer_<steps>.npz``, or an older run's ``.pkl`` only with ``trust_pickle``."""
    from rbenv.agents import weights

    if getattr(model, "replay_buffer", None) is None:
        return
    path = Path(directory) / f"replay_buffer_{steps}.npz"
    legacy = path.with_suffix(".pkl")
    try:
        if path.is_file():
            size = weights.load_replay_buffer(model, path)
        elif legacy.is_file():
            runs.require_trust(legacy, "a pickled replay buffer", trust_pickle)
            model.load_replay_buffer(str(legacy))
            path, size = legacy, model.replay_buffer.size()
        else:
            print(f"no replay buffer saved with checkpoint {steps}; {type(model).__name__} "
                  "refills it from the resumed policy")
            return
    except Exception as e:  # refused, torn or foreign: train on, say what was lost
        print(f"replay buffer not restored ({type(e).__name__}: {e}); "
              f"{type(model).__name__} refills it from the resumed policy")
        return
    print(f"replay buffer restored: {size} transitions ({path.name})")


def latest_checkpoint(directory: Path) -> dict | None:
    """The checkpoint latest.json records, if both its files exist; else None."""
    return runs.latest_checkpoint(directory)


def load_checkpoint(cfg: TrainConfig, directory: Path, base, trust_pickle: bool = False):
    """(model, env, checkpoint) from the newest checkpoint that loads, or None if none exists.

    A checkpoint that fails (missing or corrupt file, a pickle without ``trust_pickle``, or a
    claimed step count that its model contradicts) is reported, naming the file, and the next
    older one is tried. The model's own ``num_timesteps`` is the truth; the returned
    checkpoint carries it. Raises :class:`RunFolderError` if complete checkpoints exist but
    none loads; only incomplete ones (a kill during the first checkpoint) mean starting from 0.
    """
    tried, incomplete, untrusted = [], [], False
    for ckpt in runs.checkpoints(directory):
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
            untrusted |= isinstance(e, runs.UntrustedPickleError)
            continue
        if tried or incomplete:
            print(f"falling back to the last complete checkpoint: {ckpt.model} "
                  f"({ckpt.steps} timesteps)")
        return model, env, ckpt
    if tried:
        hint = (f"; they are pickles of an older run: pass {runs.TRUST_FLAG} if you trust "
                "them" if untrusted else "")
        raise RunFolderError(f"no usable checkpoint in {str(directory)!r} (tried "
                             f"{', '.join(tried)}){hint}; pass --force without --resume to "
                             "start over")
    return None


def _missing_file(ckpt: runs.Checkpoint) -> Path | None:
    from rbenv.agents import weights

    needed = [ckpt.model, ckpt.stats]
    if ckpt.model.suffix == ".pt":
        needed.append(weights.config_path(ckpt.model))
    return next((p for p in needed if not p.is_file()), None)


def _load_pair(cfg: TrainConfig, ckpt: runs.Checkpoint, base, trust_pickle: bool) -> tuple:
    """(model, VecNormalize env) of one checkpoint; RunFolderError if it is unusable,
    including when its model's own num_timesteps is not the count claimed for it."""
    runs.check_model_file(ckpt.model)
    env = runs.load_stats(ckpt.stats, base, trust_pickle=trust_pickle)
    model = runs.load_model(ckpt.model, cfg.algo, env=env, hyperparams=cfg.hyperparams,
                            seed=cfg.seed, trust_pickle=trust_pickle)
    own = int(model.num_timesteps)
    if own != ckpt.steps:
        claim = ckpt.source or ckpt.model
        raise RunFolderError(f"{str(claim)!r} claims {ckpt.steps} timesteps but the model "
                             f"{str(ckpt.model)!r} holds {own}; the checkpoint is the truth")
    return model, env


def _algo_class(name: str):
    from stable_baselines3 import PPO, SAC, TD3

    if name in ("tqc", "crossq"):
        from sb3_contrib import TQC, CrossQ

        return {"tqc": TQC, "crossq": CrossQ}[name]
    return {"ppo": PPO, "sac": SAC, "td3": TD3}[name]


def model_kwargs(cfg: TrainConfig, env) -> dict:
    """The model's keyword arguments from ``cfg.hyperparams``: the zoo's ``noise_type`` and
    ``noise_std`` become an ``action_noise`` (as rl_zoo3 builds it); the rest pass through."""
    hp = copy.deepcopy(cfg.hyperparams)  # SB3 writes into policy_kwargs
    noise_type, noise_std = hp.pop("noise_type", None), hp.pop("noise_std", None)
    if noise_type is not None:
        from stable_baselines3.common.noise import NormalActionNoise

        if noise_type != "normal":
            raise InvalidParameterError(f"noise_type must be 'normal', got {noise_type!r}")
        dim = env.action_space.shape[0]
        hp["action_noise"] = NormalActionNoise(np.zeros(dim), float(noise_std) * np.ones(dim))
    return hp


def _versions() -> dict:
    import stable_baselines3
    import torch

    return {"python": platform.python_version(), "numpy": np.__version__,
            "gymnasium": gym.__version__, "stable_baselines3": stable_baselines3.__version__,
            "torch": torch.__version__, "cpu": _cpu_kind()}


def _cpu_kind() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def set_threads(n: int) -> None:
    """torch intra-op threads for training (1 is fastest for small MLPs on a busy machine)."""
    import torch

    torch.set_num_threads(int(n))


# --- the run ----------------------------------------------------------------------------------

def resumed_config(out: Path, timesteps: int | None = None,
                   threads: int | None = None) -> TrainConfig:
    """The saved configuration of the run in ``out``, for that folder; new total and threads."""
    saved = runs.read_config(out)
    known = TrainConfig.__dataclass_fields__
    try:
        cfg = TrainConfig(**{k: v for k, v in saved.items() if k in known})
    except TypeError as e:
        raise RunFolderError(f"run configuration {str(out / runs.CONFIG)!r} is invalid: {e}"
                             ) from None
    cfg.out = str(out)  # the folder given, not the one recorded when the run started
    cfg.timesteps = timesteps or cfg.timesteps
    cfg.threads = threads or cfg.threads
    try:
        return cfg.resolve()
    except (TypeError, ValueError) as e:
        raise RunFolderError(f"run configuration {str(out / runs.CONFIG)!r}: {e}") from None


def train(cfg: TrainConfig, *, resume: bool = False, force: bool = False,
          tensorboard: str | None = None, progress_bar: bool = True, report: bool = True,
          verbose: int = 0, trust_pickle: bool = False) -> Path:
    """Train (or resume) and save the run; returns the run directory.

    With ``resume``, the run in ``cfg.out`` defines the experiment; only ``cfg.timesteps`` (a
    new total) and ``cfg.threads`` are taken from ``cfg``. ``trust_pickle``: a resume may
    unpickle the checkpoints of a run folder written before issue 19 (never needed for runs
    written now, which hold no pickle).
    """
    out = Path(cfg.out or TrainConfig(algo=cfg.algo, scene=cfg.scene, seed=cfg.seed)
               .resolve().out)
    if resume:
        cfg = resumed_config(out, cfg.timesteps, cfg.threads)
    else:
        cfg.out = str(out)
        cfg.resolve()
    out.mkdir(parents=True, exist_ok=True)
    with runs.RunLock(out):
        if resume:
            for p in runs.remove_temporaries(out):
                print(f"removed {str(p)!r}, left by a killed writer")
            finished = runs.is_finished(out)
            if finished and int(finished.get("timesteps", 0)) >= cfg.timesteps:
                print(f"run {str(out)!r} is already finished ({finished['timesteps']} timesteps)"
                      f"; nothing to do (pass --timesteps N > {finished['timesteps']} "
                      "to train further)")
                return out
        else:
            runs.prepare_new_run(out, force)
            write_json(out / runs.CONFIG, {**asdict(cfg), "versions": _versions()})
        summary = _train_locked(cfg, out, resume, tensorboard, progress_bar, verbose,
                                trust_pickle)
    if report:
        from rbenv.agents.report import write_report

        write_report(out, cfg, summary)
    print(f"run saved in {out}; {runs.LOAD_HINT.replace('PATH', repr(str(out)))}")
    return out


def _train_locked(cfg: TrainConfig, out: Path, resume: bool, tensorboard, progress_bar,
                  verbose, trust_pickle: bool = False) -> dict:
    set_threads(cfg.threads)
    ckpt_dir = out / runs.CHECKPOINTS
    base = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    loaded = load_checkpoint(cfg, ckpt_dir, base, trust_pickle) if resume else None
    if loaded is not None:
        model, env, ckpt = loaded
        done, clock = int(model.num_timesteps), WallClock(ckpt.wall_time_s or 0.0)
        print(f"resuming {cfg.algo} in {str(out)!r} from {done} timesteps ({ckpt.model.name})")
        load_replay_buffer(model, ckpt_dir, done, trust_pickle)
    else:
        if resume:
            print(f"no checkpoint in {str(ckpt_dir)!r} yet; starting {str(out)!r} from 0 "
                  "timesteps")
        env = VecNormalize(base, gamma=cfg.hyperparams.get("gamma", 0.99),
                           **(cfg.normalize or {"norm_obs": False, "norm_reward": False}))
        model = _algo_class(cfg.algo)("MlpPolicy", env, seed=cfg.seed, device="cpu",
                                      verbose=verbose, **model_kwargs(cfg, env))
        done, clock = 0, WallClock()
    if tensorboard:
        from stable_baselines3.common.logger import configure

        model.set_logger(configure(str(Path(tensorboard) / out.name),
                                   ["stdout", "tensorboard"] if verbose else ["tensorboard"]))
    eval_env = VecNormalize(make_vec_env(cfg, min(cfg.eval_episodes, 50), cfg.seed + 10_000),
                            training=False, norm_reward=False)
    # Evaluation before checkpoint: a checkpoint at step N implies the evaluation due at N is
    # logged, so a kill between the two never loses an entry of the history.
    callbacks = [PeriodicEval(eval_env, out / runs.EVAL_LOG, cfg.eval_every, cfg.eval_episodes,
                              done, run_config=asdict(cfg)),
                 AtomicCheckpoint(ckpt_dir, cfg.checkpoint_every, clock)]
    if progress_bar:
        callbacks.append(RateProgress())
    remaining = max(cfg.timesteps - done, 0)
    if remaining:
        model.learn(remaining, callback=CallbackList(callbacks), reset_num_timesteps=done == 0)
    steps = int(model.num_timesteps)
    latest = latest_checkpoint(ckpt_dir)
    if latest is None or latest["timesteps"] != steps:
        save_checkpoint(model, ckpt_dir, steps, clock.total())  # a longer resume continues here
    from rbenv.agents import weights

    weights.save_model(model, out / runs.FINAL_MODEL)
    atomic_write(out / runs.FINAL_STATS, lambda p: weights.save_stats(env, p))
    updates = int(getattr(model, "_n_updates", 0))
    summary = {"timesteps": steps, "wall_time_s": clock.total(),
               "session_wall_time_s": clock.session(),
               "session_steps_per_s": (steps - done) / max(clock.session(), 1e-9),
               "resumed_from": done or None, "threads": cfg.threads,
               "gradient_updates": updates, "trained": updates > 0}
    if not summary["trained"]:
        warnings.warn(f"{cfg.algo} took no gradient step in {steps} timesteps: the saved "
                      "policy is untrained", stacklevel=3)
    write_json(out / runs.SUMMARY, summary)
    env.close()
    eval_env.close()
    return summary
