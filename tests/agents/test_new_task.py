"""A new task is one module plus its entries: this file is the module.

It defines "point a body axis at the Sun" (nothing else in the repository knows it), registers
its env entry with :func:`rbenv.envs.registry.register` and its training settings with
:func:`rbenv.agents.settings.register`, and then uses it as a user would: ``gym.make`` and
``gym.make_vec`` by id, Gymnasium's and SB3's env checkers, and ``rbenv train`` for 4096 steps,
which ends with the report that compares the policy with the entry's scripted baseline.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from typing import ClassVar

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents import settings
from rbenv.agents.settings import tuned
from rbenv.core import kernels as k
from rbenv.core.errors import InvalidParameterError

import rbenv
from rbenv.envs import registry, transition
from rbenv.envs.env import AttitudeEnv
from rbenv.envs.vector_env import AttitudeVectorEnv
from rbenv.tasks.base import _DEG, Task, Weights, option_table, unit
from rbenv.tasks.spec import TaskSpec

SUN_ID = "rbenvtest/PointSun-v0"
_AXIS_B = (1.0, 0.0, 0.0)  # the body axis that must point at the Sun (a panel normal)


@dataclass(frozen=True)
class SunWeights(Weights):
    """Reward weights, one per reward term (their names and order; ``SunWeights.Terms`` is
    derived from them): pointing error ``−w·θ/π`` and ``+w`` per step on target."""

    pointing: float = 1.0
    on_target: float = 1.0


@dataclass(frozen=True, eq=False)
class PointSun(Task):
    """Point body +x at a fixed Sun direction (world frame); any roll about it is fine."""

    name: ClassVar[str] = "point_sun"
    observation_structure: ClassVar[dict] = {"sun_B": 3, "omega_B": 3}
    error_info_key: ClassVar[str] = "sun_angle_deg"
    WeightsType: ClassVar[type] = SunWeights
    state_fields: ClassVar[dict] = {"sun_W": "c3", "sun_angle": "f", "on_target": "i"}

    weights: SunWeights = SunWeights()

    def sample_start(self, draws) -> dict:
        g = draws.normal("task", 7)
        return {"q": k.qnormalize(g[0:4]), "omega_B": (0.0 * g[0],) * 3,
                "sun_W": unit(g[4:7], draws.xp)}

    def complete_start(self, start: dict, xp) -> None:
        angle = self._angle(start["q"], start["sun_W"], xp)
        start.update(sun_angle=angle, on_target=0 * angle)

    @staticmethod
    def _angle(q, sun_W, xp):
        c = k.dot(k.rotate(q, _AXIS_B), sun_W)
        return xp.atan2(xp.sqrt(xp.maximum(1.0 - c * c, 0.0)), c)

    def observe(self, st, q, w, xp) -> tuple:
        s = self.inv_rate_limit
        return (*k.rotate_inverse(q, st.sun_W),
                *(xp.clip(w[i] * s, -1.0, 1.0) for i in range(3)))

    def evaluate(self, st, effort, xp):
        angle = self._angle(st.q, st.sun_W, xp)
        w = st.omega_B
        rate = xp.sqrt(k.dot(w, w))
        inside = (angle < self.success_angle) & (rate < self.success_rate)
        st.on_target = xp.where(inside, st.on_target + 1, 0)
        st.sun_angle = angle
        terms = self.Terms(-self.weights.pointing * angle / math.pi,
                         self.weights.on_target * inside)
        return terms, st.on_target >= self.hold_steps, rate > self.rate_limit

    def info(self, st, xp) -> dict:
        return {"sun_angle_deg": st.sun_angle * _DEG}


def make_point_sun(plant, reward_weights=None, max_initial_angle_deg=None,
                   max_initial_rate=None, task_options=None) -> PointSun:
    option_table(plant.scene, PointSun, task_options)
    return PointSun(plant=plant, weights=SunWeights.from_mapping(reward_weights))


class SunHold:
    """The entry's scripted baseline: damp the rate (it never turns toward the Sun)."""

    def __init__(self, n_act: int):
        self.n_act = n_act

    @classmethod
    def from_env(cls, env):
        return cls(getattr(env, "single_action_space", env.action_space).shape[0])

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation)
        shape = (self.n_act,) if obs.ndim == 1 else (obs.shape[0], self.n_act)
        return np.zeros(shape, np.float32), state


SPEC = TaskSpec(env_id=SUN_ID, task=PointSun, make=make_point_sun,
                env_doc="Point body +x at the Sun (a test task).")
TRAINING = settings.TrainingSettings(
    env_id=SUN_ID, baselines={"hold": SunHold},
    recipes={settings.Recipe("ppo"): {**tuned.PPO, "n_timesteps": 4096}})


@pytest.fixture(autouse=True, scope="module")
def _registered():
    """The two entries; removed afterwards, so no other test meets this task."""
    registry.register(SPEC)
    settings.register(TRAINING)
    yield
    registry.unregister(SUN_ID)
    settings.unregister(SUN_ID)


# --------------------------------------------------------------------------- the tests


