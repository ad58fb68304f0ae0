"""An exported C policy flown from Python: :class:`CPolicy`, behind the same ``predict()``.

``rbenv export RUN --format c --out DIR`` (:mod:`rbenv.agents.policies.export`) writes
``DIR/policy.c``, ``DIR/policy.h`` and ``DIR/export.json`` (the run's env id and env options).
:class:`CPolicy` compiles ``policy.c`` into a shared library with the system C compiler (``$CC``,
else ``cc``), or opens a library compiled from it, and calls ``rbenv_policy`` through ctypes
for every observation, so that ``rbenv evaluate --policy DIR/policy.c`` flies the very code a
flight computer would run. Flying a C policy runs its code: open only files you trust, as you
would run any program. Nothing here needs torch.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from rbenv.agents.policies.runfolder import RunFolderError, TrainedOn, read_json

C_SOURCE, C_HEADER, LIBRARY = "policy.c", "policy.h", "policy.so"
MANIFEST = "export.json"
SUFFIXES = (".c", ".so")
FUNCTION = "rbenv_policy"


class CompileError(RunFolderError):
    """An exported C policy could not be compiled or loaded (no compiler, a compiler error)."""


def compiler() -> str | None:
    """The system C compiler: ``$CC`` if set, else ``cc`` on the PATH; None if there is none."""
    return shutil.which(os.environ.get("CC", "cc"))


def compile_shared(source: Path, library: Path, flags: tuple[str, ...] = ("-O2",)) -> Path:
    """Compile the C file ``source`` into the shared library ``library`` (C99, ``-lm``)."""
    cc = compiler()
    if cc is None:
        raise CompileError(f"no C compiler to build {str(source)!r}: install one (Debian: "
                           "apt-get install gcc) or set CC")
    cmd = [cc, "-std=c99", *flags, "-shared", "-fPIC", str(source), "-o", str(library), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise CompileError(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    return Path(library)


def manifest(path: Path) -> dict:
    """``export.json`` beside an exported ``policy.c``/``policy.so`` (or in its folder)."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    return read_json(folder / MANIFEST, "export manifest")


def is_exported(path) -> bool:
    """Whether ``path`` names an exported C policy, a ``.c`` or ``.so`` file (its export.json
    beside it is read when it is opened, and its absence named then)."""
    path = Path(path)
    return path.suffix in SUFFIXES and path.is_file()


def _load(library: Path):
    """The loaded shared library and its ``rbenv_policy`` function."""
    try:
        lib = ctypes.CDLL(str(library.resolve()))
        return lib, getattr(lib, FUNCTION)
    except (OSError, AttributeError) as e:
        raise CompileError(f"{str(library)!r} is not a loadable library with {FUNCTION}: {e}"
                           ) from None


class CPolicy(TrainedOn):
    """``rbenv_policy`` of an exported ``policy.c`` (compiled here) or of its compiled library.

    ``predict`` takes raw env observations, one ``(obs_dim,)`` or a batch ``(n, obs_dim)``, and
    returns the env's actions as float32, one C call per observation. ``config``: the
    manifest's ``env_id``, ``scene`` and ``env_kwargs``, so :meth:`make_env` builds the env the
    run was trained on.
    """

    def __init__(self, path):
        path = Path(path)
        if path.suffix not in SUFFIXES or not path.is_file():
            raise RunFolderError(f"C policy {str(path)!r} must be an exported policy.c or its "
                                 "compiled shared library (.so)")
        info = manifest(path)
        self.config = {k: info[k] for k in ("env_id", "scene", "env_kwargs") if k in info}
        self.source = str(path)
        self.obs_dim, self.act_dim = int(info["obs_dim"]), int(info["act_dim"])
        if path.suffix == ".c":
            # A loaded library stays mapped after its file is removed: compile, load, clean up.
            with tempfile.TemporaryDirectory(prefix="rbenv-cpolicy-") as tmp:
                lib, fn = _load(compile_shared(path, Path(tmp) / LIBRARY))
        else:
            lib, fn = _load(path)
        fn.argtypes = [ctypes.POINTER(ctypes.c_float), ctypes.POINTER(ctypes.c_float)]
        fn.restype = None
        self._lib, self._fn = lib, fn

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.ascontiguousarray(observation, dtype=np.float32)
        single = obs.ndim == 1
        batch = obs[None] if single else obs
        if batch.ndim != 2 or batch.shape[1] != self.obs_dim:
            raise ValueError(f"observation shape {obs.shape} does not match the C policy's "
                             f"({self.obs_dim},) ({self.source})")
        out = np.empty((len(batch), self.act_dim), np.float32)
        f32 = ctypes.POINTER(ctypes.c_float)
        for row, act in zip(batch, out, strict=True):
            self._fn(row.ctypes.data_as(f32), act.ctypes.data_as(f32))
        return (out[0] if single else out), state
