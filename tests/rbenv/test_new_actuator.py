"""A new actuator is one module plus one registration: this file is the module.

It defines an ideal three-axis torquer (a body torque per axis, as a fraction of its limit;
nothing else in the repository knows it), registers its scene table with
:func:`rbenv.satellite.actuators.register`, and uses it as a user would: a scene with its table,
``gym.make`` and ``gym.make_vec``, Gymnasium's env checker, rendering. The physics is checked
against SciPy's integration of Euler's equations, and it shares a scene with the shipped wheels.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import ClassVar

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from scipy.integrate import solve_ivp

import rbenv
from rbenv.satellite import actuators
from rbenv.satellite.actuators.base import ActuatorDefaults, Contribution, action_components
from rbenv.satellite.scene import Scene

TABLE = "torquer"


@dataclass(frozen=True)
class TorquerTable:
    max_torque: float  # N·m per axis


def parse_torquer(table: dict, com_B=None) -> TorquerTable:
    unknown = sorted(set(table) - {"max_torque"})
    if unknown:
        raise InvalidParameterError(f"torquer has unknown key(s) {unknown}")
    return TorquerTable(validation.number("torquer.max_torque", table.get("max_torque"),
                                          low=0.0, low_open=True, high=1.0))


@dataclass(frozen=True, eq=False)
class Torquer(ActuatorDefaults):
    """τ_B = a·τ_max per axis, a in [-1, 1]; effort Σ|a|/3; observes its last torque."""

    scene_table: ClassVar[str] = TABLE
    start_stream: ClassVar[str] = TABLE
    info_keys: ClassVar[tuple] = ("torquer_impulse_Nms",)
    action_shape: ClassVar[tuple] = (3,)
    action_bounds: ClassVar[tuple] = (-np.ones(3), np.ones(3))
    state_fields: ClassVar[dict] = {"torquer_B": "c3", "torquer_impulse_Nms": "f"}
    observation_structure: ClassVar[dict] = {"torquer_B": 3}

    params: TorquerTable
    control_dt: float
    scale: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "scale", 1.0 / self.params.max_torque)

    def command(self, a, in_place=False, xp=None):
        return tuple(xp.clip(c, -1.0, 1.0) * self.params.max_torque
                     for c in action_components(a, xp))

    def actuate(self, st, torque_B, noise, xp) -> Contribution:
        st.torquer_B = torque_B
        size = abs(torque_B[0]) + abs(torque_B[1]) + abs(torque_B[2])
        st.torquer_impulse_Nms = st.torquer_impulse_Nms + size * self.control_dt
        return Contribution(torque_B, None, None, None, size * (self.scale / 3.0))

    def sample_start(self, draws) -> dict:
        zero = draws.xp.zeros(draws.n)
        return {"torquer_B": (zero, zero, zero), "torquer_impulse_Nms": zero}

    def observe(self, st, xp, sensed=None) -> tuple:
        return k.scale(st.torquer_B, self.scale)

    def info(self, st, xp, out: dict) -> None:
        out["torquer_impulse_Nms"] = st.torquer_impulse_Nms


def make_torquer(scene, action_mode="throttle", allocator="pinv") -> Torquer:
    return Torquer(scene.actuators[TABLE], scene.physics.control_dt)


@pytest.fixture
def registered():
    actuators.register(TABLE, parse_torquer, make_torquer)  # the one call a user makes
    yield
    del actuators.ACTUATORS[TABLE]


INERTIA = np.diag([0.2, 0.3, 0.4])


def _scene(**tables) -> Scene:
    return Scene.from_dict({"name": "torquer-sat", "body": {"mass": 12.0,
                                                           "inertia": [0.2, 0.3, 0.4]},
                            "physics": {"integrator": "rk4", "substeps": 4, "control_dt": 0.5},
                            **tables})


def test_a_registered_actuator_drives_the_env_as_euler_says(registered):
    env = gym.make(rbenv.DETUMBLE_ID, scene=_scene(torquer={"max_torque": 0.01}))
    plant = env.unwrapped.plant
    assert isinstance(plant.actuator(TABLE), Torquer) and plant.actuator("thrusters") is None
    assert env.action_space.shape == (3,)
    obs, _ = env.reset(seed=3)
    st = env.unwrapped._st
    w0 = np.array(st.omega_B)
    action = np.array([0.5, -1.0, 2.0], np.float32)  # the last is clipped to 1
    obs, _, _, _, info = env.step(action)
    tau = np.array([0.005, -0.01, 0.01])

    def euler(t, w):
        return np.linalg.solve(INERTIA, tau - np.cross(w, INERTIA @ w))

    ref = solve_ivp(euler, (0.0, 0.5), w0, rtol=1e-12, atol=1e-15).y[:, -1]
    np.testing.assert_allclose(env.unwrapped._st.omega_B, ref, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(obs[-3:], [0.5, -1.0, 1.0])  # its observation part, last
    assert info["torquer_impulse_Nms"] == pytest.approx(0.025 * 0.5)
    weight = env.unwrapped.task.weights.fuel  # the task prices its effort, 2.5/3 of full rate
    assert info["reward_fuel"] == pytest.approx(-weight * 2.5 / 3.0)
    env.close()


def test_it_shares_a_scene_with_wheels_and_the_vector_env_equals_the_single(registered):
    wheels = {"axes": np.eye(3).tolist(), "inertia": 1e-4, "max_torque": 0.002,
              "max_speed_rpm": 6000}
    scene = _scene(torquer={"max_torque": 0.01}, wheels=wheels)
    env = gym.make(rbenv.DETUMBLE_ID, scene=scene)
    venv = gym.make_vec(rbenv.DETUMBLE_ID, num_envs=2, vectorization_mode="vector_entry_point",
                        scene=scene)
    plant = env.unwrapped.plant
    assert [a.scene_table for a in plant.actuators] == ["wheels", TABLE]  # registry order
    assert env.action_space.shape == (6,)
    obs, _ = env.reset(seed=5)
    vobs, _ = venv.reset(seed=5)
    rng = np.random.default_rng(0)
    for _ in range(5):
        a = rng.uniform(-1, 1, 6).astype(np.float32)
        obs, r, *_ = env.step(a)
        vobs, vr, *_ = venv.step(np.stack([a, a]))
        np.testing.assert_array_equal(vobs[0], obs)
        assert vr[0] == r
    env.close()
    venv.close()


def test_the_env_checker_passes_and_a_frame_is_drawn(registered):
    env = gym.make(rbenv.DETUMBLE_ID, scene=_scene(torquer={"max_torque": 0.01}),
                   render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.ndim == 3 and frame.dtype == np.uint8
    env.close()


def test_its_table_is_checked_by_its_parser(registered):
    with pytest.raises(InvalidParameterError, match=r"torquer\.max_torque"):
        _scene(torquer={"max_torque": -1.0})


def test_without_registration_the_table_is_unknown():
    with pytest.raises(InvalidParameterError, match="torquer"):
        _scene(torquer={"max_torque": 0.01})


def test_register_refuses_what_is_not_an_actuator_entry():
    with pytest.raises(TypeError, match="register"):
        actuators.register("torquer", parse_torquer, None)
