"""Field checks shared by every boundary: core constructors, scenes, rendering, tasks and envs.

Each check takes the field's ``name`` (a path such as ``"physics.substeps"`` or
``"reset options['angular_velocity']"``) and the raw ``value``, and either returns the value
in a canonical form (float, int, str, bool or a finite float array) or raises a
:class:`rbenv.core.errors.RbenvValueError` subclass whose message names the field, the value and the
rule. The rules, in one place:

* a *number* is a real Python or NumPy int or float (``np.int64``, ``np.float32`` ...); bools,
  numeric strings, complex numbers and containers are refused, and so are NaN and ±inf;
* an *integer* is a Python or NumPy int (an integral float such as ``2.0`` is accepted where
  the caller says so);
* a *flag* is ``True`` or ``False`` only (``max_force = true`` is not 1 N);
* an *array* holds real numbers only (no bools, complex, strings, objects), is rectangular,
  has the documented shape and is finite;
* a *count* is an integer inside documented caps, so a tiny input cannot request unbounded
  work.

:func:`read_regular_file` is the one way rbenv reads user-named files: regular files only (a
FIFO, a device such as ``/dev/zero`` or a directory is refused at once, without blocking) and
at most a documented number of bytes.
"""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import numpy as np
from rbenv.core.errors import InvalidParameterError, NonFiniteError, describe

__all__ = [
    "UNIT_TOL",
    "array",
    "batch_shape",
    "choice",
    "count",
    "finite_array",
    "flag",
    "integer",
    "is_number",
    "number",
    "positive",
    "read_regular_file",
    "show",
    "unit_quaternion",
    "vectors",
]

# |q| of an orientation given as unit must be within this of 1.
UNIT_TOL = 1e-6
# Object arrays (e.g. huge Python ints) larger than this are refused without inspecting them.
_MAX_OBJECT_ENTRIES = 100_000

show = describe  # one repr for every error message (rbenv.core.errors)


def _type_name(value) -> str:
    return type(value).__name__


# --------------------------------------------------------------------------- scalars


def is_number(value) -> bool:
    """True for a real Python or NumPy int or float; False for bool, str, complex, containers."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _bounds_rule(low, high, low_open, high_open) -> str:
    parts = []
    if low is not None:
        parts.append(f"{'>' if low_open else '>='} {low!r}")
    if high is not None:
        parts.append(f"{'<' if high_open else '<='} {high!r}")
    return " and ".join(parts)


def _check_bounds(name, x, value, low, high, low_open, high_open) -> None:
    below = low is not None and (x <= low if low_open else x < low)
    above = high is not None and (x >= high if high_open else x > high)
    if below or above:
        rule = _bounds_rule(low, high, low_open, high_open)
        raise InvalidParameterError(f"{name} must be {rule}, got {show(value)}")


def number(name: str, value, *, low=None, high=None, low_open: bool = False,
           high_open: bool = False) -> float:
    """``value`` as a finite float within the bounds (``*_open``: strict inequality).

    A 0-d NumPy array of a real dtype counts as its number.
    """
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if not is_number(value):
        raise InvalidParameterError(
            f"{name} must be a real number (int or float), got {show(value)} "
            f"of type {_type_name(value)}"
        )
    try:
        x = float(value)
    except OverflowError:
        raise NonFiniteError(f"{name} must be finite, got an integer too large for a float: "
                             f"{show(value)}") from None
    if not math.isfinite(x):
        raise NonFiniteError(f"{name} must be finite, got {x!r}")
    _check_bounds(name, x, value, low, high, low_open, high_open)
    return x


def positive(name: str, value, *, high=None) -> float:
    """``value`` as a finite float > 0 (and <= ``high`` if given)."""
    return number(name, value, low=0.0, low_open=True, high=high)


def integer(name: str, value, *, low=None, high=None, allow_integral_float: bool = False) -> int:
    """``value`` as an int within [low, high]; bools and non-integral floats are refused.

    ``allow_integral_float``: also accept a finite float with an integral value (``2.0``).
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        n = int(value)
    elif allow_integral_float and isinstance(value, (float, np.floating)):
        if not math.isfinite(value) or value != math.floor(value):
            raise InvalidParameterError(f"{name} must be an integer, got {show(value)}")
        n = int(value)
    else:
        raise InvalidParameterError(
            f"{name} must be an integer, got {show(value)} of type {_type_name(value)}"
        )
    _check_bounds(name, n, value, low, high, False, False)
    return n


