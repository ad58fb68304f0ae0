"""Training run folders: what makes a folder a run, its lock, atomic writes, checkpoints, loading.

A run folder (written by ``rbenv train``)::

    config.json             resolved TrainConfig (scene, env_kwargs, hyperparameters, threads)
    run.lock                held (fcntl) by the live training process; pid and start time inside
    checkpoints/            policy_<steps>.pt + policy_<steps>.json + obs_stats_<steps>.npz
                            (+ replay_buffer_<steps>.npz for SAC), latest.json
    eval/evaluations.npz    periodic evaluations over the whole run (kept across resumes)
    policy.pt, policy.json, obs_stats.npz, training.json, report.md, *.png    the finished run

A run folder is data: weights are tensors loaded with ``torch.load(weights_only=True)``, the
rest JSON or ``.npz`` loaded without pickle (:mod:`rbenv.agents.weights`). Run folders written
before issue 19 (``model.zip``, ``vecnormalize.pkl``, ``model_<N>.zip``, ``vecnormalize_<N>.pkl``,
``replay_buffer_<N>.pkl``) and foreign SB3 ``.zip`` files are pickles: unpickling runs any code
their author put in them, so they load only with ``trust_pickle=True`` (``--trust-pickle``)
and are refused otherwise with :class:`UntrustedPickleError`.

Loading a trained policy for plain ``gym.make`` code::

    from rbenv.agents.runs import load_policy
    policy = load_policy("runs/ppo-cubesat-12u-seed0")       # or .../checkpoints/model_N.zip
    env = policy.make_env()                                   # the run's task, scene and env kwargs
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)                           # observations normalised inside

The bare weights give a policy that expects normalised observations: it fails silently on raw
ones. Use :func:`load_policy`, or apply ``obs_stats.npz`` yourself.

This module imports neither torch nor Stable-Baselines3 until a model is loaded.
"""

from __future__ import annotations

import json
import os
import re
import socket
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rbenv.core.errors import InvalidParameterError, RbenvValueError

CONFIG = "config.json"
LOCK = "run.lock"
CHECKPOINTS = "checkpoints"
LATEST = "latest.json"
FINAL_MODEL, FINAL_STATS, SUMMARY = "policy.pt", "obs_stats.npz", "training.json"
FINAL_CONFIG = "policy.json"
# The pickle-based names of run folders written before issue 19 (need trust_pickle).
LEGACY_MODEL, LEGACY_STATS = "model.zip", "vecnormalize.pkl"
EVAL_LOG = Path("eval") / "evaluations.npz"
# Everything `rbenv train` writes into a run folder; `--force` removes exactly these.
RUN_FILES = (CONFIG, FINAL_MODEL, FINAL_CONFIG, FINAL_STATS, LEGACY_MODEL, LEGACY_STATS, SUMMARY,
             "report.md", "evaluation.json", "episode.png", "training_curve.png")
RUN_DIRS = (CHECKPOINTS, "eval")
_MODEL_RE = re.compile(r"policy_(\d+)\.pt")
_LEGACY_RE = re.compile(r"model_(\d+)\.zip")
TRUST_FLAG = "trust_pickle=True (rbenv: --trust-pickle)"
LOAD_HINT = ("load it with agents.runs.load_policy(PATH), which applies the run's observation "
             "normalisation (obs_stats.npz); the bare weights expect normalised observations "
             "and fail silently on raw ones")


class RunFolderError(RbenvValueError):
    """A run folder, or a file in it, is missing, corrupt, locked or not what was asked for."""


class RunLockedError(RunFolderError):
    """Another live process is training into the same run folder."""


class UntrustedPickleError(RunFolderError):
    """A pickle-based file (an SB3 ``.zip``, a ``.pkl``) was to be loaded without trust."""


SB3_HINT = ("Run folders written by this rbenv hold no pickle (policy.pt, policy.json, "
            "obs_stats.npz); retrain, or load an old folder once with the flag")


