"""The goal-conditioned form of reorientation: ``rbenv/SatelliteReorientGoal-v1``.

A ``Dict`` observation ``{"observation", "achieved_goal", "desired_goal"}`` and a vectorised
:meth:`GoalReorientEnv.compute_reward`, as SB3's ``HerReplayBuffer`` and Gymnasium-Robotics'
``GoalEnv`` expect. The episodes, physics, termination and success are
``rbenv/SatelliteReorient-v1``'s; the reward is v1's (:mod:`rbenv.tasks.v1`) written as a
function of the goals, and the env's own reward *is* ``compute_reward`` of what it returns, so
the two agree exactly, also for goals that HER substitutes.

* ``observation`` (12): the attitude as two columns of R(q) (body → world) and the rate
  features of v1 (``ω_B/L`` clipped, ``ω_B/(ω_s + |ω|)``): nothing about the goal.
* ``desired_goal`` (6): the target attitude, two columns of R(q_target).
* ``achieved_goal`` (6): the attitude now, two columns of R(q), as the desired goal (HER
  substitutes achieved goals for desired ones, so both have one space).
* ``info["goal_history"]`` (6·(n − 1) + K): the attitude at the n − 1 steps before (n =
  max(K, 2), K the hold steps; before the episode start, the start attitude), then K flags
  (1.0: |ω| below the success rate after that step, now first; 0.0 before the start). A goal
  is reached when the error to it stayed below the success angle with the flag set for the
  last K steps, which is the task's hold.

``compute_reward(achieved, desired, info)`` (with SB3's ``HerReplayBuffer`` pass
``copy_info_dict=True``, so that it gets the infos): error ``−w·ψ(θ₀)``, progress
``w·(ψ(θ₁) − ψ(θ₀))``, success ``+w`` when the hold is complete, plus the goal-free terms
that ``info`` carries (``reward_rate``, ``reward_fuel``, ``reward_failure``); θ_k is the angle
from attitude k to the desired goal.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import gymnasium as gym
import numpy as np

from rbenv.core.backend import FLOAT
from rbenv.envs.env import SatelliteReorientV1Env
from rbenv.envs.options import take
from rbenv.satellite.draws import check_seed
from rbenv.tasks import reorient, v1

GOAL_ID = "rbenv/SatelliteReorientGoal-v1"
# Its registry entry: Reorient-v1's task under the goal id (rbenv/__init__.py registers it with
# GoalReorientEnv, rbenv.envs.registry.register: another form of that task, not a task of its own).
SPEC = dataclasses.replace(reorient.SPEC_V1, env_id=GOAL_ID, env_doc=__doc__)
GOAL_FREE = ("reward_rate", "reward_fuel", "reward_failure")  # terms no goal changes


def _columns(q: np.ndarray) -> np.ndarray:
    """rot6 (..., 6) of quaternions (..., 4): the first two columns of R(q)."""
    return np.stack(v1.rot6(tuple(np.moveaxis(np.asarray(q, dtype=float), -1, 0))), axis=-1)


def _angle(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between attitudes given as rot6 (..., 6): from M = R_dᵀR_a,
    ``atan2(|vee(M − Mᵀ)|/2, (tr M − 1)/2)``, accurate near 0 and π."""
    ra, rd = v1.matrix_from_rot6(a), v1.matrix_from_rot6(d)  # (float64 arrays of a and d)
    m = np.einsum("...ki,...kj->...ij", rd, ra)
    x = m[..., 2, 1] - m[..., 1, 2]
    y = m[..., 0, 2] - m[..., 2, 0]
    z = m[..., 1, 0] - m[..., 0, 1]
    s = 0.5 * np.sqrt(x * x + y * y + z * z)
    c = 0.5 * (m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2] - 1.0)
    return np.arctan2(s, c)


