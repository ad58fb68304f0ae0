"""The one seam between one body (Python floats) and many (arrays): array namespaces.

Every formula in :mod:`rbenv.core.kernels`, :mod:`rbenv.satellite.plant` and the tasks is written
once on *components* (a vector is 3 values, a quaternion 4), and each component is either a Python
float (one satellite: about 30 ns per operation, no NumPy call at all) or an (N,) array (a batch,
structure of arrays). Arithmetic works on both as it is. The few operations that differ
(``sqrt``, ``where``, ``clip``, ...) are taken from a namespace with array-API names, so the
same expression runs on either:

* :data:`FLOAT`, built on :mod:`math`, for Python floats;
* :data:`NUMPY`, built on NumPy, for arrays.

Code that holds a namespace (the envs pass theirs down) uses it directly; a kernel that only
receives components asks :func:`namespace` once, which dispatches on the component's type
(:func:`register` adds an array type). The step of the envs (rbenv's transition, plant,
actuators, tasks and the explicit integrators) makes every array call through these names, so
another backend is one more class with the same names: the tests run the whole step under a
strict NumPy namespace whose arrays refuse any direct ``np.`` call.

Names beyond the element-wise functions, for the per-actuator rows ((N, n) arrays; a single
satellite's rows are NumPy (n,) arrays, so :data:`FLOAT` has none of them): ``where``,
``expand_dims``, ``sum``, ``max``, ``abs``, ``sign``, ``einsum``, ``clamp`` / ``clamp_into``
(clip to bounds, the latter in place where the backend can), ``to_float`` (bool → 0.0/1.0),
``isnan_any``, and ``const`` (a plant constant, a read-only NumPy array, in the backend: itself
for NumPy, a cached device copy for torch, :mod:`rbenv.core.torch_backend`).
"""

from __future__ import annotations

import math
import threading

import numpy as np

__all__ = ["FLOAT", "NUMPY", "matmul", "namespace", "row_product"]


class _Scratch(threading.local):
    """Each thread's one-entry float64 arrays: two inputs and an output for
    :func:`_numpy_scalar` (a ufunc on them skips the conversions of Python floats to NumPy
    scalars and back, a quarter of the call)."""

    def __init__(self):
        self.arrays = (np.empty(1), np.empty(1), np.empty(1))


_SCRATCH = _Scratch()


