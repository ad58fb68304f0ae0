"""``compile=True`` for the torch vector env: its step under ``torch.compile``, or eager.

Two functions are compiled: :meth:`rbenv.envs.torch_env.TorchVectorEnv._physics` (the transition,
its flags and the stacked observation; no host reads) and ``_restart_all`` (the autoreset:
starts drawn for every row, the ended ones selected), each traced with ``fullgraph=True`` and
``dynamic=False``: one graph each per env (scene, task, options, N, dtype, device), and a graph
break is an error, not a silent slow path. The plant's NumPy constants are traced as tensors
(:meth:`rbenv.envs.torch_env.DeferredTorchNamespace.const`).

Where compilation is unavailable (no working compiler, an unsupported platform) the first call
fails; the env then warns once and steps eagerly, with identical results.

:class:`CompiledStep` counts how often Dynamo compiled a frame for it (``compiles``: 1 is one
graph; more is a recompilation, which the tests and the benchmark report).
"""

from __future__ import annotations

import warnings

import torch

__all__ = ["CompiledStep"]


def _frames_compiled() -> int:
    from torch._dynamo.utils import counters

    return int(counters["stats"]["unique_graphs"])


class CompiledStep:
    """A function of the env (its step, its restart), compiled on first call; eager after a
    failed compilation."""

    def __init__(self, eager):
        self.eager = eager
        self.compiled = torch.compile(eager, fullgraph=True, dynamic=False)
        self.compiles = 0  # graphs Dynamo made for this step (recompilations included)
        self.fallback: str | None = None  # why it runs eagerly, if it does

    def __call__(self, *args):
        if self.fallback is not None:
            return self.eager(*args)
        before = _frames_compiled()
        try:
            out = self.compiled(*args)
        except Exception as exc:
            self.fallback = f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}"
            warnings.warn(f"compile=True fell back to eager torch: {self.fallback}",
                          RuntimeWarning, stacklevel=3)
            return self.eager(*args)
        self.compiles += _frames_compiled() - before
        return out

