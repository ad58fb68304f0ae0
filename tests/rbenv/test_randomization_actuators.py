"""Domain randomization on wheels and magnetorquers: the draws, their physics, their streams.

Issue 44: a rods-only scene crashed on the thrusters it lacks, and every reaction-wheel scene was
refused. Here the wheel and rod draws are checked against independent references: a tilted
wheel pushes along its tilted axis, the total angular momentum (bus plus rotors, world frame) is
conserved with no external torque, the torque scale scales the applied motor torque exactly, the
speed-sensor scale changes the observation only, the rod scale scales the dipole, and the single
env and sub-env i of the vector env draw the same physics for the same (seed, episode).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import quaternion
from rbenv.core.backend import FLOAT
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite.plant import NO_NOISE, make_plant
from rbenv.satellite.scene import load_scene

REORIENT_V1, DETUMBLE_V1 = "rbenv/SatelliteReorient-v1", "rbenv/SatelliteDetumble-v1"
J_ROTOR = 2.94e-5  # kg m^2, the wheels' spin-axis inertia below

WHEELS_ONLY = """
name = "wheels-only"
[body]
mass = 12.0
inertia = [0.185, 0.144, 0.061]
[wheels]
axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.577, 0.577, 0.577]]
inertia = 2.94e-5
max_torque = 0.0032
max_speed_rpm = 6500.0
initial_speed_rpm = [1000.0, -2000.0, 500.0, 3000.0]
[physics]
integrator = "rk4"
substeps = 20
control_dt = 0.5
"""


def rods_only_text() -> str:
    """cubesat-6u-rw without its [wheels] (and the desaturate tables that need them)."""
    text = (rbenv.__path__[0] + "/scenes/cubesat-6u-rw.toml")
    with open(text, encoding="utf-8") as f:
        src = f.read()
    head, rest = src.split("[wheels]", 1)
    rest = rest[rest.index("[magnetorquers]"):]
    rest = rest[:rest.index("# Magnetic unloading")]  # the [tasks.desaturate.*] tables
    return head.replace('name = "cubesat-6u-rw"', 'name = "rods-only"') + rest


@pytest.fixture
def wheels_scene(tmp_path):
    path = tmp_path / "wheels-only.toml"
    path.write_text(WHEELS_ONLY)
    return str(path)


@pytest.fixture
def rods_scene(tmp_path):
    path = tmp_path / "rods-only.toml"
    path.write_text(rods_only_text())
    return str(path)


# --------------------------------------------------------------------------- issue 44 repros


@pytest.mark.parametrize("env_id", [REORIENT_V1, DETUMBLE_V1])
def test_inertia_randomization_runs_on_a_rods_only_scene(rods_scene, env_id):
    """Item 2: the draw read the thrusters unconditionally (AttributeError on None)."""
    assert sorted(load_scene(rods_scene).actuators) == ["magnetorquers"]
    env = gym.make(env_id, scene=rods_scene, randomize={"inertia_scale": 0.1})
    obs, _ = env.reset(seed=0)
    model = env.unwrapped._st.model
    assert model.action_matrix is None and model.wheel_axes is None
    assert not np.allclose(model.inertia, env.unwrapped.plant.scene.body.inertia)
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.high)
    assert np.isfinite(obs).all() and np.isfinite(reward)


@pytest.mark.parametrize("env_id", [REORIENT_V1, DETUMBLE_V1])
def test_inertia_randomization_runs_on_a_reaction_wheel_scene(env_id):
    """Item 3: cubesat-6u-rw was refused ("does not know the spin inertia ... yet")."""
    env = gym.make(env_id, scene="cubesat-6u-rw", randomize={"inertia_scale": 0.1})
    env.reset(seed=0)
    obs, reward, *_ = env.step(env.action_space.high)
    assert np.isfinite(obs).all() and np.isfinite(reward)


def test_the_bus_is_randomized_with_the_rotors_inside_it(wheels_scene):
    """The drawn inertia is the bus's (what the plant integrates); the whole spacecraft's is the
    drawn bus plus every rotor's J ĝ'ĝ'ᵀ about its drawn axis; all valid inertias."""
    env = gym.make(REORIENT_V1, scene=wheels_scene,
                   randomize={"inertia_scale": 0.3, "inertia_rotation_deg": 20.0,
                              "wheel_misalignment_deg": 5.0})
    plant = env.unwrapped.plant
    nominal_bus = plant.body.inertia
    spin_nominal = (plant.scene.actuators["wheels"].axes_B.T * J_ROTOR) \
        @ plant.scene.actuators["wheels"].axes_B
    np.testing.assert_allclose(nominal_bus + spin_nominal, plant.scene.body.inertia, atol=1e-15)
    seen = []
    for episode in range(20):
        env.reset(seed=10 + episode)
        m = env.unwrapped._st.model
        g = np.asarray(m.wheel_axes)
        np.testing.assert_allclose(m.total_inertia, m.inertia + (g.T * J_ROTOR) @ g, atol=1e-15)
        np.testing.assert_array_equal(m.body.inertia, m.inertia)  # what the integrator steps
        for inertia in (m.inertia, m.total_inertia):
            eig = np.linalg.eigvalsh(inertia)
            assert eig.min() > 0 and eig[0] + eig[1] >= eig[2]
        seen.append(np.trace(m.inertia))
    assert min(seen) < np.trace(nominal_bus) < max(seen)


