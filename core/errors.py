"""Exceptions raised by the rigid-body core.

Every error is a ``ValueError`` subclass whose message names the field, the offending value and
the rule it broke, so that a user can fix the input without reading the source.
"""

from __future__ import annotations

import numpy as np


class RbenvValueError(ValueError):
    """Base class: a parameter, state or input broke a documented rule."""


class InvalidInertiaError(RbenvValueError):
    """An inertia tensor is not a physically valid, invertible rigid-body inertia."""


class InvalidParameterError(RbenvValueError):
    """A scalar or array parameter (mass, dt, size, ...) is outside its allowed range."""


class NonFiniteError(RbenvValueError):
    """An input or a simulated state contains NaN or infinity."""


def describe(value) -> str:
    """Short, readable rendering of a value for error messages."""
    arr = np.asarray(value)
    if arr.ndim == 0:
        return repr(arr.item())
    if arr.size <= 9:
        return np.array2string(arr, precision=6, separator=", ")
    return f"array of shape {arr.shape}"


def require_finite(name: str, value) -> np.ndarray:
    """``value`` as a float array; raises :class:`NonFiniteError` if any entry is not finite."""
    arr = np.asarray(value, dtype=float)
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))
        where = "" if arr.ndim == 0 else f" at index {tuple(int(i) for i in bad[0])}"
        raise NonFiniteError(
            f"{name} must be finite, got {describe(value)} (non-finite entry{where})"
        )
    return arr


def require_positive(name: str, value) -> float:
    """Return ``value`` as a float, raising unless it is finite and strictly positive."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"{name} must be a positive number, got {value!r}") from exc
    if not np.isfinite(x) or x <= 0.0:
        raise InvalidParameterError(f"{name} must be finite and > 0, got {x!r}")
    return x
