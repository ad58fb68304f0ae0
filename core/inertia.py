"""Inertia tensors: closed forms for the lecture's shapes, particle sums, meshes and checks.

All tensors are (3, 3) arrays in kg·m², expressed in body axes and taken about the centre of mass
unless an ``about=`` argument says otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import InvalidInertiaError, describe

__all__ = [
    "InvalidInertiaError",
    "MassProperties",
    "parallel_axis",
    "principal_axes",
    "validate",
]

# Relative tolerance for symmetry and for the triangle inequality of principal moments.
_RTOL = 1e-9


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), centre of mass (m, (3,)) and inertia about the centre of mass (kg·m², (3, 3))."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def validate(inertia, *, name: str = "inertia") -> np.ndarray:
    """Check that ``inertia`` (3, 3) is a physically valid, invertible rigid-body inertia.

    Rules: shape (3, 3); finite; symmetric; positive definite (every principal moment > 0);
    principal moments obey the triangle inequality ``I1 + I2 >= I3``. Returns the tensor as a
    float array (symmetrised to round-off). Raises :class:`InvalidInertiaError` naming the rule.
    """
    arr = np.asarray(inertia, dtype=float)
    if arr.shape != (3, 3):
        raise InvalidInertiaError(f"{name} must have shape (3, 3), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidInertiaError(f"{name} must be finite, got {describe(arr)}")
    scale = float(np.abs(arr).max())
    if scale == 0.0:
        raise InvalidInertiaError(f"{name} is all zeros; a rigid body needs positive moments")
    asym = float(np.abs(arr - arr.T).max())
    if asym > _RTOL * scale:
        raise InvalidInertiaError(
            f"{name} must be symmetric, got {describe(arr)} (max |I - Iᵀ| = {asym:.3g})"
        )
    arr = 0.5 * (arr + arr.T)
    moments = np.linalg.eigvalsh(arr)
    if moments[0] <= _RTOL * scale:
        raise InvalidInertiaError(
            f"{name} must be positive definite, got principal moments {describe(moments)}: a zero "
            "or negative moment (a thin rod, a point mass, or a sign error) has no inverse, so "
            "angular acceleration I⁻¹τ is undefined"
        )
    if moments[0] + moments[1] < moments[2] * (1.0 - _RTOL):
        raise InvalidInertiaError(
            f"{name} principal moments {describe(moments)} break the triangle inequality "
            f"I1 + I2 >= I3 ({moments[0] + moments[1]:.6g} < {moments[2]:.6g}); no mass "
            "distribution has this inertia"
        )
    return arr


def principal_axes(inertia) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and axes of a symmetric (3, 3) tensor.

    Returns ``(moments, R)``: moments (3,) ascending; R (3, 3) a proper rotation (det +1) whose
    columns are the principal axes in body coordinates, so ``inertia == R @ diag(moments) @ R.T``.
    """
    arr = np.asarray(inertia, dtype=float)
    moments, R = np.linalg.eigh(0.5 * (arr + arr.T))
    if np.linalg.det(R) < 0:
        R[:, 2] = -R[:, 2]
    return moments, R


def parallel_axis(inertia_com, mass: float, offset) -> np.ndarray:
    """Inertia about a point displaced by ``offset`` (m, (3,)) from the centre of mass.

    ``I_P = I_C + m (|d|² E − d dᵀ)``. inertia_com: (3, 3) about the centre of mass; mass in kg.
    To move between two points neither of which is the centre of mass, go through it.
    """
    d = np.asarray(offset, dtype=float)
    return np.asarray(inertia_com, dtype=float) + mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