class GoalReorientEnv(gym.Env):
    """Goal-conditioned ``rbenv/SatelliteReorient-v1`` (see the module docstring), made by
    ``gym.make(GOAL_ID, **options)``.

    Its options are the v1 env's (:data:`rbenv.envs.options.OPTIONS_OF` ``["goal"]``: the env
    options and ``render_mode``), checked by :func:`rbenv.envs.options.take` as every shell's;
    ``self.env`` is the v1 env they make, which this env renders. It is built from its class,
    not through ``gym.make``: the registry would call v1 out of date (Reorient-v2 exists) on
    every goal env made, though the goal form is v1's on purpose."""

    metadata: ClassVar[dict] = {"render_modes": ["human", "rgb_array"], "render_fps": 2}

    def __init__(self, scene=None, **options):
        env = SatelliteReorientV1Env(**take(type(self).__name__, "goal",
                                            {"scene": scene, **options}))
        task = env.task
        self.env, self.task = env, task
        self.render_mode = env.render_mode
        self.metadata = {**type(self).metadata, "render_fps": env.metadata["render_fps"]}
        self.hold = task.hold_steps
        self.n = max(self.hold, 2)
        self.action_space = env.action_space
        self.observation_space = gym.spaces.Dict({
            "observation": _box(12), "achieved_goal": _box(6), "desired_goal": _box(6)})
        self._attitudes = self._flags = self._desired = None

    def reset(self, *, seed=None, options=None):
        super().reset(seed=None if seed is None else check_seed(seed))
        _, info = self.env.reset(seed=seed, options=options)
        st = self.env._st
        self._attitudes = np.repeat(_columns(np.array(st.q))[None], self.n, axis=0)
        self._flags = np.zeros(self.hold)
        self._desired = _columns(np.array(self.task.target(st))).astype(np.float32)
        return self._obs(), self._info(info)

    def step(self, action):
        _, _, terminated, truncated, info = self.env.step(action)
        st = self.env._st
        self._attitudes = np.roll(self._attitudes, 1, axis=0)
        self._attitudes[0] = _columns(np.array(st.q))
        self._flags = np.roll(self._flags, 1)
        self._flags[0] = float(st.rate < self.task.success_rate)
        obs, info = self._obs(), self._info(info)
        reward = float(self.compute_reward(obs["achieved_goal"], obs["desired_goal"], info))
        return obs, reward, terminated, truncated, info

    def _obs(self) -> dict:
        st = self.env._st
        rate = v1.rate_features(st.omega_B, self.task.inv_rate_limit, self.task.success_rate,
                                FLOAT)
        return {"observation": np.array((*self._attitudes[0], *rate), np.float32),
                "achieved_goal": self._attitudes[0].astype(np.float32),
                "desired_goal": self._desired.copy()}

    def _info(self, info: dict) -> dict:
        info["goal_history"] = np.concatenate([self._attitudes[1:].ravel(), self._flags]
                                              ).astype(np.float32)
        return info

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """v1's reward for goals (N, ·) or (·,) and infos (a dict or a sequence of N): the
        goal terms from :func:`rbenv.tasks.v1.terms`, plus the goal-free terms of ``info``."""
        single, infos, theta, reached = self._goal_angles(achieved_goal, desired_goal, info)
        task = self.task
        zero = 0.0 * theta[:, 0]
        goal = v1.terms(task.weights,
                        v1.log_scale_drop(theta[:, 1], theta[:, 0], task.success_angle,
                                          math.pi, np),
                        v1.log_scale(theta[:, 0], task.success_angle, math.pi, np),
                        zero, zero, reached, zero > 0)
        reward = sum(goal[1:], goal[0])
        for key in GOAL_FREE:
            reward = reward + _info_values(infos, key)
        return reward[0] if single else reward

    def goal_reached(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Whether the hold on each desired goal is complete (the task's success, which ends
        the episode, for that goal), in :meth:`compute_reward`'s shapes: what a replay buffer
        needs to end relabelled episodes where the task would."""
        single, _, _, reached = self._goal_angles(achieved_goal, desired_goal, info)
        return reached[0] if single else reached

    def _goal_angles(self, achieved_goal, desired_goal, info) -> tuple:
        """(single, infos, θ (N, n): angle of attitude k back to the goal, reached (N,))."""
        achieved = np.asarray(achieved_goal, dtype=float)
        single = achieved.ndim == 1
        achieved = np.atleast_2d(achieved)
        desired = np.atleast_2d(np.asarray(desired_goal, dtype=float))
        infos = [info] if isinstance(info, dict) else list(info)
        n = len(achieved)
        history = _info_values(infos, "goal_history")  # (N, 6·(n − 1) + K)
        att = np.concatenate([achieved[:, None, :],
                              history[:, :6 * (self.n - 1)].reshape(n, self.n - 1, 6)], axis=1)
        theta = _angle(att, desired[:, None, :])  # (N, n): angle of attitude k to the goal
        inside = (theta[:, :self.hold] < self.task.success_angle) & \
            (history[:, 6 * (self.n - 1):] > 0.5)
        return single, infos, theta, np.all(inside, axis=1)

    def render(self):
        """The inner env's frame (``rgb_array``: (H, W, 3) uint8), drawn to its window
        (``human``), or None (no render_mode, with Gymnasium's warning)."""
        return self.env.render()

    def close(self):
        self.env.close()


def _info_values(infos: list, key: str) -> np.ndarray:
    """``info[key]`` of every info, as an (N,) or (N, m) float array."""
    try:
        return np.array([np.asarray(i[key], dtype=float) for i in infos])
    except KeyError:
        raise ValueError(
            f"compute_reward needs the step's info[{key!r}] (the goal-free reward terms "
            f"{list(GOAL_FREE)} and goal_history), got info with keys "
            f"{sorted(infos[0]) if infos else []}; "
            "with SB3's HerReplayBuffer pass replay_buffer_kwargs={'copy_info_dict': True}"
        ) from None


def _box(n: int) -> gym.spaces.Box:
    return gym.spaces.Box(-1.0, 1.0, (n,), np.float32)
