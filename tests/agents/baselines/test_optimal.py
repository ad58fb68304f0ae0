"""The trajectory optimiser (rbenv.agents.baselines.optimal): its own rollout matches the env, and
the trajectories it optimises, replayed in the env, never beat the lower bounds of
rbenv.agents.baselines.bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rbenv.agents.baselines import bounds as rb
from rbenv.agents.baselines import optimal

SEED = 1_000_000  # the first held-out episode (as tests/rbenv/test_bounds.py)


@pytest.mark.slow  # SLSQP, tens of seconds
def test_optimised_trajectory_is_above_the_bounds():
    """A time-optimised open-loop sequence (SLSQP), replayed in the env on a 21° episode,
    succeeds no sooner than the settle bound and spends no less than the propellant bound
    at its own settle time; it is faster than the bang-bang controller."""
    seed = SEED + 343  # the smallest initial angle among the first 500 held-out episodes
    lim = rb.scene_limits("cubesat-12u")
    st = rb.episode_starts(1, seed)
    assert math.degrees(st["angle"][0]) == pytest.approx(20.9, abs=0.05)
    settle = rb.settle_time_bound(lim, st["angle"], st["omega_B"], st["bias_B"])["sampled"][0]
    bang = optimal.replay("bangbang", seed)
    problem = optimal.Problem.from_seed(seed)
    sol = optimal.time_optimal(problem, int(np.rint(bang["settle_time_s"] / 0.5)),
                               bang["throttles"], int(np.rint(settle / 0.5)) - 1, maxiter=60)
    rep = optimal.replay(sol.throttles, seed)
    assert rep["success"]
    assert settle <= rep["settle_time_s"] < bang["settle_time_s"]
    own = rb.fuel_bound(lim, st["angle"], st["omega_B"], st["bias_B"],
                        time_s=rep["settle_time_s"])["kg"][0]
    assert rep["fuel_kg"] >= own


@pytest.mark.slow  # SLSQP, tens of seconds
def test_fuel_optimised_trajectory_is_above_the_propellant_bound():
    """A propellant-optimised sequence (SLSQP, settling at 78.5 s), replayed in the env,
    succeeds, spends less than the PD and no less than the bound for any policy."""
    seed = SEED + 3  # 118°: a positive propellant bound
    lim = rb.scene_limits("cubesat-12u")
    st = rb.episode_starts(1, seed)
    bound = rb.fuel_bound(lim, st["angle"], st["omega_B"], st["bias_B"])["kg"][0]
    assert bound > 0
    pd = optimal.replay("pd", seed)
    sol = optimal.fuel_optimal(optimal.Problem.from_seed(seed), pd["throttles"], maxiter=60)
    rep = optimal.replay(sol.throttles, seed)
    assert rep["success"]
    assert bound <= rep["fuel_kg"] < pd["fuel_kg"]


def test_own_rollout_matches_the_env():
    """The optimiser's RK4 reproduces the env's trajectory under the bang-bang throttles."""
    seed = SEED + 3
    bang = optimal.replay("bangbang", seed)
    problem = optimal.Problem.from_seed(seed)
    q, w = problem.rollout(bang["throttles"][None])
    angle = math.degrees(2 * math.asin(math.sqrt(problem.error_sin2(q[0, -1]))))
    assert angle < 1.0 and np.linalg.norm(w[0, -1]) < 0.01
