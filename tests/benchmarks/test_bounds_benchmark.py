"""``python -m benchmarks.bounds --quick``: every file written, no episode below a bound."""

from __future__ import annotations

import json

import pytest

from benchmarks import bounds as bench


@pytest.mark.slow  # the --quick benchmark, about a minute
def test_benchmark_quick_smoke(tmp_path):
    data = bench.main(["--quick", "--out", str(tmp_path)])
    for name in ("bounds.json", "bounds.md", "bounds.png"):
        assert (tmp_path / name).stat().st_size > 0
    saved = json.loads((tmp_path / "bounds.json").read_text())
    # The suite's PPO policy is evaluated when its (uncommitted) run folder is present.
    trained = bench.trained_seeds([0]) == [0]
    assert set(saved["policies"]) == {"pd", "bangbang"} | ({"ppo seed 0"} if trained else set())
    assert saved["missing_ppo_seeds"] == ([] if trained else [0])
    assert all(v == 0 for counts in saved["violations"].values() for v in counts.values())
    for r in data["policies"].values():
        assert r["settle_ratio"]["min"] >= 1.0
    (spot,) = data["optimal"]
    assert spot["time_optimal"]["success"]
    assert spot["time_optimal"]["settle_time_s"] >= spot["settle_bound_s"]
    assert "| pd |" in (tmp_path / "bounds.md").read_text()
