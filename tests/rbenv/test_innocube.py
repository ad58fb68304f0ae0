"""Wheels and sensors as flown (innocube-3u) against closed forms: a one-axis wheel spun by an
acceleration command (deadband, realized gain, start-up delay, clamp, speed quantization),
a gyro-integrated attitude drifting at its bias, a one-step observation delay, the wheel
reset options, and the flight PD's law."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines.controllers import InnoCubePD, NotApplicable
from rbenv.core.backend import FLOAT
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite.actuators.wheels import lift_over_deadband
from rbenv.satellite.scene import Scene

RPM = math.pi / 30.0
V1 = "rbenv/SatelliteReorient-v1"
I_Z, J = 0.00985, 5.4e-5


def _scene(wheels=None, **tables) -> Scene:
    """One wheel along −z on a still bus (no orbit): spin-up is one-axis, so exact."""
    data = {"name": "t", "body": {"mass": 4.2, "inertia": [0.0428, 0.0422, I_Z]},
            "wheels": {"axes": [[0.0, 0.0, -1.0]], "inertia": J, "max_torque": 0.002,
                       "max_speed_rpm": 6000.0, "max_acceleration_rpm_s": 100.0,
                       **(wheels or {})},
            "physics": {"control_dt": 1.0, "substeps": 10},
            "episode": {"duration": 100.0, "rate_limit": 1.0, "max_initial_rate": 0.0}}
    data.update(tables)
    return Scene.from_dict(data)


def _speeds(scene, actions, mode="acceleration", **reset):
    """Wheel speed (rad/s) and body rate z (rad/s) after each step of ``actions``."""
    env = gym.make(V1, scene=scene, action_mode=mode).unwrapped
    env.reset(seed=0, options={"q": [1.0, 0, 0, 0], "q_target": [1.0, 0, 0, 0], **reset})
    out = []
    for a in actions:
        env.step(np.array([a], np.float32))
        out.append((env._st.wheel_speed[0], env._st.omega_B[2]))
    return np.array(out), env


def test_acceleration_command_spins_the_wheel_at_the_commanded_rate_and_conserves_momentum():
    out, _ = _speeds(_scene(), [0.5] * 5 + [2.0] * 3)  # 50 RPM/s, then past the clamp
    expected = np.concatenate([50.0 * np.arange(1, 6), 250.0 + 100.0 * np.arange(1, 4)]) * RPM
    np.testing.assert_allclose(out[:, 0], expected, rtol=1e-12)
    # Spin momentum along −z, J (Ω − ω_z), plus the bus's I_RW ω_z stays zero.
    i_rw = I_Z - J
    np.testing.assert_allclose(i_rw * out[:, 1] - J * (out[:, 0] - out[:, 1]), 0.0, atol=1e-15)
    assert out[-1, 1] > 0.0  # the wheel speeds up along −z: the bus turns about +z


def test_deadband_and_realized_gain():
    scene = _scene({"deadband_rpm_s": 3.0, "realized_gain": 0.8})
    out, _ = _speeds(scene, [0.029] * 3 + [0.5] * 2)  # 2.9 RPM/s: nothing; 50: 40 realized
    np.testing.assert_array_equal(out[:3, 0], 0.0)
    np.testing.assert_allclose(out[3:, 0], np.array([40.0, 80.0]) * RPM, rtol=1e-12)


def test_lift_over_deadband_is_its_closed_form():
    up = 4.0 * RPM
    alpha = np.array([-2.0, -0.5, -0.99, -1.0, -1.01, -3.0, 0.0, 0.99, 1.0, 3.9, 4.0, 4.5, 50.0])
    lifted = lift_over_deadband(alpha * RPM, up) / RPM
    expected = np.array([-4.0, 0.0, 0.0, -4.0, -4.0, -4.0, 0.0, 0.0, 4.0, 4.0, 4.0, 4.5, 50.0])
    np.testing.assert_allclose(lifted, expected, rtol=1e-12)
    for a in alpha:  # the float path of one satellite agrees with the array path
        assert lift_over_deadband(float(a) * RPM, up, FLOAT) == pytest.approx(
            lift_over_deadband(a * RPM, up), rel=1e-15, abs=0.0)


def test_lifted_commands_pass_every_drawn_deadband():
    # The flight's range, 2-4 RPM/s, gain 0.8: 1.5 RPM/s asked (0.015 of the clamp) is lifted
    # to 4, which passes any deadband of the range and realizes 3.2 RPM/s; 0.5 asked is none.
    scene = _scene({"deadband_rpm_s": [2.0, 4.0], "realized_gain": 0.8})
    out, _ = _speeds(scene, [0.005] * 2 + [0.015] * 3 + [-0.5], mode="acceleration_lifted")
    np.testing.assert_array_equal(out[:2, 0], 0.0)
    expected = np.array([3.2, 6.4, 9.6, 9.6 - 40.0]) * RPM
    np.testing.assert_allclose(out[2:, 0], expected, rtol=1e-12)
    plain, _ = _speeds(scene, [0.015] * 3, mode="acceleration")  # the same request, not lifted
    np.testing.assert_array_equal(plain[:, 0], 0.0)
    with pytest.raises(InvalidParameterError, match=r"acceleration_lifted.*deadband"):
        gym.make(V1, scene=_scene(), action_mode="acceleration_lifted")


def test_lifted_mode_observes_the_last_command_and_plain_mode_does_not():
    scene = _scene({"deadband_rpm_s": [2.0, 4.0]})
    env = gym.make(V1, scene=scene, action_mode="acceleration_lifted").unwrapped
    assert env.observation_structure["wheel_command"] == 1
    obs, _ = env.reset(seed=0)
    assert obs[-1] == 0.0
    seen = [env.step(np.array([a], np.float32))[0][-1] for a in (0.015, -0.5, 0.005, 2.0)]
    np.testing.assert_allclose(seen, [0.04, -0.5, 0.0, 1.0], rtol=1e-6)  # lifted, clamped
    plain = gym.make(V1, scene=scene, action_mode="acceleration").unwrapped
    assert "wheel_command" not in plain.observation_structure
    assert plain.observation_space.shape[0] == env.observation_space.shape[0] - 1


def test_both_checkers_pass_in_the_lifted_mode():
    import warnings

    from gymnasium.utils.env_checker import check_env

    sb3 = pytest.importorskip("stable_baselines3.common.env_checker",
                              reason="stable-baselines3 is not installed (train extra)")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        check_env(gym.make(V1, scene="innocube-3u", action_mode="acceleration_lifted").unwrapped)
        sb3.check_env(gym.make(V1, scene="innocube-3u",
                               action_mode="acceleration_lifted").unwrapped)


@pytest.mark.slow
def test_slew_law_holds_where_the_flight_pd_stalls():
    from rbenv.agents.policies.evaluate import evaluate

    # Wheels as flown, attitude sensed exactly: the true final error is the law's own.
    scene = rbenv.scene_variant("innocube-3u", {"sensors": None}, name="exact-sensing")
    kw = {"episodes": 4, "env_id": V1, "record": 0, "scene": scene,
          "env_kwargs": {"action_mode": "acceleration_lifted"}}
    slew = evaluate("innocube-slew", **kw).final_error_deg
    lifted_pd = evaluate("innocube-pd", **kw).final_error_deg
    pd = evaluate("innocube-pd", **{**kw, "env_kwargs": {"action_mode": "acceleration"}}
                  ).final_error_deg
    assert np.all(slew < 0.1) and np.median(pd) > 1.0, (slew, pd)
    assert np.median(lifted_pd) < 0.5  # the lift alone takes the PD below its stall


def test_startup_delay_holds_the_wheel_still_after_the_first_command():
    scene = _scene({"startup_delay_s": 3.0})
    out, _ = _speeds(scene, [0.0] * 2 + [0.5] * 6)
    # First command on step 3 (t = 2 s): still over steps 3-5, moving from step 6 on.
    np.testing.assert_array_equal(out[:5, 0], 0.0)
    np.testing.assert_allclose(out[5:, 0], 50.0 * RPM * np.arange(1, 4), rtol=1e-12)
    started, _ = _speeds(scene, [0.5] * 2, wheel_clock_s=[100.0])  # a start in mid-run
    np.testing.assert_allclose(started[:, 0], 50.0 * RPM * np.arange(1, 3), rtol=1e-12)


def test_ranged_parameters_are_drawn_per_episode_within_their_range():
    scene = _scene({"deadband_rpm_s": [2.0, 4.0], "realized_gain": [0.75, 0.85],
                    "startup_delay_s": [6.0, 10.0]})
    env = gym.make(V1, scene=scene, action_mode="acceleration").unwrapped
    draws = []
    for _ in range(20):
        env.reset(seed=None if draws else 3)
        draws.append(env._st.wheel_flown)
    d = np.array(draws)
    assert np.all((d[:, 0] >= 2 * RPM) & (d[:, 0] <= 4 * RPM))
    assert np.all((d[:, 1] >= 0.75) & (d[:, 1] <= 0.85))
    assert np.all((d[:, 2] >= 6.0) & (d[:, 2] <= 10.0))
    assert len(np.unique(d[:, 1])) == 20
    env.reset(seed=3)
    assert env._st.wheel_flown == draws[0]  # seeded: the same draw


def test_speed_quantization_rounds_the_observed_speed_only():
    scene = _scene({"speed_quantization_rpm": 1.0})
    out, env = _speeds(scene, [0.0], wheel_speed=[12.3456])
    assert out[0, 0] == pytest.approx(12.3456)
    obs = env.step(np.array([0.0], np.float32))[0]
    assert obs[-1] == np.float32(round(12.3456 / RPM) * RPM / (6000 * RPM))


def test_wheel_reset_options_are_checked():
    env = gym.make(V1, scene=_scene(), action_mode="acceleration").unwrapped
    with pytest.raises(InvalidParameterError, match=r"wheel_speed'\]\[0\] must be within"):
        env.reset(options={"wheel_speed": [700.0]})
    with pytest.raises(InvalidParameterError, match="wheel_speed"):
        env.reset(options={"wheel_speed": [1.0, 2.0]})
    with pytest.raises(InvalidParameterError, match="max_acceleration"):
        gym.make(V1, action_mode="acceleration", scene=Scene.from_dict(
            {"name": "t", "body": {"mass": 1.0, "inertia": [1, 1, 1]},
             "wheels": {"axes": [[0, 0, 1]], "inertia": J, "max_torque": 0.002,
                        "max_speed_rpm": 6000}}))


def test_scene_keys_name_their_units_and_rules():
    with pytest.raises(InvalidParameterError, match="both deadband"):
        _scene({"deadband": 0.3, "deadband_rpm_s": 3.0})
    with pytest.raises(InvalidParameterError, match="realized_gain"):
        _scene({"realized_gain": 0.0})
    with pytest.raises(InvalidParameterError, match=r"startup_delay_s.*low <= high"):
        _scene({"startup_delay_s": [5.0, 2.0]})
    with pytest.raises(InvalidParameterError, match=r"sensors\.gyro_noise_dps"):
        _scene(sensors={"gyro_noise_dps": 0.1})  # attitude "true": the gyro is off


def test_gyro_attitude_drifts_at_the_bias():
    scene = _scene(sensors={"attitude": "gyro", "gyro_bias_sigma_dps": 0.05})
    env = gym.make(V1, scene=scene, action_mode="acceleration").unwrapped
    env.reset(seed=5, options={"q": [1.0, 0, 0, 0], "q_target": [1.0, 0, 0, 0]})
    b = np.array(env._st.gyro_bias)
    assert 0.0 < np.linalg.norm(b) < math.radians(0.5)
    for _ in range(40):
        info = env.step(np.array([0.0], np.float32))[-1]
    # Still body, true error 0: the estimate has turned by |b|·t about b.
    assert info["attitude_error_deg"] == 0.0
    assert math.radians(info["sensed_attitude_error_deg"]) == pytest.approx(
        np.linalg.norm(b) * 40.0, rel=1e-9)
    drift = np.array(env._st.gyro_drift)  # q* ⊗ q_est: about the bias's axis
    np.testing.assert_allclose(drift[1:] / np.linalg.norm(drift[1:]), b / np.linalg.norm(b),
                               atol=1e-9)


def test_one_step_observation_delay_shows_the_previous_state():
    delayed = _scene(sensors={"delay_steps": 1})
    envs = [gym.make(V1, scene=s, action_mode="acceleration").unwrapped
            for s in (_scene(), delayed)]
    obs = [[e.reset(seed=2, options={"omega_B": [0.0, 0.0, 0.01]})[0]] for e in envs]
    for a in (0.3, -0.2, 0.5, 0.0):
        for e, o in zip(envs, obs, strict=True):
            o.append(e.step(np.array([a], np.float32))[0])
    # Attitude and rate features (15) are a step late; the wheel speed (last) is not.
    late, now = np.array(obs[1]), np.array(obs[0])
    np.testing.assert_array_equal(late[2:, :15], now[1:-1, :15])
    np.testing.assert_array_equal(late[0], now[0])
    np.testing.assert_array_equal(late[:, 15], now[:, 15])


def test_innocube_pd_is_the_flight_law():
    env = gym.make(V1, scene="innocube-3u", action_mode="acceleration")
    pd = InnoCubePD.from_env(env)
    q = np.array([[0.9, 0.1, -0.2, 0.3], [-0.99, 0.001, 0.002, -0.003]])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = np.array([[0.01, -0.02, 0.003], [0.0, 0.0, 0.001]])
    qv = q[:, 1:] * np.sign(q[:, :1])
    expected = np.clip(-np.array([670, 670, 134]) * qv
                       - np.array([2500, 2500, 500]) * (1 + np.sum(qv**2, 1))[:, None] * w,
                       -100, 100)
    np.testing.assert_allclose(pd.command_rpm_s(q, w), expected, rtol=1e-12)
    with pytest.raises(NotApplicable, match="action_mode"):
        InnoCubePD.from_env(gym.make(V1, scene="innocube-3u", action_mode="torque"))


def test_flight_pd_stalls_with_the_wheels_as_flown_and_converges_without():
    from rbenv.agents.policies.evaluate import evaluate

    ideal = rbenv.scene_variant("innocube-3u", {
        "wheels": {"deadband_rpm_s": None, "realized_gain": None, "startup_delay_s": None},
        "sensors": None}, name="ideal")
    kw = {"episodes": 4, "env_id": V1, "env_kwargs": {"action_mode": "acceleration"},
          "record": 0}
    flown = evaluate("innocube-pd", scene="innocube-3u", **kw).final_error_deg
    clean = evaluate("innocube-pd", scene=ideal, **kw).final_error_deg
    assert np.all(clean < 0.2) and np.median(flown) > 1.0


def test_scene_variant_switches_single_effects_off():
    shipped = rbenv.load_scene("innocube-3u")
    assert shipped.actuators["wheels"].as_flown and shipped.sensors.enabled
    assert shipped.orbit.residual_dipole is not None
    ideal = rbenv.scene_variant("innocube-3u", {
        "wheels": {"deadband_rpm_s": None, "realized_gain": None, "startup_delay_s": None},
        "sensors": None, "orbit": {"residual_dipole": None}}, name="ideal")
    assert ideal.name == "ideal" and not ideal.actuators["wheels"].as_flown
    assert not ideal.sensors.enabled and ideal.orbit.residual_dipole is None
    fixed = rbenv.scene_variant("innocube-3u", {"wheels": {"realized_gain": 0.8}})
    assert fixed.actuators["wheels"].realized_gain == 0.8
    with pytest.raises(InvalidParameterError, match="overrides must be a dict"):
        rbenv.scene_variant("innocube-3u", [("wheels", {})])
    with pytest.raises(InvalidParameterError, match="shipped name"):
        rbenv.scene_variant("no-such-scene", {})
