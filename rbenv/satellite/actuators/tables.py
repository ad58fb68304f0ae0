"""Reading an actuator's scene table: the checks every table parser shares.

Each error names the table and key (``wheels.max_torque[2]``), the value and the rule.
"""

from __future__ import annotations

import numpy as np

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError, describe
from rbenv.core.vec import safe_to_square, unit_rows

__all__ = ["axes", "axis_rows", "keys", "per_element", "safe_to_square"]

MAX_ELEMENTS = 16  # wheels or rods in one table


def keys(name: str, table: dict, allowed: set, required: tuple) -> None:
    """Unknown keys and missing required keys of table ``name`` raise, naming them."""
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InvalidParameterError(f"{name} has unknown key(s) {unknown}; allowed: "
                                    f"{sorted(allowed)}")
    for key in required:
        if key not in table:
            raise InvalidParameterError(f"{name}.{key} is required")


def axis_rows(name: str, value) -> np.ndarray:
    """``name.axes``: 1 to 16 [x, y, z] body axes as given (finite), (n, 3)."""
    arr = validation.finite_array(f"{name}.axes", value)
    if arr.ndim != 2 or arr.shape[1] != 3 or not 1 <= len(arr) <= MAX_ELEMENTS:
        raise InvalidParameterError(
            f"{name}.axes must be a list of 1 to {MAX_ELEMENTS} [x, y, z] axes, got shape "
            f"{arr.shape}")
    return arr


def axes(name: str, value) -> np.ndarray:
    """``name.axes``: 1 to 16 non-zero [x, y, z] body axes, returned normalised, (n, 3)."""
    return unit_rows(f"{name}.axes", axis_rows(name, value))


def per_element(name: str, table: dict, key: str, n: int, default, low, high) -> np.ndarray:
    """``name.key``: one number for all n elements or n numbers, each in [low, high], (n,)."""
    arr = validation.finite_array(f"{name}.{key}", table.get(key, default))
    arr = np.broadcast_to(arr, (n,)) if arr.ndim == 0 else arr
    if arr.shape != (n,):
        raise InvalidParameterError(f"{name}.{key} must be a number or {n} numbers, got "
                                    f"shape {arr.shape}")
    for i, v in enumerate(arr):
        validation.number(f"{name}.{key}[{i}]", float(v), low=low, high=high)
    return np.array(arr, dtype=float)


def bounded_array(path: str, value, shape, *, bound=None) -> np.ndarray:
    """A read-only finite float array of ``shape``; entries within ±``bound`` if given."""
    arr = validation.array(path, value, shape, readonly=True)
    if bound is not None and arr.size and np.abs(arr).max() > bound:
        raise InvalidParameterError(
            f"{path} entries must lie within ±{bound:g}, got {describe(arr)}"
        )
    return arr
