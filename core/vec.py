"""Small batched 3-vector kernels.

``np.cross`` and ``np.linalg.solve`` carry microseconds of overhead per call on tiny arrays;
these component-wise versions work on any leading batch shape ``(..., 3)`` and stay cheap both
for one body and for thousands.
"""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product ``a × b``. a, b: (..., 3) (broadcast). Returns (..., 3)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the last axis. a, b: (..., 3). Returns (...)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm(a: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis. a: (..., 3). Returns (...)."""
    return np.sqrt(dot(a, a))


def matvec(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Matrix-vector product ``m @ v`` with broadcasting. m: (..., 3, 3), v: (..., 3)."""
    return np.einsum("...ij,...j->...i", m, v)


def solve3(cols: tuple[np.ndarray, np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for 3×3 systems given by their columns, by Cramer's rule.

    cols: three (..., 3) arrays, the columns of A; b: (..., 3). Returns x: (..., 3).
    Used inside Newton iterations where A is well conditioned (near the identity).
    """
    c0, c1, c2 = cols
    c12 = cross(c1, c2)
    det = dot(c0, c12)
    x0 = dot(b, c12)
    x1 = dot(c0, cross(b, c2))
    x2 = dot(c0, cross(c1, b))
    return np.stack((x0, x1, x2), axis=-1) / det[..., None]
