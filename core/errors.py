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


class NonFiniteError(InvalidParameterError):
    """An input or a simulated state contains NaN or infinity (or overflowed).

    A subclass of :class:`InvalidParameterError`, since a non-finite input is a bad parameter;
    catch ``NonFiniteError`` alone to tell a diverged simulation apart.
    """


def describe(value) -> str:
    """Short, readable rendering of a value for error messages; see
    :func:`rbenv.core.validation.show`."""
    from rbenv.core.validation import show

    return show(value)


def require_finite(name: str, value) -> np.ndarray:
    """``value`` as a finite float array; see :func:`rbenv.core.validation.finite_array`."""
    from rbenv.core.validation import finite_array

    return finite_array(name, value)


def require_positive(name: str, value) -> float:
    """``value`` as a finite float > 0; see :func:`rbenv.core.validation.positive`."""
    from rbenv.core.validation import positive

    return positive(name, value)
