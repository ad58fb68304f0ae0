"""The energy-rate settle bounds (wheels, rods, detumbling) and the detumble propellant bound
of rbenv.envs.bounds: the premise checked on the simulator, closed forms, and no scripted
controller beating a bound on seeded episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import rbenv
from rbenv.envs import bounds as rb
from rbenv.satellite.scene import load_scene


def _bus(scene):
    return rb.torque_limits(scene).inertia_B


@pytest.mark.parametrize("scene", ["cubesat-6u-rw", "cubesat-12u-rw", "innocube-3u"])
def test_the_energy_rate_never_moves_faster_than_its_bound_in_the_simulator(scene):
    """|ṡ| ≤ A with s = √(ωᵀ I_bus ω), whatever the wheels store: random commands for 80 steps
    (sub-stepped by the env's integrator), s read at every control step, |Δs| ≤ A·dt."""
    env = gym.make(rbenv.ENV_ID, scene=scene, action_mode="torque")
    lim = rb.torque_limits(env.unwrapped.plant.scene)
    inertia = lim.inertia_B
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    def s_of():
        w = np.asarray(env.unwrapped._st.omega_B, float)
        return math.sqrt(w @ inertia @ w)
    s, worst = s_of(), 0.0
    for _ in range(80):
        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        s_new = s_of()
        worst = max(worst, abs(s_new - s) / lim.control_dt)
        s = s_new
        if term or trunc:
            break
    accel = lim.rate_gain_control + lim.torque_ext / math.sqrt(lim.inertia_min)
    assert 0.0 < worst <= accel * (1 + 1e-9), (worst, accel)


def test_an_isotropic_single_axis_slew_matches_the_closed_form():
    """I = λE, from rest, no external torque: s = √λ v, A = |τ|max/√λ; the bound is the
    bang-coast-bang time of v with acceleration |τ|max/λ, cap L + (|τ|max/λ) dt."""
    lam, tau, L, dt = 0.2, 0.01, 0.17, 0.5
    lim = rb.TorqueLimits(inertia_B=lam * np.eye(3), inertia_min=lam, inertia_max=lam,
                          rate_gain_control=tau / math.sqrt(lam), torque_ext=0.0,
                          rate_limit=L, control_dt=dt, success_angle=math.radians(1.0),
                          success_rate=0.01, settle_time_max=78.5)
    theta = math.radians(120.0)
    got = rb.energy_settle_bound(lim, np.zeros((1, 3)), np.array([theta]))["continuous"][0]
    a, cap, d, v_end = tau / lam, L + tau / lam * dt, theta - math.radians(1.0), 0.01
    ramps = (2 * cap ** 2 - v_end ** 2) / (2 * a)  # 0 → cap and cap → v_end
    want = (2 * cap - v_end) / a + (d - ramps) / cap  # a trapezoid (the angle is large)
    assert got == pytest.approx(want, rel=1e-12)
    w0 = np.array([[0.05, 0.0, 0.0]])
    det = rb.energy_settle_bound(lim, w0)["continuous"][0]
    assert det == pytest.approx((0.05 - 0.01) / a, rel=1e-12)


def _evaluate(policy, env_id, scene, episodes=40, **kw):
    from rbenv.agents.policies.evaluate import evaluate  # agents: the controllers

    return evaluate(policy, episodes=episodes, seed=2_000_000, env_id=env_id, scene=scene, **kw)


@pytest.mark.parametrize(("policy", "env_id", "scene"), [
    ("pd", rbenv.ENV_ID, "cubesat-6u-rw"),
    ("pd", rbenv.ENV_ID, "cubesat-12u-rw"),
    ("pd", rbenv.DETUMBLE_ID, "cubesat-12u"),
    ("pd", rbenv.DETUMBLE_ID, "cubesat-6u-rw"),
    ("bdot", rbenv.DETUMBLE_ID, "cubesat-6u-rw"),
])
def test_no_scripted_controller_settles_before_the_bound(policy, env_id, scene):
    r = _evaluate(policy, env_id, scene)
    per = r.optimality_per_episode
    assert r.optimality["defined"] and r.success.mean() > 0.9
    settle = np.asarray(per["settle_ratio"], float)
    assert np.isfinite(settle).sum() == r.success.sum()
    assert np.nanmin(settle) >= 1.0
    for name in ("fuel_ratio", "fuel_ratio_own_time"):
        if name in per:
            assert np.nanmin(per[name]) >= 1.0, name


def test_a_thruster_detumble_spends_at_least_its_propellant_bound():
    """The bound at the policy's own settle time is larger than the any-policy one, and the
    PD spends more than both on every episode."""
    r = _evaluate("pd", rbenv.DETUMBLE_ID, "cubesat-12u")
    per = r.optimality_per_episode
    own, anyp = (np.asarray(per[k], float) for k in ("fuel_ratio_own_time", "fuel_ratio"))
    keep = np.isfinite(own) & np.isfinite(anyp)
    assert keep.sum() > 30 and (own[keep] <= anyp[keep] + 1e-12).all()
    assert np.nanmin(own) >= 1.0


@pytest.mark.parametrize(("kwargs", "reason"), [
    ({"scene": "boom-sat"}, "disturbance noise"),
    ({"scene": "cubesat-12u-dr"}, "randomizes the model"),
])
def test_where_no_torque_bound_holds_the_reason_is_given(kwargs, reason):
    assert reason in rb.why_no_torque_limits(load_scene(kwargs["scene"]))
    with pytest.raises(rbenv.core.errors.InvalidParameterError, match=reason):
        rb.torque_limits(kwargs["scene"])


def test_the_field_bound_is_the_dipoles_largest_magnitude():
    """|B| over many orbit positions and Earth rotations stays below 2 (R/r)³ |m| and
    reaches within 2 % of it (the dipole's poles)."""
    orbit = load_scene("cubesat-6u-rw").orbit
    top = rb.field_max(orbit)
    from rbenv.satellite.orbit import IGRF14_2025_NT, R_REF

    m = 1e-9 * np.array([IGRF14_2025_NT[1], IGRF14_2025_NT[2], IGRF14_2025_NT[0]])
    r = np.random.default_rng(1).normal(size=(20000, 3))
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    B = (R_REF / orbit.radius) ** 3 * (3 * (r @ m)[:, None] * r - m)
    mags = np.linalg.norm(B, axis=1)
    assert mags.max() <= top and mags.max() > 0.98 * top