def _numpy_scalar(ufunc):
    """``ufunc`` (one or two inputs) on Python floats, returning a Python float: NumPy's value,
    bit for bit.

    NumPy computes a number the same way in an array of any length (tests/core/test_backend.py
    checks it), so FLOAT and NUMPY agree to the bit. The numbers go through the calling
    thread's one-entry arrays (:class:`_Scratch`).
    """
    if ufunc.nin == 1:
        def f(x: float) -> float:
            a, _, out = _SCRATCH.arrays
            a[0] = x
            return ufunc(a, out).item()
    else:
        def f(x: float, y: float) -> float:
            a, b, out = _SCRATCH.arrays
            a[0] = x
            b[0] = y
            return ufunc(a, b, out).item()

    f.__name__ = f.__qualname__ = ufunc.__name__
    return f


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for 2-d a (m, n) and b (n, p), each entry the same bits whatever m and p.

    NumPy hands a single row or column to BLAS's matrix–vector product and anything larger to
    its matrix–matrix product, which add the n terms in different orders; and some OpenBLAS
    kernels (the Haswell/Zen ones on AMD EPYC, for one) compute the last row or column of an
    odd count with a narrower micro-kernel that adds them in yet another order. So an odd m or
    p is padded to the next even count (the last row or column repeated, the extra one dropped
    from the result): one satellite's wrench is, to the bit, one sub-env's of a batch of any
    size. Where BLAS was already consistent, the padding changes no bit.
    """
    m, p = a.shape[0], b.shape[1]
    if m % 2:
        a = _pad_rows(a)
    if p % 2:
        b = _pad_rows(b.T).T
    return (a @ b)[:m, :p]


def _pad_rows(x: np.ndarray) -> np.ndarray:
    """x (m, n) with its last row repeated once: (m + 1, n), C-contiguous."""
    out = np.empty((x.shape[0] + 1, x.shape[1]), x.dtype)
    out[:-1] = x
    out[-1] = x[-1]
    return out


def row_product(u: np.ndarray, matrix: np.ndarray) -> list:
    """``u @ matrix`` for one row u (n,) float64 and a C-contiguous float64 matrix (n, k ≥ 2),
    as k Python floats: each the bits :func:`matmul` gives that row in a batch of any size.

    :func:`matmul`'s two-row pad, multiplied by ``ndarray.dot``: for two C-contiguous float64
    matrices it makes the same BLAS gemm call as ``@``, without the ufunc and array-function
    dispatch that cost one satellite more than the product (tests/core/test_backend.py holds
    it to the bit).
    """
    two = np.empty((2, u.shape[0]))
    two[...] = u
    return two.dot(matrix)[0].tolist()


class FloatNamespace:
    """Array-API names over Python floats (bools for comparisons)."""

    name = "float"
    sqrt = staticmethod(math.sqrt)  # correctly rounded in libm and NumPy alike
    # The transcendental functions are NumPy's, not libm's: on some CPUs (AVX-512) NumPy
    # evaluates them with its own SIMD code, which differs from libm in the last bit, and one
    # satellite must step exactly as one sub-env of a batch (`_numpy_scalar`).
    sin = staticmethod(_numpy_scalar(np.sin))
    cos = staticmethod(_numpy_scalar(np.cos))
    tan = staticmethod(_numpy_scalar(np.tan))
    atan2 = staticmethod(_numpy_scalar(np.arctan2))
    log1p = staticmethod(_numpy_scalar(np.log1p))
    power = staticmethod(_numpy_scalar(np.power))
    isfinite = staticmethod(math.isfinite)

    @staticmethod
    def where(cond, a, b):
        """``a`` if cond else ``b`` (both are evaluated, as with arrays)."""
        return a if cond else b

    @staticmethod
    def clip(x, low, high):
        """``x`` limited to [low, high]."""
        return low if x < low else (high if x > high else x)

    @staticmethod
    def minimum(a, b):
        return a if a < b else b

    @staticmethod
    def maximum(a, b):
        return a if a > b else b

    @staticmethod
    def sign_nonneg(x):
        """−1 for x < 0, else +1 (zero counts as positive, unlike ``sign``)."""
        return -1.0 if x < 0.0 else 1.0

    @staticmethod
    def round(x):
        """The nearest whole number as a float (halves to even, as NumPy's)."""
        return float(round(x))

    @staticmethod
    def sign(x):
        """−1, 0 or +1."""
        return (x > 0.0) - (x < 0.0) + 0.0

    @staticmethod
    def all_finite(components) -> bool:
        """True when every component is finite (one sum: any NaN or inf propagates)."""
        return math.isfinite(sum(components))

    @staticmethod
    def not_finite(components) -> bool:
        """True when some component is not finite (one sum: any NaN or inf propagates)."""
        return not math.isfinite(sum(components))

    @staticmethod
    def any(x) -> bool:
        return bool(x)

    @staticmethod
    def zeros(n):
        """A zero component (``n`` is ignored: one body)."""
        return 0.0


class NumpyNamespace:
    """Array-API names over NumPy (N,) arrays."""

    name = "numpy"
    sqrt = staticmethod(np.sqrt)
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    tan = staticmethod(np.tan)
    atan2 = staticmethod(np.arctan2)
    log1p = staticmethod(np.log1p)
    power = staticmethod(np.power)
    isfinite = staticmethod(np.isfinite)
    where = staticmethod(np.where)
    clip = staticmethod(np.clip)
    minimum = staticmethod(np.minimum)
    maximum = staticmethod(np.maximum)
    round = staticmethod(np.round)

    @staticmethod
    def sign_nonneg(x):
        """−1 where x < 0, else +1."""
        return np.where(x < 0.0, -1.0, 1.0)

    @staticmethod
    def all_finite(components) -> bool:
        """True when every entry of every component is finite."""
        return bool(np.isfinite(sum(components)).all())

    @staticmethod
    def not_finite(components):
        """(N,) bool: True where some component's entry is not finite."""
        return ~np.isfinite(sum(components))

    @staticmethod
    def any(x) -> bool:
        return bool(np.any(x))

    @staticmethod
    def zeros(n):
        return np.zeros(n)

    # Row operations (per-actuator rows: (N, n), or a single satellite's (n,)).
    expand_dims = staticmethod(np.expand_dims)
    einsum = staticmethod(np.einsum)
    matmul = staticmethod(matmul)
    abs = staticmethod(np.abs)
    sign = staticmethod(np.sign)

    @staticmethod
    def sum(x, axis=None):
        return np.sum(x, axis=axis)

    @staticmethod
    def max(x, axis=None):
        return np.max(x, axis=axis)

    @staticmethod
    def clamp(x, low, high):
        """``min(max(x, low), high)`` element-wise (NaN stays NaN)."""
        return np.minimum(np.maximum(x, low), high)

    @staticmethod
    def clamp_into(x, low, high):
        """:meth:`clamp`, written into ``x`` (the caller owns it): no temporaries."""
        np.maximum(x, low, out=x)
        return np.minimum(x, high, out=x)

    @staticmethod
    def to_float(x):
        """A bool array as 0.0 / 1.0 float64."""
        return x.astype(float)

    @staticmethod
    def isnan_any(x) -> bool:
        return bool(np.isnan(x).any())

    @staticmethod
    def const(value):
        """A constant of the plant (a NumPy array) in this backend: itself."""
        return value


FLOAT = FloatNamespace()
NUMPY = NumpyNamespace()
# Component type → namespace, for :func:`namespace` (one dict lookup on the hot path).
_BY_TYPE: dict = {float: FLOAT, int: FLOAT, np.ndarray: NUMPY}


def register(array_type: type, ns) -> None:
    """Make :func:`namespace` return ``ns`` for components of ``array_type`` (a backend)."""
    _BY_TYPE[array_type] = ns


def namespace(x):
    """The namespace of a component: :data:`FLOAT` for a Python float or int, the registered
    namespace of its array type, else :data:`NUMPY` (NumPy scalars and arrays)."""
    ns = _BY_TYPE.get(type(x))
    if ns is not None:
        return ns
    return FLOAT if isinstance(x, (float, int)) else NUMPY


def rows(xp):
    """The namespace of the per-actuator rows for a state in ``xp`` (FLOAT's rows are NumPy)."""
    return NUMPY if xp is FLOAT else xp
