"""The task family: detumble and track beside reorient, on every scene, through one transition."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from rbenv.agents.baselines.controllers import RateDamping, TrackingPD, WheelHoldPD, baseline
from rbenv.agents.policies.evaluate import evaluate
from rbenv.core import quaternion
from rbenv.core.errors import InvalidParameterError

import rbenv

IDS = tuple(rbenv.ENV_IDS)
NEW_IDS = (rbenv.DETUMBLE_ID, rbenv.TRACK_ID)


@pytest.mark.parametrize("scene", rbenv.list_scenes())
@pytest.mark.parametrize("env_id", NEW_IDS)
def test_new_tasks_pass_both_checkers_without_warnings(env_id, scene):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # v0 ids have a v1: Gymnasium's registry calls them out of date (its convention).
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        check_env(gym.make(env_id, scene=scene).unwrapped, skip_render_check=True)
        sb3_checker.check_env(gym.make(env_id, scene=scene).unwrapped)


@pytest.mark.parametrize("env_id", NEW_IDS)
def test_torque_mode_and_rendering_work_for_new_tasks(env_id):
    pytest.importorskip("pygame")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # v0 ids have a v1: Gymnasium's registry calls them out of date (its convention).
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        check_env(gym.make(env_id, action_mode="torque", render_mode="rgb_array").unwrapped)
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape[2] == 3 and frame.std() > 0


@pytest.mark.parametrize("env_id", IDS)
def test_registration_spaces_and_observation_structure(env_id):
    env = gym.make(env_id)
    u = env.unwrapped
    assert env.spec.vector_entry_point == "rbenv.envs.registry:make_vector_env"
    assert type(u) is getattr(rbenv.envs.env, rbenv.ENV_IDS[env_id][0])  # the id's own class
    size = sum(u.observation_structure.values())
    assert env.observation_space.shape == (size,)
    slices = u.task.observation_slices()
    assert [s.start for s in slices.values()] == [0, *np.cumsum(
        list(u.task.observation_structure.values()))[:-1].tolist()]  # the actuators' follow
    venv = gym.make_vec(env_id, num_envs=3)
    assert venv.single_observation_space == env.observation_space
    assert venv.unwrapped.observation_structure == u.observation_structure


@pytest.mark.parametrize("env_id", IDS)
def test_reward_terms_sum_to_the_reward_and_decode_gives_physical_rates(env_id):
    env = gym.make(env_id)
    u = env.unwrapped
    obs, info = env.reset(seed=4)
    terms = [f"reward_{t}" for t in u.task.Terms._fields]
    assert all(info[t] == 0.0 for t in terms)
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, env.action_space.shape))
        total = 0.0
        for t in terms:
            total += info[t]
        assert total == reward
        if terminated or truncated:
            break
    decoded = u.task.decode(obs)
    rate_key = "omega_B" if "omega_B" in decoded else "omega_err_B"
    assert decoded[rate_key].shape == (3,)
    if rate_key == "omega_B":  # float32 observation of the true body rate
        L = u.task.rate_limit  # clipped at the rate limit (a wheel step can pass it)
        np.testing.assert_allclose(decoded["omega_B"], np.clip(u._st.omega_B, -L, L),
                                   atol=1e-7 * L)


def _biased_actions(n, steps, seed, size=12):
    a = np.random.default_rng(seed).uniform(-1, 1, (steps, n, size)).astype(np.float32)
    a[:, :, -2:] += 0.6  # some sub-envs lose control and reset
    return a


@pytest.mark.parametrize(("env_id", "scene"), [(rbenv.DETUMBLE_ID, "cubesat-12u"),
                                               (rbenv.TRACK_ID, "cubesat-12u"),
                                               (rbenv.ENV_ID, "cubesat-12u-dr"),
                                               (rbenv.TRACK_ID, "cubesat-12u-dr")])
def test_vector_env_equals_single_envs_through_autoresets(env_id, scene, lockstep):
    """Sub-env i seeded s + i equals a single env seeded s + i, episode after episode,
    however the other sub-envs' episodes end (counter-based starts, rbenv.satellite.draws)."""
    n, steps, seed = 5, 340, 21
    venv = gym.make_vec(env_id, num_envs=n, scene=scene)
    singles = [gym.make(env_id, scene=scene) for _ in range(n)]
    obs, _ = venv.reset(seed=seed)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(env.reset(seed=seed + i)[0], obs[i])
    actions = _biased_actions(n, steps, 5)
    prev_done = np.zeros(n, bool)
    resets = 0
    step_alongside, assert_sub_env_matches = lockstep
    for t in range(steps):
        vec_out, singles_out = step_alongside(venv, singles, actions[t], prev_done)
        obs, _, terminated, truncated, info = vec_out
        resets += int(prev_done.sum())
        for i, env in enumerate(singles):
            assert_sub_env_matches(env, singles_out[i], venv, vec_out, i)
            o, inf = singles_out[i][0], singles_out[i][4]
            np.testing.assert_allclose(o, obs[i], rtol=0, atol=1e-6)
            for key, value in inf.items():
                assert abs(float(value) - float(info[key][i])) <= 1e-9 * max(1, abs(value))
        prev_done = terminated | truncated
    assert resets >= 4