# --------------------------------------------------------------------------- physics


def _one_step_contribution(env, action):
    """The plant's contribution for ``action`` from the env's current state (no noise)."""
    st = env.unwrapped._st.copy()
    return env.unwrapped.plant.actuate(st, np.asarray(action, dtype=float), NO_NOISE, FLOAT)


def test_a_misaligned_wheel_pushes_along_its_tilted_axis(wheels_scene):
    env = gym.make(REORIENT_V1, scene=wheels_scene, randomize={"wheel_misalignment_deg": 5.0})
    nominal = env.unwrapped.plant.scene.actuators["wheels"].axes_B
    tilts = []
    for seed in range(8):
        env.reset(seed=seed)
        axes = np.asarray(env.unwrapped._st.model.wheel_axes)
        np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, rtol=1e-14)
        for i in range(4):
            action = np.zeros(4)
            action[i] = 0.5
            c = _one_step_contribution(env, action)
            u = 0.5 * 0.0032  # N m, far from the speed limit, no friction
            # ḣ_B = ĝ'_i u: the motor's reaction torque on the bus is −ĝ'_i u.
            np.testing.assert_allclose(c.momentum_rate_B, axes[i] * u, rtol=1e-13, atol=1e-18)
            tilts.append(np.degrees(np.arccos(np.clip(axes[i] @ nominal[i], -1, 1))))
    assert max(tilts) <= 5.0 + 1e-9 and max(tilts) > 3.0 and min(tilts) > 0.0


def _total_momentum_W(st, model) -> np.ndarray:
    """World-frame angular momentum of bus and rotors: R(q) (I_bus ω + Σ ĝ' J (Ω + ĝ'ᵀω))."""
    w = np.asarray(st.omega_B)
    g = np.asarray(model.wheel_axes)
    h = J_ROTOR * (np.asarray(st.wheel_speed) + g @ w)
    return quaternion.to_matrix(np.asarray(st.q)) @ (model.inertia @ w + g.T @ h)


def test_total_angular_momentum_is_conserved_with_randomized_bus_and_wheels(wheels_scene):
    env = gym.make(REORIENT_V1, scene=wheels_scene,
                   randomize={"inertia_scale": 0.3, "inertia_rotation_deg": 20.0,
                              "wheel_misalignment_deg": 5.0, "wheel_torque_scale": 0.3})
    env.reset(seed=4)
    st = env.unwrapped._st
    model = st.model
    H0 = _total_momentum_W(st, model)
    rng = np.random.default_rng(0)
    for _ in range(60):  # 30 s of random motor torques (internal: no external torque)
        env.step(rng.uniform(-1, 1, 4))
        st = env.unwrapped._st
        # RK4 at h = 0.025 s conserves it to its truncation error (~1e-11 relative here).
        np.testing.assert_allclose(_total_momentum_W(st, model), H0,
                                   atol=1e-9 * np.linalg.norm(H0))
    # The same sum with the scene's nominal axes is off by percents: the tilt is real physics.
    st.model.wheel_axes[...] = env.unwrapped.plant.scene.actuators["wheels"].axes_B
    assert np.linalg.norm(_total_momentum_W(st, st.model) - H0) > 1e-3 * np.linalg.norm(H0)


def _paired(scene, extra: dict, seed: int = 2):
    """Two single envs with the same randomized inertia (stream "randomization"): one with
    ``extra`` (drawn from the wheels' and rods' own streams), one without."""
    base = {"inertia_scale": 0.1}
    a = gym.make(REORIENT_V1, scene=scene, randomize={**base, **extra})
    b = gym.make(REORIENT_V1, scene=scene, randomize=base)
    oa, _ = a.reset(seed=seed)
    ob, _ = b.reset(seed=seed)
    np.testing.assert_array_equal(a.unwrapped._st.model.inertia, b.unwrapped._st.model.inertia)
    return a, b, oa, ob


