"""Unit quaternions for attitude, batched over leading dimensions.

Convention (used everywhere in rbenv): scalar first ``q = (w, x, y, z)``, Hamilton product, and
``q`` maps body to world: ``v_W = q ⊗ (0, v_B) ⊗ q*``. SciPy's ``Rotation`` is scalar-last by
default; pass ``scalar_first=True`` when converting at the boundary.

Every function accepts arrays with leading batch dimensions, ``(..., 4)`` for quaternions and
``(..., 3)`` for vectors, and broadcasts them.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import kernels
from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError, describe
from rbenv.core.vec import dot

_EPS = np.finfo(float).eps
# A rotation matrix must satisfy |RᵀR − E| <= this entrywise (and det R > 0). Matrices built in
# float64 from quaternions are orthonormal to ~1e-15; 1e-6 also admits matrices written with
# seven significant digits (as CAD tools and papers print them), as UNIT_TOL does for |q|.
ROTATION_TOL = 1e-6


def _split(q: np.ndarray):
    return q[..., 0], q[..., 1], q[..., 2], q[..., 3]


def _parts(a) -> tuple:
    """Components of an (..., k) array as views (floats for a single (k,) vector)."""
    return kernels.unpack(np.asarray(a, dtype=float))


def identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity quaternion(s) ``(1, 0, 0, 0)`` of batch shape ``shape``. Returns (*shape, 4)."""
    q = np.zeros((*shape, 4))
    q[..., 0] = 1.0
    return q


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` (apply q first, then p). p, q: (..., 4). Returns (..., 4)."""
    return kernels.pack(kernels.qmul(_parts(p), _parts(q)))


def conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``; the inverse of a unit quaternion. q: (..., 4)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def normalize(q: np.ndarray) -> np.ndarray:
    """Scale ``q`` (..., 4) to unit length; a zero quaternion raises ``InvalidParameterError``."""
    q = check.vectors("quaternion", q, 4)
    n = np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    if np.all((n > 0.0) & (n < np.inf)):
        return q / n
    # |q|² overflowed or underflowed somewhere: divide by the largest entry first.
    return check.unit_quaternion("quaternion", q, normalize=True)


def canonical(q: np.ndarray) -> np.ndarray:
    """Representative with ``w >= 0`` of the double cover ``q ~ -q``. q: (..., 4)."""
    q = np.asarray(q, dtype=float)
    return np.where(q[..., :1] < 0.0, -q, q)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors by unit quaternions: ``q ⊗ (0, v) ⊗ q*``. q: (..., 4), v: (..., 3).

    With body→world ``q`` this maps ``v_B`` to ``v_W``; ``rotate(conjugate(q), v_W)`` gives ``v_B``.
    A non-unit ``q`` (|q| off 1 by more than ``rbenv.core.validation.UNIT_TOL``), which would scale
    the vectors by |q|², raises :class:`InvalidParameterError`.
    """
    q = check.unit_quaternion("q", q)
    return kernels.pack(kernels.rotate(_parts(q), _parts(check.vectors("v", v, 3))))


def rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate by the inverse of unit ``q``: ``q* ⊗ (0, v) ⊗ q`` (world→body for body→world q)."""
    q = check.unit_quaternion("q", q)
    return kernels.pack(kernels.rotate_inverse(_parts(q), _parts(check.vectors("v", v, 3))))


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix ``R`` with ``R v = rotate(q, v)``. q: (..., 4) unit. Returns (..., 3, 3).

    A q of another shape or not of unit length raises :class:`InvalidParameterError`.
    """
    w, x, y, z = _split(check.unit_quaternion("q", q))
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    rows = (
        (1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)),
        (2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)),
        (2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)),
    )
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (canonical, ``w >= 0``) of rotation matrices R: (..., 3, 3).

    Uses Shepperd's method: pick the largest of ``w², x², y², z²`` as pivot, so the result is
    accurate for every rotation, including angles near π. A matrix that is not a proper
    rotation (orthonormal within :data:`ROTATION_TOL`, det +1) raises
    :class:`InvalidParameterError`: a reflection or a scaled matrix has no quaternion.
    """
    R = rotation_matrix("R", R)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    trace = m00 + m11 + m22
    # Four candidate solutions, one per pivot; each row is (w, x, y, z) times 4*pivot.
    cand = np.stack(
        (
            np.stack((1 + trace, R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                      R[..., 1, 0] - R[..., 0, 1]), axis=-1),
            np.stack((R[..., 2, 1] - R[..., 1, 2], 1 + m00 - m11 - m22, R[..., 0, 1] + R[..., 1, 0],
                      R[..., 0, 2] + R[..., 2, 0]), axis=-1),
            np.stack((R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0], 1 - m00 + m11 - m22,
                      R[..., 1, 2] + R[..., 2, 1]), axis=-1),
            np.stack((R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0],
                      R[..., 1, 2] + R[..., 2, 1], 1 - m00 - m11 + m22), axis=-1),
        ),
        axis=-2,
    )
    pivots = np.stack((1 + trace, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22),
                      axis=-1)
    best = np.argmax(pivots, axis=-1)
    q = np.take_along_axis(cand, best[..., None, None], axis=-2)[..., 0, :]
    return canonical(normalize(q))


def rotation_matrix(name: str, value) -> np.ndarray:
    """``value`` as finite (..., 3, 3) proper rotation matrices, else a named error."""
    R = check.finite_array(name, value)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise InvalidParameterError(f"{name} must have shape (3, 3) or (..., 3, 3), got "
                                    f"{describe(R)} of shape {R.shape}")
    off = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(initial=0.0)
    det = np.linalg.det(R)
    if not off <= ROTATION_TOL or (det <= 0.0).any():
        raise InvalidParameterError(
            f"{name} must be a rotation matrix (RᵀR = E within {ROTATION_TOL} and det R = +1), "
            f"got {describe(R)} with max |RᵀR − E| = {off:.3g} and det R = {describe(det)}")
    return R


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation by ``angle`` (rad, (...)) about ``axis`` ((..., 3), any non-zero length)."""
    axis = check.vectors("axis", axis, 3)
    n = np.sqrt(dot(axis, axis))
    if not np.all((n > 0.0) & (n < np.inf)):
        raise InvalidParameterError(
            f"axis must be a non-zero 3-vector of finite length, got {describe(axis)}"
        )
    half = 0.5 * check.finite_array("angle", angle)
    s = (np.sin(half) / n)[..., None]
    return np.concatenate((np.cos(half)[..., None] * np.ones_like(s), s * axis), axis=-1)


def from_rotation_vector(v: np.ndarray) -> np.ndarray:
    """Exponential map: the rotation by angle ``|v|`` (rad) about ``v/|v|``. v: (..., 3).

    Exact for every ``|v|``; uses the Taylor series of ``sin(θ/2)/θ`` near zero.
    """
    return kernels.pack(kernels.exp(_parts(v)))


def to_rotation_vector(q: np.ndarray) -> np.ndarray:
    """Logarithm map: rotation vector (rad) of unit ``q`` (..., 4), angle in [0, π]."""
    q = canonical(q)
    s = np.sqrt(dot(q[..., 1:], q[..., 1:]))
    theta = 2.0 * np.arctan2(s, q[..., 0])
    small = s < 1e-12
    k = np.where(small, 2.0 / np.maximum(q[..., 0], _EPS), theta / np.where(small, 1.0, s))
    return k[..., None] * q[..., 1:]


def angle(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Geodesic angle (rad, in [0, π]) between orientations p and q: the angle of ``p* ⊗ q``.

    p, q: (..., 4) unit. Insensitive to the double cover (``angle(p, -p) == 0``).
    """
    d = multiply(conjugate(p), q)
    s = np.sqrt(dot(d[..., 1:], d[..., 1:]))
    return 2.0 * np.arctan2(s, np.abs(d[..., 0]))


def random(rng: np.random.Generator, shape: tuple[int, ...] = ()) -> np.ndarray:
    """Uniformly distributed unit quaternions on SO(3) (Haar measure), shape (*shape, 4)."""
    q = rng.standard_normal((*shape, 4))
    return normalize(q)
