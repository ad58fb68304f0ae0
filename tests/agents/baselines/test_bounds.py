"""Lower bounds on settle time and propellant (rbenv.agents.baselines.bounds), checked against
closed forms,
independent numerics (quadrature, an ODE solver, linprog) and the scripted controllers on 200
episodes. Optimised trajectories against the bounds: tests/agents/baselines/test_optimal.py;
the benchmark: tests/benchmarks/test_bounds_benchmark.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rbenv.agents.baselines import bounds as rb
from rbenv.core.errors import InvalidParameterError
from scipy.integrate import quad, solve_ivp

from rbenv.satellite.scene import load_scene

SEED = 1_000_000


@pytest.fixture(scope="module")
def limits():
    return rb.scene_limits("cubesat-12u")


# --- closed forms -----------------------------------------------------------------------------

def _numeric_time(d, v0, v_end, a, cap):
    """The same minimum time by bisection on the quadrature of the largest speed profile."""
    def covered(T):
        f = lambda t: min(v0 + a * t, cap, v_end + a * (T - t))  # noqa: E731
        return quad(f, 0.0, T, limit=200, points=[min(T, max(0.0, (cap - v0) / a))])[0]

    lo = max(0.0, (v0 - v_end) / a)
    if covered(lo) >= d:
        return lo
    hi = lo + 1.0
    while covered(hi) < d:
        hi *= 2.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if covered(mid) >= d else (mid, hi)
    return hi


def test_bang_coast_bang_rest_to_rest_closed_forms():
    a, cap = 0.1, 0.2
    # Triangle: T = 2√(d/a) while the peak √(ad) stays below the cap.
    assert rb.bang_coast_bang_time(0.3, 0.0, 0.0, a, cap) == pytest.approx(2 * math.sqrt(3.0))
    # Trapezoid: T = d/V + V/a.
    assert rb.bang_coast_bang_time(3.0, 0.0, 0.0, a, cap) == pytest.approx(3.0 / cap + cap / a)
    # Nothing to cover, but a rate to brake: T = (v0 − v_end)/a.
    assert rb.bang_coast_bang_time(0.0, 0.05, 0.01, a, cap) == pytest.approx(0.4)


@pytest.mark.parametrize("case", range(40))
def test_bang_coast_bang_matches_quadrature(case):
    rng = np.random.default_rng(case)
    a, cap = rng.uniform(0.02, 0.3), rng.uniform(0.05, 0.3)
    v0, v_end = rng.uniform(0.0, cap), rng.uniform(0.0, cap)
    d = rng.choice([rng.uniform(0.0, 0.02), rng.uniform(0.0, 4.0)])
    got = float(rb.bang_coast_bang_time(d, v0, v_end, a, cap))
    assert got == pytest.approx(_numeric_time(d, v0, v_end, a, cap), rel=1e-6, abs=1e-9)


def test_settle_bound_grows_with_angle_and_shrinks_with_a_helpful_rate(limits):
    angles = np.radians([10.0, 60.0, 120.0, 180.0])
    t = rb.settle_time_bound(limits, angles, np.zeros((4, 3)))["continuous"]
    assert np.all(np.diff(t) > 0)
    faster = rb.settle_time_bound(limits, angles, np.full((4, 3), 0.01))["continuous"]
    assert np.all(faster < t)
    # Quantised to control steps, never below the continuous bound.
    out = rb.settle_time_bound(limits, angles, np.zeros((4, 3)))
    assert np.all(out["sampled"] >= out["continuous"])
    assert np.allclose(out["sampled"] / limits.control_dt,
                       np.round(out["sampled"] / limits.control_dt))


# --- the scene's constants against independent numerics --------------------------------------

def test_largest_torque_is_the_support_function_maximum(limits):
    """max_u |M B u| = max over unit e of Σ max(0, e·M b_i): dense directions come within
    0.1 % from below; random throttles never exceed it."""
    rng = np.random.default_rng(0)
    for weight in (None, np.linalg.inv(limits.inertia_B)):
        MB = limits.torque_matrix_B if weight is None else weight @ limits.torque_matrix_B
        value = rb.max_weighted_torque(limits.torque_matrix_B, weight)
        e = rng.normal(size=(200_000, 3))
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        support = np.maximum(e @ MB, 0.0).sum(axis=1).max()
        assert support <= value * (1 + 1e-12)
        assert support >= value * 0.999
        u = rng.uniform(size=(20_000, MB.shape[1]))
        assert np.linalg.norm(u @ MB.T, axis=1).max() <= value * (1 + 1e-12)
    assert limits.accel_max <= limits.accel_axis


def test_gyro_coefficient_bounds_random_directions_tightly(limits):
    I = limits.inertia_B
    w = np.random.default_rng(1).normal(size=(200_000, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    sampled = np.linalg.norm(np.linalg.solve(I, np.cross(w, w @ I.T).T).T, axis=1).max()
    assert sampled <= limits.gyro_coeff <= 1.02 * sampled
    lam = np.linalg.eigvalsh(I)
    assert limits.gyro_coeff <= (lam[-1] - lam[0]) / (2 * lam[0])  # the analytic bound


def test_rate_cap_holds_between_control_steps(limits):
    """Integrate Euler's equations (solve_ivp, tight tolerances) over one step from |ω| = L
    under the strongest constant torques: whenever |ω| ≤ L at both ends, |ω| ≤ rate_cap
    throughout; the cap is above the limit by less than 10 %."""
    I, B = limits.inertia_B, limits.torque_matrix_B
    inv = np.linalg.inv(I)
    L, dt = limits.rate_limit, limits.control_dt
    rng = np.random.default_rng(2)
    peak, counted = 0.0, 0
    for _ in range(60):
        w0 = rng.normal(size=3)
        w0 *= L / np.linalg.norm(w0)
        u = (rng.uniform(size=B.shape[1]) < 0.5).astype(float)
        tau = B @ u
        sol = solve_ivp(lambda t, w, tau=tau: inv @ (tau - np.cross(w, I @ w)), (0, dt), w0,
                        rtol=1e-10, atol=1e-12, dense_output=True)
        rates = np.linalg.norm(sol.sol(np.linspace(0, dt, 201)).T, axis=1)
        if rates[-1] <= L:
            peak, counted = max(peak, rates.max()), counted + 1
    assert counted >= 10
    assert peak <= limits.rate_cap
    assert L < limits.rate_cap < 1.1 * L


def test_min_impulse_lp_is_never_below_the_bounds_constant(limits):
    """The LP's least impulse per unit weighted torque impulse, over random directions, is ≥
    1/k with k = max_i |W b_i|/F_i, and equals it along the best thruster."""
    f = rb.weighted_rate_forms(limits.inertia_B, -0.6 / limits.inertia_max)
    WB = f["W"] @ limits.torque_matrix_B
    k = (np.linalg.norm(WB, axis=0) / limits.max_force).max()
    rng = np.random.default_rng(3)
    lps = [rb.min_impulse_lp(limits.torque_matrix_B, limits.max_force, e, f["W"])
           for e in rng.normal(size=(40, 3))]
    assert min(lps) >= 1.0 / k * (1 - 1e-9)
    best = int(np.argmax(np.linalg.norm(WB, axis=0) / limits.max_force))
    assert rb.min_impulse_lp(limits.torque_matrix_B, limits.max_force, WB[:, best],
                             f["W"]) == pytest.approx(1.0 / k)


def test_fuel_bound_shape(limits):
    angles = np.radians([0.5, 30.0, 90.0, 179.0])
    still = np.zeros((4, 3))
    f = rb.fuel_bound(limits, angles, still)["kg"]
    assert f[0] == 0.0 and np.all(np.diff(f) > 0)
    # Settling sooner needs more; a tumble that may help lowers the bound.
    assert np.all(rb.fuel_bound(limits, angles[1:], still[1:], time_s=20.0)["kg"] > f[1:])
    assert np.all(rb.fuel_bound(limits, angles[1:], np.full((3, 3), 0.01))["kg"] < f[1:])


def test_weighted_rate_form_must_be_positive_definite(limits):
    with pytest.raises(InvalidParameterError, match="kappa"):
        rb.weighted_rate_forms(limits.inertia_B, -1.0 / limits.inertia_max)


def test_unbounded_disturbance_is_refused():
    from dataclasses import replace

    sc = load_scene("cubesat-12u")
    noisy = replace(sc, disturbance=replace(sc.disturbance, noise_sigma=1e-6))
    with pytest.raises(InvalidParameterError, match="noise_sigma"):
        rb.scene_limits(noisy)


# --- against what controllers achieve -----------------------------------------------------------

def test_bounds_lie_below_pd_and_bang_bang_on_200_episodes(limits):
    from rbenv.agents.policies.evaluate import evaluate

    n = 200
    st = rb.episode_starts(n, SEED)
    settle = rb.settle_time_bound(limits, st["angle"], st["omega_B"], st["bias_B"])["sampled"]
    fuel = rb.fuel_bound(limits, st["angle"], st["omega_B"], st["bias_B"])["kg"]
    for name in ("pd", "bangbang"):
        ev = evaluate(name, episodes=n, seed=SEED, record=0)
        assert ev.success.all()
        assert np.all(ev.settle_time_s >= settle)
        assert np.all(ev.fuel_kg >= fuel)
        own = rb.fuel_bound(limits, st["angle"], st["omega_B"], st["bias_B"],
                            time_s=ev.settle_time_s)["kg"]
        assert np.all(ev.fuel_kg >= own)
    # The starts are the env's: the bound's angle is the episode's initial error.
    import gymnasium as gym

    import rbenv

    envs = gym.make_vec(rbenv.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    _, info = envs.reset(seed=SEED)
    envs.close()
    assert np.allclose(np.degrees(st["angle"]), info["attitude_error_deg"])