def test_wheel_torque_scale_scales_the_applied_torque_exactly(wheels_scene):
    a, b, _, _ = _paired(wheels_scene, {"wheel_torque_scale": 0.3})
    gain = np.asarray(a.unwrapped._st.model.wheel_torque_scale)
    assert np.all(np.abs(gain - 1.0) <= 0.3) and np.ptp(gain) > 0.05
    action = np.array([0.7, -0.4, 1.0, -1.0])
    a.step(action)
    b.step(action)
    realized = np.asarray(a.unwrapped._st.wheel_torque)
    commanded = np.asarray(b.unwrapped._st.wheel_torque)
    np.testing.assert_array_equal(commanded, action * 0.0032)  # what the firmware sends
    np.testing.assert_array_equal(realized, commanded * gain)


def test_wheel_speed_scale_changes_only_the_measurement(wheels_scene):
    a, b, oa, ob = _paired(wheels_scene, {"wheel_speed_scale": 0.2})
    scale = np.asarray(a.unwrapped._st.model.wheel_speed_scale)
    assert np.all(np.abs(scale - 1.0) <= 0.2) and np.ptp(scale) > 0.02
    structure = a.unwrapped.observation_structure
    start = sum(w for name, w in structure.items() if name != "wheel_speed"
                and list(structure).index(name) < list(structure).index("wheel_speed"))
    sl = slice(start, start + structure["wheel_speed"])
    max_speed = np.asarray(a.unwrapped.plant.actuator("wheels").max_speed)
    rng = np.random.default_rng(1)
    for _ in range(10):
        np.testing.assert_array_equal(np.delete(oa, np.arange(sl.start, sl.stop)),
                                      np.delete(ob, np.arange(sl.start, sl.stop)))
        true = np.asarray(a.unwrapped._st.wheel_speed)
        np.testing.assert_array_equal(true, np.asarray(b.unwrapped._st.wheel_speed))
        # The observation is float32: equal to its rounding.
        np.testing.assert_allclose(oa[sl], np.clip(true * scale / max_speed, -1, 1),
                                   rtol=1e-6)
        np.testing.assert_allclose(ob[sl], true / max_speed, rtol=1e-6)
        assert np.all(np.abs(oa[sl] - ob[sl]) > 1e-4 * np.abs(ob[sl]))
        action = rng.uniform(-1, 1, 4)
        oa, *_ = a.step(action)
        ob, *_ = b.step(action)
    np.testing.assert_array_equal(a.unwrapped._st.q, b.unwrapped._st.q)


def test_rod_dipole_scale_scales_each_rods_dipole(rods_scene):
    a, b, _, _ = _paired(rods_scene, {"rod_dipole_scale": 0.3})
    scale = np.asarray(a.unwrapped._st.model.rod_dipole_scale)
    assert np.all(np.abs(scale - 1.0) <= 0.3) and np.ptp(scale) > 0.05
    action = np.array([0.5, -1.0, 0.25])
    a.step(action)
    b.step(action)
    # The rods lie along x, y, z: component i of the dipole is rod i's.
    np.testing.assert_allclose(a.unwrapped._st.mtq_dipole_B,
                               np.asarray(b.unwrapped._st.mtq_dipole_B) * scale, rtol=1e-15)
    np.testing.assert_allclose(b.unwrapped._st.mtq_dipole_B, action * 0.2, rtol=1e-15)
    assert a.unwrapped._st.mtq_energy_J == b.unwrapped._st.mtq_energy_J  # power unchanged


def test_gravity_gradient_acts_on_the_episodes_whole_spacecraft():
    """With an orbit, the gravity gradient reads the drawn whole-spacecraft inertia."""
    plant = make_plant("cubesat-6u-rw", randomize={"inertia_scale": 0.5})
    env = gym.make(REORIENT_V1, scene="cubesat-6u-rw", randomize={"inertia_scale": 0.5})
    env.reset(seed=3)
    st = env.unwrapped._st
    tq = plant.orbit_torque
    q = st.q
    nominal = np.asarray(tq.torque_B(0, q, None, FLOAT))
    step = tq.for_step(0, None, FLOAT, st.model.whole_body)
    drawn = np.asarray(step.substep(0)(0.0, q, st.omega_B))
    r_B = quaternion.to_matrix(np.asarray(q)).T @ np.asarray(
        plant.orbit_table.lookup("direction", 0, FLOAT))
    expect = 3 * plant.orbit.mean_motion ** 2 * np.cross(r_B, st.model.total_inertia @ r_B)
    np.testing.assert_allclose(drawn, expect, rtol=1e-9, atol=1e-20)
    assert not np.allclose(drawn, nominal, rtol=1e-3)


