"""Scripted controllers: control laws, allocation, hysteresis and closed-loop success."""

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines.controllers import (
    EigenaxisBangBang,
    QuaternionPD,
    RandomPolicy,
    ZeroPolicy,
)
from rbenv.agents.policies.evaluate import evaluate
from rbenv.core import quaternion

import rbenv


@pytest.fixture(scope="module")
def env():
    e = gym.make("rbenv/SatelliteReorient-v0")  # the tests write v0 observations (q_err, ω)
    yield e
    e.close()


def obs_from(q_err, omega_B, rate_limit):
    return np.concatenate([q_err, np.asarray(omega_B) / rate_limit]).astype(np.float32)


def test_pd_torque_is_the_quaternion_feedback_law(env):
    pd = QuaternionPD.from_env(env, natural_frequency=0.2, damping=0.8, max_rate=10.0)
    I = env.unwrapped.config.scene.body.inertia
    q_err = quaternion.from_axis_angle([0.3, -0.5, 0.8], np.radians(10.0))[None]
    omega_B = np.array([[0.01, -0.02, 0.005]])
    k, c = 2 * 0.2**2, 2 * 0.8 * 0.2
    expected = -(k * q_err[:, 1:] + c * omega_B) @ I.T + np.cross(omega_B, omega_B @ I.T)
    assert np.allclose(pd.torque(q_err, omega_B), expected, rtol=1e-12, atol=1e-15)


def test_pd_rate_command_is_capped_along_the_eigenaxis(env):
    pd = QuaternionPD.from_env(env, natural_frequency=0.3, damping=1.0, max_rate=0.05)
    I = env.unwrapped.config.scene.body.inertia
    axis = np.array([0.0, 0.6, 0.8])
    q_err = quaternion.from_axis_angle(axis, np.radians(170.0))[None]
    tau = pd.torque(q_err, np.zeros((1, 3)))
    # At rest far from the target the demand is c·I·ω_c with |ω_c| = max_rate along −axis.
    omega_c = np.linalg.solve(I, tau[0]) / (2 * 1.0 * 0.3)
    assert np.linalg.norm(omega_c) == pytest.approx(0.05, rel=1e-9)
    assert np.allclose(omega_c / 0.05, -axis, atol=1e-9)


def test_predict_allocates_demanded_torque_with_valid_throttles(env):
    pd = QuaternionPD.from_env(env)
    cfg = env.unwrapped.config
    rng = np.random.default_rng(0)
    q = quaternion.canonical(quaternion.from_axis_angle(rng.normal(size=(64, 3)),
                                                        np.radians(rng.uniform(0, 5, 64))))
    w = rng.normal(0, 0.005, (64, 3))
    obs = np.hstack([q, w / cfg.scene.episode.rate_limit]).astype(np.float32)
    actions, state = pd.predict(obs)
    assert actions.shape == (64, *cfg.action_shape) and actions.dtype == np.float32
    assert np.all((actions >= 0) & (actions <= 1))
    demanded = pd.torque(q, obs[:, 4:7].astype(float) * cfg.scene.episode.rate_limit)
    achieved = actions.astype(float) @ cfg.scene.thrusters.torque_matrix_B.T
    assert np.allclose(achieved, demanded, atol=1e-6 * np.abs(demanded).max())
    single, _ = pd.predict(obs[0])
    assert single.shape == cfg.action_shape
    assert np.allclose(single, actions[0])
    assert state.shape == (64, 4)


def test_hysteresis_keeps_direction_near_180_degrees(env):
    pd = QuaternionPD.from_env(env, hysteresis=0.05)
    rl = env.unwrapped.config.scene.episode.rate_limit
    axis = np.array([1.0, 0.0, 0.0])
    # Canonical observation just past 180° (w = +0.01): the short way round flipped sign, but
    # the previous step was turning the other way, so the controller must keep going.
    q_obs = np.array([0.01, np.sqrt(1 - 0.01**2), 0.0, 0.0])
    prev = -q_obs  # what the controller used on the last step
    _, state = pd.predict(obs_from(q_obs, [0, 0, 0], rl), state=prev)
    assert np.allclose(state, -q_obs)
    # Clearly on the other side (w > hysteresis): take the short way.
    q_far = quaternion.from_axis_angle(axis, np.radians(160.0))
    _, state = pd.predict(obs_from(q_far, [0, 0, 0], rl), state=-q_far)
    assert np.allclose(state, q_far)
    # A new episode forgets the memory.
    _, state = pd.predict(obs_from(q_obs, [0, 0, 0], rl), state=prev, episode_start=[True])
    assert np.allclose(state, q_obs)


def test_bangbang_saturates_far_and_hands_over_near(env):
    bb = EigenaxisBangBang.from_env(env)
    rl = env.unwrapped.config.scene.episode.rate_limit
    far = obs_from(quaternion.from_axis_angle([0, 0, 1], np.radians(120.0)), [0, 0, 0], rl)
    action, _ = bb.predict(far)
    assert action.max() == pytest.approx(1.0, abs=1e-6)  # full authority along the eigenaxis
    q_near = quaternion.from_axis_angle([0, 1, 0], np.radians(1.0))[None]
    w_near = np.array([[0.0, -0.002, 0.0]])
    assert np.allclose(bb.torque(q_near, w_near), bb.pd.torque(q_near, w_near))
    assert bb.alpha > 0


def test_scripted_policies_reorient_every_seeded_episode():
    for name in ("pd", "bangbang"):
        result = evaluate(name, episodes=64, seed=123)
        assert result.success.all(), name
        assert np.nanmax(result.final_error_deg) < 1.0


def test_pd_settles_from_exactly_180_degrees():
    env = gym.make(rbenv.ENV_ID)
    pd = QuaternionPD.from_env(env)
    q_target = np.array([1.0, 0.0, 0.0, 0.0])
    q = quaternion.from_axis_angle([0.2, -0.7, 0.4], np.pi)
    obs, _ = env.reset(seed=5, options={"q": q, "q_target": q_target, "omega_B": np.zeros(3)})
    state, done = None, False
    while not done:
        action, state = pd.predict(obs, state)
        obs, _, term, trunc, info = env.step(action)
        done = term or trunc
    assert info["is_success"]
    assert info["time_s"] < 0.75 * env.unwrapped.config.scene.episode.duration


def test_baselines_have_the_right_shapes():
    zero, rand = ZeroPolicy(12), RandomPolicy(12, seed=1)
    a0, _ = zero.predict(np.zeros((5, 7)))
    assert a0.shape == (5, 12) and np.all(a0 == -1.0)
    a1, _ = rand.predict(np.zeros(7))
    assert a1.shape == (12,) and np.all(np.abs(a1) <= 1)
    assert np.allclose(RandomPolicy(12, seed=1).predict(np.zeros(7))[0], a1)


def test_torque_action_mode_is_supported():
    env = gym.make(rbenv.ENV_ID, action_mode="torque")
    pd = QuaternionPD.from_env(env)
    obs, _ = env.reset(seed=0)
    action, _ = pd.predict(obs)
    assert action.shape == (3,) and np.all(np.abs(action) <= 1)
