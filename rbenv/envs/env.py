"""Single-satellite Gymnasium envs: a thin adapter over :mod:`rbenv.envs.transition`.

One class, :class:`AttitudeEnv`, serves every task; each shipped id has a subclass that names
its task entry and carries its documentation (``SatelliteReorientEnv``,
``SatelliteDetumbleEnv``, ...); an id registered without one runs on :class:`AttitudeEnv`,
given its entry as ``task``. The state is held as Python floats, so a step
costs tens of nanoseconds per arithmetic operation and no NumPy call in the physics.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np

from rbenv.core.backend import FLOAT
from rbenv.envs import transition
from rbenv.envs.adapter import TaskAdapter, action_array
from rbenv.envs.options import take
from rbenv.satellite.draws import EpisodeDraws, check_seed
from rbenv.satellite.plant import NO_NOISE
from rbenv.satellite.state import from_start
from rbenv.tasks import desaturate, detumble, reorient, track

RENDER_MODES = ("human", "rgb_array")
_F32, _F64 = np.dtype(np.float32), np.dtype(np.float64)


class AttitudeEnv(TaskAdapter, gym.Env):
    """A satellite, its actuators and one task, as a Gymnasium env (see the subclasses)."""

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 2}

    def __init__(self, scene=None, **options):
        """Options: :data:`rbenv.envs.options.OPTIONS_OF` ``["single"]`` (the Arguments table)."""
        o = take(type(self).__name__, "single", {"scene": scene, **options})
        self.action_space, self.observation_space = self._setup(o, RENDER_MODES)
        self.metadata = {**type(self).metadata, "render_fps": 1.0 / self.plant.control_dt}
        self._max_steps = self.plant.scene.episode_steps
        self._seed_key: int | None = None
        self._episode = 0
        self._st = None
        self._diverged = False
        self._renderer = None
        self._estimation = None  # the MEKF in the loop, for scenes with [estimator]
        if self.plant.scene.estimator is not None:
            from rbenv.envs.estimated import EstimatorLoop

            self._estimation = EstimatorLoop(self.plant, self.task, single=True)

    # ------------------------------------------------------------------- Gymnasium API

    def reset(self, *, seed=None, options=None):
        """Start an episode; ``options`` replace parts of the sampled start (see the task)."""
        if seed is not None:
            seed = check_seed(seed)
        super().reset(seed=seed)
        if seed is not None:
            self._seed_key, self._episode = seed % 2**64, 0
        elif self._seed_key is None:
            self._seed_key = int(self.np_random.integers(2**63))
        draws = EpisodeDraws(self._seed_key, self._episode, single=True,
                             block_slots=self._block_slots)
        self._episode += 1
        start = transition.start(self.plant, self.task, draws, options)
        self._st = st = from_start(self._layout, start, single=True)
        self._diverged = False
        noise = self.plant.draw_sensor_noise(self._np_random, None)
        obs = np.array(transition.observe(self.plant, self.task, st, noise, FLOAT), np.float32)
        info = transition.info(self.plant, self.task, st, transition.zero_terms(self.task),
                               False, FLOAT)
        if self._estimation is not None:
            self._estimation.reset(st, (self._seed_key, self._episode, 41))
            obs = self._estimation.observe(st, FLOAT)
            info = self._estimation.add_info(st, info)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        """One control step: (obs, reward: float, terminated: bool, truncated: bool, info)."""
        st = self._st
        if st is None:
            raise gym.error.ResetNeeded(
                "the last step diverged (or raised for a NaN action): call reset() before step()"
                if self._diverged else "call reset() before step()")
        plant = self.plant
        dtype = action.dtype if type(action) is np.ndarray else None
        if (dtype is _F32 or dtype is _F64) and action.shape == plant.action_shape:
            a = action  # the common case, as it is: each actuator's command makes float64
        else:  # lists, other dtypes (strings, complex: refused), wrong shapes: named errors
            a = action_array(action, plant.action_shape)
        noise = plant.draw_step_noise(self._np_random, None) if plant.noisy else NO_NOISE
        st, out = transition.step(plant, self.task, st, a, noise, FLOAT, donate=True,
                                  max_steps=self._max_steps,
                                  observe_truth=self._estimation is None)
        if out.diverged:  # the step updated the state it was given: the episode is over
            self._st = None
            self._diverged = True
            transition.raise_diverged(plant, st, a)
        self._st = st
        if self.render_mode == "human":
            self.render()
        if self._estimation is not None:
            self._estimation.step(st)
            return (self._estimation.observe(st, FLOAT), out.reward, bool(out.terminated),
                    out.truncated, self._estimation.add_info(st, out.info))
        return (np.array(out.obs, dtype=np.float32), out.reward, bool(out.terminated),
                out.truncated, out.info)

    # ------------------------------------------------------------------- rendering

    def render(self):
        """``rgb_array``: an (H, W, 3) uint8 frame; ``human``: draw to a window, return None."""
        renderer = self._ready_renderer()
        if renderer is None:
            return None
        frame = self._frame()
        if self.render_mode == "human":
            renderer.show(frame)
            return None
        return frame

    def close(self):
        """Close the render window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


# One class per shipped id: its task entry and its documentation (the entry's). rbenv/__init__.py
# names each where it registers the id (rbenv.envs.registry.register).
class SatelliteReorientEnv(AttitudeEnv):
    __doc__ = reorient.SPEC.env_doc
    task_spec = reorient.SPEC


class SatelliteDetumbleEnv(AttitudeEnv):
    __doc__ = detumble.SPEC.env_doc
    task_spec = detumble.SPEC


class SatelliteTrackEnv(AttitudeEnv):
    __doc__ = track.SPEC.env_doc
    task_spec = track.SPEC


class SatelliteDesaturateEnv(AttitudeEnv):
    __doc__ = desaturate.SPEC.env_doc
    task_spec = desaturate.SPEC


class SatelliteReorientV1Env(AttitudeEnv):
    __doc__ = reorient.SPEC_V1.env_doc
    task_spec = reorient.SPEC_V1


class SatelliteDetumbleV1Env(AttitudeEnv):
    __doc__ = detumble.SPEC_V1.env_doc
    task_spec = detumble.SPEC_V1


class SatelliteTrackV1Env(AttitudeEnv):
    __doc__ = track.SPEC_V1.env_doc
    task_spec = track.SPEC_V1


class SatelliteReorientV2Env(AttitudeEnv):
    __doc__ = reorient.SPEC_V2.env_doc
    task_spec = reorient.SPEC_V2


class SatelliteDesaturateV1Env(AttitudeEnv):
    __doc__ = desaturate.SPEC_V1.env_doc
    task_spec = desaturate.SPEC_V1
