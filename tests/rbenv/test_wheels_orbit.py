"""Reaction wheels, magnetorquers and the orbit's torques against independent references:
conservation of total angular momentum, the wheel spin-up closed form (Basilisk's BOE test),
gravity-gradient libration frequencies and equilibria, and B-dot's monotone energy."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import kernels as k
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite.orbit import Orbit
from rbenv.satellite.scene import Scene

DETUMBLE = rbenv.DETUMBLE_ID


def _scene(**tables) -> Scene:
    data = {"name": "test", "body": {"mass": 12.0, "inertia": [[0.185, 0.0, 0.0],
                                                              [0.0, 0.144, 0.0],
                                                              [0.0, 0.0, 0.061]]},
            "episode": {"duration": 2000.0, "rate_limit": 5.0, "max_initial_rate": 1.0,
                        "success_rate": 1e-9}}
    data.update(tables)
    return Scene.from_dict(data)


def _env(scene, env_id=DETUMBLE, **kwargs):
    return gym.make(env_id, scene=scene, **kwargs).unwrapped  # no TimeLimit: long runs


def _total_momentum_W(env) -> np.ndarray:
    """R(q) (I_RW ω + G h): the bus plus the wheels' absolute spin momentum, world frame."""
    st, plant = env._st, env.plant
    wheels = plant.actuators[0].wheels
    h = wheels.inertia * (st.wheel_speed + wheels.axes_B @ np.array(st.omega_B))
    m_B = plant.body.inertia @ np.array(st.omega_B) + h @ wheels.axes_B
    return np.array(k.rotate(st.q, tuple(m_B)))


