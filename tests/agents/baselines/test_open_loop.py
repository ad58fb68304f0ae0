"""rbenv.agents.baselines.open_loop: its own dynamics reproduce the env's for the same commands,
and what it optimises, replayed in the env, never beats a lower bound of
rbenv.agents.baselines.bounds."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines import bounds as rb
from rbenv.agents.baselines import open_loop as ol
from rbenv.agents.policies.optimality import episode_bounds
from rbenv.core.errors import InvalidParameterError

import rbenv


def _env_trajectory(ep: ol.Episode, commands: np.ndarray) -> dict:
    """The env's ω_B and wheel speeds after each step under ``commands`` (others idle)."""
    env = gym.make(ep.env_id, scene=ep.scene_arg)
    try:
        base = env.unwrapped
        env.reset(seed=ep.seed)
        w, speed = [], []
        for c in commands:
            a = np.zeros(ep.action_size, np.float32)
            a[ep.action_slice] = c
            _, _, term, trunc, _ = env.step(a)
            w.append(np.array(base._st.omega_B, float).ravel())
            if getattr(base._st, "wheel_speed", None) is not None:
                speed.append(np.array(base._st.wheel_speed, float).ravel())
            if term or trunc:
                break
        return {"omega_B": np.array(w), "wheel_speed": np.array(speed)}
    finally:
        env.close()


def _commands(ep: ol.Episode, steps: int, scale: float, seed: int = 0) -> np.ndarray:
    """Random commands the env receives exactly (float32 values)."""
    rng = np.random.default_rng(seed)
    return (scale * rng.uniform(ep.low, 1.0, (steps, ep.n))).astype(np.float32).astype(float)


@pytest.mark.parametrize(("env_id", "scene", "actuator"), [
    (rbenv.ENV_ID, "cubesat-12u-rw", "wheels"),
    (rbenv.DETUMBLE_ID, "cubesat-12u", "thrusters"),
])
def test_the_rollout_reproduces_the_env_without_orbit_torques(env_id, scene, actuator):
    """Same RK4, same order of operations: equal to rounding over 20 steps."""
    ep = ol.Episode.from_seed(5, env_id, scene, actuator)
    U = _commands(ep, 20, 0.3)
    mine = ep.rollout(U[None])
    env = _env_trajectory(ep, U)
    k = len(env["omega_B"])
    assert k == 20
    assert np.abs(mine["omega_B"][0, 1:k + 1] - env["omega_B"]).max() < 1e-12
    assert np.abs(mine["omega_B"][0, -1]).max() > 1e-3  # the commands did turn it
    if actuator == "wheels":
        assert np.abs(mine["wheel_speed"][0, 1:k + 1] - env["wheel_speed"]).max() < 1e-9


def test_the_rollout_applies_the_envs_speed_limit_rule():
    """Wheel x driven at full torque for 6 s passes its speed limit unless the rule stops it:
    the rollout and the env agree, and both hold it at 6000 rpm (to the bus rate's change
    within a step, which the rule does not foresee)."""
    ep = ol.Episode.from_seed(5, rbenv.ENV_ID, "cubesat-12u-rw", "wheels")
    U = np.zeros((12, 3))
    U[:, 0] = 1.0
    mine = ep.rollout(U[None])
    env = _env_trajectory(ep, U)
    top = float(ep.scene.actuators["wheels"].max_speed[0])
    assert np.abs(env["wheel_speed"][:, 0]).max() == pytest.approx(top, rel=1e-6)
    assert np.abs(mine["wheel_speed"][0, 1:] - env["wheel_speed"]).max() < 1e-9
    assert np.abs(mine["omega_B"][0, 1:] - env["omega_B"]).max() < 1e-12


@pytest.mark.parametrize(("env_id", "actuator", "scale"), [
    (rbenv.DETUMBLE_ID, "magnetorquers", 1.0),  # 10 s steps, 4 substeps, rods through the field
    (rbenv.ENV_ID, "wheels", 0.05),
])
def test_with_orbit_torques_modelled_the_rollout_reproduces_the_env(env_id, actuator, scale):
    """cubesat-6u-rw's gravity gradient and field (the rods' torque m × B), modelled: equal to
    rounding over 20 steps, and the commands did turn it."""
    ep = ol.Episode.from_seed(5, env_id, "cubesat-6u-rw", actuator, orbit_torques=True)
    U = _commands(ep, 20, scale)
    env = _env_trajectory(ep, U)
    assert len(env["omega_B"]) == 20
    assert np.abs(ep.rollout(U[None])["omega_B"][0, 1:] - env["omega_B"]).max() < 1e-15
    assert np.abs(env["omega_B"][-1] - ep.omega0_B).max() > 1e-3


def test_with_orbit_torques_the_rollout_stays_within_the_margins():
    """cubesat-6u-rw has gravity gradient, which the optimiser leaves out: over 20 steps its
    rate differs from the env's by far less than the margin on the success rate (0.3 × 0.01)."""
    ep = ol.Episode.from_seed(5, rbenv.ENV_ID, "cubesat-6u-rw", "wheels")
    U = _commands(ep, 20, 0.2)
    diff = np.abs(ep.rollout(U[None])["omega_B"][0, 1:] - _env_trajectory(ep, U)["omega_B"])
    assert 0.0 < diff.max() < 1e-4


