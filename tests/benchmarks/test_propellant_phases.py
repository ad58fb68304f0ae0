"""benchmarks.propellant_phases: the three phases add up to the episode's propellant, which is
what rbenv evaluate measures on the same episodes, and the cuts fall where they should."""

from __future__ import annotations

import numpy as np
import pytest
from rbenv.agents.policies.evaluate import evaluate

from benchmarks import propellant_phases


@pytest.mark.parametrize("policy", ["pd", "bangbang"])
def test_the_phases_add_up_to_what_evaluate_measures(policy):
    n, seed = 12, 5_000_000
    row = propellant_phases.phases(policy, n, seed)
    ref = evaluate(policy, episodes=n, seed=seed, env_id=propellant_phases.ENV_ID, record=0)
    g = row["propellant_g"]
    assert g["spin_up"] + g["cruise"] + g["capture"] == pytest.approx(g["total"], rel=1e-12)
    assert g["total"] == pytest.approx(1000 * float(np.mean(ref.fuel_kg)), rel=1e-12)
    assert row["success_rate"] == float(np.mean(ref.success)) == 1.0
    assert min(g.values()) > 0.0
    # The PD brakes slowly (many capture steps); the bang-bang turns at the rate limit's
    # neighbourhood (10 deg/s on cubesat-12u).
    assert 0.0 < row["peak_rate_dps_median"] <= 10.0 + 1e-9
    assert 0 < row["capture_steps_median"] < row["episode_steps_median"]
