"""benchmarks.episode_drift's comparison: what it reports could be wrong in each field."""

from __future__ import annotations

from benchmarks.episode_drift import compare


def _episode(rewards, obs, success=True):
    return {"rewards": rewards, "obs": obs, "success": success}


def test_compare_reports_the_largest_differences_and_the_episodes_that_part():
    old = {"a": _episode([1.0, 2.0], [[0.0, 1.0], [0.5, 0.5]]),
           "b": _episode([1.0], [[0.0, 0.0]]),
           "c": _episode([1.0, 1.0], [[0.0, 0.0], [0.0, 0.0]], success=False),
           "d": _episode([3.0], [[1.0, 1.0]])}
    new = {"a": _episode([1.0, 2.0 + 1e-12], [[0.0, 1.0], [0.5, 0.5 - 3e-11]]),
           "b": _episode([1.0], [[0.0, 0.0]]),
           "c": _episode([1.0, 1.0], [[0.0, 0.0], [0.0, 0.0]], success=True),
           "d": _episode([3.0, 0.0], [[1.0, 1.0], [0.0, 0.0]])}
    got = compare(old, new)
    assert got["episodes"] == 4 and got["steps"] == 6
    assert got["bit_identical_episodes"] == 2  # b and c (c parts on success only)
    assert got["length_or_success_differs"] == ["c", "d"]
    assert abs(got["max_abs_reward_diff"] - 1e-12) < 1e-15
    assert abs(got["max_abs_obs_diff"] - 3e-11) < 1e-15
