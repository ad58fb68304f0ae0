"""Desaturate-v1 (issue 45): the policy commands the rods, the wheels' attitude hold is in the
loop (rbenv/tasks/desaturate.py, DesaturateV1), and the observation adds the cross-product
law's direction. Checked against v0 run by hand: the same starts and, under the same wheel
torques, the same episode; the inner loop's torques and the new feature against their
formulas written out here; the unload baseline's episode equal to its v0 one."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines.controllers import Unload, WheelHoldPD, applicable_baselines, baseline
from rbenv.core.errors import InvalidParameterError

import rbenv
from tests.rbenv.quiet import make as _make

V1, V0 = "rbenv/SatelliteDesaturate-v1", "rbenv/SatelliteDesaturate-v0"
SCENE = "cubesat-6u-rw"


def test_v1_is_registered_with_its_own_classes_and_history():
    spec = rbenv.envs.registry.get(V1)
    assert spec.task.name == "desaturate_v1" and spec.task.table_name() == "desaturate"
    assert spec.default_scene == SCENE and spec.max_episode_steps == 300
    assert rbenv.ENV_IDS[V1] == ("SatelliteDesaturateV1Env", "SatelliteDesaturateV1VectorEnv")
    assert "**Version History**" in spec.env_doc and "* v1:" in spec.env_doc
    assert not rbenv.envs.registry.get(V0).task.inner_loop and spec.task.inner_loop
    env = _make(V1)
    assert env.unwrapped.plant.scene.name == SCENE
    assert env.action_space.shape == _make(V0).action_space.shape == (6,)


def test_both_checkers_pass_with_warnings_as_errors():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(V1, render_mode="rgb_array").unwrapped)
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(gym.make(V1), warn=True)


def _hold_torques(env) -> np.ndarray:
    """The documented inner loop from the env's state, written out with NumPy: the
    WheelHoldPD law τ = −I c (ω − ω_c) + ω × (I ω + h_w) (ω_n = min(0.3, 0.2/dt), ζ = 1,
    ω_c = −(k/c) q_v capped at 0.1 of the rate limit), minus the rods' m × B, to wheel
    fractions u/u_max of u = −G⁺ τ scaled down as a whole at a limit."""
    st, plant, task = env._st, env.plant, env.task
    dt = plant.control_dt
    wn = min(0.3, 0.2 / dt)
    k, c = 2 * wn**2, 2 * wn
    q_err, w = np.array(st.q_err), np.array(st.omega_B)
    inertia = plant.scene.body.inertia
    ws = plant.actuator("wheels").wheels
    h_w = (np.array(st.wheel_speed) * ws.inertia) @ ws.axes_B
    wc = -(k / c) * q_err[1:]
    wc *= min(1.0, 0.1 * task.rate_limit / np.linalg.norm(wc))
    tau = -c * inertia @ (w - wc) + np.cross(w, inertia @ w + h_w)
    return tau, ws


def test_zero_action_is_the_documented_wheel_hold():
    """A zero action: the wheels get the inner loop's torques (checked against the law
    written out, step by step), the rods nothing; the attitude is held, nothing unloads."""
    env = _make(V1).unwrapped
    env.reset(seed=4)
    h0 = env.task.stored_momentum(env._st.wheel_speed, np)
    for _ in range(30):
        tau, ws = _hold_torques(env)
        u = -np.linalg.pinv(ws.axes_B.T) @ tau
        u = u / max(1.0, np.max(np.abs(u) / ws.max_torque))
        plant_action = env.task.command(env._st, np.zeros(6, np.float32), rbenv.core.backend.FLOAT)
        np.testing.assert_allclose(plant_action[:3], u / ws.max_torque, rtol=1e-9, atol=1e-15)
        np.testing.assert_array_equal(plant_action[3:], 0.0)
        _, _, term, _, info = env.step(np.zeros(6, np.float32))
        assert not term
    assert info["attitude_error_deg"] < 1.0 and info["mtq_energy_J"] == 0.0
    assert abs(info["wheel_momentum_Nms"] - h0) < 0.05 * h0


def test_the_rod_entries_are_the_dipole_and_the_wheels_feed_its_torque_forward():
    """Rod entries (clipped) make the body dipole Σ a_i μ_max ĝ_i; the wheel torques are the
    hold's minus m × B; the policy's wheel entries are not read."""
    env = _make(V1).unwrapped
    env.reset(seed=2)
    a = np.array([0.9, -0.4, 0.1, 0.5, -2.0, 0.25], np.float32)
    tau, ws = _hold_torques(env)
    rods = env.plant.actuator("magnetorquers")
    m = np.clip(a[3:].astype(float), -1, 1) @ rods.dipole_matrix
    tau = tau - np.cross(m, np.array(env._st.field_B_T))
    u = -np.linalg.pinv(ws.axes_B.T) @ tau
    u = u / max(1.0, np.max(np.abs(u) / ws.max_torque))
    out = env.task.command(env._st, a, rbenv.core.backend.FLOAT)
    np.testing.assert_allclose(out[:3], u / ws.max_torque, rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(out[3:], a[3:])  # the plant clips them
    assert a[0] == np.float32(0.9)  # the policy's action is not changed
    b = a.copy()
    b[:3] = [-1.0, 1.0, 0.0]
    np.testing.assert_array_equal(env.task.command(env._st, b, rbenv.core.backend.FLOAT), out)
    env.step(a)
    np.testing.assert_allclose(env._st.mtq_dipole_B, [0.2 * 0.5, -0.2, 0.2 * 0.25], rtol=1e-7)


def _v0_part(obs):
    """v0's observation inside v1's: q_err, ω_B, then the actuators' parts (v1 adds dump_B)."""
    return np.concatenate([obs[..., :7], obs[..., 10:]], axis=-1)