def count(name: str, value, *, low: int = 1, high: int) -> int:
    """An integer in [low, high]: a size or count with a documented cap ``high``."""
    return integer(name, value, low=low, high=high)


def choice(name: str, value, options) -> str:
    """``value`` if it is one of the string ``options``."""
    if not isinstance(value, str) or value not in options:
        raise InvalidParameterError(f"{name} must be one of {list(options)}, got {show(value)}")
    return value


def flag(name: str, value) -> bool:
    """``value`` if it is a bool (``True``/``False``; NumPy bools too); 0, 1 and strings are not."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidParameterError(f"{name} must be true or false, got {show(value)}")
    return bool(value)


# --------------------------------------------------------------------------- arrays


def finite_array(name: str, value) -> np.ndarray:
    """``value`` as a float array of any shape: real numbers only, rectangular and finite.

    Refuses bools, complex, strings, dicts and other objects with an error naming ``name``;
    NaN, ±inf and ints too large for a float raise :class:`NonFiniteError`.
    """
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise InvalidParameterError(
            f"{name} must be a number or an array of numbers, got {show(value)} "
            f"of type {_type_name(value)}"
        )
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError, RecursionError, OverflowError):
        raise InvalidParameterError(
            f"{name} must be a rectangular array of real numbers, got {show(value)}"
        ) from None
    kind = arr.dtype.kind
    if kind == "O":
        arr = _object_to_float(name, value, arr)
    elif kind not in "iuf":
        what = {"b": "bools", "c": "complex numbers", "U": "strings", "S": "bytes"}.get(
            kind, f"dtype {arr.dtype}")
        raise InvalidParameterError(
            f"{name} must hold real numbers (int or float), got {what}: {show(value)}"
        )
    else:
        arr = arr.astype(float, copy=False)
    if not np.isfinite(arr).all():
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        where = f" at index {bad}" if bad else ""
        raise NonFiniteError(f"{name} must be finite, got {show(arr)} (non-finite entry{where})")
    return arr


def _object_to_float(name: str, value, arr: np.ndarray) -> np.ndarray:
    """An object array of real numbers (e.g. huge Python ints) as floats, else a named error."""
    if arr.size > _MAX_OBJECT_ENTRIES or (arr.ndim == 0 and not is_number(arr.item())):
        bad = arr.item() if arr.ndim == 0 else None
        raise InvalidParameterError(
            f"{name} must be a rectangular array of real numbers, got {show(value)}"
            + ("" if bad is None else f" of type {_type_name(bad)}")
        )
    for index, item in np.ndenumerate(arr):
        if not is_number(item):
            raise InvalidParameterError(
                f"{name} must hold real numbers (int or float), got {show(item)} of type "
                f"{_type_name(item)} at index {index}"
            )
    try:
        return arr.astype(float)
    except OverflowError:
        raise NonFiniteError(f"{name} must be finite, got an integer too large for a float "
                             f"in {show(value)}") from None


def _with_shape(arr: np.ndarray) -> str:
    text = show(arr)
    return text if "shape" in text else f"{text} of shape {arr.shape}"


def _shape_text(shape) -> str:
    dims = ", ".join("n" if s is None else str(s) for s in shape)
    return f"({dims},)" if len(shape) == 1 else f"({dims})"


def array(name: str, value, shape: tuple, *, readonly: bool = False) -> np.ndarray:
    """``value`` as a finite float array of exactly ``shape`` (``None`` entries: any size).

    ``readonly``: return a private, write-protected copy (for frozen dataclasses).
    """
    arr = finite_array(name, value)
    if arr.ndim != len(shape) or any(
        s is not None and a != s for a, s in zip(arr.shape, shape, strict=True)
    ):
        raise InvalidParameterError(
            f"{name} must have shape {_shape_text(shape)}, got {_with_shape(arr)}"
        )
    if readonly:
        arr = np.array(arr, dtype=float)
        arr.setflags(write=False)
    return arr


def vectors(name: str, value, width: int) -> np.ndarray:
    """``value`` as a finite float array of shape (..., width): one vector or a batch."""
    arr = finite_array(name, value)
    if arr.ndim == 0 or arr.shape[-1] != width:
        raise InvalidParameterError(
            f"{name} must have shape ({width},) or (..., {width}), got {_with_shape(arr)}"
        )
    return arr


def unit_quaternion(name: str, value, *, normalize: bool = False,
                    single: bool = False) -> np.ndarray:
    """Quaternion(s) (..., 4), scalar first, checked to be unit (``single``: exactly (4,)).

    ``normalize=False``: |q| must be 1 within :data:`UNIT_TOL` (normalise first with
    ``rbenv.core.quaternion.normalize``). ``normalize=True``: any non-zero length is accepted and
    scaled to 1 (computed without overflow, so 1e200 entries are fine).
    """
    q = array(name, value, (4,)) if single else vectors(name, value, 4)
    big = np.max(np.abs(q), axis=-1, keepdims=True)
    if (big == 0.0).any():
        raise InvalidParameterError(f"{name} must be a non-zero quaternion (w, x, y, z), "
                                    f"got {show(q)}")
    scaled = q / big
    norm = big[..., 0] * np.sqrt(np.sum(scaled * scaled, axis=-1))
    if normalize:
        return scaled / np.sqrt(np.sum(scaled * scaled, axis=-1, keepdims=True))
    if np.abs(norm - 1.0).max(initial=0.0) > UNIT_TOL:
        raise InvalidParameterError(
            f"{name} must be a unit quaternion (|q| = 1 within {UNIT_TOL}), got |q| = "
            f"{show(norm)}; use core.quaternion.normalize"
        )
    return q


def batch_shape(fields: dict) -> tuple:
    """The common batch shape of named arrays, else an error listing every field's shape.

    fields: ``{name: (array, core_ndim)}``: the last ``core_ndim`` axes of each array are its
    own (3 for a vector ...), the leading ones are batch axes that must broadcast together.
    An empty batch (a 0 in the shape) is valid.
    """
    shapes = {n: a.shape[:a.ndim - k] for n, (a, k) in fields.items()}
    try:
        return tuple(np.broadcast_shapes(*shapes.values())) if shapes else ()
    except ValueError:
        listed = ", ".join(f"{n} {s}" for n, s in shapes.items())
        raise InvalidParameterError(
            f"batch shapes do not broadcast together: {listed}; leading (batch) dimensions must "
            "be equal or 1"
        ) from None


# --------------------------------------------------------------------------- files


def read_regular_file(name: str, path, *, max_bytes: int) -> bytes:
    """The bytes of a regular file of at most ``max_bytes`` bytes, else a named error.

    Opens without blocking (a FIFO does not hang), refuses anything that is not a regular
    file after symlinks are resolved (``/dev/zero``, a FIFO, a socket, a directory), and never
    reads more than ``max_bytes + 1`` bytes, so a file that grows while read is refused too.
    """
    path = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise InvalidParameterError(f"{name} {str(path)!r} cannot be opened: "
                                    f"{exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise InvalidParameterError(
                f"{name} {str(path)!r} must be a regular file, got a "
                f"{_file_kind(info.st_mode)}; only regular files are read"
            )
        if info.st_size > max_bytes:
            raise InvalidParameterError(
                f"{name} {str(path)!r} is {info.st_size} bytes; the limit is {max_bytes} bytes"
            )
        chunks, total = [], 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as exc:
        raise InvalidParameterError(f"{name} {str(path)!r} cannot be read: "
                                    f"{exc.strerror or exc}") from None
    finally:
        os.close(fd)
    if total > max_bytes:
        raise InvalidParameterError(
            f"{name} {str(path)!r} is larger than the limit of {max_bytes} bytes"
        )
    return b"".join(chunks)


def _file_kind(mode: int) -> str:
    for test, kind in ((stat.S_ISDIR, "directory"), (stat.S_ISFIFO, "FIFO (named pipe)"),
                       (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
                       (stat.S_ISSOCK, "socket")):
        if test(mode):
            return kind
    return "special file"
