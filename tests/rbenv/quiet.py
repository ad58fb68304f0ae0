"""``gym.make`` without Gymnasium's "is out of date" warning, which it gives for every id that
has a newer version (its convention), for tests that make the older ids on purpose."""

from __future__ import annotations

import warnings

import gymnasium as gym


def make(env_id: str, **kwargs):
    """``gym.make(env_id, **kwargs)`` with the out-of-date warning silenced."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        return gym.make(env_id, **kwargs)