def test_a_thruster_detumble_optimised_and_replayed_is_above_every_bound():
    """Time-optimal and propellant-optimal detumbles of one episode, replayed in the env:
    successful, and no earlier than the settle bound, no cheaper than either propellant
    bound (any policy, and at the trajectory's own settle time)."""
    seed = 2_000_000
    ep = ol.Episode.from_seed(seed, rbenv.DETUMBLE_ID, "cubesat-12u", "thrusters")
    bounds = episode_bounds(1, seed, rbenv.DETUMBLE_ID, {"scene": "cubesat-12u"})
    pd = ol.replay("pd", ep)
    assert pd["success"]
    step = round(pd["settle_time_s"] / ep.dt)
    fast = ol.time_optimal(ep, step, pd["commands"], int(bounds.settle_s[0] / ep.dt) - 1,
                           maxiter=60)
    rep = ol.replay(fast.commands, ep)
    assert fast.feasible and rep["success"]
    assert bounds.settle_s[0] <= rep["settle_time_s"] <= pd["settle_time_s"]
    cheap = ol.replay(ol.fuel_optimal(ep, step, pd["commands"], maxiter=60).commands, ep)
    assert cheap["success"]
    own = bounds.fuel_at(np.array([cheap["settle_time_s"]]))[0]
    assert 0.0 < bounds.fuel_kg[0] <= own <= cheap["fuel_kg"]
    assert cheap["fuel_kg"] < pd["fuel_kg"]  # the optimiser did optimise


def test_a_wheel_detumble_optimised_and_replayed_is_above_the_bound():
    seed = 2_000_000
    ep = ol.Episode.from_seed(seed, rbenv.DETUMBLE_ID, "cubesat-6u-rw", "wheels")
    bound = rb.energy_settle_bound(rb.torque_limits(ep.scene, used=("wheels",)),
                                   ep.omega0_B[None])["sampled"][0]
    sol = ol.time_optimal(ep, 3, None, 0, maxiter=60)
    rep = ol.replay(sol.commands, ep)
    assert sol.feasible and rep["success"]
    assert bound <= rep["settle_time_s"] <= 3 * ep.dt


@pytest.mark.slow  # two bisections on wheel reorientations, about a minute
@pytest.mark.parametrize("scene", ["cubesat-6u-rw", "cubesat-12u-rw"])
def test_a_wheel_reorientation_optimised_and_replayed_is_above_both_bounds(scene):
    """A 52° turn through the wheels alone: the env's settle time is at least the bound the
    evaluations report and the wheels-only bound, and beats the PD's."""
    seed = 1_000_028
    ep = ol.Episode.from_seed(seed, rbenv.ENV_ID, scene, "wheels")
    st = rb.episode_starts(1, seed, scene, env_id=rbenv.ENV_ID)
    reported = episode_bounds(1, seed, rbenv.ENV_ID, {"scene": scene}).settle_s[0]
    alone = rb.energy_settle_bound(rb.torque_limits(scene, used=("wheels",)), st["omega_B"],
                                   st["angle"], st["bias_B"])["sampled"][0]
    pd = ol.replay("pd", ep)
    sol = ol.time_optimal(ep, round(pd["settle_time_s"] / ep.dt), pd["commands"],
                          round(alone / ep.dt) - 1, maxiter=80)
    rep = ol.replay(sol.commands, ep)
    assert rep["success"]
    assert reported <= alone <= rep["settle_time_s"] < pd["settle_time_s"]


def test_bad_requests_are_named():
    with pytest.raises(InvalidParameterError, match="actuator='thrusters'"):
        ol.Episode.from_seed(1, rbenv.ENV_ID, "cubesat-6u-rw", "thrusters")
    ep = ol.Episode.from_seed(1, rbenv.ENV_ID, "cubesat-6u-rw", "wheels")
    with pytest.raises(InvalidParameterError, match="objective='fuel' needs thrusters"):
        ol.solve(ep, 10, objective="fuel")
    with pytest.raises(InvalidParameterError, match="the rods need the orbit's magnetic field"):
        ol.Episode.from_seed(1, rbenv.DETUMBLE_ID, "cubesat-6u-rw", "magnetorquers",
                             orbit_torques=False)


@pytest.mark.slow  # a rods detumble, 10 s steps: one optimisation, tens of seconds
def test_a_rods_detumble_optimised_and_replayed_is_above_the_bound_and_beats_b_dot():
    seed = 2_000_000
    ep = ol.Episode.from_seed(seed, rbenv.DETUMBLE_ID, "cubesat-6u-rw", "magnetorquers")
    bound = rb.energy_settle_bound(rb.torque_limits(ep.scene, used=("magnetorquers",)),
                                   ep.omega0_B[None])["sampled"][0]
    bdot = ol.replay("bdot", ep)
    assert bdot["success"]
    sol = ol.solve(ep, round(bdot["settle_time_s"] / ep.dt), guess=bdot["commands"],
                   block=2, maxiter=60)
    rep = ol.replay(sol.commands, ep)
    assert sol.feasible and rep["success"]
    assert bound <= rep["settle_time_s"] <= bdot["settle_time_s"]