# --------------------------------------------------------------------------- detumble


def test_detumble_starts_within_the_scene_fractions_and_rate_damping_stops_it():
    env = gym.make(rbenv.DETUMBLE_ID)
    limit = env.unwrapped.task.rate_limit
    rates = [np.radians(env.reset(seed=s)[1]["rate_dps"]) for s in range(200)]
    assert 0.3 * limit - 1e-12 <= min(rates) and max(rates) <= 0.8 * limit + 1e-12
    assert max(rates) - min(rates) > 0.4 * limit  # spread over the range
    for scene in ("cubesat-12u", "microsat-100kg"):
        pd = evaluate("pd", episodes=200, seed=1_000_000, scene=scene, env_id=rbenv.DETUMBLE_ID)
        zero = evaluate("zero", episodes=50, seed=1_000_000, scene=scene,
                        env_id=rbenv.DETUMBLE_ID)
        assert pd.summary()["success_rate"] >= 0.95
        assert zero.summary()["success_rate"] == 0.0


def test_detumble_task_options_from_scene_tables_and_kwargs():
    env = gym.make(rbenv.DETUMBLE_ID, task_options={"min_rate_fraction": 0.5,
                                                    "max_rate_fraction": 0.5})
    limit = env.unwrapped.task.rate_limit
    assert math.radians(env.reset(seed=0)[1]["rate_dps"]) == pytest.approx(0.5 * limit)
    with pytest.raises(InvalidParameterError, match="unknown option"):
        gym.make(rbenv.DETUMBLE_ID, task_options={"max_rate": 0.1})
    with pytest.raises(InvalidParameterError, match="max_rate_fraction"):
        gym.make(rbenv.DETUMBLE_ID, task_options={"max_rate_fraction": 1.5})
    with pytest.raises(InvalidParameterError, match="unknown option"):
        gym.make(rbenv.ENV_ID, task_options={"anything": 1})


# --------------------------------------------------------------------------- track


def test_track_target_turns_at_the_drawn_constant_rate():
    """After k steps the target has turned by |Ω|·k·dt about Ω (closed form)."""
    env = gym.make(rbenv.TRACK_ID)
    u = env.unwrapped
    omega = np.array([0.01, -0.02, 0.015])
    q0 = quaternion.from_axis_angle([0.3, 0.4, 0.5], 1.0)
    env.reset(seed=0, options={"q_target": q0, "omega_target_W": omega, "q": q0,
                               "omega_B": np.zeros(3)})
    dt = u.plant.control_dt
    for k in range(1, 41):
        env.step(-np.ones(12))
        q_t = np.array(u.task.target(u._st))
        expected = quaternion.multiply(quaternion.from_rotation_vector(omega * k * dt), q0)
        assert quaternion.angle(q_t, expected) < 1e-12


def test_track_observation_carries_target_rate_in_body_axes():
    env = gym.make(rbenv.TRACK_ID)
    u = env.unwrapped
    omega = np.array([0.02, 0.0, -0.01])
    q = quaternion.from_axis_angle([1.0, 2.0, 0.5], 0.7)
    w = np.array([0.005, -0.004, 0.003])
    obs, _ = env.reset(seed=0, options={"q": q, "omega_B": w, "q_target": q,
                                        "omega_target_W": omega})
    d = u.task.decode(obs)
    w_t = quaternion.rotate_inverse(q, omega)
    np.testing.assert_allclose(d["omega_target_B"], w_t, atol=1e-8)
    np.testing.assert_allclose(d["omega_err_B"], w - w_t, atol=1e-8)
    np.testing.assert_allclose(d["q_err"], [1, 0, 0, 0], atol=1e-7)


