"""The run-folder engine every training back end runs under: one way to start, resume, lock,
checkpoint on a schedule, keep the evaluation history, record versions and report.

A back end (:mod:`rbenv.agents.training.sb3`, :mod:`rbenv.agents.training.rllib`) supplies a
:class:`Backend`: it trains under the lock and returns what it did; :func:`run` does the rest.
A run is safe to kill, corrupt and share:

- every file is written to a unique temporary name and renamed, and ``latest.json`` moves
  only after a checkpoint is complete, so ``kill -9`` at any moment leaves the last complete
  checkpoint (temporaries a killed writer left are removed on resume);
- ``resume`` continues the folder given (never the folder recorded in its config.json);
- an exclusive lock refuses a second live run on the folder; a lock left by a killed run is
  recognised as stale;
- a new run into a non-empty folder needs ``force``; a finished run resumes as a no-op.
"""

from __future__ import annotations

import fcntl
import importlib
import json
import os
import platform
import shutil
import socket
import time
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import Protocol

import gymnasium as gym
import numpy as np
from rbenv.agents.policies.runfolder import (
    CHECKPOINTS,
    CONFIG,
    EVAL_LOG,
    LATEST,
    LOCK,
    RUN_DIRS,
    RUN_FILES,
    SUMMARY,
    RunFolderError,
    RunLockedError,
    atomic_write,
    is_finished,
    write_json,
)
from rbenv.agents.training.config import RunConfig, resumed_config

EVAL_KEYS = ("timesteps", "results", "ep_lengths", "successes")
LOCK_RECORD_WAIT_S = 2.0  # how long a refused start waits for a lock holder's record (s)


class Backend(Protocol):
    """What a training back end gives the engine (one object per training session)."""

    packages: tuple[str, ...]  # modules whose versions config.json records (beside NumPy, ...)

    def check(self, cfg: RunConfig) -> None:
        """Refuse, with a named error, a resolved config that this back end cannot train;
        called before anything is written."""

    def fit(self, cfg: RunConfig, out: Path, resume: bool) -> dict:
        """Train under the run's lock (from the newest checkpoint if ``resume``), save the
        final policy; return the summary (:func:`session_summary` plus the back end's keys)."""

    def report(self, out: Path, cfg: RunConfig, summary: dict) -> Path:
        """Write report.md of the finished run."""

    def load_hint(self, out: Path) -> str:
        """How to load the run's policy, printed at the end."""


def run(cfg: RunConfig, backend: Backend, *, resume: bool = False, force: bool = False,
        report: bool = True, dry_run: bool = False) -> Path:
    """Train (or resume) ``cfg`` with ``backend`` into its run folder; returns the folder.

    With ``resume``, the run in ``cfg.out`` defines the experiment; only the fields of
    ``cfg.RESUME_OVERRIDES`` (a new total of timesteps, the threads...) are taken from ``cfg``.
    Every field is checked, and the env made once, before anything is written. ``dry_run``:
    those checks, and what the run folder would refuse (:func:`check_folder`), then return
    without writing anything.
    """
    out = Path(cfg.out or cfg.default_out())
    if resume:
        cfg = resumed_config(type(cfg), out, {k: getattr(cfg, k) for k in cfg.RESUME_OVERRIDES},
                             engine=cfg.engine)
    else:
        cfg.out = str(out)
        cfg.resolve()
        cfg.check_env()
    backend.check(cfg)
    if dry_run:
        check_folder(out, resume, force)
        print(f"dry run: every check passed; nothing written (the run would "
              f"{'resume' if resume else 'start'} in {str(out)!r})")
        return out
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        if resume:
            for p in remove_temporaries(out):
                print(f"removed {str(p)!r}, left by a killed writer")
            report_missing_pointer(out / CHECKPOINTS)
            if _already_finished(out, cfg.timesteps):
                return out
        else:
            prepare_new_run(out, force)
            write_json(out / CONFIG, {**asdict(cfg), "versions": versions(backend.packages)})
        summary = backend.fit(cfg, out, resume)
        write_json(out / SUMMARY, summary)
    if report:
        backend.report(out, cfg, summary)
    print(f"run saved in {out}; {backend.load_hint(out)}")
    return out


