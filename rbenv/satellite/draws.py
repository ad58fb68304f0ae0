"""Counter-based random draws for episode starts: a number is a function of where it is used.

Every random number that starts an episode (target, attitude, tumble, disturbance bias, faults,
domain-randomization draws) is a pure function of four integers::

    value = f(seed, episode, stream, slot)

``seed`` is the env's seed (sub-env ``i`` of a vector env reset with ``seed=s`` uses ``s + i``),
``episode`` counts the episodes started since that seed (0, 1, 2, ...), ``stream`` names the
consumer (the task, the plant, the randomizer: each has its own, so adding a consumer never
shifts another's numbers) and ``slot`` is the index of the number within the stream.

This is the contract that lets scripted and learned policies meet identical episodes: episode
``e`` of sub-env ``i`` after ``reset(seed=s)`` is episode ``e`` of a single env after
``reset(seed=s + i)``, bit for bit, however the episodes of other sub-envs end. And because no
generator object is kept per sub-env, a vector env resets any subset of its sub-envs with a few
NumPy calls on (N,) arrays instead of a Python loop over generators.

The mixing function is SplitMix64's finaliser (Steele, Lea & Flood, "Fast splittable
pseudorandom number generators", OOPSLA 2014) applied to a key built from the four integers;
uniforms take its top 53 bits, normals come from the Box–Muller transform of two uniforms.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from rbenv.core import validation
from rbenv.core.backend import FLOAT, NUMPY

__all__ = ["STREAMS", "EpisodeDraws", "check_seed"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_EPISODE_MUL = np.uint64(0xD1B54A32D192ED03)
_S30, _S27, _S31, _S11 = (np.uint64(s) for s in (30, 27, 31, 11))
_TO_UNIT = 2.0**-53
_TWO_PI = 2.0 * np.pi
_BLOCK = 32  # slots hashed at once per stream for a small batch (covers every task's start)
_BLOCK_ELEMENTS = 1 << 20  # a batch whose block would exceed this hashes per request
_NORMAL_CHUNK = 4  # normals per hashing pass for a batch that hashes per request


def check_seed(value, name: str = "seed") -> int:
    """A reset seed as an int: a non-negative integer (Python or NumPy); bools, floats,
    strings and negative numbers raise :class:`InvalidParameterError` naming ``name``, the
    value and the rule. Every env's ``reset(seed=)`` checks its seeds here."""
    return validation.integer(name, value, low=0)

# One stream per consumer of episode-start randomness. These three have fixed numbers; any
# other name (an actuator's scene table, say) gets a key from a hash of the name, so a new
# consumer needs no entry here and shifts no other stream's numbers.
STREAMS = {"task": 1, "plant": 2, "randomization": 3}
# Each stream's key offset, computed once with Python ints (NumPy scalars warn on wrapping).
_STREAM_INTS = {name: (i * 0xABC98388FB8FAC03) % 2**64 for name, i in STREAMS.items()}


class _StreamKeys(dict):
    """Stream name → uint64 key; names beyond :data:`STREAMS` are hashed (BLAKE2b, 8 bytes)."""

    def __missing__(self, name: str) -> np.uint64:
        digest = hashlib.blake2b(f"rbenv-stream:{name}".encode(), digest_size=8).digest()
        key = self[name] = np.uint64(int.from_bytes(digest, "little"))
        return key


_STREAM_KEYS = _StreamKeys({name: np.uint64(key) for name, key in _STREAM_INTS.items()})