def test_track_success_is_judged_over_the_second_half_and_tracking_pd_earns_it():
    result = evaluate("pd", episodes=200, seed=1_000_000, env_id=rbenv.TRACK_ID)
    zero = evaluate("zero", episodes=50, seed=1_000_000, env_id=rbenv.TRACK_ID)
    assert result.summary()["success_rate"] >= 0.95
    assert zero.summary()["success_rate"] == 0.0
    # Every episode runs its full length (success does not end it), unless control is lost.
    assert np.all(result.episode_time_s[result.success] == pytest.approx(80.0))
    env = gym.make(rbenv.TRACK_ID)
    pd = TrackingPD.from_env(env)
    obs, info = env.reset(seed=3)
    state, fractions = None, []
    while True:
        action, state = pd.predict(obs, state)
        obs, _, terminated, truncated, info = env.step(action)
        fractions.append(info["track_fraction"])
        if terminated or truncated:
            break
    assert info["is_success"] and info["track_fraction"] >= 0.9
    assert fractions[0] == 0.0  # the first half does not count


def test_tracking_feedforward_matters_at_high_target_rate():
    """Without the target-rate terms the same PD lags a fast target; with them it tracks."""
    opts = {"task_options": {"max_target_rate_fraction": 0.6}}
    good = evaluate("pd", episodes=100, seed=5, env_id=rbenv.TRACK_ID, env_kwargs=opts)

    class NoFeedforward(TrackingPD):
        def control(self, obs, state, episode_start):
            blind = dict(obs, omega_err_B=obs["omega_err_B"] + obs["omega_target_B"],
                         omega_target_B=0.0 * obs["omega_target_B"])
            return super().control(blind, state, episode_start)

    env = gym.make_vec(rbenv.TRACK_ID, num_envs=100, **opts)
    bad = evaluate(NoFeedforward.from_env(env), episodes=100, seed=5, env_id=rbenv.TRACK_ID,
                   env_kwargs=opts)
    assert good.summary()["success_rate"] >= 0.9
    assert bad.summary()["success_rate"] <= good.summary()["success_rate"] - 0.3


# --------------------------------------------------------------------------- seam


def test_a_task_is_one_module_and_one_registry_line():
    assert {s.name for s in rbenv.envs.registry.specs()} >= {"reorient", "detumble", "track"}
    for env_id in IDS:
        env = gym.make(env_id)
        task = env.unwrapped.task
        assert rbenv.envs.registry.get(env_id).task is type(task)
        assert isinstance(baseline(env, "pd"), (RateDamping, TrackingPD, WheelHoldPD)) or \
            task.table_name() == "reorient"
    with pytest.raises(ValueError, match="bangbang"):
        baseline(gym.make(rbenv.DETUMBLE_ID), "bangbang")


# Each task's reward terms, in order, as released: the names of the info["reward_<term>"] keys.
RELEASED_TERMS = {
    "Detumble": ("rate", "progress", "fuel", "hold", "failure"),
    "DetumbleV1": ("error", "rate", "fuel", "progress", "success", "failure"),
    "Reorient": ("attitude", "rate", "fuel", "progress", "hold", "failure", "precision"),
    "ReorientV1": ("error", "rate", "fuel", "progress", "success", "failure"),
    "ReorientV2": ("error", "rate", "fuel", "progress", "success", "failure", "time"),
    "Desaturate": ("attitude", "momentum", "progress", "effort", "hold", "failure"),
    "DesaturateV1": ("attitude", "momentum", "progress", "effort", "hold", "failure"),
    "Track": ("attitude", "rate", "fuel", "progress", "on_target", "failure"),
    "TrackV1": ("error", "rate", "fuel", "progress", "success", "failure"),
}


@pytest.mark.parametrize("env_id", IDS)
def test_reward_terms_are_the_weights_fields_in_their_released_order(env_id):
    import pickle
    from dataclasses import fields

    task = gym.make(env_id).unwrapped.task
    names = tuple(f.name for f in fields(task.WeightsType))
    assert task.Terms._fields == names == RELEASED_TERMS[type(task).__name__]
    assert task.Terms is task.WeightsType.Terms is type(task.weights).Terms
    assert task.reward_keys == tuple(f"reward_{t}" for t in names)
    terms = task.Terms(*range(len(names)))
    assert pickle.loads(pickle.dumps(terms)) == terms


def test_a_task_cannot_declare_its_own_terms():
    from typing import ClassVar

    from rbenv.tasks.base import Task
    from rbenv.tasks.reorient import ReorientWeights

    with pytest.raises(TypeError, match="declares Terms; the reward terms are the fields"):
        class Stray(Task):
            WeightsType: ClassVar[type] = ReorientWeights
            Terms: ClassVar[type] = tuple


def test_a_weights_subclass_without_new_fields_shares_its_parents_terms():
    from rbenv.tasks.detumble import DetumbleV1Weights
    from rbenv.tasks.reorient import ReorientV2Weights
    from rbenv.tasks.v1 import V1Weights

    assert DetumbleV1Weights.Terms is V1Weights.Terms
    assert ReorientV2Weights.Terms is not V1Weights.Terms
    assert ReorientV2Weights.Terms._fields[-1] == "time"
