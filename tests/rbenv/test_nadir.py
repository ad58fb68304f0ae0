"""The track task's nadir target (``task_options={"target": "nadir"}``): the LVLH frame of the
scene's orbit (reference note §6), checked against the closed-form gravity-gradient pitch
libration of a body whose principal axes lie on LVLH in the Lagrange region (§5)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import kernels as k
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite.scene import Scene

SCENE = "cubesat-6u-rw"


def _lagrange_scene(Ix, Iy, Iz, orbit=True) -> Scene:
    data = {"name": "lagrange", "body": {"mass": 10.0, "inertia": np.diag([Ix, Iy, Iz]).tolist()},
            "wheels": {"axes": [[1, 0, 0]], "inertia": 1e-9, "max_torque": 1e-6,
                       "max_speed_rpm": 1.0},  # a dormant actuator: the scene needs one
            "physics": {"integrator": "rk4", "control_dt": 10.0},
            "episode": {"duration": 6000.0, "rate_limit": 5.0, "max_initial_rate": 0.0,
                        "success_rate": 1e-9}}
    if orbit:
        data["orbit"] = {"model": "circular", "altitude_km": 500.0, "inclination_deg": 45.0,
                         "raan_deg": 30.0, "arg_latitude_deg": 20.0, "gravity_gradient": True}
    return Scene.from_dict(data)


def test_nadir_target_is_the_lvlh_frame():
    """At the start: body z (target axes) along −r̂, body y along −ĥ; rate [0, −n, 0]."""
    scene = _lagrange_scene(0.30, 0.35, 0.20)
    env = gym.make(rbenv.TRACK_ID, scene=scene,
                   task_options={"target": "nadir", "max_initial_angle_deg": 0.0}).unwrapped
    _, info = env.reset(seed=0)
    orbit = scene.orbit
    q_t = env.task.target(env._st)
    r_hat = np.array(orbit.direction_N(0.0, np))
    h_hat = np.cross(orbit.p_hat, orbit.q_hat)
    np.testing.assert_allclose(k.rotate(q_t, (0.0, 0.0, 1.0)), -r_hat, atol=1e-12)
    np.testing.assert_allclose(k.rotate(q_t, (0.0, 1.0, 0.0)), -h_hat, atol=1e-12)
    np.testing.assert_allclose(env._st.omega_target_B, [0.0, -orbit.mean_motion, 0.0],
                               atol=1e-15)
    assert info["attitude_error_deg"] < 1e-12


def test_uncontrolled_nadir_start_only_librates_at_the_closed_form_pitch_frequency():
    """Principal axes on LVLH, Lagrange region I_y > I_x > I_z, a 1° pitch offset and the
    orbital rate: the error to the moving nadir target follows |θ0 cos(ω_p t)|, ω_p =
    n √(3 (I_x − I_z)/I_y), for one orbit (0.05° of 1°; a target turning the wrong way or
    not at all would leave it by tens of degrees)."""
    Ix, Iy, Iz = 0.30, 0.35, 0.20
    scene = _lagrange_scene(Ix, Iy, Iz)
    env = gym.make(rbenv.TRACK_ID, scene=scene,
                   task_options={"target": "nadir", "max_initial_angle_deg": 0.0}).unwrapped
    env.reset(seed=0)
    theta0 = math.radians(1.0)
    q = k.qmul(env.task.target(env._st), (math.cos(theta0 / 2), 0.0, math.sin(theta0 / 2), 0.0))
    env.reset(seed=0, options={"q": q,
                               "omega_B": k.rotate_inverse(q, env._st.omega_target_W)})
    n = scene.orbit.mean_motion
    w_p = n * math.sqrt(3 * (Ix - Iz) / Iy)
    steps = int(scene.orbit.period / 10.0)
    err = np.empty(steps)
    for i in range(steps):
        _, _, _, _, info = env.step(np.zeros(1, np.float32))
        err[i] = info["attitude_error_deg"]
    t = 10.0 * np.arange(1, steps + 1)
    expected = np.abs(math.degrees(theta0) * np.cos(w_p * t))
    assert np.abs(err - expected).max() < 0.05
    assert err.max() > 0.95  # it does librate through its amplitude


def test_nadir_needs_an_orbit_and_the_default_target_is_unchanged():
    with pytest.raises(InvalidParameterError, match=r"tasks\.track\.target = 'nadir'.*no"):
        gym.make(rbenv.TRACK_ID, scene=_lagrange_scene(0.3, 0.35, 0.2, orbit=False),
                 task_options={"target": "nadir"})
    with pytest.raises(InvalidParameterError, match=r"tasks\.track\.target"):
        gym.make(rbenv.TRACK_ID, scene=SCENE, task_options={"target": "sun"})
    a = gym.make(rbenv.TRACK_ID, scene=SCENE).unwrapped
    b = gym.make(rbenv.TRACK_ID, scene=SCENE, task_options={"target": "random"}).unwrapped
    a.reset(seed=11)
    b.reset(seed=11)
    assert a._st.q == b._st.q and a._st.omega_target_W == b._st.omega_target_W