def add_run_arguments(parser) -> None:
    """The flags of :func:`run` itself: ``--resume`` or ``--force``, and ``--no-report``."""
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true",
                      help="continue the run in --out from its last complete checkpoint, with "
                           "its saved configuration (a finished run is left as it is)")
    mode.add_argument("--force", action="store_true",
                      help="start a new run in a non-empty --out, deleting the old run's files")
    parser.add_argument("--no-report", action="store_true",
                        help="skip the final evaluation report")
    parser.add_argument("--dry-run", action="store_true",
                        help="run every check that runs before anything is written (flags, "
                             "the config, the env made once, the run folder), then exit "
                             "without writing anything")


def check_folder(out: Path, resume: bool, force: bool) -> None:
    """What the run folder ``out`` would refuse, read only: a live run holding its lock, or
    (a new run without ``force``) files of another run in it."""
    out = Path(out)
    if (out / LOCK).is_file():
        fd = os.open(out / LOCK, os.O_RDONLY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(fd, fcntl.LOCK_UN)
        except BlockingIOError:
            holder = _lock_record(fd)
            raise RunLockedError(f"run folder {str(out)!r} is in use by pid "
                                 f"{holder.get('pid', '?')} (lock {str(out / LOCK)!r}); wait "
                                 "for it or use another --out") from None
        finally:
            os.close(fd)
    if not resume and not force and out.is_dir():
        present = _run_files(out)
        if present:
            raise _not_empty(out, present)


def report_missing_pointer(directory: Path) -> bool:
    """Say so if checkpoints exist in ``directory`` but its latest.json does not (deleted, or
    lost): the resume then takes the newest complete checkpoint on disk. Returns whether."""
    directory = Path(directory)
    if (directory / LATEST).exists() or not directory.is_dir():
        return False
    if not any(p.name.startswith(("policy_", "model_", "ckpt_")) for p in directory.iterdir()):
        return False
    print(f"the checkpoint pointer {str(directory / LATEST)!r} is missing; resuming from the "
          "newest complete checkpoint on disk instead")
    return True


def _already_finished(out: Path, timesteps: int) -> bool:
    finished = is_finished(out)
    if finished and int(finished.get("timesteps", 0)) >= timesteps:
        print(f"run {str(out)!r} is already finished ({finished['timesteps']} timesteps); "
              f"nothing to do (pass --timesteps N > {finished['timesteps']} to train further)")
        return True
    return False


# --- the session: clock, schedule, summary ----------------------------------------------------

class WallClock:
    """Training wall time accumulated over every session of a run (kept in checkpoints), and
    this session's process CPU time (the figure that other busy processes do not inflate)."""

    def __init__(self, before: float = 0.0):
        self.before, self.start = float(before), time.perf_counter()
        self.cpu_start = time.process_time()

    def session(self) -> float:
        return time.perf_counter() - self.start

    def session_cpu(self) -> float:
        return time.process_time() - self.cpu_start

    def total(self) -> float:
        return self.before + self.session()


def next_multiple(steps: int, every: int) -> int:
    """The first multiple of ``every`` after ``steps``: when a periodic task is next due."""
    return (int(steps) // int(every) + 1) * int(every)


def session_summary(cfg: RunConfig, steps: int, resumed_from: int, clock: WallClock) -> dict:
    """training.json's keys every back end writes."""
    session = clock.session()
    return {"engine": cfg.engine, "timesteps": int(steps), "wall_time_s": clock.total(),
            "session_wall_time_s": session, "session_cpu_time_s": clock.session_cpu(),
            # The machine's load while training: read a wall time beside it.
            "load_average_1min": round(os.getloadavg()[0], 2),
            "session_steps_per_s": (steps - resumed_from) / max(session, 1e-9),
            "resumed_from": resumed_from or None, "threads": cfg.threads}


def versions(packages: tuple[str, ...]) -> dict:
    """Python, NumPy, Gymnasium, the back end's ``packages`` and the CPU: what a run ran on."""
    found = {name: importlib.import_module(name).__version__ for name in packages}
    return {"python": platform.python_version(), "numpy": np.__version__,
            "gymnasium": gym.__version__, **found, "cpu": cpu_kind()}


def cpu_kind() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def point_latest(directory: Path, steps: int, wall_time_s: float | None, **files: str) -> None:
    """Point latest.json at checkpoint ``steps`` (its ``files`` by key); call only once they
    are complete, so the pointer never names a torn checkpoint."""
    write_json(Path(directory) / LATEST, {"timesteps": int(steps), **files,
                                          "wall_time_s": wall_time_s})


# --- the evaluation history -------------------------------------------------------------------

def load_eval_history(log: Path, upto: int) -> dict:
    """Evaluations at timesteps <= ``upto`` from ``log`` (empty if absent; warns if corrupt).

    Entries after a resumed checkpoint are dropped, since those steps are trained again.
    """
    history = {k: [] for k in EVAL_KEYS}
    if upto <= 0 or not log.exists():
        return history
    try:
        with open(log, "rb") as f, np.load(f) as data:  # closed also when the zip is torn
            loaded = {k: data[k].tolist() for k in EVAL_KEYS}
    except Exception as e:  # a torn or foreign file: keep training, say what was lost
        warnings.warn(f"evaluation history {str(log)!r} is unreadable ({type(e).__name__}: "
                      f"{e}); starting a new one", stacklevel=2)
        return history
    keep = [i for i, t in enumerate(loaded["timesteps"]) if t <= upto]
    return {k: [loaded[k][i] for i in keep] for k in EVAL_KEYS}


def record_evaluation(log: Path, history: dict, steps: int, outcome: dict) -> None:
    """Append one evaluation (``results``, ``ep_lengths``, ``successes`` per episode) and
    rewrite ``log`` atomically, in the format of SB3's ``EvalCallback``."""
    history["timesteps"].append(int(steps))
    for key in EVAL_KEYS[1:]:
        history[key].append(list(outcome[key]))
    log.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(log, lambda p: _savez(p, history))


def _savez(path: Path, history: dict) -> None:
    with open(path, "wb") as f:  # np.savez on a name would append ".npz"
        np.savez(f, **{k: np.asarray(v) for k, v in history.items()})


# --- a new run --------------------------------------------------------------------------------

def prepare_new_run(run_dir: Path, force: bool) -> None:
    """Refuse a non-empty folder unless ``force``; with ``force`` remove the old run's files."""
    run_dir = Path(run_dir)
    remove_temporaries(run_dir)  # left by a writer killed before the run had a config.json
    present = _run_files(run_dir)
    if not present:
        return
    if not force:
        raise _not_empty(run_dir, present)
    for name in RUN_FILES:
        (run_dir / name).unlink(missing_ok=True)
    for name in RUN_DIRS:
        if (run_dir / name).is_dir():
            shutil.rmtree(run_dir / name)


def _run_files(run_dir: Path) -> list[str]:
    """The names in ``run_dir`` that a new run would have to replace (not its lock, nor the
    temporaries a killed writer left)."""
    return sorted(p.name for p in run_dir.iterdir()
                  if p.name != LOCK and not p.match(".*.tmp") and not p.match(".*.tmpdir"))


def _not_empty(run_dir: Path, present: list[str]) -> RunFolderError:
    shown = ", ".join(present[:5]) + (", ..." if len(present) > 5 else "")
    return RunFolderError(
        f"out folder {str(run_dir)!r} is not empty (it holds {shown}); pass --resume to "
        "continue the run in it, --force to replace it, or choose another --out")


def remove_temporaries(run_dir: Path) -> list[Path]:
    """Delete the temporary files and folders (``.*.tmp``, ``.*.tmpdir``) a killed writer left
    (call only while holding the run's lock)."""
    run_dir = Path(run_dir)
    stale = [p for d in (run_dir, run_dir / CHECKPOINTS, run_dir / EVAL_LOG.parent)
             if d.is_dir() for pattern in (".*.tmp", ".*.tmpdir") for p in d.glob(pattern)]
    for p in stale:
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
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
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        holder = self._wait_for_holder(fd)
        if holder is not None:
            os.close(fd)
            who = (f"pid {holder.get('pid')} on {holder.get('host')}, started "
                   f"{holder.get('started')}") if holder else "another process"
            raise RunLockedError(f"run folder {str(self.path.parent)!r} is in use by {who} "
                                 f"(lock {str(self.path)!r}); wait for it or use another --out"
                                 )
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

    @staticmethod
    def _wait_for_holder(fd: int) -> dict | None:
        """Take the flock on ``fd`` and return None, or return the live holder's record.

        A holder writes its record just after it takes the lock and clears it just before it
        lets go, so an empty record under a held lock is a holder in one of those two moments:
        try again for up to :data:`LOCK_RECORD_WAIT_S` until it has a record or has gone, and
        return ``{}`` (no record) only if neither happens.
        """
        deadline = time.monotonic() + LOCK_RECORD_WAIT_S
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return None
            except BlockingIOError:
                holder = _lock_record(fd)
            if holder or time.monotonic() >= deadline:
                return holder
            time.sleep(0.02)

    def release(self) -> None:
        if self._fd is None:
            return
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