PYRAMID = [[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
           for b in [math.asin(1 / math.sqrt(3))] for a in np.radians([45, 135, 225, 315])]


def _momentum_drift(integrator, substeps=1):
    scene = _scene(wheels={"axes": PYRAMID, "inertia": 2.94e-5, "max_torque": 0.0032,
                           "max_speed_rpm": 6500, "initial_speed_rpm": [1000, -500, 300, 0]},
                   physics={"integrator": integrator, "control_dt": 0.5, "substeps": substeps})
    env = _env(scene)
    env.reset(seed=1, options={"omega_B": [0.05, -0.1, 0.08]})
    L0 = _total_momentum_W(env)
    rng = np.random.default_rng(0)
    for _ in range(400):  # 200 s of random motor torques (internal: L_W must not move)
        env.step(rng.uniform(-1, 1, 4).astype(np.float32))
    assert np.abs(np.array(env._st.wheel_speed)).max() > 10.0  # the wheels really moved
    return np.abs(_total_momentum_W(env) - L0).max() / np.linalg.norm(L0)


def test_total_angular_momentum_is_conserved_under_any_motor_torque():
    """midpoint keeps L_W to round-off whatever the (internal) motor torques; RK4 drifts at
    its order: half the step, about 1/16 of the drift."""
    assert _momentum_drift("midpoint") <= 1e-13
    coarse, fine = _momentum_drift("rk4"), _momentum_drift("rk4", substeps=2)
    assert coarse < 1e-4 and coarse / fine > 10.0


def test_wheel_spin_up_matches_the_closed_form():
    """Basilisk's BOE case: hub I1 = 2 kg·m² without the wheel, J_s = 0.15915 kg·m² on z,
    u = 0.2 N·m: ω_z = ω_z0 − (u/I1) t and Ω = u (I1 + J_s)/(I1 J_s) t."""
    I1, J, u, w0 = 2.0, 100.0 / (6000 * 2 * math.pi / 60), 0.2, 0.35
    scene = _scene(body={"mass": 10.0, "inertia": [[I1, 0, 0], [0, I1, 0], [0, 0, I1 + J]]},
                   wheels={"axes": [[0, 0, 1]], "inertia": J, "max_torque": u,
                           "max_speed_rpm": 1e5},
                   physics={"integrator": "rk4", "control_dt": 0.5})
    env = _env(scene)
    env.reset(seed=0, options={"omega_B": [0.0, 0.0, w0]})
    for _ in range(10):
        env.step(np.ones(1, np.float32))
    t = 5.0
    assert env._st.omega_B[2] == pytest.approx(w0 - u / I1 * t, abs=1e-12)  # −0.15 rad/s
    assert env._st.wheel_speed[0] == pytest.approx(u * (I1 + J) / (I1 * J) * t, rel=1e-12)
    assert env._st.wheel_speed[0] == pytest.approx(6.7832, abs=1e-4)  # Basilisk's figure


def test_a_wheel_at_its_speed_limit_cannot_be_accelerated_further():
    scene = _scene(wheels={"axes": [[0, 0, 1]], "inertia": 1e-3, "max_torque": 0.01,
                           "max_speed_rpm": 60.0, "initial_speed_rpm": 60.0},
                   physics={"integrator": "rk4", "control_dt": 0.5})
    env = _env(scene)
    env.reset(seed=0, options={"omega_B": [0.0, 0.0, 0.0]})
    env.step(np.ones(1, np.float32))  # pushes further: refused
    assert env._st.wheel_torque[0] == 0.0
    assert env._st.wheel_speed[0] == pytest.approx(2 * math.pi, rel=1e-12)
    env.step(-np.ones(1, np.float32))  # slowing down is allowed
    assert env._st.wheel_torque[0] == pytest.approx(-0.01)


def test_a_wheel_near_its_limit_stops_at_it_within_the_step():
    """u·dt/J = 50 rad/s would carry it far past 2π rad/s: the motor gives only what reaches
    the limit (Basilisk checks at the step's start only, and overshoots)."""
    scene = _scene(wheels={"axes": [[0, 0, 1]], "inertia": 1e-4, "max_torque": 0.01,
                           "max_speed_rpm": 60.0, "initial_speed_rpm": 30.0},
                   physics={"integrator": "rk4", "control_dt": 0.5})
    env = _env(scene)
    env.reset(seed=0, options={"omega_B": [0.0, 0.0, 0.0]})
    env.step(np.ones(1, np.float32))
    assert env._st.wheel_speed[0] == pytest.approx(2 * math.pi, rel=1e-9)
    j_eff = 1.0 / (1.0 / 1e-4 + 1.0 / (0.061 - 1e-4))  # the bus turns back: Ω moves faster
    assert env._st.wheel_torque[0] == pytest.approx(math.pi * j_eff / 0.5, rel=1e-9)


def test_rotors_heavier_than_the_bus_allows_are_refused_naming_the_wheels():
    with pytest.raises(InvalidParameterError, match=r"wheels\.inertia"):
        _env(_scene(wheels={"axes": np.eye(3).tolist(), "inertia": 0.04, "max_torque": 0.01,
                            "max_speed_rpm": 600.0}))


def _lvlh_quaternion(orbit: Orbit, t: float, pitch: float) -> tuple:
    r_hat = np.array(orbit.direction_N(t, np))
    h_hat = np.cross(orbit.p_hat, orbit.q_hat)
    z, y = -r_hat, -h_hat
    x = np.cross(y, z)
    c, s = math.cos(pitch), math.sin(pitch)
    R = np.column_stack([x, y, z]) @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    from scipy.spatial.transform import Rotation

    return tuple(Rotation.from_matrix(R).as_quat(scalar_first=True))


def _pitch_history(inertia, pitch0, orbits=3.0, dt=10.0):
    scene = _scene(body={"mass": 10.0, "inertia": np.diag(inertia).tolist()},
                   wheels={"axes": [[1, 0, 0]], "inertia": 1e-9, "max_torque": 1e-6,
                           "max_speed_rpm": 1.0},  # a dormant actuator: the scene needs one
                   orbit={"model": "circular", "altitude_km": 500.0, "inclination_deg": 45.0,
                          "gravity_gradient": True},
                   physics={"integrator": "rk4", "control_dt": dt},
                   episode={"duration": 1e6, "rate_limit": 5.0, "max_initial_rate": 1.0,
                            "success_rate": 1e-9})
    env = _env(scene)
    orbit = scene.orbit
    n = orbit.mean_motion
    env.reset(seed=0, options={"q": _lvlh_quaternion(orbit, 0.0, pitch0),
                               "omega_B": [0.0, -n * math.cos(0), 0.0]})
    steps = int(orbits * orbit.period / dt)
    pitch = np.empty(steps)
    for i in range(steps):
        env.step(np.zeros(1, np.float32))
        q_L = _lvlh_quaternion(orbit, (i + 1) * dt, 0.0)
        rel = k.qmul((q_L[0], -q_L[1], -q_L[2], -q_L[3]), env._st.q)  # body in LVLH axes
        sign = -1.0 if rel[0] < 0.0 else 1.0  # q and −q are one attitude
        pitch[i] = 2.0 * math.atan2(sign * rel[2], sign * rel[0])
    return pitch, n, dt


def test_gravity_gradient_pitch_libration_has_its_closed_form_frequency():
    """Lagrange region I_y > I_x > I_z: pitch ω_p = n √(3 (I_x − I_z)/I_y) = 0.9258 n."""
    Ix, Iy, Iz = 0.30, 0.35, 0.20
    pitch, n, dt = _pitch_history((Ix, Iy, Iz), math.radians(1.0), orbits=6.0)
    # The period from the upward zero crossings (linear interpolation between samples).
    i = np.flatnonzero((pitch[:-1] < 0.0) & (pitch[1:] >= 0.0))
    crossings = (i + 1 + pitch[i] / (pitch[i] - pitch[i + 1])) * dt
    measured = 2.0 * math.pi / np.mean(np.diff(crossings))
    expected = n * math.sqrt(3 * (Ix - Iz) / Iy)
    assert expected / n == pytest.approx(0.9258, abs=1e-4)
    assert len(crossings) >= 4
    assert measured == pytest.approx(expected, rel=2e-3)
    assert np.abs(pitch).max() < math.radians(1.2)  # stable: it librates, it does not leave


def test_gravity_gradient_pitch_equilibrium_is_unstable_outside_the_lagrange_region():
    """I_x < I_z: pitch has no restoring torque and a 1° offset grows past 20°."""
    pitch, _, _ = _pitch_history((0.20, 0.35, 0.30), math.radians(1.0), orbits=2.0)
    assert np.abs(pitch).max() > math.radians(20.0)


def test_the_dipole_field_has_its_textbook_size_at_500_km():
    orbit = Orbit(model="circular", altitude_km=500.0, inclination_deg=90.0,
                  magnetic_field=True)
    # The field along a polar orbit: 2·B0 (R/r)³ near the dipole's axis, B0 (R/r)³ at its
    # equator (the dipole is tilted 9.2°, so the extremes are within a few percent).
    t = np.linspace(0.0, orbit.period, 2000)
    b = np.linalg.norm(np.array(orbit.field_N(t, np)), axis=0)
    b0 = math.sqrt(sum(c * c for c in (-29350.0, -1410.3, 4545.5))) * 1e-9
    eq = b0 * (6371.2e3 / orbit.radius) ** 3
    assert eq == pytest.approx(23.7e-6, rel=0.01)
    assert b.max() == pytest.approx(2 * eq, rel=0.03)
    assert b.min() == pytest.approx(eq, rel=0.05)


def test_b_dot_lowers_the_kinetic_energy_at_every_step():
    scene = _scene(magnetorquers={"axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                  "max_dipole": 0.2, "power_W": 0.2},
                   orbit={"model": "circular", "altitude_km": 500.0, "inclination_deg": 97.4,
                          "magnetic_field": True},
                   physics={"integrator": "rk4", "control_dt": 1.0})
    env = _env(scene)
    env.reset(seed=3, options={"omega_B": [0.08, -0.06, 0.1]})
    inertia = env.plant.body.inertia
    gain = 2e4  # A·m²/(T·rad/s): saturates at these rates, as bang-bang B-dot does

    def energy():
        w = np.array(env._st.omega_B)
        return 0.5 * w @ inertia @ w

    e = [energy()]
    for _ in range(3000):
        w, b = np.array(env._st.omega_B), np.array(env._st.field_B_T)
        m = np.clip(gain * np.cross(w, b), -0.2, 0.2)  # m = k ω × B: τ = −k|B|² ω⊥
        env.step((m / 0.2).astype(np.float32))
        e.append(energy())
    e = np.array(e)
    assert np.all(np.diff(e) <= 1e-15 * e[0])
    assert e[-1] < 0.5 * e[0]  # and it really detumbles


def test_scene_errors_name_the_field():
    with pytest.raises(InvalidParameterError, match=r"wheels\.max_torque"):
        _scene(wheels={"axes": [[0, 0, 1]], "inertia": 1e-3, "max_torque": -1.0,
                       "max_speed_rpm": 100.0})
    with pytest.raises(InvalidParameterError, match=r"magnetorquers need Earth's field"):
        _env(_scene(magnetorquers={"axes": [[0, 0, 1]], "max_dipole": 0.2}))
    with pytest.raises(InvalidParameterError, match=r"orbit\.gravity_gradient"):
        Orbit(gravity_gradient=True)
    with pytest.raises(InvalidParameterError, match="at least one actuator"):
        Scene.from_dict({"name": "bare", "body": {"mass": 1.0, "inertia": np.eye(3).tolist()}})


@pytest.mark.parametrize("mode", ["throttle", "torque"])
@pytest.mark.parametrize("env_id", list(rbenv.ENV_IDS))
def test_both_checkers_pass_on_the_wheel_scene_for_every_task(env_id, mode):
    import warnings

    from gymnasium.utils.env_checker import check_env

    sb3 = pytest.importorskip("stable_baselines3.common.env_checker",
                              reason="stable-baselines3 is not installed (train extra)")
    if rbenv.envs.registry.get(env_id).task.inner_loop and mode != "throttle":
        with pytest.raises(InvalidParameterError, match="action_mode must be 'throttle'"):
            gym.make(env_id, scene="cubesat-6u-rw", action_mode=mode)  # its loop: torques
        return
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        check_env(gym.make(env_id, scene="cubesat-6u-rw", action_mode=mode,
                           render_mode="rgb_array").unwrapped)
        sb3.check_env(gym.make(env_id, scene="cubesat-6u-rw", action_mode=mode).unwrapped)


def test_wheel_scene_observes_wheel_speeds_and_the_magnetometer():
    env = gym.make("rbenv/SatelliteReorient-v0", scene="cubesat-6u-rw").unwrapped  # v0's layout
    assert list(env.observation_structure) == ["q_err", "omega_B", "wheel_speed", "field_B"]
    obs, _ = env.reset(seed=0)
    b = obs[10:13] * 5e-5  # T
    assert 20e-6 < np.linalg.norm(b) < 50e-6  # LEO field strength, in body axes
    np.testing.assert_allclose(b, np.array(env._st.field_B_T), rtol=1e-6)


@pytest.mark.parametrize("value", ["true", "[0.1]", '"0.1"', "inf", "1.5"])
def test_a_bad_option_of_another_task_fails_on_any_env_of_the_scene(tmp_path, value):
    """[tasks.detumble] of a wheel scene is checked when a reorientation env is made on it too
    (the fuzz found such values accepted until a detumble env was made)."""
    text = (Path(rbenv.__file__).parent / "scenes" / "cubesat-6u-rw.toml").read_text()
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("min_rate_fraction = 0.1", f"min_rate_fraction = {value}"))
    with pytest.raises(InvalidParameterError, match=r"tasks\.detumble\.min_rate_fraction"):
        gym.make(rbenv.ENV_ID, scene=str(path))


def _rods_only(tmp_path, extra: str = "") -> str:
    """cubesat-6u-rw without its [wheels] table: rods only, [tasks.desaturate.*] kept."""
    text = (Path(rbenv.__file__).parent / "scenes" / "cubesat-6u-rw.toml").read_text()
    start, end = text.index("[wheels]"), text.index("[magnetorquers]")
    path = tmp_path / "rods.toml"
    path.write_text(text[:start] + text[end:] + extra)
    return str(path)


@pytest.mark.parametrize("env_id", [DETUMBLE, "rbenv/SatelliteDetumble-v0"])
def test_a_task_that_cannot_run_on_the_scene_does_not_refuse_another_tasks_env(tmp_path,
                                                                               env_id):
    """Issue 44, item 4: [tasks.desaturate] on a scene without wheels is inert for a detumble
    env (it failed with "task 'desaturate' unloads reaction wheels"); desaturation itself is
    still refused by name."""
    scene = _rods_only(tmp_path)
    env = gym.make(env_id, scene=scene)
    env.reset(seed=0)
    _, _, terminated, truncated, _ = env.step(env.action_space.sample())
    assert not (terminated or truncated)
    with pytest.raises(InvalidParameterError, match=r"'desaturate' unloads reaction wheels"):
        gym.make(rbenv.DESATURATE_ID, scene=scene)


def test_an_inapplicable_tables_option_names_are_still_checked_and_named(tmp_path):
    scene = _rods_only(tmp_path, "\n[tasks.desaturate]\nmomentum_treshold_fraction = 0.1\n")
    with pytest.raises(InvalidParameterError,
                       match=r"table \[tasks\.desaturate\] \(options of task 'desaturate'"
                             r".*unknown option\(s\) \['momentum_treshold_fraction'\]"):
        gym.make(DETUMBLE, scene=scene)


def test_a_bad_value_of_another_task_names_its_table_and_task(tmp_path):
    text = (Path(rbenv.__file__).parent / "scenes" / "cubesat-6u-rw.toml").read_text()
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("min_rate_fraction = 0.1", "min_rate_fraction = 2.0"))
    with pytest.raises(InvalidParameterError,
                       match=r"table \[tasks\.detumble\] \(options of task 'detumble', "
                             r"checked whatever task is made\)"):
        gym.make(rbenv.ENV_ID, scene=str(path))


