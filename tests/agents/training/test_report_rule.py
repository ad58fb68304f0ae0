"""The run report states the success thresholds of the run's own scene and task."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from rbenv.agents.training.report import success_rule


@pytest.mark.parametrize(("env_id", "scene", "want"), [
    ("rbenv/SatelliteReorient-v1", "innocube-3u",
     "scene 'innocube-3u': attitude error < 0.25°, |ω| < 0.002 rad/s, held 20 s"),
    ("rbenv/SatelliteReorient-v1", None,
     "scene 'cubesat-12u': attitude error < 1°, |ω| < 0.01 rad/s, held 2 s"),
    ("rbenv/SatelliteDetumble-v1", "cubesat-6u-rw",
     "scene 'cubesat-6u-rw': attitude error < 1°, |ω| < 0.01 rad/s, held 10 s"),
])
def test_the_report_names_the_scenes_own_thresholds(env_id, scene, want):
    """It said 1° and 0.01 rad/s for every scene (innocube-3u's are 0.25° and 0.002 rad/s),
    and nothing of the task's own hold (detumbling cubesat-6u-rw holds 10 s)."""
    cfg = SimpleNamespace(env_id=env_id, env_kwargs={}, scene=scene)
    assert success_rule(cfg).endswith(want)
