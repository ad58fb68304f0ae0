"""The shipped InnoCube policy (docs/innocube/policy) against its teacher innocube-slew on random
slews of the flight's kind, every flown effect on (benchmarks.innocube_policy): issue 45 asks
for a median settle and a mean sensed steady error both below the teacher's. 40 seeded slews
(seed 2, neither the validation nor the report's seeds); the report's 500 are in
docs/innocube/learned-policy.md."""

from pathlib import Path

import pytest

from benchmarks import innocube_policy

ROOT = Path(__file__).resolve().parents[2]
LIFTED = {"action_mode": "acceleration_lifted"}


def test_the_shipped_innocube_policy_beats_its_teacher():
    pytest.importorskip("torch")
    learned, teacher = (innocube_policy.run(name, 40, 2, "innocube-3u", LIFTED)["summary"]
                        for name in (str(ROOT / "docs/innocube/policy"), "innocube-slew"))
    assert learned["settled_fraction"] == teacher["settled_fraction"] == 1.0
    assert learned["settle_1deg_s_median"] < teacher["settle_1deg_s_median"], (learned, teacher)
    assert learned["steady_deg_mean"] < teacher["steady_deg_mean"], (learned, teacher)


def test_on_an_estimator_scene_the_believed_error_is_the_mekf_estimate():
    """On innocube-3u-mekf what the satellite believes is the filter's estimate: the benchmark's
    sensed steady error is the error of the estimate to the target, apart from the true one by
    the estimation error (0.1-0.3° with these sensors), and close to what the slew law holds on
    the estimate."""
    scene = str(ROOT / "docs/innocube/innocube-3u-mekf.toml")
    out = innocube_policy.run("innocube-slew", 8, 3, scene, LIFTED)
    sensed = [e["steady_deg"] for e in out["episodes_detail"]]
    true = [e["true_steady_deg"] for e in out["episodes_detail"]]
    assert all(abs(s - t) > 1e-6 for s, t in zip(sensed, true, strict=True)), (sensed, true)
    assert out["summary"]["steady_deg_mean"] < 0.15 < out["summary"]["true_steady_deg_mean"], \
        out["summary"]