def test_a_bad_per_task_table_is_named_by_its_own_task_only(tmp_path):
    """A bad [tasks.desaturate.episode] was reported as "tasks.detumble: tasks.desaturate: ..."
    (the detumble table's copy of the scene re-checked the others under its own prefix)."""
    scene = _rods_only(tmp_path)
    path = Path(scene)
    path.write_text(path.read_text().replace("hold_time = 50.0", "hold_time = 50.0\nbogus = 1"))
    with pytest.raises(InvalidParameterError) as err:
        gym.make(rbenv.ENV_ID, scene=scene)
    assert "tasks.desaturate.episode has unknown field(s) ['bogus']" in str(err.value)
    assert "tasks.detumble" not in str(err.value)


def _noisy_magnetometer_scene(base: str, sigma: float):
    import dataclasses

    from rbenv.satellite.scene import SensorNoise, load_scene

    return dataclasses.replace(load_scene(base),
                               sensor_noise=SensorNoise("gaussian", magnetometer=sigma))


def test_the_magnetometer_noise_has_its_scene_sigma():
    """Observed field minus the true field: zero mean and the scene's σ on every axis."""
    from rbenv.satellite.actuators.magnetorquers import FIELD_SCALE_T

    sigma = 2e-6
    env = gym.make(rbenv.DETUMBLE_ID, scene=_noisy_magnetometer_scene("cubesat-6u-rw", sigma))
    env.reset(seed=0)
    base = env.unwrapped
    names = list(base.observation_structure)
    where = sum(base.observation_structure[n] for n in names[:names.index("field_B")])
    errors = []
    for _ in range(1500):
        obs, *_ , term, trunc, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        true_B = np.array(base._st.field_B_T)
        errors.append(obs[where:where + 3] * FIELD_SCALE_T - true_B)
        if term or trunc:
            env.reset()
    errors = np.array(errors)
    # float32 observations: a rounding of ~3e-12 T, far below σ = 2e-6 T.
    assert np.all(np.abs(errors.mean(axis=0)) < 4 * sigma / np.sqrt(len(errors)))
    assert np.allclose(errors.std(axis=0), sigma, rtol=0.08)


def test_magnetometer_noise_without_a_magnetometer_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match=r"sensor_noise\.magnetometer"):
        gym.make(rbenv.ENV_ID, scene=_noisy_magnetometer_scene("cubesat-12u", 1e-6))
