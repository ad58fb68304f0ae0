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

import numpy as np

__all__ = ["STREAMS", "EpisodeDraws"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_EPISODE_MUL = np.uint64(0xD1B54A32D192ED03)
_STREAM_MUL = np.uint64(0xABC98388FB8FAC03)
_S30, _S27, _S31, _S11 = (np.uint64(s) for s in (30, 27, 31, 11))
_TO_UNIT = 2.0**-53
_TWO_PI = 2.0 * np.pi

# One stream per consumer of episode-start randomness.
STREAMS = {"task": 1, "plant": 2, "randomization": 3}


def _mix(z: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on a uint64 array (wrapping arithmetic)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


class EpisodeDraws:
    """The random numbers of one episode start for each of N envs (N = 1 for the single env).

    seeds, episodes: (N,) uint64 arrays. ``uniform(stream, count)`` and ``normal(stream,
    count)`` return ``count`` arrays of shape (N,): slot ``j`` of each stream is always the same
    number for the same (seed, episode), whatever else was drawn.
    """

    __slots__ = ("_keys", "n")

    def __init__(self, seeds: np.ndarray, episodes: np.ndarray):
        with np.errstate(over="ignore"):
            self._keys = _mix(_mix(seeds.astype(np.uint64) ^ _GOLDEN)
                              + episodes.astype(np.uint64) * _EPISODE_MUL)
        self.n = len(self._keys)

    def _bits(self, stream: str, count: int, offset: int) -> np.ndarray:
        """(count, N) uint64: slots offset … offset + count − 1 of ``stream``."""
        base = self._keys + np.uint64(STREAMS[stream]) * _STREAM_MUL
        slots = (np.arange(offset, offset + count, dtype=np.uint64) + np.uint64(1)) * _GOLDEN
        return _mix(base[None, :] + slots[:, None])

    def uniform(self, stream: str, count: int, offset: int = 0) -> np.ndarray:
        """(count, N) floats uniform on [0, 1) from slots ``offset…`` of ``stream``."""
        with np.errstate(over="ignore"):
            return (self._bits(stream, count, offset) >> _S11).astype(np.float64) * _TO_UNIT

    def normal(self, stream: str, count: int, offset: int = 0) -> np.ndarray:
        """(count, N) standard normals (Box–Muller on uniform slots ``offset + 2k, + 2k + 1``).

        Uses ``2·count`` uniform slots starting at ``offset``.
        """
        u = self.uniform(stream, 2 * count, offset)
        radius = np.sqrt(-2.0 * np.log1p(-u[0::2]))  # 1 − u in (0, 1]: finite
        return radius * np.cos(_TWO_PI * u[1::2])
