"""Counter-based episode-start draws on torch tensors: :mod:`rbenv.satellite.draws` on the device.

The same numbers as :class:`rbenv.satellite.draws.EpisodeDraws` (``value = f(seed, episode, stream,
slot)``, SplitMix64's finaliser, top 53 bits, Box–Muller), computed with int64 tensor
operations on any device, so an autoreset needs no generator object and no host round trip.
torch has no uint64 arithmetic on CPU, so the hash runs on int64: multiplication and addition
wrap modulo 2⁶⁴ as uint64 does (two's complement), and a right shift is made logical by masking
the sign-extended bits. The integer keys are bit-identical to NumPy's; the uniforms are exact
(``z >> 11 < 2⁵³``); normals may differ from NumPy's in the last bit, where torch's ``log1p``
or ``cos`` rounds differently.

The constants (golden ratio, multipliers, stream keys) are taken from :mod:`rbenv.satellite.draws`,
never restated.
"""

from __future__ import annotations

import math

import torch

from rbenv.satellite import draws as _np_draws

__all__ = ["TorchDraws"]

_SLOT_KEYS: dict = {}  # (stream, count, offset, device) -> (count, 1) int64 slot keys


def _signed(value: int) -> int:
    """A uint64 value (Python int) as the int64 with the same bits."""
    value %= 2**64
    return value - 2**64 if value >= 2**63 else value


_GOLDEN = _signed(int(_np_draws._GOLDEN))
_M1 = _signed(int(_np_draws._M1))
_M2 = _signed(int(_np_draws._M2))
_EPISODE_MUL = _signed(int(_np_draws._EPISODE_MUL))


def _shr(z: torch.Tensor, s: int) -> torch.Tensor:
    """Logical right shift of int64 bits (as uint64 ``>>``)."""
    return (z >> s) & ((1 << (64 - s)) - 1)


def _mix(z: torch.Tensor) -> torch.Tensor:
    """SplitMix64's finaliser on int64 tensors (the bits of :func:`rbenv.satellite.draws._mix`)."""
    z = (z ^ _shr(z, 30)) * _M1
    z = (z ^ _shr(z, 27)) * _M2
    return z ^ _shr(z, 31)


def keys(seeds: torch.Tensor, episodes: torch.Tensor) -> torch.Tensor:
    """(N,) int64 episode keys from (N,) int64 seeds and episode counters."""
    return _mix(_mix(seeds ^ _GOLDEN) + episodes * _EPISODE_MUL)


class TorchDraws:
    """The random numbers of one episode start for each of N envs, as (N,) tensors.

    The interface of :class:`rbenv.satellite.draws.EpisodeDraws` for a batch (``single`` is False):
    ``uniform``/``normal`` give components, ``uniform_array``/``normal_array`` (count, N)
    tensors, in ``xp.dtype`` on ``xp.device``; ``xp`` is the env's torch namespace.
    seeds, episodes: (N,) int64 tensors on the device.
    """

    single = False

    def __init__(self, seeds: torch.Tensor, episodes: torch.Tensor, xp):
        self.xp = xp
        self.n = int(seeds.shape[0])
        self._keys = keys(seeds, episodes)

    def _slot_keys(self, stream: str, count: int, offset: int) -> torch.Tensor:
        """(count, 1) int64: ``(slot + 1)·golden + stream key`` for slots offset… Cached per
        module (the env's first, eager reset fills it, so a compiled restart reads constants
        and never traces the NumPy stream keys)."""
        key = (stream, count, offset, self._keys.device)
        hit = _SLOT_KEYS.get(key)
        if hit is None:
            base = int(_np_draws._STREAM_KEYS[stream])
            golden = int(_np_draws._GOLDEN)
            values = [_signed((slot + 1) * golden + base)
                      for slot in range(offset, offset + count)]
            hit = _SLOT_KEYS[key] = torch.tensor(
                values, dtype=torch.int64, device=self._keys.device).unsqueeze(1)
        return hit

    def _uniform64(self, stream: str, count: int, offset: int) -> torch.Tensor:
        z = _mix(self._slot_keys(stream, count, offset) + self._keys)
        return _shr(z, 11).to(torch.float64) * _np_draws._TO_UNIT

    def uniform_array(self, stream: str, count: int, offset: int = 0) -> torch.Tensor:
        """(count, N) uniforms on [0, 1) from slots ``offset…`` of ``stream``."""
        return self._uniform64(stream, count, offset).to(self.xp.dtype)

    def normal_array(self, stream: str, count: int, offset: int = 0) -> torch.Tensor:
        """(count, N) standard normals from uniform slot pairs (``offset`` even)."""
        if offset % 2:
            raise ValueError(f"normal draws start at an even slot, got offset {offset}")
        u = self._uniform64(stream, 2 * count, offset)
        radius = torch.sqrt(-2.0 * torch.log1p(-u[0::2]))
        return (radius * torch.cos((2.0 * math.pi) * u[1::2])).to(self.xp.dtype)

    def components(self, arr) -> tuple:
        """Rows of a (count, N) array (tensor or NumPy, from reset options) as components."""
        if not isinstance(arr, torch.Tensor):
            arr = torch.as_tensor(arr, dtype=self.xp.dtype, device=self._keys.device)
        return tuple(arr)

    def uniform(self, stream: str, count: int, offset: int = 0) -> tuple:
        return self.components(self.uniform_array(stream, count, offset))

    def normal(self, stream: str, count: int, offset: int = 0) -> tuple:
        return self.components(self.normal_array(stream, count, offset))
