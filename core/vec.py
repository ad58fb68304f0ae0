"""Array front-end, shape (..., 3), for the component kernels of :mod:`rbenv.core.kernels`.

The formulas live once, in :mod:`rbenv.core.kernels`; these wrappers split arrays into components
and stack the result, for code that holds vectors as (..., 3) arrays (quaternion helpers, force
generators, reference solutions). ``np.cross`` is avoided: it costs microseconds per call on
small arrays.
"""

from __future__ import annotations

import numpy as np
from rbenv.core import kernels


def _parts(a) -> tuple:
    return kernels.unpack(np.asarray(a, dtype=float))


def cross(a, b) -> np.ndarray:
    """Cross product ``a × b``. a, b: (..., 3) (broadcast). Returns (..., 3)."""
    return kernels.pack(kernels.cross(_parts(a), _parts(b)))


def dot(a, b):
    """Dot product over the last axis. a, b: (..., 3). Returns (...) (a float for (3,) inputs)."""
    return kernels.dot(_parts(a), _parts(b))