def test_dump_b_is_the_cross_product_laws_direction():
    """dump_B = (h_w × B)/(h_0 · 50 µT) from the wheel speeds and the field (written out);
    decoded by name, it is h_w × B in N·m·s·T."""
    env = _make(V1).unwrapped
    assert list(env.observation_structure) == ["q_err", "omega_B", "dump_B", "wheel_speed",
                                               "field_B"]
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        for _ in range(seed * 5):
            obs, *_ = env.step(env.action_space.sample())
        ws = env.plant.actuator("wheels").wheels
        h = (np.array(env._st.wheel_speed) * ws.inertia) @ ws.axes_B
        b = np.array(env._st.field_B_T)
        h0 = 0.3 * float(np.min(ws.inertia * ws.max_speed))
        np.testing.assert_allclose(obs[7:10], np.cross(h, b) / (h0 * 5e-5), rtol=1e-6,
                                   atol=1e-7)
        np.testing.assert_allclose(env.task.decode(obs[:10])["dump_B"], np.cross(h, b),
                                   rtol=1e-6, atol=1e-13)


def test_v1_episodes_are_v0_episodes_under_the_same_plant_action():
    """Same seed: the same start and observation; stepping v0 with the action v1 makes for
    the plant gives v1's episode exactly (observation, reward, info)."""
    new, old = _make(V1).unwrapped, _make(V0).unwrapped
    o1, i1 = new.reset(seed=11)
    o0, i0 = old.reset(seed=11)
    np.testing.assert_array_equal(_v0_part(o1), o0)
    assert i1["wheel_momentum_Nms"] == i0["wheel_momentum_Nms"]
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, 6).astype(np.float32)
        plant_action = new.task.command(new._st, a, rbenv.core.backend.FLOAT)
        r1 = new.step(a)
        r0 = old.step(plant_action)
        np.testing.assert_array_equal(_v0_part(r1[0]), r0[0])
        assert r1[1] == r0[1] and r1[4]["wheel_momentum_Nms"] == r0[4]["wheel_momentum_Nms"]


def test_unload_runs_on_v1_as_on_v0():
    """The row's baseline: on v1 it sends only its rod law (the env holds the attitude) and
    its episode is v0's to round-off; it succeeds."""
    results = []
    for env_id in (V0, V1):
        env = _make(env_id)
        policy = baseline(env, "unload")
        assert isinstance(policy, Unload)
        obs, info = env.reset(seed=3)
        state, trace = None, []
        for _ in range(300):
            action, state = policy.predict(obs, state)
            if env_id == V1:
                assert np.all(action[:3] == 0.0)
            obs, _, term, trunc, info = env.step(action)
            trace.append(info["wheel_momentum_Nms"])
            if term or trunc:
                break
        results.append((np.array(trace), info))
    (h0, i0), (h1, i1) = results
    assert i0["is_success"] and i1["is_success"] and len(h0) == len(h1)
    np.testing.assert_allclose(h1, h0, rtol=1e-6)
    assert applicable_baselines(V1, SCENE) == ["unload", "pd"]
    assert isinstance(baseline(_make(V1), "pd"), WheelHoldPD)


def test_vector_env_equals_single_env():
    envs = gym.make_vec(V1, num_envs=3)
    obs, _ = envs.reset(seed=21)
    single = _make(V1)
    o, _ = single.reset(seed=21)
    assert obs.shape == (3, 16)
    np.testing.assert_array_equal(obs[0], o)
    rng = np.random.default_rng(1)
    for _ in range(10):
        a = rng.uniform(-1, 1, (3, 6)).astype(np.float32)
        obs, r, *_ = envs.step(a)
        o, r1, *_ = single.step(a[0])
        np.testing.assert_array_equal(obs[0], o)
        assert r[0] == r1
    envs.close()


def test_v1_errors_name_the_rule():
    with pytest.raises(InvalidParameterError, match=r"has no \[wheels\]"):
        gym.make(V1, scene="cubesat-12u")
    with pytest.raises(InvalidParameterError, match=r"cubesat-12u-rw.*no \[magnetorquers\]"):
        gym.make(V1, scene="cubesat-12u-rw")
    with pytest.raises(InvalidParameterError, match=r"action_mode must be 'throttle'.*'torque'"):
        gym.make(V1, action_mode="torque")
    with pytest.raises(InvalidParameterError, match=r"initial_speed_fraction.*1\.5"):
        gym.make(V1, task_options={"initial_speed_fraction": 1.5})