def test_registered_task_makes_single_and_vector_envs_by_id():
    env = gym.make(SUN_ID)
    obs, info = env.reset(seed=3)
    assert obs.shape == (6,) and "sun_angle_deg" in info
    np.testing.assert_allclose(np.linalg.norm(obs[:3]), 1.0, rtol=1e-6)
    venv = gym.make_vec(SUN_ID, num_envs=4)
    vobs, _ = venv.reset(seed=3)
    np.testing.assert_array_equal(vobs[0], obs)  # sub-env 0 meets the single env's episode
    # No class of its own: the generic shells, told their task by the registration.
    assert type(env.unwrapped) is AttitudeEnv and type(venv.unwrapped) is AttitudeVectorEnv
    assert env.unwrapped.task_spec == SPEC and isinstance(env.unwrapped.task, PointSun)
    assert rbenv.envs.registry.get(SUN_ID) is SPEC and settings.get(SUN_ID) is TRAINING


def test_both_checkers_pass_on_the_new_task():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(SUN_ID).unwrapped, skip_render_check=True)
    sb3 = pytest.importorskip("stable_baselines3.common.env_checker",
                              reason="stable-baselines3 is not installed (train extra)")
    sb3.check_env(gym.make(SUN_ID), warn=True)


@pytest.mark.slow
def test_rbenv_train_runs_on_the_new_task_and_reports_its_baseline(tmp_path):
    pytest.importorskip("stable_baselines3", reason="stable-baselines3 is not installed "
                        "(train extra)")
    from rbenv.agents.cli import main

    out = tmp_path / "sun"
    main(["train", "--env-id", SUN_ID, "--timesteps", "4096", "--n-envs", "16",
          "--out", str(out), "--no-progress", "--checkpoint-every", "4096",
          "--eval-every", "4096", "--hyperparams", '{"n_steps": 64, "batch_size": 256}'])
    report = (out / "report.md").read_text()
    assert "hold" in report  # the entry's baseline was evaluated beside the policy
    assert list(out.glob("policy*.pt")) and not list(out.glob("*.zip"))  # weights, no pickle


def test_rbenv_train_refuses_an_id_without_training_settings_saying_what_to_add():
    from rbenv.agents.training.config import TrainConfig

    settings.unregister(SUN_ID)
    try:
        with pytest.raises(InvalidParameterError, match=re.escape(
                f"rbenv.agents.settings.register(TrainingSettings(env_id='{SUN_ID}'")):
            TrainConfig(env_id=SUN_ID).resolve()
    finally:
        settings.register(TRAINING)
    gym.make(SUN_ID).close()  # the env itself needs no training settings


@pytest.mark.parametrize(("change", "named"), [
    ({"baselines": {}}, "baselines"),
    ({"baselines": {"pd": 3}}, "baselines['pd']"),
    ({"recipes": {**TRAINING.recipes, settings.Recipe("sac", "sbx"): {"n_timesteps": 1000}}},
     "'sac' has no general recipe Recipe('sac')"),
    ({"recipes": {settings.Recipe("sac"): {"n_timesteps": 1000}}}, "no Recipe('ppo')"),
    ({"recipes": {settings.Recipe("ppo"): {**tuned.PPO, "n_timesteps": 0}}},
     "recipes[Recipe('ppo')]['n_timesteps'] must be a positive int"),
    ({"recipes": {settings.Recipe("ppo"): {**tuned.PPO, "n_timesteps": 4096.0}}},
     "['n_timesteps'] must be a positive int"),
    ({"recipes": {**TRAINING.recipes,
                  settings.Recipe("ppo", scene="boom-sat"): {"n_timesteps": -1}}},
     "recipes[Recipe('ppo', scene='boom-sat')]['n_timesteps']"),
    ({"recipes": {}}, "recipes has no Recipe('ppo')"),
])
def test_incomplete_training_settings_are_refused_when_registered(change, named):
    from dataclasses import replace

    bad = replace(TRAINING, env_id="rbenvtest/Broken-v0", **change)
    with pytest.raises(InvalidParameterError, match=re.escape(named)):
        settings.register(bad)
    with pytest.raises(InvalidParameterError, match="has no training settings"):
        settings.get("rbenvtest/Broken-v0")


@pytest.mark.parametrize(("change", "named"), [
    ({"env_id": "PointSun"}, "namespace/Name-v0"),
    ({"task": object}, "Task subclass"),
    ({"make": 3}, "make must be callable"),
])
def test_a_bad_env_entry_is_refused_when_made(change, named):
    from dataclasses import replace

    with pytest.raises(InvalidParameterError, match=re.escape(named)):
        replace(SPEC, **{"env_id": "rbenvtest/Broken-v0", **change})
    assert "rbenvtest/Broken-v0" not in gym.registry


def test_a_state_field_declared_twice_is_refused_naming_both_owners():
    from dataclasses import dataclass as dc

    @dc(frozen=True, eq=False)
    class Clash(PointSun):
        name: ClassVar[str] = "clash"
        state_fields: ClassVar[dict] = {"q": "c4", "fuel_kg": "f"}

    with pytest.raises(InvalidParameterError, match="'q' is declared by both plant and task"):
        transition.layout(gym.make(SUN_ID).unwrapped.plant, Clash)
