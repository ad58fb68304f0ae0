"""Exceptions raised by the rigid-body core.

Every error is a ``ValueError`` subclass whose message names the field, the offending value and
the rule it broke, so that a user can fix the input without reading the source.
"""

from __future__ import annotations

import reprlib

import numpy as np


class RbenvValueError(ValueError):
    """Base class: a parameter, state or input broke a documented rule."""


class InvalidInertiaError(RbenvValueError):
    """An inertia tensor is not a physically valid, invertible rigid-body inertia."""


class InvalidParameterError(RbenvValueError):
    """A scalar or array parameter (mass, dt, size, ...) is outside its allowed range."""


class NonFiniteError(InvalidParameterError):
    """An input or a simulated state contains NaN or infinity (or overflowed).

    A subclass of :class:`InvalidParameterError`, since a non-finite input is a bad parameter;
    catch ``NonFiniteError`` alone to tell a diverged simulation apart.
    """


# Bounds of describe()'s repr: long strings, deep nesting and big containers are cut short.
_repr = reprlib.Repr()
_repr.maxstring = 60
_repr.maxother = 60
_repr.maxlevel = 3
_repr.maxlist = _repr.maxtuple = _repr.maxdict = _repr.maxset = 6


def describe(value) -> str:
    """A short repr of any value for error messages (bounded in length and nesting depth);
    :func:`rbenv.core.validation.show` is this function."""
    if (isinstance(value, np.ndarray) and value.ndim == 0) or isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, np.ndarray):
        if value.size <= 9:
            return np.array2string(value, precision=6, separator=", ", threshold=9)
        return f"array of shape {value.shape}, dtype {value.dtype}"
    try:
        return _repr.repr(value)
    except Exception:  # a hostile __repr__ must not replace the real error
        return f"<{type(value).__name__}>"
