"""The torch namespace: the names of :class:`rbenv.core.backend.NumpyNamespace` over torch tensors.

Optional (torch comes with the ``train`` extra); nothing else in ``core`` or ``rbenv`` imports
this module. Importing it registers ``torch.Tensor`` with :func:`rbenv.core.backend.register`, so
:func:`rbenv.core.backend.namespace` of a tensor component is :data:`TORCH`, and the same kernels,
plant, actuators and tasks run on (N,) tensors on any device. No formula is restated here:
these are the array primitives the step calls by name.

Constants of the plant (NumPy arrays built from the scene: a thruster matrix, action bounds,
an orbit table) reach the device once, through :meth:`TorchNamespace.const`, which caches each
read-only array per device and dtype; the step then makes no host round-trip.
"""

from __future__ import annotations

import numpy as np
import torch
from rbenv.core import backend

__all__ = ["TORCH", "TorchNamespace"]


def _scalar(x) -> bool:
    return isinstance(x, (int, float, bool))


class TorchNamespace:
    """Array-API names over torch tensors (float64 by default; the dtype of its inputs)."""

    name = "torch"

    def __init__(self, device="cpu", dtype=torch.float64):
        self.device, self.dtype = torch.device(device), dtype
        self._consts: dict = {}

    # element-wise
    sqrt = staticmethod(torch.sqrt)
    sin = staticmethod(torch.sin)
    cos = staticmethod(torch.cos)
    tan = staticmethod(torch.tan)
    atan2 = staticmethod(torch.atan2)
    log1p = staticmethod(torch.log1p)
    power = staticmethod(torch.pow)
    isfinite = staticmethod(torch.isfinite)
    abs = staticmethod(torch.abs)
    sign = staticmethod(torch.sign)
    round = staticmethod(torch.round)
    einsum = staticmethod(torch.einsum)
    matmul = staticmethod(torch.matmul)

    @staticmethod
    def where(cond, a, b):
        return torch.where(cond, a, b)

    @staticmethod
    def clip(x, low, high):
        return torch.clamp(x, low, high)

    def minimum(self, a, b):
        if _scalar(b):
            return torch.clamp(a, max=b)
        if _scalar(a):
            return torch.clamp(b, max=a)
        return torch.minimum(a, b)

    def maximum(self, a, b):
        if _scalar(b):
            return torch.clamp(a, min=b)
        if _scalar(a):
            return torch.clamp(b, min=a)
        return torch.maximum(a, b)

    @staticmethod
    def sign_nonneg(x):
        return torch.where(x < 0.0, -1.0, 1.0).to(x.dtype)

    @staticmethod
    def all_finite(components) -> bool:
        return bool(torch.isfinite(sum(components)).all())

    @staticmethod
    def not_finite(components):
        return ~torch.isfinite(sum(components))

    @staticmethod
    def any(x) -> bool:
        """A host bool (one synchronisation: the adapters' divergence check)."""
        return bool(torch.as_tensor(x).any())

    def zeros(self, n):
        return torch.zeros(n, dtype=self.dtype, device=self.device)

    # rows (per-actuator (N, n) tensors)
    @staticmethod
    def expand_dims(x, axis):
        return torch.unsqueeze(x, axis)

    @staticmethod
    def sum(x, axis=None):
        return torch.sum(x) if axis is None else torch.sum(x, dim=axis)

    @staticmethod
    def max(x, axis=None):
        return torch.amax(x) if axis is None else torch.amax(x, dim=axis)

    def clamp(self, x, low, high):
        return torch.minimum(torch.maximum(x, self.const(low)), self.const(high))

    def clamp_into(self, x, low, high):
        torch.maximum(x, self.const(low), out=x)
        return torch.minimum(x, self.const(high), out=x)

    def to_float(self, x):
        return x.to(self.dtype)

    @staticmethod
    def isnan_any(x) -> bool:
        return bool(torch.isnan(x).any())

    # constants
    def const(self, value):
        """A read-only NumPy constant of the plant as a tensor on this device (cached)."""
        if not isinstance(value, np.ndarray):
            return value
        key = id(value)
        hit = self._consts.get(key)
        if hit is None or hit[0] is not value:
            dtype = self.dtype if value.dtype.kind == "f" else None
            hit = self._consts[key] = (value, torch.tensor(value, dtype=dtype,
                                                           device=self.device))  # a copy
        return hit[1]


TORCH = TorchNamespace()
backend.register(torch.Tensor, TORCH)