def _mix(z: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on a uint64 array, in place (wrapping arithmetic); returns z."""
    t = z >> _S30
    z ^= t
    z *= _M1
    np.right_shift(z, _S27, out=t)
    z ^= t
    z *= _M2
    np.right_shift(z, _S31, out=t)
    z ^= t
    return z


def _to_unit(z: np.ndarray) -> np.ndarray:
    """Uniform floats on [0, 1) from the top 53 bits of uint64 hashes (exact: z >> 11 < 2⁵³)."""
    return np.multiply(np.right_shift(z, _S11, out=z), _TO_UNIT, dtype=np.float64)


@functools.cache
def _slot_keys(streams: tuple, offset: int = 0) -> np.ndarray:
    """Per-row key offsets of the slots ``offset …`` of each (stream, count) in ``streams``,
    stacked: ``(slot + 1)·golden + stream key`` (uint64, wrapping; read-only)."""
    rows = [(np.arange(offset, offset + count, dtype=np.uint64) + np.uint64(1)) * _GOLDEN
            + _STREAM_KEYS[stream] for stream, count in streams]
    out = np.concatenate(rows) if rows else np.zeros(0, dtype=np.uint64)
    out.setflags(write=False)
    return out


_MASK = 2**64 - 1
_M1_INT, _M2_INT, _GOLDEN_INT = int(_M1), int(_M2), int(_GOLDEN)
_EPISODE_MUL_INT = int(_EPISODE_MUL)


def _mix_int(z: int) -> int:
    """:func:`_mix` on one Python int (exact: the same bits as the uint64 array version)."""
    z = ((z ^ (z >> 30)) * _M1_INT) & _MASK
    z = ((z ^ (z >> 27)) * _M2_INT) & _MASK
    return z ^ (z >> 31)


class EpisodeDraws:
    """The random numbers of one episode start for each of N envs.

    seeds, episodes: (N,) integer arrays, or one int each with ``single=True`` (the single
    env), which hands out numbers as Python floats instead of (N,) arrays; ``xp`` is the
    matching :mod:`rbenv.core.backend` namespace, so task code written on components serves both.
    Both cases run the same NumPy arithmetic on the same bits (one env is a batch of one), so a
    single env and a sub-env draw the same numbers. Slot ``j`` of a stream is always the same
    number for the same (seed, episode), whatever else was drawn.
    """

    __slots__ = ("_blocks", "_keys", "_sizes", "n", "single", "xp")

    def __init__(self, seeds, episodes, single: bool = False, block_slots: dict | None = None):
        """block_slots: stream → the slots its consumer draws (a hint: a small batch hashes
        those blocks of every hinted stream at once; the numbers do not depend on it)."""
        self.single = bool(single)
        self.xp = FLOAT if self.single else NUMPY
        self._blocks = {}  # stream -> (slots, N) uniforms, small batches only
        self._sizes = block_slots or {}
        if self.single:  # one int each: mixed on Python ints, cheaper than one-element arrays
            key = _mix_int((_mix_int((int(seeds) % 2**64) ^ _GOLDEN_INT)
                            + (int(episodes) % 2**64) * _EPISODE_MUL_INT) & _MASK)
            self._keys, self.n = np.array([key], dtype=np.uint64), 1
        else:
            # uint64 array arithmetic wraps silently (only NumPy scalars warn on overflow).
            self._keys = _mix(_mix(np.asarray(seeds, dtype=np.uint64) ^ _GOLDEN)
                              + np.asarray(episodes, dtype=np.uint64) * _EPISODE_MUL)
            self.n = len(self._keys)
        if self._sizes and self.n * sum(self._sizes.values()) <= _BLOCK_ELEMENTS:
            self._hash_blocks()

    def _hash_blocks(self) -> None:
        """Every hinted stream's block in one pass: one (Σ slots, N) hash, split by stream."""
        streams = tuple(self._sizes.items())
        u = _to_unit(_mix(np.add.outer(_slot_keys(streams), self._keys)))
        start = 0
        for stream, size in streams:
            self._blocks[stream] = u[start:start + size]
            start += size

    def components(self, arr: np.ndarray) -> tuple:
        """Rows of a (count, N) array as components: floats (single) or (N,) arrays."""
        return tuple(arr[:, 0].tolist()) if self.single else tuple(arr)

    def _hash_uniforms(self, stream: str, count: int, offset: int) -> np.ndarray:
        """(count, N) uniforms: slots offset … offset + count − 1 of ``stream``."""
        return _to_unit(_mix(np.add.outer(_slot_keys(((stream, count),), offset), self._keys)))

    def uniform_array(self, stream: str, count: int, offset: int = 0) -> np.ndarray:
        """(count, N) floats uniform on [0, 1) from slots ``offset…`` of ``stream``.

        A small batch (one env, or the few sub-envs an autoreset restarts) hashes a block of a
        stream's first slots once (the ``block_slots`` hint, else 32) and serves every request
        from it, saving NumPy calls; a large one hashes each request alone, which keeps its
        temporaries small. The numbers are the same either way.
        """
        if self._per_request(stream):
            return self._hash_uniforms(stream, count, offset)
        block = self._blocks.get(stream)
        if block is None or len(block) < offset + count:
            block = self._blocks[stream] = self._hash_uniforms(
                stream, max(offset + count, self._sizes.get(stream, _BLOCK)), 0)
        return block[offset:offset + count]

    def _per_request(self, stream: str) -> bool:
        """True when this batch is too large to cache a block of ``stream``."""
        return self.n * self._sizes.get(stream, _BLOCK) > _BLOCK_ELEMENTS

    def normal_array(self, stream: str, count: int, offset: int = 0) -> np.ndarray:
        """(count, N) standard normals, Box–Muller on uniform slots ``offset + 2k, + 2k + 1``.

        Uses ``2·count`` uniform slots from ``offset``, which must be even (slot pairs are
        aligned: normal ``k`` of a stream is always made from slots ``2k`` and ``2k + 1``).
        """
        if offset % 2:
            raise ValueError(f"normal draws start at an even slot, got offset {offset}")
        if count > _NORMAL_CHUNK and self._per_request(stream):
            # A large batch hashed per request: a few normals at a time into the result, so
            # the uint64 and uniform temporaries stay a few rows tall (memory per sub-env).
            out = np.empty((count, self.n))
            for k in range(0, count, _NORMAL_CHUNK):
                rows = min(_NORMAL_CHUNK, count - k)
                out[k:k + rows] = self.normal_array(stream, rows, offset + 2 * k)
            return out
        u = self.uniform_array(stream, 2 * count, offset)
        radius = np.sqrt(-2.0 * np.log1p(-u[0::2]))  # 1 − u in (0, 1]: finite
        radius *= np.cos(_TWO_PI * u[1::2])
        return radius

    def uniform(self, stream: str, count: int, offset: int = 0) -> tuple:
        """``count`` uniform components (floats or (N,) arrays), slots ``offset…``."""
        return self.components(self.uniform_array(stream, count, offset))

    def normal(self, stream: str, count: int, offset: int = 0) -> tuple:
        """``count`` standard-normal components, from uniform slots ``offset…`` (even)."""
        return self.components(self.normal_array(stream, count, offset))
