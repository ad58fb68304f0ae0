"""Reading an actuator's scene table: the checks every table parser shares.

Each error names the table and key (``wheels.max_torque[2]``), the value and the rule.
"""

from __future__ import annotations

import numpy as np

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError

__all__ = ["axes", "keys", "per_element"]

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


def safe_to_square(rows: np.ndarray) -> np.ndarray:
    """The (n, 3) rows, each whose |entry| exceeds 1e150 divided by its largest |entry|, so its
    squared norm cannot overflow; a direction is unchanged, other rows are returned as given."""
    huge = np.abs(rows).max(axis=1) > 1e150
    if not huge.any():
        return rows
    rows = np.array(rows, dtype=float)
    rows[huge] /= np.abs(rows[huge]).max(axis=1, keepdims=True)
    return rows


def axes(name: str, value) -> np.ndarray:
    """``name.axes``: 1 to 16 non-zero [x, y, z] body axes, returned normalised, (n, 3)."""
    arr = validation.finite_array(f"{name}.axes", value)
    if arr.ndim != 2 or arr.shape[1] != 3 or not 1 <= len(arr) <= MAX_ELEMENTS:
        raise InvalidParameterError(
            f"{name}.axes must be a list of 1 to {MAX_ELEMENTS} [x, y, z] axes, got shape "
            f"{arr.shape}")
    arr = safe_to_square(arr)
    norms = np.linalg.norm(arr, axis=1)
    if np.any(norms < 1e-9):
        raise InvalidParameterError(f"{name}.axes must be non-zero, got {arr.tolist()}")
    return arr / norms[:, None]


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
