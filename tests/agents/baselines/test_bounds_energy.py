"""The energy-rate settle bounds (wheels, rods, detumbling) and the detumble propellant bound
of rbenv.agents.baselines.bounds: the premise checked on the simulator, closed forms, and no
scripted
controller beating a bound on seeded episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines import bounds as rb

import rbenv
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


# ------------------------------------------------------------ the wheels' rate and momentum caps

@pytest.mark.parametrize("scene", ["cubesat-6u-rw", "cubesat-12u-rw"])
def test_the_momentum_caps_premises_hold_in_the_simulator(scene):
    """Wheel commands held for random spells of 1-10 steps (z at 0.3 of full torque, which keeps
    cubesat-6u-rw's minor axis longer below the rate limit), the other actuators idle (so the
    wheels-only limits apply), up to 150 steps: at every control step |H| stays within |H|max
    at that time, every rotor's |h_i| within J_i(Ω̄_i + L), and |ω| within the momentum cap."""
    env = gym.make(rbenv.ENV_ID, scene=scene)
    base = env.unwrapped
    plant = base.plant
    lim = rb.torque_limits(plant.scene, used=("wheels",))
    wh = lim.wheels
    env.reset(seed=11)
    st = base._st
    w0 = np.array(st.omega_B, float).ravel()
    bias = np.zeros(3) if st.bias is None else np.array(st.bias, float).ravel()
    caps = rb.rate_caps_with_wheels(lim, w0[None], bias[None],
                                    rb.energy_settle_bound(lim, w0[None], np.array([1.0]),
                                                           bias[None])["accel"])
    h0 = caps["momentum_max"][0] - (lim.torque_ext + wh.torque_other + np.linalg.norm(bias)) \
        * lim.settle_time_max
    rate_h = lim.torque_ext + wh.torque_other + np.linalg.norm(bias)
    rng = np.random.default_rng(4)
    a = np.zeros(env.action_space.shape, np.float32)
    worst = {"H": 0.0, "h": 0.0, "w": 0.0}
    hold = 0
    for k in range(1, 151):
        if hold == 0:
            a[:3] = rng.choice([-1.0, -0.3, 0.3, 1.0], size=3) * np.array([1.0, 1.0, 0.3])
            hold = int(rng.integers(1, 11))
        hold -= 1
        _, _, term, _, _ = env.step(a)
        st = base._st
        w = np.array(st.omega_B, float).ravel()
        h = wh.inertia * (np.array(st.wheel_speed, float).ravel() + wh.axes_B @ w)
        H = lim.inertia_B @ w + wh.axes_B.T @ h
        worst["H"] = max(worst["H"], np.linalg.norm(H) / (h0 + rate_h * k * lim.control_dt))
        h_top = wh.inertia * (wh.speed_bound + lim.rate_limit)
        worst["h"] = max(worst["h"], float(np.max(np.abs(h) / h_top)))
        worst["w"] = max(worst["w"], np.linalg.norm(w) / caps["momentum"][0])
        if term:  # past the rate limit: the episode (and the caps' premise) ends
            break
    assert all(0.0 < v <= 1.0 for v in worst.values()), worst
    assert worst["h"] > 0.8  # a rotor did reach its speed limit


@pytest.mark.parametrize("scene", ["cubesat-6u-rw", "cubesat-12u-rw"])
def test_the_wheel_caps_only_tighten_the_energy_bound(scene):
    """On 300 episodes the wheel bound is never below the energy bound without the caps, and
    on cubesat-6u-rw (no thrusters) the rate cap raises its median by 3 s (11.5 → 14.5 s)."""
    import dataclasses

    lim = rb.torque_limits(scene)
    st = rb.episode_starts(300, 1_000_000, scene, env_id=rbenv.ENV_ID)
    new = rb.energy_settle_bound(lim, st["omega_B"], st["angle"], st["bias_B"])
    old = rb.energy_settle_bound(dataclasses.replace(lim, wheels=None), st["omega_B"],
                                 st["angle"], st["bias_B"])
    assert (new["continuous"] >= old["continuous"] - 1e-12).all()
    assert (new["rate_cap"]["cap"] <= new["rate_cap"]["energy"]).all()
    if scene == "cubesat-6u-rw":
        assert np.median(new["sampled"]) - np.median(old["sampled"]) == pytest.approx(3.0)


def test_wheels_alone_the_momentum_cap_binds_on_cubesat_12u_rw():
    """Without the thrusters |H| stays near its start, and the three RWP015 (15 mN·m·s) cap
    the rate below the rate limit: the wheels-only bound is the larger, by the cap."""
    st = rb.episode_starts(50, 1_000_000, "cubesat-12u-rw", env_id=rbenv.ENV_ID)
    alone = rb.energy_settle_bound(rb.torque_limits("cubesat-12u-rw", used=("wheels",)),
                                   st["omega_B"], st["angle"], st["bias_B"])
    every = rb.energy_settle_bound(rb.torque_limits("cubesat-12u-rw"), st["omega_B"],
                                   st["angle"], st["bias_B"])
    caps = alone["rate_cap"]
    assert (caps["cap"] == caps["momentum"]).all() and (caps["momentum"] < 0.1745).all()
    assert (alone["sampled"] >= every["sampled"]).all()
    assert np.median(alone["sampled"]) > 1.5 * np.median(every["sampled"])


def test_thruster_scenes_have_no_wheel_caps():
    lim = rb.torque_limits("cubesat-12u")
    assert lim.wheels is None
    out = rb.energy_settle_bound(lim, np.zeros((1, 3)), np.array([2.0]))
    assert "rate_cap" not in out


def test_a_bad_actuator_set_is_named():
    with pytest.raises(rbenv.core.errors.InvalidParameterError, match=r"used=\['rods'\]"):
        rb.torque_limits("cubesat-6u-rw", used=("rods",))