def require_trust(path: Path, what: str, trust_pickle: bool, hint: str = SB3_HINT) -> None:
    """Refuse the pickle-based file ``path`` unless ``trust_pickle``, naming the flag."""
    if not trust_pickle:
        raise UntrustedPickleError(
            f"{str(path)!r} is {what}, a pickle-based file: loading it runs any code its author "
            f"put in it. Pass {TRUST_FLAG} only for a file from a source you trust. {hint}")


def stats_name(model: Path) -> Path:
    """The statistics file that belongs to a model file (final or checkpoint, either format)."""
    model = Path(model)
    for pattern, stats in ((_MODEL_RE, "obs_stats_{}.npz"), (_LEGACY_RE, "vecnormalize_{}.pkl")):
        m = pattern.fullmatch(model.name)
        if m:
            return model.with_name(stats.format(m.group(1)))
    return model.with_name(FINAL_STATS if model.suffix == ".pt" else LEGACY_STATS)


# --- files ------------------------------------------------------------------------------------

def atomic_write(path: Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a unique temporary file beside ``path``, fsync, then rename.

    Readers see the old file or the complete new one, never a partial one; concurrent writers
    never share a temporary name.
    """
    path = Path(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_json(path: Path, data) -> Path:
    """Atomically write ``data`` as indented JSON."""
    text = json.dumps(data, indent=2) + "\n"
    return atomic_write(path, lambda p: p.write_text(text))


def read_json(path: Path, what: str) -> dict:
    """A JSON object from ``path``; :class:`RunFolderError` naming the file if it is not one."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise RunFolderError(f"{what} {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise RunFolderError(f"{what} {str(path)!r} is unreadable or not valid JSON: {e}") from None
    if not isinstance(data, dict):
        raise RunFolderError(f"{what} {str(path)!r} must hold a JSON object, got "
                             f"{type(data).__name__}")
    return data


def read_config(run_dir: Path) -> dict:
    """The run's config.json; :class:`RunFolderError` if ``run_dir`` is not a run folder."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunFolderError(f"run folder {str(run_dir)!r} does not exist or is not a folder")
    if not (run_dir / CONFIG).is_file():
        raise RunFolderError(f"{str(run_dir)!r} is not a training run: it has no {CONFIG} "
                             "(start a new run there without --resume)")
    return read_json(run_dir / CONFIG, "run configuration")


def is_finished(run_dir: Path) -> dict | None:
    """training.json of a run that completed (and wrote its final model), else None."""
    run_dir = Path(run_dir)
    final = (run_dir / FINAL_MODEL).is_file() or (run_dir / LEGACY_MODEL).is_file()
    if not ((run_dir / SUMMARY).is_file() and final):
        return None
    try:
        summary = read_json(run_dir / SUMMARY, "training summary")
        int(summary["timesteps"])
    except (RunFolderError, KeyError, TypeError, ValueError) as e:
        print(f"ignoring the training summary {str(run_dir / SUMMARY)!r} ({e}); the run "
              "continues from its checkpoints")
        return None
    return summary


def prepare_new_run(run_dir: Path, force: bool) -> None:
    """Refuse a non-empty folder unless ``force``; with ``force`` remove the old run's files."""
    run_dir = Path(run_dir)
    remove_temporaries(run_dir)  # left by a writer killed before the run had a config.json
    present = sorted(p.name for p in run_dir.iterdir() if p.name != LOCK)
    if not present:
        return
    if not force:
        shown = ", ".join(present[:5]) + (", ..." if len(present) > 5 else "")
        raise RunFolderError(
            f"out folder {str(run_dir)!r} is not empty (it holds {shown}); pass --resume to "
            "continue the run in it, --force to replace it, or choose another --out")
    import shutil

    for name in RUN_FILES:
        (run_dir / name).unlink(missing_ok=True)
    for name in RUN_DIRS:
        if (run_dir / name).is_dir():
            shutil.rmtree(run_dir / name)


def remove_temporaries(run_dir: Path) -> list[Path]:
    """Delete temporary files a killed writer left (call only while holding the run's lock)."""
    run_dir = Path(run_dir)
    stale = [p for d in (run_dir, run_dir / CHECKPOINTS, run_dir / EVAL_LOG.parent)
             if d.is_dir() for p in d.glob(".*.tmp")]
    for p in stale:
        p.unlink(missing_ok=True)
    return stale


# --- lock -------------------------------------------------------------------------------------

class RunLock:
    """An exclusive ``fcntl.flock`` on ``run_dir/run.lock`` for the life of a training process.

    The kernel drops the lock when its process dies, however it dies, so a lock file left by a
    ``kill -9`` is recognised as stale (and reported) and taken over; a live holder makes
    :meth:`acquire` raise :class:`RunLockedError` naming its pid.
    """

    def __init__(self, run_dir: Path):
        self.path = Path(run_dir) / LOCK
        self._fd: int | None = None
        self.stale: dict | None = None  # the record left by a dead holder, if any

    def acquire(self) -> RunLock:
        import fcntl

        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _lock_record(fd)
            os.close(fd)
            who = (f"pid {holder.get('pid')} on {holder.get('host')}, started "
                   f"{holder.get('started')}") if holder else "another process"
            raise RunLockedError(f"run folder {str(self.path.parent)!r} is in use by {who} "
                                 f"(lock {str(self.path)!r}); wait for it or use another --out"
                                 ) from None
        self.stale = _lock_record(fd) or None
        if self.stale:
            print(f"found a stale lock {str(self.path)!r} from pid {self.stale.get('pid')} "
                  f"(started {self.stale.get('started')}), which no longer holds it "
                  "(killed?); taking it over")
        record = json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                             "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
        os.ftruncate(fd, 0)
        os.pwrite(fd, record.encode(), 0)
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        import fcntl

        os.ftruncate(self._fd, 0)  # a clean exit leaves no record, so nothing looks stale
        fcntl.flock(self._fd, fcntl.LOCK_UN)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def _lock_record(fd: int) -> dict:
    try:
        data = json.loads(os.pread(fd, 4096, 0).decode() or "{}")
    except (ValueError, UnicodeDecodeError):
        return {"pid": "?", "started": "?", "host": "?"}
    return data if isinstance(data, dict) else {}


# --- checkpoints ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Checkpoint:
    """One checkpoint: the model and its own observation statistics, both inside the run."""

    steps: int  # as claimed by latest.json or the file name; the model's own count wins
    model: Path
    stats: Path
    wall_time_s: float | None = None  # cumulative training wall time when it was written
    source: Path | None = None  # the file that claims ``steps`` (latest.json), None: the name


def confined(directory: Path, name, what: str) -> Path:
    """``directory/name`` for a bare file name that stays inside ``directory``; else an error."""
    directory = Path(directory)
    if not isinstance(name, str) or not name or Path(name).name != name or name in (".", ".."):
        raise RunFolderError(f"{what} must be a bare file name inside {str(directory)!r}, "
                             f"got {name!r}")
    path = directory / name
    if not path.resolve().is_relative_to(directory.resolve()):
        raise RunFolderError(f"{what} {str(path)!r} resolves outside {str(directory)!r} "
                             f"(to {str(path.resolve())!r})")
    return path


def checkpoint_pointer(directory: Path) -> Checkpoint:
    """The checkpoint latest.json names; :class:`RunFolderError` naming the file if unusable."""
    directory = Path(directory)
    pointer = directory / LATEST
    info = read_json(pointer, "checkpoint pointer")
    try:
        steps = int(info["timesteps"])
        model = confined(directory, info["model"], f"{pointer}: 'model'")
        key = "stats" if "stats" in info else "vecnormalize"  # the name before issue 19
        stats = confined(directory, info[key], f"{pointer}: {key!r}")
    except KeyError as e:
        raise RunFolderError(f"checkpoint pointer {str(pointer)!r} lacks the key {e}") from None
    except (TypeError, ValueError) as e:
        if isinstance(e, RunFolderError):
            raise
        raise RunFolderError(f"checkpoint pointer {str(pointer)!r}: 'timesteps' must be an "
                             f"integer, got {info.get('timesteps')!r}") from None
    wall = info.get("wall_time_s")
    return Checkpoint(steps, model, stats, float(wall) if isinstance(wall, int | float) else None,
                      pointer)


def checkpoints(directory: Path, report: Callable[[str], object] = print) -> list[Checkpoint]:
    """Checkpoints to try, best first: latest.json's, then every policy_<N>.pt (and, from run
    folders before issue 19, model_<N>.zip) by N descending, the pickle-free first at equal N.

    Problems with latest.json are passed to ``report`` (naming the file) and skipped. A model
    file that latest.json names is listed again under its own N if the pointer claims another
    count, so that a pointer that disagrees with its checkpoint can be skipped.
    """
    directory = Path(directory)
    found: list[Checkpoint] = []
    if (directory / LATEST).exists():
        try:
            found.append(checkpoint_pointer(directory))
        except RunFolderError as e:
            report(f"ignoring {e}")
    on_disk = []
    for rank, pattern in enumerate((_MODEL_RE, _LEGACY_RE)):
        for path in directory.iterdir() if directory.is_dir() else ():
            m = pattern.fullmatch(path.name)
            if m:
                on_disk.append((-int(m.group(1)), rank,
                                Checkpoint(int(m.group(1)), path, stats_name(path))))
    for *_, ckpt in sorted(on_disk, key=lambda t: t[:2]):
        if all((c.model, c.steps) != (ckpt.model, ckpt.steps) for c in found):
            found.append(ckpt)
    return found


def latest_checkpoint(directory: Path) -> dict | None:
    """latest.json's record if its two files exist (a quick look; no file is opened)."""
    try:
        ckpt = checkpoint_pointer(directory)
    except RunFolderError:
        return None
    if not (ckpt.model.is_file() and ckpt.stats.is_file()):
        return None
    return {"timesteps": ckpt.steps, "model": ckpt.model.name, "stats": ckpt.stats.name,
            "wall_time_s": ckpt.wall_time_s}


def check_model_file(path: Path) -> None:
    """Cheap integrity check of a model file, an SB3 ``.zip`` or a torch ``.pt`` (both zip
    archives): the CRCs of every member; raises naming it. Nothing is unpickled."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            bad = z.testzip()
            names = set(z.namelist())
    except (OSError, zipfile.BadZipFile, EOFError, ValueError) as e:
        raise RunFolderError(f"model file {str(path)!r} is missing or not a valid zip: {e}"
                             ) from None
    torch_file = any(n.endswith("/data.pkl") for n in names)
    complete = torch_file if Path(path).suffix == ".pt" else {"data", "policy.pth"} <= names
    if bad is not None or not complete:
        raise RunFolderError(f"model file {str(path)!r} is corrupt "
                             f"({'bad member ' + bad if bad else 'members missing'})")


def load_stats(path: Path, venv=None, *, trust_pickle: bool = False):
    """Observation statistics from ``path``: ``.npz`` (no pickle), or a legacy
    ``vecnormalize*.pkl`` only with ``trust_pickle``. With ``venv``: a ``VecNormalize`` over
    it; without: an object with ``normalize_obs`` and ``obs_rms``. Errors name the file."""
    path = Path(path)
    if path.suffix != ".pkl":
        from rbenv.agents import weights

        stats = weights.load_stats(path)
        return stats if venv is None else stats.vecnormalize(venv)
    if not path.is_file():
        raise RunFolderError(f"normalisation statistics {str(path)!r} do not exist")
    require_trust(path, "a pickled VecNormalize", trust_pickle)
    return _unpickle_stats(path, venv)


def _unpickle_stats(path: Path, venv):
    import pickle

    from stable_baselines3.common.vec_env import VecNormalize

    try:
        with open(path, "rb") as f:
            stats = pickle.load(f)
    except Exception as e:  # a corrupt pickle can raise almost anything
        raise RunFolderError(f"normalisation statistics {str(path)!r} are corrupt: "
                             f"{type(e).__name__}: {e}") from None
    if not isinstance(stats, VecNormalize):
        raise RunFolderError(f"{str(path)!r} holds a {type(stats).__name__}, not VecNormalize "
                             "statistics")
    if venv is not None:
        stats.set_venv(venv)
    return stats


def load_model(path: Path, algo: str | None = None, *, env=None, hyperparams=None,
               seed: int | None = None, trust_pickle: bool = False):
    """A model from ``policy*.pt`` + its ``.json`` (no pickle), or from an SB3 ``.zip`` (PPO or
    SAC; ``algo`` if known) only with ``trust_pickle``; raises naming the file.

    With ``env``, the model is rebuilt for training on it, with ``hyperparams`` (the run's)
    and ``seed``, and every saved state (optimizers too) is restored; without, it is built for
    inference from the saved spaces.
    """
    path = Path(path)
    check_model_file(path)
    if path.suffix == ".pt":
        from rbenv.agents import weights

        return weights.load_model(path, env=env, hyperparams=hyperparams, seed=seed)
    require_trust(path, "a Stable-Baselines3 .zip (it holds cloudpickled objects)",
                  trust_pickle)
    return _load_zip(path, algo, env)


def _load_zip(path: Path, algo: str | None, env):
    known = _model_classes()
    classes = (known[algo],) if algo in known else tuple(known.values())
    errors = []
    for cls in classes:
        try:
            return cls.load(path, device="cpu", **({} if env is None else {"env": env}))
        except Exception as e:  # wrong algorithm or a corrupt member
            errors.append(f"{cls.__name__}: {type(e).__name__}: {e}")
    raise RunFolderError(f"model file {str(path)!r} could not be loaded as "
                         f"{' or '.join(c.__name__ for c in classes)}: {'; '.join(errors)}")


def _model_classes() -> dict:
    """``rbenv train``'s algorithms by name (TQC and CrossQ only if sb3-contrib is installed)."""
    from stable_baselines3 import PPO, SAC, TD3

    classes = {"ppo": PPO, "sac": SAC, "td3": TD3}
    try:
        from sb3_contrib import TQC, CrossQ
    except ImportError:
        return classes
    return {**classes, "tqc": TQC, "crossq": CrossQ}


# --- loading a trained policy -----------------------------------------------------------------

@dataclass(frozen=True)
class RunFiles:
    """Where a policy's files are: the model, its own statistics, and the run's config."""

    model: Path
    stats: Path | None
    config: dict | None
    run_dir: Path | None


def locate(path) -> RunFiles:
    """Resolve a run folder, its final ``policy.pt`` or a checkpoint ``policy_<N>.pt`` (or the
    pickle-based ``model.zip`` / ``model_<N>.zip`` of older runs and foreign SB3 files).

    A checkpoint is paired with its own statistics (``obs_stats_<N>.npz``), a final model with
    ``obs_stats.npz`` (``vecnormalize*.pkl`` for the older names); the run's ``config.json`` is
    found beside the model or one level up. Nothing is opened but JSON.
    """
    path = Path(path)
    if path.is_dir():
        return _locate_in_run(path)
    if not path.is_file():
        raise RunFolderError(f"policy {str(path)!r} is neither a run folder nor a model file")
    checkpoint = _MODEL_RE.fullmatch(path.name) or _LEGACY_RE.fullmatch(path.name)
    stats = stats_name(path)
    zoo_stats = path.with_suffix("") / LEGACY_STATS  # RL Zoo keeps them in a folder named so
    if not checkpoint and not stats.is_file() and zoo_stats.is_file():
        stats = zoo_stats
    if not checkpoint and not stats.is_file():
        warnings.warn(f"no {stats.name} beside {str(path)!r} (nor the RL Zoo's "
                      f"{str(zoo_stats)!r}): the policy sees raw observations, which is right "
                      "only for a model trained without VecNormalize", stacklevel=3)
    if checkpoint and not stats.is_file():
        raise RunFolderError(f"checkpoint {str(path)!r} has no statistics file {str(stats)!r}; "
                             "without them the policy sees unnormalised observations")
    for run_dir in (path.parent, path.parent.parent):
        if (run_dir / CONFIG).is_file():
            return RunFiles(path, stats if stats.is_file() else None, read_config(run_dir),
                            run_dir)
    return RunFiles(path, stats if stats.is_file() else None, None, None)


def _locate_in_run(path: Path) -> RunFiles:
    config = read_config(path)
    for model, stats in ((FINAL_MODEL, FINAL_STATS), (LEGACY_MODEL, LEGACY_STATS)):
        if (path / model).is_file():
            return RunFiles(path / model, path / stats, config, path)
    ckpt = next(iter(checkpoints(path / CHECKPOINTS)), None)
    if ckpt is None:
        raise RunFolderError(f"run folder {str(path)!r} has no {FINAL_MODEL} and no "
                             "checkpoint yet")
    return RunFiles(ckpt.model, ckpt.stats, config, path)


def env_kwargs_of(config: dict | None) -> dict:
    """gym.make options of a run: its scene and env_kwargs (empty for an unknown run)."""
    if not config:
        return {}
    kwargs = config.get("env_kwargs") or {}
    if not isinstance(kwargs, dict):
        raise RunFolderError(f"run configuration: 'env_kwargs' must be an object, got {kwargs!r}")
    return {"scene": config.get("scene", "cubesat-12u"), **kwargs}


POLICY_ACTIONS = ("auto", "mean_throttle", "mode")


class RunPolicy:
    """A trained model with its observation statistics, behind SB3's ``predict`` interface.

    Works on one observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``; observations are the
    raw ones a ``gym.make``/``gym.make_vec`` env returns.

    action: what ``predict(..., deterministic=True)`` returns. ``"mode"``: SB3's deterministic
    action (the Gaussian's mean μ; the env clips it). ``"mean_throttle"``: the mean throttle
    E[clip(μ + σε, 0, 1)] of the stochastic policy that was trained (:func:`expected_throttle`).
    ``"auto"`` (default): ``mean_throttle`` for an unsquashed Gaussian policy (PPO, A2C) acting
    in throttle mode, where clip(μ, 0, 1) switches off every thruster whose mean is below zero
    but which the trained policy fires through its noise, and ``mode`` otherwise.
    """

    def __init__(self, model, vecnormalize=None, config: dict | None = None,
                 source: str = "model", action: str = "auto"):
        self.model, self.vecnormalize = model, vecnormalize
        self.config, self.source = config, source
        self.action = self._resolve_action(action)

    def _resolve_action(self, action: str) -> str:
        from rbenv.core import validation

        validation.choice("action", action, POLICY_ACTIONS)
        gaussian = _is_unsquashed_gaussian(self.model)
        if action == "auto":
            throttle = self.env_kwargs.get("action_mode", "throttle") == "throttle" \
                and _thrusters_only(self.config)
            return "mean_throttle" if gaussian and throttle else "mode"
        if action == "mean_throttle" and not gaussian:
            raise InvalidParameterError(
                f"action 'mean_throttle' needs an unsquashed Gaussian policy (PPO, A2C); "
                f"{type(self.model).__name__} from {self.source} has none; use 'mode'")
        return action

    @property
    def env_kwargs(self) -> dict:
        """The ``gym.make`` options the policy was trained with (scene, action mode, ...)."""
        return env_kwargs_of(self.config)

    @property
    def env_id(self) -> str:
        """The registered id (task) the policy was trained on; reorientation if unknown."""
        import rbenv

        return (self.config or {}).get("env_id") or rbenv.ENV_ID

    def make_env(self, **overrides):
        """``gym.make`` of the env this policy was trained on (``overrides`` win)."""
        import gymnasium as gym

        return gym.make(self.env_id, **{**self.env_kwargs, **overrides})

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Observations as the policy saw them in training."""
        obs = np.asarray(obs)
        expected = self.model.observation_space.shape
        if obs.shape[-len(expected):] != expected:
            raise ValueError(f"observation shape {obs.shape} does not match the policy's "
                             f"{expected} ({self.source}); evaluate it in the env it was "
                             f"trained on: {self.env_kwargs or 'see its config.json'}")
        return obs if self.vecnormalize is None else self.vecnormalize.normalize_obs(obs)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if deterministic and self.action == "mean_throttle":
            return self.mean_throttle(observation), state
        return self.model.predict(self.normalize(observation), state=state,
                                  episode_start=episode_start, deterministic=deterministic)

    def mean_throttle(self, observation) -> np.ndarray:
        """E[clip(μ + σε, 0, 1)] for one observation (n_act,) or a batch (n, n_act), float32."""
        import torch

        obs = np.asarray(self.normalize(observation), dtype=np.float32)
        batch = obs.ndim > 1
        with torch.no_grad():
            dist = self.model.policy.get_distribution(
                torch.as_tensor(obs if batch else obs[None])).distribution
            mean, std = dist.mean.numpy(), dist.stddev.numpy()
        out = expected_throttle(mean, std).astype(np.float32)
        return out if batch else out[0]


def _is_unsquashed_gaussian(model) -> bool:
    """True for an SB3 actor-critic policy whose actions are a diagonal Gaussian (PPO, A2C)."""
    from stable_baselines3.common.distributions import DiagGaussianDistribution

    return type(getattr(getattr(model, "policy", None), "action_dist", None)) \
        is DiagGaussianDistribution


def expected_throttle(mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    """E[clip(mean + std·ε, 0, 1)], ε ~ N(0, 1): the mean throttle of a clipped Gaussian policy.

    With the env's ``throttle = clip(a, 0, 1)`` the deterministic action clip(mean, 0, 1) is
    *not* the mean throttle of the stochastic policy: a mean below 0 gives 0, while the policy
    it was trained as fires that thruster a fraction of the time. mean, std: same shape.
    """
    from scipy.stats import norm

    lo, hi = -mean / std, (1.0 - mean) / std
    return (mean * (norm.cdf(hi) - norm.cdf(lo)) + std * (norm.pdf(lo) - norm.pdf(hi))
            + norm.sf(hi))


def _thrusters_only(config) -> bool:
    """Whether the run's scene actuates with thrusters alone (then a throttle action is a
    duty cycle in [0, 1]; a wheel's or a rod's action spans [-1, 1])."""
    import rbenv

    scene = (config or {}).get("scene")
    if scene is None:
        return True
    try:
        sc = rbenv.load_scene(scene)
    except ValueError:  # a scene file that is gone: keep the thruster default
        return True
    return sc.thrusters is not None and not sc.actuators


def load_policy(path, action: str = "auto", *, trust_pickle: bool = False) -> RunPolicy:
    """A ready policy from a run folder, its ``policy.pt`` or a checkpoint ``policy_<N>.pt``.

    The model comes with its own observation statistics and the run's configuration
    (``policy.make_env()`` builds the env it was trained on). A final model without statistics
    beside it (a model trained without VecNormalize) is used as is, with a warning; a
    checkpoint without its own statistics is an error. Nothing is unpickled: a pickle-based
    file (an older run's ``model.zip``/``vecnormalize.pkl``, a foreign SB3 ``.zip``) raises
    :class:`UntrustedPickleError` unless ``trust_pickle=True``.
    """
    files = locate(path)
    algo = (files.config or {}).get("algo")
    if files.stats is not None and files.stats.suffix == ".pkl":
        require_trust(files.stats, "a pickled VecNormalize", trust_pickle)
    model = load_model(files.model, algo,
                       trust_pickle=trust_pickle)
    stats = load_stats(files.stats, trust_pickle=trust_pickle) if files.stats else None
    return RunPolicy(model, stats, files.config, source=str(files.model), action=action)
