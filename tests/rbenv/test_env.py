"""The single env: checkers, spaces, reward bookkeeping, termination, actions, physics errors."""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from rbenv.core import quaternion
from rbenv.core.errors import InvalidParameterError, NonFiniteError

import rbenv
from rbenv.satellite.scene import load_scene
from rbenv.tasks.base import restricted_haar_angle
from rbenv.tasks.reorient import ReorientWeights

ID = "rbenv/SatelliteReorient-v0"  # this file checks the first release: its observation, reward
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
MODES = ("throttle", "on_off", "torque")


def make(**kwargs):
    return gym.make(ID, **kwargs)


def pd_action(env, obs, wn=0.3, zeta=0.9, w_max=0.1):
    """Rate-limited quaternion-feedback PD (eigenaxis), as a torque-mode action.

    Gains k = 2ωn², c = 2ζωn (small angles: q_v ≈ θ/2·ê, so θ̈ + cθ̇ + ωn²θ = 0). The
    commanded rate −(k/c)·q_v is capped at w_max (Wie–Lu rate limit) and τ = −J c (ω − ω_cmd).
    q_err is canonical (w ≥ 0), which is the sgn(q0) of Wie's regulator (no unwinding).
    """
    u = env.unwrapped
    J, L = u.scene.body.inertia, u.scene.episode.rate_limit
    k, c = 2 * wn**2, 2 * zeta * wn
    v, w = obs[1:4].astype(float), obs[4:7].astype(float) * L
    w_cmd = -(k / c) * v
    n = np.linalg.norm(w_cmd)
    if n > w_max:
        w_cmd *= w_max / n
    tau = -J @ (c * (w - w_cmd))
    return (tau / u.config.torque_authority).astype(np.float32)


# --------------------------------------------------------------------------- checkers


@pytest.mark.parametrize(("scene", "mode"), [
    (scene, mode) for scene in rbenv.list_scenes() for mode in MODES
    if mode != "on_off" or (rbenv.load_scene(scene).thrusters is not None  # on/off: thrusters
                            and "wheels" not in rbenv.load_scene(scene).actuators)])
def test_gymnasium_and_sb3_checkers_pass_without_warnings(scene, mode):
    """Gymnasium's checker runs in a base install too; SB3's where SB3 is installed."""
    render = scene == "cubesat-12u" and mode == "throttle"
    if render:
        try:
            import pygame  # noqa: F401
        except ImportError:
            render = False  # the render check needs the render extra
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        check_env(make(scene=scene, action_mode=mode).unwrapped, skip_render_check=not render)
    try:
        from stable_baselines3.common import env_checker as sb3_checker
    except ImportError:
        return  # a base install: Gymnasium's checker above is the whole check
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        sb3_checker.check_env(make(scene=scene, action_mode=mode).unwrapped)


def test_registration_and_spaces():
    env = make()
    assert env.spec.max_episode_steps == rbenv.MAX_EPISODE_STEPS
    # one route for every id: the registry's entry points, told the entry, pick the class
    assert env.spec.entry_point == "rbenv.envs.registry:make_env"
    assert env.spec.vector_entry_point == "rbenv.envs.registry:make_vector_env"
    assert type(env.unwrapped) is rbenv.SatelliteReorientEnv
    venv = gym.make_vec(env.spec.id, num_envs=2)
    assert type(venv) is rbenv.SatelliteReorientVectorEnv
    assert env.action_space == gym.spaces.Box(-1, 1, (12,), np.float32)
    assert env.observation_space == gym.spaces.Box(-1, 1, (7,), np.float32)
    assert make(action_mode="torque").action_space.shape == (3,)
    assert env.unwrapped.metadata["render_fps"] == 2.0
    assert type(env.unwrapped).metadata["render_fps"] == 2  # class metadata untouched


@pytest.mark.parametrize("bad", [
    {"action_mode": "pwm"}, {"integrator": "nope"}, {"control_dt": -1.0}, {"substeps": 0},
    {"reward_weights": {"atitude": 1.0}}, {"reward_weights": {"fuel": -1.0}},
    {"max_initial_angle_deg": 200.0}, {"max_initial_rate": 1.0}, {"render_mode": "ansi"},
])
@pytest.mark.filterwarnings("ignore:.*render_mode")
def test_bad_options_raise_value_errors(bad):
    with pytest.raises(InvalidParameterError):
        make(**bad)


