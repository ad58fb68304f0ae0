"""Domain randomization and counter-based draws: seeded, valid, the same in both envs."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from rbenv.core import inertia as inertia_lib
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.satellite.draws import EpisodeDraws
from rbenv.satellite.plant import make_plant
from rbenv.satellite.randomization import draw_episode_model

BIG = {"inertia_scale": 0.9, "inertia_rotation_deg": 90.0, "com_offset": 0.05,
       "force_scale": 0.5, "misalignment_deg": 20.0, "delay_probability": 0.5}


def test_counter_based_draws_are_uniform_and_normal_and_streams_independent():
    draws = EpisodeDraws(np.arange(20_000), np.zeros(20_000))
    u = draws.uniform_array("task", 4)
    g = draws.normal_array("plant", 3)
    assert u.min() >= 0.0 and u.max() < 1.0
    np.testing.assert_allclose(u.mean(axis=1), 0.5, atol=0.006)  # 1/sqrt(12 n) = 0.002
    np.testing.assert_allclose(u.var(axis=1), 1 / 12, atol=0.002)
    np.testing.assert_allclose(g.mean(axis=1), 0.0, atol=0.025)
    np.testing.assert_allclose(g.var(axis=1), 1.0, atol=0.04)
    assert abs(np.corrcoef(u[0], draws.uniform_array("plant", 1)[0])[0, 1]) < 0.03
    assert abs(np.corrcoef(u[0], u[1])[0, 1]) < 0.03
    later = EpisodeDraws(np.arange(20_000), np.ones(20_000)).uniform_array("task", 1)
    assert abs(np.corrcoef(u[0], later[0])[0, 1]) < 0.03  # next episode: fresh numbers


def test_one_env_draws_equal_the_batch_row_bit_for_bit():
    batch = EpisodeDraws(np.array([3, 99, 2**40]), np.array([0, 7, 12]))
    for i, (seed, episode) in enumerate([(3, 0), (99, 7), (2**40, 12)]):
        one = EpisodeDraws(seed, episode, single=True)
        assert one.uniform("task", 9) == tuple(batch.uniform_array("task", 9)[:, i].tolist())
        assert one.normal("randomization", 5) == tuple(
            batch.normal_array("randomization", 5)[:, i].tolist())


def test_every_way_of_serving_a_draw_gives_the_same_numbers():
    """Block cache with slot hints (small batch), one hash per request, and normals in chunks
    (large batch) are performance choices only: row i is always the same numbers."""
    n = 60_000  # 2 * 12 * n slots exceed the block budget: hashed per request, in chunks
    large = EpisodeDraws(np.arange(n), np.zeros(n))
    big_normals, big_uniforms = large.normal_array("task", 12), large.uniform_array("task", 30)
    rows = np.array([0, 17, n - 1])
    hinted = EpisodeDraws(rows, np.zeros(3), block_slots={"task": 24, "plant": 6})
    plain = EpisodeDraws(rows, np.zeros(3))
    for small in (hinted, plain):
        np.testing.assert_array_equal(small.normal_array("task", 12), big_normals[:, rows])
        np.testing.assert_array_equal(small.uniform_array("task", 30), big_uniforms[:, rows])
    np.testing.assert_array_equal(hinted.normal_array("task", 4, offset=16),
                                  big_normals[8:12, rows])


def test_randomized_inertia_is_always_physically_valid():
    plant = make_plant("boom-sat", randomize=BIG)  # inertia ratio 186:1, the hardest case
    model = draw_episode_model(plant, EpisodeDraws(np.arange(3000), np.zeros(3000)))
    for I in model.inertia[:3000:7]:
        inertia_lib.validate(I)
    eig = np.linalg.eigvalsh(model.inertia)
    assert (eig > 0).all()
    assert (eig[:, 0] + eig[:, 1] >= eig[:, 2] * (1 - 1e-12)).all()  # triangle inequality
    nominal = np.trace(plant.scene.body.inertia)
    traces = np.trace(model.inertia, axis1=1, axis2=2)
    assert traces.min() < nominal < traces.max()  # spread on both sides


def test_randomized_thrusters_follow_the_drawn_offsets_and_tilts():
    plant = make_plant("microsat-100kg", randomize=BIG)  # translation: force columns present
    thr = plant.scene.thrusters
    model = draw_episode_model(plant, EpisodeDraws(np.arange(500), np.zeros(500)))
    force = model.action_matrix[:, :, 3]  # N at full throttle
    force_B = model.action_matrix[:, :, 4:7]
    assert np.all(np.abs(force / thr.max_force - 1) <= 0.5 + 1e-12)
    np.testing.assert_allclose(np.linalg.norm(force_B, axis=2), force, rtol=1e-12)
    cos = np.clip(np.sum(force_B / force[..., None] * thr.directions_B, axis=2), -1, 1)
    tilt = np.degrees(np.arccos(cos))
    assert tilt.max() <= 20.0 + 1e-9 and tilt.max() > 15.0  # fills the cone
    assert np.linalg.norm(model.com_offset_B, axis=1).max() <= 0.05 + 1e-12
    arms = thr.positions_B - thr.com_B - model.com_offset_B[:, None, :]  # new lever arms
    np.testing.assert_allclose(model.action_matrix[:, :, :3], np.cross(arms, force_B),
                               atol=1e-15)


def test_randomization_is_seeded_hidden_and_the_same_in_both_envs():
    env = gym.make(rbenv.ENV_ID, scene="cubesat-12u-dr")
    nominal = gym.make(rbenv.ENV_ID)
    obs, _ = env.reset(seed=7)
    obs_nominal, _ = nominal.reset(seed=7)
    np.testing.assert_array_equal(obs, obs_nominal)  # the draws never show in the observation
    first = env.unwrapped._st.model
    env.reset(seed=7)
    again = env.unwrapped._st.model
    np.testing.assert_array_equal(first.inertia, again.inertia)
    np.testing.assert_array_equal(first.action_matrix, again.action_matrix)
    env.reset()
    other = env.unwrapped._st.model
    assert not np.array_equal(first.inertia, other.inertia)
    venv = gym.make_vec(rbenv.ENV_ID, num_envs=3, scene="cubesat-12u-dr")
    venv.reset(seed=5)
    vm = venv.unwrapped._st.model
    for i in range(3):
        env.reset(seed=5 + i)
        sm = env.unwrapped._st.model
        np.testing.assert_array_equal(sm.inertia, vm.inertia[i])
        np.testing.assert_array_equal(sm.action_matrix, vm.action_matrix[i])
        assert sm.delayed == bool(vm.delayed[i])


def test_control_delay_fires_the_previous_command():
    delayed = gym.make(rbenv.ENV_ID, randomize={"delay_probability": 1.0})
    plain = gym.make(rbenv.ENV_ID)
    a1, a2 = np.full(12, 0.5), np.full(12, -1.0)
    a2[0] = 1.0
    delayed.reset(seed=1)
    plain.reset(seed=1)
    _, _, _, _, i1 = delayed.step(a1)
    assert i1["fuel_kg"] == 0.0  # nothing commanded before the first step
    _, _, _, _, i2 = delayed.step(a2)
    _, _, _, _, p1 = plain.step(a1)
    assert i2["fuel_kg"] == pytest.approx(p1["fuel_kg"], rel=1e-12)


def test_randomization_off_is_the_nominal_plant_and_bad_sizes_are_named():
    assert make_plant("cubesat-12u").randomization is None
    assert make_plant("cubesat-12u-dr", randomize=False).randomization is None
    assert make_plant("cubesat-12u-dr").randomization.inertia_scale == 0.2
    with pytest.raises(InvalidParameterError, match=r"randomization\.force_scale"):
        make_plant("cubesat-12u", randomize={"force_scale": 2.0})
    with pytest.raises(InvalidParameterError, match="unknown field"):
        make_plant("cubesat-12u", randomize={"mass_scale": 0.1})
    with pytest.raises(InvalidParameterError, match="inertia_scale"):
        make_plant("cubesat-12u", randomize={"inertia_scale": True})
    with pytest.raises(InvalidParameterError, match="splitting"):
        make_plant("cubesat-12u-dr", integrator="splitting")
    assert make_plant("cubesat-12u-dr", integrator="splitting",
                      randomize={"inertia_scale": 0.0, "inertia_rotation_deg": 0.0})


def test_scripted_baselines_use_the_nominal_model_under_randomization():
    from rbenv.agents.policies.evaluate import evaluate

    pd = evaluate("pd", episodes=200, seed=1_000_000, scene="cubesat-12u-dr").summary()
    bang = evaluate("bangbang", episodes=200, seed=1_000_000, scene="cubesat-12u-dr").summary()
    nominal = evaluate("bangbang", episodes=200, seed=1_000_000).summary()
    assert pd["success_rate"] >= 0.95
    # The deadbeat bang-bang trusts the nominal model: delay and errors cost it dearly.
    assert bang["success_rate"] < nominal["success_rate"] - 0.3
