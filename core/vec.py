"""Array front-end, shape (..., 3), for the component kernels of :mod:`rbenv.core.kernels`.

The formulas live once, in :mod:`rbenv.core.kernels`; these wrappers split arrays into components
and stack the result, for code that holds vectors as (..., 3) arrays (quaternion helpers, force
generators, reference solutions). ``np.cross`` is avoided: it costs microseconds per call on
small arrays.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import kernels
from rbenv.core.errors import InvalidParameterError


def _parts(a) -> tuple:
    return kernels.unpack(np.asarray(a, dtype=float))


def cross(a, b) -> np.ndarray:
    """Cross product ``a × b``. a, b: (..., 3) (broadcast). Returns (..., 3)."""
    return kernels.pack(kernels.cross(_parts(a), _parts(b)))


def dot(a, b):
    """Dot product over the last axis. a, b: (..., 3). Returns (...) (a float for (3,) inputs)."""
    return kernels.dot(_parts(a), _parts(b))


def safe_to_square(rows: np.ndarray) -> np.ndarray:
    """The (n, 3) rows, each whose |entry| exceeds 1e150 divided by its largest |entry|, so its
    squared norm cannot overflow; a direction is unchanged, other rows are returned as given."""
    huge = np.abs(rows).max(axis=1) > 1e150
    if not huge.any():
        return rows
    rows = np.array(rows, dtype=float)
    rows[huge] /= np.abs(rows[huge]).max(axis=1, keepdims=True)
    return rows


def unit_rows(name: str, rows: np.ndarray) -> np.ndarray:
    """The (n, 3) rows of finite floats ``rows`` normalised (spin or rod axes); a row shorter
    than 1e-9 (after scaling a huge one down) raises, naming ``name``."""
    rows = safe_to_square(rows)
    norms = np.linalg.norm(rows, axis=1)
    if np.any(norms < 1e-9):
        raise InvalidParameterError(f"{name} must be non-zero, got {rows.tolist()}")
    return rows / norms[:, None]