# --------------------------------------------------------------------------- streams


NEW_KEYS = {"inertia_scale": 0.2, "wheel_misalignment_deg": 4.0, "wheel_torque_scale": 0.2,
            "wheel_speed_scale": 0.1, "rod_dipole_scale": 0.3}


def test_single_env_and_sub_env_draw_the_same_wheel_and_rod_physics():
    venv = gym.make_vec(REORIENT_V1, num_envs=3, scene="cubesat-6u-rw", randomize=NEW_KEYS)
    env = gym.make(REORIENT_V1, scene="cubesat-6u-rw", randomize=NEW_KEYS)
    obs_v, _ = venv.reset(seed=11)
    vm = venv.unwrapped._st.model
    rng = np.random.default_rng(5)
    actions = rng.uniform(-1, 1, (4, 3, 6))
    for a in actions:
        obs_v = np.vstack([obs_v, venv.step(a)[0]])
    for i in range(3):
        obs, _ = env.reset(seed=11 + i)
        sm = env.unwrapped._st.model
        for name in ("inertia", "total_inertia", "wheel_axes", "wheel_torque_scale",
                     "wheel_speed_scale", "rod_dipole_scale"):
            np.testing.assert_array_equal(getattr(sm, name), getattr(vm, name)[i], err_msg=name)
        rows = [obs] + [env.step(a[i])[0] for a in actions]
        np.testing.assert_allclose(np.array(rows), obs_v[i::3], rtol=1e-12, atol=1e-15)


def test_new_streams_shift_no_earlier_draw():
    """Turning the wheel and rod draws on leaves the body's draws (stream "randomization")."""
    on = make_plant("cubesat-6u-rw", randomize=NEW_KEYS)
    off = make_plant("cubesat-6u-rw", randomize={"inertia_scale": 0.2})
    from rbenv.satellite.draws import EpisodeDraws
    from rbenv.satellite.randomization import draw_episode_model

    draws = EpisodeDraws(np.arange(50), np.zeros(50))
    np.testing.assert_array_equal(draw_episode_model(on, draws).inertia,
                                  draw_episode_model(off, draws).inertia)


