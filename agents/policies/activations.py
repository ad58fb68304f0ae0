"""Hidden-layer activations by name, so that a policy's settings and model files stay JSON.

Settings and ``<name>.json`` model files write ``policy_kwargs["activation_fn"]`` as a name
(``"tanh"``, ``"relu"``, ...); :func:`to_classes` turns it into the torch module class SB3
builds its networks with, and :func:`to_names` turns it back when a model is saved.

``"tanh"`` is :class:`Tanh`: the same function as ``torch.nn.Tanh``, evaluated on the CPU by
NumPy, whose float32 ``tanh`` is about 9× faster than torch's on this project's machines
(4096 × 64: about 0.1 ms against 0.9 ms); a [64, 64] tanh MLP spends about a third of PPO's
update time in ``torch.tanh``. The gradient is torch's own ``tanh_backward``. On any other
device, dtype or layout it calls ``torch.tanh``. Both round to within one unit in the last
place of the exact value, so a model trained with one runs with the other
(``tests/agents/policies/test_activations.py``; docs/performance.md has the timing).
"""

from __future__ import annotations

import numpy as np
import torch
from rbenv.core.errors import InvalidParameterError

__all__ = ["ACTIVATIONS", "Tanh", "to_classes", "to_names"]


class _NumpyTanh(torch.autograd.Function):
    """tanh of a CPU float tensor by NumPy; backward by ``aten::tanh_backward``."""

    @staticmethod
    def forward(ctx, x):
        y = torch.from_numpy(np.tanh(x.detach().numpy()))
        ctx.save_for_backward(y)
        return y

    @staticmethod
    def backward(ctx, grad):
        (y,) = ctx.saved_tensors
        return torch.ops.aten.tanh_backward(grad, y)


class Tanh(torch.nn.Module):
    """Elementwise tanh (``torch.nn.Tanh``'s function), fast on the CPU; see the module doc.
    Input and output: any shape, float."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.device.type == "cpu" and x.dtype in (torch.float32, torch.float64) \
                and x.layout == torch.strided and not torch.jit.is_tracing():
            return _NumpyTanh.apply(x.contiguous())
        return torch.tanh(x)


ACTIVATIONS: dict[str, type] = {"tanh": Tanh, "relu": torch.nn.ReLU, "elu": torch.nn.ELU,
                                "leaky_relu": torch.nn.LeakyReLU}
_NAMES = {torch.nn.Tanh: "tanh", **{cls: name for name, cls in ACTIVATIONS.items()}}


def to_classes(policy_kwargs: dict | None) -> dict:
    """A copy of ``policy_kwargs`` with ``activation_fn`` as a module class (a name from
    :data:`ACTIVATIONS`, or a class, which passes); an unknown name raises, naming them."""
    kwargs = dict(policy_kwargs or {})
    name = kwargs.get("activation_fn")
    if isinstance(name, str):
        if name not in ACTIVATIONS:
            raise InvalidParameterError(f"policy_kwargs activation_fn must be one of "
                                        f"{sorted(ACTIVATIONS)}, got {name!r}")
        kwargs["activation_fn"] = ACTIVATIONS[name]
    return kwargs


def to_names(policy_kwargs: dict | None) -> dict:
    """A copy of ``policy_kwargs`` with an ``activation_fn`` class written as its name (a class
    not in :data:`ACTIVATIONS` stays, and saving it then fails as not JSON)."""
    kwargs = dict(policy_kwargs or {})
    cls = kwargs.get("activation_fn")
    if cls in _NAMES:
        kwargs["activation_fn"] = _NAMES[cls]
    return kwargs