# --------------------------------------------------------------------------- step contract


def test_step_types_info_keys_and_reward_terms_sum_exactly():
    env = make()
    obs, info = env.reset(seed=3)
    assert obs.dtype == np.float32 and obs.shape == (7,)
    assert info["is_success"] is False and all(info[f"reward_{t}"] == 0.0
                                               for t in ReorientWeights.Terms._fields)
    rng = np.random.default_rng(0)
    for _ in range(50):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 12))
        assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
        assert env.observation_space.contains(obs)
        total = 0.0
        for t in ReorientWeights.Terms._fields:
            total += info[f"reward_{t}"]
        assert total == reward
        for key in ("attitude_error_deg", "rate_dps", "fuel_kg", "impulse_Ns", "time_s"):
            assert math.isfinite(info[key])
    assert info["fuel_kg"] > 0
    scene = env.unwrapped.scene
    isp = scene.actuators["thrusters"].isp
    assert info["fuel_kg"] == pytest.approx(info["impulse_Ns"] / (isp * 9.80665))
    assert info["time_s"] == pytest.approx(50 * scene.physics.control_dt)


def test_precision_term_is_off_by_default_and_pulls_over_the_last_degrees():
    """Off: exactly 0, so default rewards are unchanged. On: w·θ_s/(θ_s + θ) from the true
    error angle, the full weight w on target."""
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (40, 12))
    default, pulled = make(), make(reward_weights={"precision": 2.0})
    default.reset(seed=4)
    pulled.reset(seed=4)
    theta_s = math.radians(default.unwrapped.scene.episode.success_angle_deg)
    for a in actions:
        _, r0, *_, i0 = default.step(a)
        _, r1, *_, i1 = pulled.step(a)
        assert i0["reward_precision"] == 0.0
        theta = math.radians(i1["attitude_error_deg"])
        assert i1["reward_precision"] == pytest.approx(2.0 * theta_s / (theta_s + theta),
                                                       rel=1e-12)
        assert r1 - r0 == pytest.approx(i1["reward_precision"], abs=1e-9)
    # On target and at rest the pull is the full weight (the disturbance bias moves it by
    # far less than a degree in one step).
    q = np.array([1.0, 0.0, 0.0, 0.0])
    pulled.reset(seed=5, options={"q": q, "q_target": q, "omega_B": np.zeros(3)})
    _, _, _, _, info = pulled.step(np.zeros(12))
    assert info["reward_precision"] == pytest.approx(2.0, rel=1e-3)


def test_observation_layout_matches_state():
    env = make()
    q_target = quaternion.from_axis_angle([0.0, 0.0, 1.0], 0.2)
    q = quaternion.from_axis_angle([1.0, 0.0, 0.0], 2.0)
    w = np.array([0.01, -0.02, 0.03])
    obs, info = env.reset(seed=0, options={"q": q, "q_target": q_target, "omega_B": w})
    q_err = quaternion.canonical(quaternion.multiply(quaternion.conjugate(q_target), q))
    np.testing.assert_allclose(obs[:4], q_err, atol=1e-7)
    np.testing.assert_allclose(obs[4:], w / env.unwrapped.scene.episode.rate_limit, atol=1e-7)
    expected = np.degrees(quaternion.angle(q_target, q))
    assert info["attitude_error_deg"] == pytest.approx(expected)


def test_seeded_resets_and_steps_are_reproducible():
    def rollout(seed):
        env = make(scene="boom-sat")  # noise, faults and disturbances all draw from np_random
        out = [env.reset(seed=seed)[0]]
        for a in np.random.default_rng(1).uniform(-1, 1, (30, 12)):
            out.append(env.step(a)[0])
        return np.array(out)

    np.testing.assert_array_equal(rollout(7), rollout(7))
    assert not np.array_equal(rollout(7), rollout(8))