def test_a_shipped_randomized_episode_is_pinned():
    """cubesat-12u-dr (thrusters, every thruster draw on): a seeded episode as of 16b331b,
    before the wheel and rod draws came; adding consumers must not move it. Pinned by values,
    not by a hash of their bits: NumPy's transcendental functions differ in the last bit
    between its AVX2 and AVX-512 paths (the rewards here by 6e-16), a difference far below any
    shift of the draws' stream, which moves the episode by whole draws. The bit-for-bit check
    between two versions of the code on one machine is benchmarks.episode_digest."""
    env = gym.make("rbenv/SatelliteReorient-v1", scene="cubesat-12u-dr")  # 16b331b's default
    obs, _ = env.reset(seed=123)
    rng = np.random.default_rng(7)
    total_abs_obs, rewards = float(np.abs(obs.astype(np.float64)).sum()), []
    for _ in range(40):
        obs, reward, *_ = env.step(rng.uniform(0, 1, 12))
        total_abs_obs += float(np.abs(obs.astype(np.float64)).sum())
        rewards.append(float(reward))
    np.testing.assert_allclose(obs, PINNED_12U_DR["last_obs"], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(total_abs_obs, PINNED_12U_DR["total_abs_obs"], rtol=1e-9)
    np.testing.assert_allclose(sum(rewards), PINNED_12U_DR["reward_sum"], rtol=1e-9)
    np.testing.assert_allclose(np.dot(rewards, np.arange(1, 41)),
                               PINNED_12U_DR["reward_weighted_sum"], rtol=1e-9)


# 16b331b's episode (its hash of the bits, 5cdd20d506c9d78c, is reproduced with NumPy's AVX-512
# paths off: NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR").
PINNED_12U_DR = {
    "last_obs": [0.40825793147087097, 0.9039765000343323, 0.1270902156829834,
                 -0.9054211974143982, 0.4187295734882355, -0.06984283030033112,
                 0.009017335250973701, -0.13134372234344482, 0.9762166738510132,
                 0.07409161329269409, -0.42429789900779724, -0.5184980034828186,
                 0.10130555182695389, -0.5801429748535156, -0.7089429497718811],
    "total_abs_obs": 229.2786701300065,  # sum of |obs| over the 41 observations
    "reward_sum": -24.51817064783487,
    "reward_weighted_sum": -503.0807559273239}  # sum of k * reward_k, k = 1..40


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(("scene", "key", "table"), [
    ("cubesat-6u-rw", "force_scale", "thrusters"),
    ("cubesat-6u-rw", "com_offset", "thrusters"),
    ("cubesat-6u-rw", "delay_probability", "thrusters"),
    ("cubesat-12u", "wheel_misalignment_deg", "wheels"),
    ("cubesat-12u", "wheel_speed_scale", "wheels"),
    ("cubesat-12u", "rod_dipole_scale", "magnetorquers"),
])
def test_a_key_for_an_absent_actuator_is_refused_by_name(scene, key, table):
    with pytest.raises(InvalidParameterError,
                       match=rf"randomization\.{key} = 0\.3 perturbs .* has no \[{table}\]"):
        gym.make(REORIENT_V1, scene=scene, randomize={key: 0.3})


@pytest.mark.parametrize(("key", "value"), [("wheel_misalignment_deg", 46.0),
                                            ("wheel_torque_scale", 0.95),
                                            ("wheel_speed_scale", -0.1),
                                            ("rod_dipole_scale", float("nan"))])
def test_new_sizes_out_of_range_are_named(key, value):
    with pytest.raises(InvalidParameterError, match=rf"randomization\.{key}"):
        make_plant("cubesat-6u-rw", randomize={key: value})


def test_the_torch_backend_refuses_the_new_draws_by_name():
    pytest.importorskip("torch")
    with pytest.raises(InvalidParameterError, match="randomize="):
        gym.make_vec(REORIENT_V1, num_envs=2, scene="cubesat-6u-rw", backend="torch",
                     randomize={"wheel_torque_scale": 0.1})


# --------------------------------------------------------------------------- friction as flown

FRICTION = WHEELS_ONLY.replace('name = "wheels-only"', 'name = "wheels-friction"').replace(
    "max_speed_rpm = 6500.0", "max_speed_rpm = 6500.0\nviscous = [1e-7, 3e-7]\n"
    "coulomb = [1e-5, 2e-5]")


@pytest.fixture
def friction_scene(tmp_path):
    path = tmp_path / "wheels-friction.toml"
    path.write_text(FRICTION)
    return str(path)


def test_wheel_friction_ranges_are_drawn_per_episode_and_applied(friction_scene):
    env = gym.make(REORIENT_V1, scene=friction_scene)
    drawn = []
    for seed in range(6):
        env.reset(seed=seed)
        st = env.unwrapped._st
        viscous, coulomb = st.wheel_friction
        assert 1e-7 <= viscous <= 3e-7 and 1e-5 <= coulomb <= 2e-5
        drawn.append((viscous, coulomb))
        speed = np.asarray(st.wheel_speed)
        env.step(np.zeros(4))  # no command: the friction alone turns the wheels
        np.testing.assert_array_equal(env.unwrapped._st.wheel_torque,
                                      -viscous * speed - coulomb * np.sign(speed))
    assert len(set(drawn)) == 6
    venv = gym.make_vec(REORIENT_V1, num_envs=3, scene=friction_scene)
    venv.reset(seed=2)
    for i in range(3):
        env.reset(seed=2 + i)
        assert env.unwrapped._st.wheel_friction == tuple(
            float(c[i]) for c in venv.unwrapped._st.wheel_friction)


def test_a_fixed_friction_scene_keeps_its_draws():
    """The friction's draws follow the wheels' others in their stream: a scene without ranges
    draws what it drew before (random speeds, as-flown effects) and keeps no friction field."""
    plant = make_plant("innocube-3u")
    wheels = plant.actuator("wheels")
    assert not wheels.friction_drawn and "wheel_friction" not in wheels.state_fields
    assert wheels.start_slots == 3


def test_the_torch_backend_draws_the_friction_as_numpy_does(friction_scene):
    torch = pytest.importorskip("torch")
    ref = gym.make_vec(REORIENT_V1, num_envs=3, scene=friction_scene)
    dev = gym.make_vec(REORIENT_V1, num_envs=3, scene=friction_scene, backend="torch")
    o_ref, _ = ref.reset(seed=9)
    o_dev, _ = dev.reset(seed=9)
    action = np.full((3, 4), 0.3)
    for _ in range(4):
        np.testing.assert_allclose(np.asarray(torch.as_tensor(o_dev).cpu()), o_ref, rtol=1e-6,
                                   atol=1e-7)
        o_ref = ref.step(action)[0]
        o_dev = dev.step(torch.as_tensor(action))[0]
    np.testing.assert_allclose(np.asarray(torch.as_tensor(o_dev).cpu()), o_ref, rtol=1e-6,
                               atol=1e-7)
