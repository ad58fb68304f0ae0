"""The run folder's format: its file names, atomic writes, JSON, checkpoints and locating a model.

A run folder (written by ``rbenv train``, :mod:`rbenv.agents.training`)::

    config.json             resolved run config (scene, env_kwargs, hyperparameters, threads)
    run.lock                held (fcntl) by the live training process; pid and start time inside
    checkpoints/            policy_<steps>.pt + policy_<steps>.json + obs_stats_<steps>.npz
                            (+ replay_buffer_<steps>.npz off-policy), latest.json
                            (RLlib: ckpt_<steps>/ folders, latest.json)
    eval/evaluations.npz    periodic evaluations over the whole run (kept across resumes)
    policy.pt, policy.json, obs_stats.npz, training.json, report.md, *.png    the finished run

A run folder is data: weights are tensors loaded with ``torch.load(weights_only=True)``, the
rest JSON or ``.npz`` loaded without pickle (:mod:`rbenv.agents.policies.weights`). Run folders
written before the pickle-free format (``model.zip``, ``vecnormalize.pkl``, ``model_<N>.zip``,
``vecnormalize_<N>.pkl``, ``replay_buffer_<N>.pkl``) and foreign SB3 ``.zip`` files are pickles:
unpickling runs any code their author put in them, so they load only with ``trust_pickle=True``
(``--trust-pickle``) and are refused otherwise with :class:`UntrustedPickleError`.

Loading a trained policy: :func:`rbenv.agents.policies.load_policy`. Training writes run folders
through :mod:`rbenv.agents.training.engine` (lock, new run, resume); this module only names
and reads what is in them, and imports neither torch nor Stable-Baselines3.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
from rbenv.core.errors import RbenvValueError

import rbenv

CONFIG = "config.json"
LOCK = "run.lock"
CHECKPOINTS = "checkpoints"
LATEST = "latest.json"
FINAL_MODEL, FINAL_STATS, SUMMARY = "policy.pt", "obs_stats.npz", "training.json"
FINAL_CONFIG = "policy.json"
FINAL_JAX_STATE = "policy.jax.npz"  # an SBX run's training state (weights.save_jax_state)
# The pickle-based names of run folders written before the pickle-free format (need trust_pickle).
LEGACY_MODEL, LEGACY_STATS = "model.zip", "vecnormalize.pkl"
EVAL_LOG = Path("eval") / "evaluations.npz"
# Everything `rbenv train` writes into a run folder; `--force` removes exactly these.
RUN_FILES = (CONFIG, FINAL_MODEL, FINAL_CONFIG, FINAL_JAX_STATE, FINAL_STATS, LEGACY_MODEL,
             LEGACY_STATS, SUMMARY, "report.md", "evaluation.json", "episode.png",
             "training_curve.png")
POLICY_DIR = "policy"  # an RLlib run's final RLModule folder
RUN_DIRS = (CHECKPOINTS, "eval", POLICY_DIR)
_MODEL_RE = re.compile(r"policy_(\d+)\.pt")
_LEGACY_RE = re.compile(r"model_(\d+)\.zip")
TRUST_FLAG = "trust_pickle=True (rbenv: --trust-pickle)"
LOAD_HINT = ("load it with rbenv.agents.policies.load_policy(PATH), which applies the run's "
             "observation normalisation (obs_stats.npz); the bare weights expect normalised "
             "observations and fail silently on raw ones")


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
    """training.json of a run that completed (and wrote its final model: policy.pt, an older
    run's model.zip, or an RLlib run's policy/), else None."""
    run_dir = Path(run_dir)
    final = (run_dir / FINAL_MODEL).is_file() or (run_dir / LEGACY_MODEL).is_file() \
        or (run_dir / POLICY_DIR).is_dir()
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
        key = "stats" if "stats" in info else "vecnormalize"  # the pickle-based format's name
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
    folders of the pickle-based format, model_<N>.zip) by N descending, the pickle-free first
    at equal N.

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


class TrainedOn:
    """What a trained policy knows of its run: ``config`` (its config.json, None if unknown),
    hence the env it was trained on. A base of every loaded policy class."""

    config: dict | None = None

    @property
    def env_kwargs(self) -> dict:
        """The ``gym.make`` options the policy was trained with (scene, action mode, ...)."""
        return env_kwargs_of(self.config)

    @property
    def env_id(self) -> str:
        """The registered id (task) the policy was trained on; reorientation if unknown."""
        return (self.config or {}).get("env_id") or rbenv.ENV_ID

    def make_env(self, **overrides):
        """``gym.make`` of the env this policy was trained on (``overrides`` win)."""
        return gym.make(self.env_id, **{**self.env_kwargs, **overrides})