def test_nan_action_raises_value_error_naming_action():
    for mode in MODES:
        env = make(action_mode=mode)
        env.reset(seed=0)
        a = np.zeros(env.action_space.shape, np.float32)
        a[1] = np.nan
        with pytest.raises(ValueError, match=r"action must not contain NaN.*index \(1,\)"):
            env.step(a)


@pytest.mark.parametrize("mode", MODES)
def test_out_of_range_actions_are_clipped(mode):
    env1, env2 = make(action_mode=mode), make(action_mode=mode)
    env1.reset(seed=4)
    env2.reset(seed=4)
    big = np.tile([7.0, -9.0, 0.5], env1.action_space.shape[0] // 3 + 1)[
        : env1.action_space.shape[0]]
    o1, r1, *_ = env1.step(big)
    o2, r2, *_ = env2.step(np.clip(big, -1, 1))
    np.testing.assert_array_equal(o1, o2)
    assert r1 == r2


def test_throttle_mapping_off_below_zero_and_on_off_is_full():
    env = make()
    env.reset(seed=0)
    *_, info = env.step(-np.ones(12))
    assert info["impulse_Ns"] == 0.0
    env_on = make(action_mode="on_off")
    env_on.reset(seed=0)
    a = np.full(12, -1.0)
    a[0] = 0.01
    *_, info = env_on.step(a)
    scene = env_on.unwrapped.scene
    assert info["impulse_Ns"] == pytest.approx(scene.thrusters.max_force[0] * 0.5)


# --------------------------------------------------------------------------- episodes


def test_pd_controller_settles_from_180_degrees_with_margin():
    """A rate-limited PD (ωn 0.3 rad/s, ζ 0.9, |ω_cmd| ≤ 0.1 rad/s) through the pinv allocator
    settles from a 180° error well within the episode (measured ≈ 41 s of 80 s)."""
    settle = []
    for axis in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [1, -2, 0.5]):
        env = make(action_mode="torque")
        q0 = quaternion.from_axis_angle(np.array(axis, float), math.pi - 1e-9)
        obs, _ = env.reset(seed=0, options={"q": q0, "q_target": IDENTITY})
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, info = env.step(pd_action(env, obs))
        assert info["is_success"] and terminated and not truncated
        settle.append(info["time_s"])
    assert max(settle) < 0.7 * env.unwrapped.scene.episode.duration


def test_pd_succeeds_from_random_starts():
    env = make(action_mode="torque")
    for seed in range(5):
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(pd_action(env, obs))
            done = terminated or truncated
        assert info["is_success"]


def test_success_needs_the_hold_time_and_pays_the_hold_bonus():
    env = make()
    env.reset(seed=0, options={"q": IDENTITY, "q_target": IDENTITY, "omega_B": np.zeros(3)})
    hold = env.unwrapped.scene.hold_steps
    for i in range(hold):
        _, _, terminated, _, info = env.step(-np.ones(12))
        assert info["reward_hold"] == 1.0
        assert terminated == (i == hold - 1) == info["is_success"]


def test_loss_of_control_terminates_without_success():
    env = make()
    limit = env.unwrapped.scene.episode.rate_limit
    env.reset(seed=0, options={"omega_B": np.array([0.0, 0.0, 0.99 * limit])})
    a = -np.ones(12)
    a[[10, 11]] = 1.0  # the +z couple spins the satellite up further
    _, reward, terminated, truncated, info = env.step(a)
    assert terminated and not truncated and not info["is_success"]
    assert info["reward_failure"] == -25.0 and reward < -24.0


def test_time_limit_truncates():
    env = make()
    env.reset(seed=1)
    steps, truncated, terminated = 0, False, False
    while not (truncated or terminated):
        _, _, terminated, truncated, _ = env.step(-np.ones(12))
        steps += 1
    assert truncated and not terminated and steps == rbenv.MAX_EPISODE_STEPS


