"""A low orbit's torques in the plant: the integrators' stage torque, closed forms of each
disturbance (drag, Sun, shadow, radiation pressure, residual dipole), the eclipse flag, the
batch against one satellite, and the named errors of the scene tables."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import INTEGRATORS, quaternion
from rbenv.core import kernels as k
from rbenv.core.backend import FLOAT
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite import disturbances as dist
from rbenv.satellite.orbit import OMEGA_EARTH, R_EQ, Orbit
from rbenv.satellite.plant import make_plant
from rbenv.satellite.scene import Scene

Q0 = tuple(quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2])).tolist())


def _scene(orbit_extra: dict, *, control_dt=0.5, duration=600.0) -> Scene:
    """The 6U bus of cubesat-6u-rw with three 0.2 A·m² rods on its 500 km orbit."""
    return Scene.from_dict({
        "name": "orbit-torques", "body": {"mass": 12.0, "inertia": [0.185, 0.144, 0.061]},
        "magnetorquers": {"axes": np.eye(3).tolist(), "max_dipole": 0.2},
        "orbit": {"model": "circular", "altitude_km": 500.0, "inclination_deg": 97.4,
                  "magnetic_field": True, **orbit_extra},
        "physics": {"integrator": "rk4", "control_dt": control_dt},
        "episode": {"duration": duration, "rate_limit": 5.0, "max_initial_rate": 0.01}})


def test_kick_schemes_refuse_a_torque_of_the_rate_by_name():
    body = make_plant(_scene({})).body

    def torque_fn(s, q, w):
        return k.scale(w, -1.0)

    torque_fn.needs_rate = True
    q, w = (1.0, 0.0, 0.0, 0.0), (0.1, 0.0, 0.0)
    for name in ("midpoint", "splitting"):
        with pytest.raises(InvalidParameterError, match=name):
            INTEGRATORS[name].advance(body, q, w, 0.1, None, None, None, None, torque_fn)
    _, w1 = INTEGRATORS["rk4"].advance(body, q, w, 0.1, None, None, None, None, torque_fn)
    z = -0.1 / 0.185  # ω̇ = −ω / I: RK4 multiplies ω by its stability polynomial at z = −h/I
    assert w1[0] == pytest.approx(0.1 * (1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24), rel=1e-12)


def test_rk4_evaluates_the_torque_at_its_four_stages():
    """A torque linear in time, τ = c·t: ω(h) = c h² / (2 I) exactly (RK4 integrates it)."""
    body = make_plant(_scene({})).body
    calls = []

    def torque_fn(s, q, w):
        calls.append(s)
        return (0.3 * s * 2.0, 0.0, 0.0)  # h = 2: t = 2 s

    _, w = INTEGRATORS["rk4"].advance(body, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 2.0,
                                      None, None, None, None, torque_fn)
    assert calls == [0.0, 0.5, 0.5, 1.0]
    assert w[0] == pytest.approx(0.3 * 4.0 / (2 * 0.185), rel=1e-12)


def test_compiled_kernels_refuse_orbit_torques_by_name():
    pytest.importorskip("numba")
    with pytest.raises(InvalidParameterError, match="orbit torques"):
        make_plant(_scene({"gravity_gradient": True}), compiled=True)


# --------------------------------------------------------------------------- closed forms


def test_density_follows_vallados_table():
    assert dist.density(500.0) == pytest.approx(6.967e-13, rel=1e-12)
    assert dist.density(550.0) == pytest.approx(6.967e-13 * math.exp(-50 / 63.822), rel=1e-12)
    assert dist.density(400.0) == pytest.approx(3.725e-12, rel=1e-12)


def test_drag_on_an_equatorial_orbit_is_the_closed_form():
    """Equatorial, prograde: v_rel = (n − ω_E) r along track, F = −½ρC_D A v_rel²."""
    orbit = Orbit(model="circular", altitude_km=500.0, inclination_deg=0.0,
                  drag={"area_m2": 0.05, "cd": 2.2})
    f = np.array(dist.drag_force_N(orbit, 0.0, FLOAT))
    v_rel = (orbit.mean_motion - OMEGA_EARTH) * orbit.radius
    expect = -0.5 * 6.967e-13 * 2.2 * 0.05 * v_rel ** 2
    np.testing.assert_allclose(f, [0.0, expect, 0.0], rtol=1e-12, atol=1e-30)
    assert v_rel == pytest.approx(7612.6 - 501.1, rel=1e-3)


def test_plant_drag_torque_is_offset_cross_force():
    sc = _scene({"drag": {"area_m2": 0.05, "cp_offset_B_m": [0.0, 0.0, 0.1]}})
    torque = make_plant(sc).orbit_torque
    q = (1.0, 0.0, 0.0, 0.0)
    tau = torque.torque_B(0, q, None, FLOAT)
    f = dist.drag_force_N(sc.orbit, 0.0, FLOAT)
    np.testing.assert_allclose(tau, np.cross([0.0, 0.0, 0.1], f), rtol=1e-12)


@pytest.mark.parametrize(("when", "longitude_deg"), [
    ("2025-03-20T09:01:00", 0.0),    # March equinox 2025 (09:01 UTC)
    ("2025-06-21T02:42:00", 90.0),   # June solstice 2025 (02:42 UTC)
    ("2025-12-21T15:03:00", 270.0),  # December solstice 2025 (15:03 UTC)
])
def test_the_sun_is_at_its_ecliptic_longitude_on_equinox_and_solstices(when, longitude_deg):
    s = np.array(dist.sun_direction_N(dist.parse_epoch("epoch", when), FLOAT))
    eps = math.radians(23.439)
    lam = math.radians(longitude_deg)
    expect = [math.cos(lam), math.cos(eps) * math.sin(lam), math.sin(eps) * math.sin(lam)]
    assert np.linalg.norm(s) == pytest.approx(1.0, abs=1e-12)
    assert math.degrees(math.acos(min(1.0, s @ expect))) < 0.02


def test_cylindrical_shadow_and_radiation_pressure():
    """Equinox, equatorial orbit: lit on the Sun's side, shadowed behind the Earth (|r⊥| =
    0 < R_E); in sunlight F = −P (1 + ρ) A ŝ."""
    orbit = Orbit(model="circular", altitude_km=500.0, inclination_deg=0.0,
                  srp={"area_m2": 0.1, "reflectivity": 0.3, "epoch": "2025-03-20T09:01:00"})
    s_hat, lit = dist.sun_and_shadow(orbit, 0.0, FLOAT)  # r along +x, the Sun too
    assert lit == 1.0
    f = np.array(dist.srp_force_N(orbit, 0.0, FLOAT))
    np.testing.assert_allclose(f, -1361.0 / 299792458.0 * 1.3 * 0.1 * np.array(s_hat),
                               rtol=1e-12)
    half = 0.5 * orbit.period
    _, lit = dist.sun_and_shadow(orbit, half, FLOAT)  # behind the Earth
    assert lit == 0.0
    # The shadow edge: |r⊥| = R_E where sin(u) = R_E / r on the night side.
    u_edge = math.pi - math.asin(R_EQ / orbit.radius)
    for du, expect in ((-1e-3, 1.0), (1e-3, 0.0)):
        _, lit = dist.sun_and_shadow(orbit, (u_edge + du) / orbit.mean_motion, FLOAT)
        assert lit == expect


def test_eclipse_is_a_flag_in_info_and_srp_vanishes_in_shadow():
    sc = _scene({"inclination_deg": 0.0, "srp": {"area_m2": 0.1,
                                                  "epoch": "2025-03-20T09:01:00"}},
                  control_dt=10.0, duration=6000.0)
    env = gym.make(rbenv.DETUMBLE_ID, scene=sc).unwrapped
    _, info = env.reset(seed=0, options={"omega_B": [0.001, 0.0, 0.0]})
    assert not info["eclipse"]  # starts on the Sun's side
    steps = round(sc.orbit.period / 10.0)
    flags = [bool(env.step(np.zeros(3, np.float32))[4]["eclipse"]) for _ in range(steps)]
    # The Sun in the orbit's plane: shadowed within asin(R_E / r) of the anti-Sun point.
    expect = math.asin(R_EQ / sc.orbit.radius) / math.pi  # 0.378 of the orbit at 500 km
    assert sum(flags) / steps == pytest.approx(expect, abs=0.005)
    torque = make_plant(sc).orbit_torque
    in_shadow = 2 * round(0.5 * sc.orbit.period / 10.0)
    tau = torque.torque_B(in_shadow, (1.0, 0.0, 0.0, 0.0), None, FLOAT)
    assert tau == (0.0, 0.0, 0.0)


def test_residual_dipole_torque_is_m_cross_b():
    m = [0.05, -0.02, 0.08]
    sc = _scene({"residual_dipole": {"moment_B_Am2": m}})
    plant = make_plant(sc)
    q = Q0
    f = plant.orbit_torque.for_step(0, None, FLOAT).substep(0)
    b_B = k.rotate_inverse(q, sc.orbit.field_N(0.0, FLOAT))
    np.testing.assert_allclose(f(0.0, q, None), np.cross(m, b_B), rtol=1e-12)
    # with a rod command the dipoles add
    g = plant.orbit_torque.for_step(0, (0.1, 0.0, 0.0), FLOAT).substep(0)
    np.testing.assert_allclose(g(0.0, q, None), np.cross(np.add(m, [0.1, 0, 0]), b_B),
                               rtol=1e-12)


# --------------------------------------------------------------------------- named errors


@pytest.mark.parametrize(("extra", "match"), [
    ({"residual_dipole": {"moment_B_Am2": [0.1, 0.2]}},
     r"orbit\.residual_dipole\.moment_B_Am2 must be 3 numbers"),
    ({"residual_dipole": {"moment_B_Am2": [0.1, 0.2, math.inf]}},
     r"orbit\.residual_dipole\.moment_B_Am2\[2\]"),
    ({"residual_dipole": {"moment": [0.1, 0.2, 0.3]}}, r"orbit\.residual_dipole.*unknown"),
    ({"drag": {"area_m2": 0.1, "density_scale": -1.0}}, r"orbit\.drag\.density_scale"),
    ({"drag": {"area_m2": -0.1}}, r"orbit\.drag\.area_m2"),
    ({"drag": {"cd": 2.2}}, r"orbit\.drag.*area_m2"),
    ({"srp": {"area_m2": 0.1, "epoch": "yesterday"}}, r"orbit\.srp\.epoch = 'yesterday'"),
    ({"srp": {"area_m2": 0.1, "epoch": "2025-01-01T00:00:00+02:00"}}, r"orbit\.srp\.epoch.*UTC"),
    ({"srp": {"area_m2": 0.1, "reflectivity": 1.5}}, r"orbit\.srp\.reflectivity"),
    ({"srp": "on"}, r"\[orbit\.srp\] must be a table"),
])
def test_bad_disturbance_tables_get_named_errors(extra, match):
    with pytest.raises(InvalidParameterError, match=match):
        _scene(extra)


def test_a_residual_dipole_needs_the_field_and_a_table_needs_an_orbit():
    with pytest.raises(InvalidParameterError, match=r"residual_dipole.*magnetic_field"):
        Orbit(model="circular", residual_dipole={"moment_B_Am2": [0.0, 0.0, 0.1]})
    with pytest.raises(InvalidParameterError, match=r"\[orbit\.drag\].*model"):
        Orbit(drag={"area_m2": 0.1})


ALL = {"gravity_gradient": True, "residual_dipole": {"moment_B_Am2": [0.01, 0.0, 0.02]},
       "drag": {"area_m2": 0.06, "cp_offset_B_m": [0.0, 0.0, 0.05]},
       "srp": {"area_m2": 0.06, "cp_offset_B_m": [0.0, 0.05, 0.0]}}


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_the_batch_runs_the_same_torques_as_one_satellite(backend):
    """Every orbit torque at once: the vector env (NumPy, or torch through the same kernels)
    equals the single env (floats) row by row."""
    if backend == "torch":
        pytest.importorskip("torch")
    sc = _scene(ALL, duration=50.0)
    n = 3
    venv = gym.make_vec(rbenv.DETUMBLE_ID, num_envs=n, scene=sc, backend=backend)
    venv.reset(seed=5)
    st = venv.unwrapped._st
    singles = []
    for i in range(n):
        env = gym.make(rbenv.DETUMBLE_ID, scene=sc).unwrapped
        env.reset(seed=0, options={"q": [float(c[i]) for c in st.q],
                                   "omega_B": [float(c[i]) for c in st.omega_B]})
        singles.append(env)
    rng = np.random.default_rng(0)
    for _ in range(20):
        action = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        if backend == "torch":
            import torch

            _, _, _, _, info = venv.step(torch.as_tensor(action, dtype=torch.float64))
        else:
            _, _, _, _, info = venv.step(action)
        for i, env in enumerate(singles):
            _, _, _, _, info_i = env.step(action[i])
            np.testing.assert_allclose([float(c[i]) for c in venv.unwrapped._st.q], env._st.q,
                                       rtol=0, atol=1e-13)
            assert bool(info["eclipse"][i]) == bool(info_i["eclipse"])
