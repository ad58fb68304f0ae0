"""Reorient-v2 (issue 45): v1's episodes and observation, a reward that prices time and
propellant on one scale, the fuel weight its trade knob (rbenv/tasks/reorient.py)."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines.controllers import QuaternionPD

import rbenv
from rbenv.tasks.reorient import ReorientV2Weights
from tests.rbenv.quiet import make as _make

V2, V1 = "rbenv/SatelliteReorient-v2", "rbenv/SatelliteReorient-v1"
G0 = 9.80665


def test_v2_is_registered_with_its_own_classes_and_history():
    spec = rbenv.envs.registry.get(V2)
    assert spec.task.name == "reorient_v2" and spec.task.table_name() == "reorient"
    assert rbenv.ENV_IDS[V2] == ("SatelliteReorientV2Env", "SatelliteReorientV2VectorEnv")
    assert "**Version History**" in spec.env_doc and "* v2:" in spec.env_doc


def test_both_checkers_pass_with_warnings_as_errors():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(V2).unwrapped, skip_render_check=True)
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(gym.make(V2), warn=True)


def _psi(theta, theta_s):
    return math.log1p(theta / theta_s) / math.log1p(math.pi / theta_s)


def test_v2_episodes_are_v1_episodes_and_its_reward_is_the_hand_computed_one():
    """Same seed, same actions: v1's observation, errors, propellant and ends; the reward
    recomputed by hand from the info: time −0.1, fuel −1.5·(mean throttle) (cubesat-12u's
    thrusters are equal: effort is the mean of clip(a, 0, 1), and the propellant of the step
    is effort·ΣF·dt/(Isp·g0)), progress 25·(ψ(θ_prev) − ψ(θ)), nothing for error or rate."""
    new, old = _make(V2), _make(V1)
    o2, i2 = new.reset(seed=7)
    o1, _ = old.reset(seed=7)
    np.testing.assert_array_equal(o2, o1)
    plant = new.unwrapped.plant
    force = np.asarray(plant.scene.thrusters.max_force, float) * np.ones(12)
    isp, dt = plant.scene.actuators["thrusters"].isp, plant.scene.physics.control_dt
    theta_s = new.unwrapped.task.success_angle
    theta_prev, fuel_prev = math.radians(i2["attitude_error_deg"]), 0.0
    rng = np.random.default_rng(0)
    for _ in range(40):
        a = rng.uniform(-1, 1, 12).astype(np.float32)
        o2, r2, t2, tr2, i2 = new.step(a)
        o1, _, t1, tr1, i1 = old.step(a)
        np.testing.assert_array_equal(o2, o1)
        assert (i2["attitude_error_deg"], i2["fuel_kg"], t2, tr2) == \
            (i1["attitude_error_deg"], i1["fuel_kg"], t1, tr1)
        effort = float(np.clip(a, 0, 1) @ force / force.sum())
        assert i2["fuel_kg"] - fuel_prev == pytest.approx(
            effort * force.sum() * dt / (isp * G0), rel=1e-9)
        theta = math.radians(i2["attitude_error_deg"])
        assert i2["reward_time"] == -0.1
        assert i2["reward_fuel"] == pytest.approx(-1.5 * effort, rel=1e-12)
        assert i2["reward_progress"] == pytest.approx(
            25.0 * (_psi(theta_prev, theta_s) - _psi(theta, theta_s)), rel=1e-9, abs=1e-12)
        assert i2["reward_error"] == 0.0 and i2["reward_rate"] == 0.0
        assert r2 == pytest.approx(-0.1 - 1.5 * effort + i2["reward_progress"]
                                   + 20.0 * i2["is_success"] - 25.0 * (t2 and not
                                                                       i2["is_success"]))
        theta_prev, fuel_prev = theta, i2["fuel_kg"]
        if t2 or tr2:
            break


def test_the_default_prices_a_gram_as_its_docstring_says():
    """cubesat-12u burns 0.471 g in a full-effort 0.5 s step, so fuel 1.5 against time 0.1
    prices a gram at (1.5/0.1)/0.471 ≈ 31.8 steps = 15.9 s."""
    plant = _make(V2).unwrapped.plant
    sc = plant.scene
    grams_per_step = 1e3 * np.sum(sc.thrusters.max_force) * sc.physics.control_dt / (
        sc.actuators["thrusters"].isp * G0)
    assert grams_per_step == pytest.approx(0.471, abs=5e-4)
    wt = ReorientV2Weights()
    assert (wt.fuel / wt.time) / grams_per_step * sc.physics.control_dt == \
        pytest.approx(15.9, abs=0.05)


def _pd_return(weights, seed=3):
    env = _make(V2, reward_weights=weights)
    pd = QuaternionPD.from_env(env)
    obs, _ = env.reset(seed=seed)
    total, steps, fuel = 0.0, 0, 0.0
    while True:
        obs, r, term, trunc, info = env.step(pd.predict(obs)[0])
        total, steps, fuel = total + r, steps + 1, info["fuel_kg"]
        if term or trunc:
            return total, steps, fuel, info["is_success"]


def test_the_fuel_weight_trades_propellant_against_time_monotonically():
    """One episode of the PD (the same trajectory whatever the weights): its return falls
    linearly in the fuel weight, by the episode's effort, and in the time weight, by its
    step count; the success pay is unchanged."""
    base, steps, fuel, ok = _pd_return(None)
    assert ok and fuel > 0
    effort_sum = None
    prev = base
    for w in (2.5, 4.0, 8.0):
        ret, n, f, _ = _pd_return({"fuel": w})
        assert (n, f) == (steps, fuel) and ret < prev
        slope = (base - ret) / (w - ReorientV2Weights().fuel)
        effort_sum = slope if effort_sum is None else effort_sum
        assert slope == pytest.approx(effort_sum, rel=1e-9)
        prev = ret
    sc = _make(V2).unwrapped.plant.scene
    assert effort_sum == pytest.approx(fuel * sc.actuators["thrusters"].isp * G0 / (
        np.sum(sc.thrusters.max_force) * sc.physics.control_dt), rel=1e-9)
    ret, *_ = _pd_return({"time": 0.3})
    assert base - ret == pytest.approx(0.2 * steps, rel=1e-9)


def test_hovering_pays_less_than_completing():
    """Inside the thresholds every default term but progress is ≤ 0 (time −0.1 per step) and
    progress telescopes, so hovering earns at most ``w_progress·ψ(1°)`` = 25·log 2/log(181)
    ≈ 3.3, less than the success pay of 20 (the v1 argument, with v2's weights)."""
    wt = ReorientV2Weights()
    psi_threshold = math.log(2) / math.log1p(180.0)
    assert _psi(math.radians(1.0), math.radians(1.0)) == pytest.approx(psi_threshold)
    assert wt.progress * psi_threshold == pytest.approx(3.33, abs=0.01)
    assert wt.progress * psi_threshold < wt.success
    assert wt.time > 0 and wt.error == wt.rate == 0.0


def test_bad_weights_are_refused_naming_the_term():
    with pytest.raises(ValueError, match="time"):
        _make(V2, reward_weights={"time": -1.0})
    with pytest.raises(ValueError, match="unknown term"):
        _make(V2, reward_weights={"hold": 1.0})


def test_vector_env_equals_single_env():
    n = 3
    venv = gym.make_vec(V2, num_envs=n, vectorization_mode="vector_entry_point")
    singles = [_make(V2) for _ in range(n)]
    venv.reset(seed=11)
    for i, env in enumerate(singles):
        env.reset(seed=11 + i)
    rng = np.random.default_rng(1)
    for _ in range(12):
        actions = rng.uniform(-1, 1, venv.action_space.shape).astype(np.float32)
        _, vrew, *_ = venv.step(actions)
        for i, env in enumerate(singles):
            _, rew, *_ = env.step(actions[i])
            assert vrew[i] == pytest.approx(rew, rel=1e-12, abs=1e-12)