def test_curriculum_limits_initial_error_and_rate():
    env = make(max_initial_angle_deg=10.0, max_initial_rate=0.001)
    for seed in range(20):
        _, info = env.reset(seed=seed)
        assert info["attitude_error_deg"] <= 10.0 + 1e-9
        assert info["rate_dps"] <= np.degrees(0.001) + 1e-9
    env.unwrapped.set_initial_ranges(max_initial_angle_deg=1.0)
    assert max(env.reset(seed=s)[1]["attitude_error_deg"] for s in range(20)) <= 1.0 + 1e-9
    angles = [make().reset(seed=s)[1]["attitude_error_deg"] for s in range(40)]
    assert max(angles) > 120.0  # the default covers all of SO(3)


def test_restricted_haar_angle_inverts_the_cdf():
    for u in (0.0, 0.3, 0.999):
        theta = restricted_haar_angle(u, math.pi)
        assert (theta - math.sin(theta)) / math.pi == pytest.approx(u, abs=1e-12)


# --------------------------------------------------------------------------- modelled effects


def test_sensor_noise_changes_observation_not_reward():
    scene = load_scene("microsat-100kg")
    env = make(scene=scene)
    opts = {"q": IDENTITY, "q_target": IDENTITY, "omega_B": np.zeros(3)}
    obs, info = env.reset(seed=0, options=opts)
    assert obs[0] < 1.0 or np.any(obs[4:] != 0.0)  # measured, not true
    quiet = make(scene=scene.__class__(**{**scene.__dict__,
                                          "sensor_noise": type(scene.sensor_noise)()}))
    obs_q, info_q = quiet.reset(seed=0, options=opts)
    np.testing.assert_array_equal(obs_q, [1, 0, 0, 0, 0, 0, 0])
    assert info_q["attitude_error_deg"] == info["attitude_error_deg"] == 0.0


def test_translation_is_modelled_only_when_declared():
    env = make(scene="microsat-100kg")
    env.reset(seed=0)
    a = -np.ones(8)
    a[0] = 1.0  # one thruster alone: net force
    *_, info = env.step(a)
    assert info["speed_mps"] == pytest.approx(1.0 * 0.5 / 100.0, rel=1e-6)
    assert "speed_mps" not in make().reset(seed=0)[1]


def test_faults_at_reset_stop_thrust_and_fuel():
    base = load_scene("cubesat-12u")
    faults = type(base.faults)(model="random", p_reset=1.0)
    env = make(scene=base.__class__(**{**base.__dict__, "faults": faults}))
    _, info = env.reset(seed=0)
    assert info["failed_thrusters"] == 12
    *_, info = env.step(np.ones(12))
    assert info["fuel_kg"] == 0.0 and info["impulse_Ns"] == 0.0


def test_isotropic_body_takes_the_cheap_path_and_still_works():
    base = load_scene("cubesat-12u")
    body = type(base.body)(mass=24.0, inertia=0.3 * np.eye(3))
    env = make(scene=base.__class__(**{**base.__dict__, "body": body}))
    assert env.unwrapped.scene.body.is_isotropic
    env.reset(seed=0)
    obs, *_ = env.step(np.ones(12))
    assert np.isfinite(obs).all()


# --------------------------------------------------------------------------- failures


def test_diverging_physics_raises_instead_of_nan_observation():
    """Explicit Euler with a huge step on a fast-spinning asymmetric body blows up."""
    env = make(scene="boom-sat", integrator="euler", control_dt=40.0, substeps=1,
               max_initial_rate=0.049)
    env.reset(seed=0, options={"omega_B": np.array([0.03, 0.0, 0.049])})
    with pytest.raises(NonFiniteError, match="integrator='euler'"):
        for _ in range(200):
            obs, *_ = env.step(-np.ones(12))
            assert np.isfinite(obs).all()


def test_step_before_reset_is_an_error():
    env = rbenv.SatelliteReorientEnv()
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(12))


def test_env_pickles_mid_episode():
    env = rbenv.SatelliteReorientEnv(scene="boom-sat")
    env.reset(seed=5)
    env.step(np.full(12, 0.1))
    clone = pickle.loads(pickle.dumps(env))
    a = np.random.default_rng(2).uniform(-1, 1, 12)
    o1, r1, *_ = env.step(a)
    o2, r2, *_ = clone.step(a)
    np.testing.assert_array_equal(o1, o2)
    assert r1 == r2
