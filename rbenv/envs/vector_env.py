"""Native NumPy vector envs: N satellites stepped by the same transition as the single env.

:class:`AttitudeVectorEnv` is the thin ``gymnasium.vector.VectorEnv`` adapter over
:mod:`rbenv.envs.transition` with (N,) arrays; each shipped id has a subclass naming its task entry,
set as the id's ``vector_entry_point``.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from gymnasium.vector.utils import batch_space

from rbenv.core import validation
from rbenv.core.backend import NUMPY
from rbenv.envs import transition
from rbenv.envs.adapter import action_array, autoreset_mode_of
from rbenv.envs.options import AUTORESET_DEFAULT, take
from rbenv.envs.vector import Step, VectorContract
from rbenv.satellite.draws import EpisodeDraws
from rbenv.satellite.state import State, assign, from_start
from rbenv.tasks import desaturate, detumble, reorient, track


class AttitudeVectorEnv(VectorContract):
    """``num_envs`` copies of a single :class:`rbenv.envs.env.AttitudeEnv` as one NumPy batch.

    Made by ``gym.make_vec(ENV_ID, num_envs=N, **kwargs)`` with the single env's kwargs plus
    ``max_episode_steps`` (``make_vec`` passes the registered value; the scene's duration also
    applies, whichever is shorter), ``autoreset_mode`` (unset: NEXT_STEP,
    :data:`rbenv.envs.options.AUTORESET_DEFAULT`), and ``compiled`` (True: step with the
    numba-compiled kernels of :mod:`rbenv.core.compiled`, from the extra ``rbenv[fast]``; the first
    step pays a few seconds of compilation).

    **Autoreset** (``self.autoreset_mode``, also in ``metadata``). NEXT_STEP (default): a
    sub-env that ended is reset by the following ``step``; its action is ignored, its reward is
    0, its flags are False and its info is the reset info. SAME_STEP: the ending step returns
    the reset observation and info; the last ones are in ``info["final_obs"]`` and
    ``info["final_info"]`` (masked by ``info["_final_obs"]``, ``info["_final_info"]``), as
    ``SyncVectorEnv``. DISABLED: nothing resets by itself; call
    ``reset(options={"reset_mask": mask})`` to reset the sub-envs where ``mask`` is True.

    **Seeding**. ``reset(seed=s)`` seeds sub-env ``i`` with ``s + i`` (or takes a list of N
    seeds); every episode start of sub-env ``i`` then equals that of a single env reset with
    seed ``s + i``, episode by episode (:mod:`rbenv.satellite.draws`), so scripted and learned
    policies meet identical episodes. ``np_random_seed`` is the tuple of the sub-envs' seeds.
    Per-step randomness (sensor and disturbance noise, mid-episode faults) is drawn for the whole
    batch from ``self.np_random``: with those models on, sub-envs are reproducible but their noise
    is not the single env's.

    **Info**: a dict of (N,) arrays with a ``_key`` mask each, keys as the single env.
    **Reset options**: as the single env with a leading num_envs axis, row i for sub-env i.
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 2,
                                "autoreset_mode": AUTORESET_DEFAULT}
    mask_kind: ClassVar[str] = "a NumPy bool array"

    def __init__(self, num_envs: int = 1, scene=None, **options):
        """Options: :data:`rbenv.envs.options.OPTIONS_OF` ``["numpy"]`` (see the class doc)."""
        o = take(type(self).__name__, "numpy", {"num_envs": num_envs, "scene": scene, **options})
        self.num_envs = validation.count("num_envs", num_envs, low=1, high=2**24)
        self.single_action_space, self.single_observation_space = self._setup(
            o, ("rgb_array",))
        self._estimation = None  # the MEKF in the loop, for scenes with [estimator]
        if self.plant.scene.estimator is not None:
            from rbenv.envs.estimated import EstimatorLoop

            self._estimation = EstimatorLoop(self.plant, self.task, single=False)
        self.autoreset_mode = autoreset_mode_of(o["autoreset_mode"])
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode,
                         "render_fps": 1.0 / self.plant.control_dt}
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._max_steps = self._episode_steps(o["max_episode_steps"])
        self._seeds: np.ndarray | None = None
        self._episodes = np.zeros(self.num_envs, dtype=np.uint64)
        self._st = None
        self._obs = None
        self._done = np.zeros(self.num_envs, dtype=bool)
        self._mask = np.ones(self.num_envs, dtype=bool)
        self._mask.setflags(write=False)
        self._renderer = None

    @property
    def np_random_seed(self) -> tuple:
        """The seed of each sub-env's episode starts (as ``SyncVectorEnv``: one per sub-env)."""
        return () if self._seeds is None else tuple(int(s) for s in self._seeds)

    # ------------------------------------------------------------------- NumPy rows

    def _seed_array(self, seeds) -> np.ndarray:
        return np.array(seeds, dtype=np.uint64)

    @staticmethod
    def _where(mask, a, b) -> np.ndarray:
        return np.where(mask, a, b).astype(b.dtype, copy=False)

    @staticmethod
    def _keep(mask, value) -> np.ndarray:
        return np.where(_rowwise(mask, value), value, np.zeros_like(value))

    @staticmethod
    def _any(mask) -> bool:
        return bool(mask.any())

    @staticmethod
    def _all(mask) -> bool:
        return bool(mask.all())

    @staticmethod
    def _mask_array(mask):
        return mask.copy() if isinstance(mask, np.ndarray) else None

    @staticmethod
    def _is_bool(array) -> bool:
        return array.dtype == np.bool_

    def _owner(self):
        """Scalars broadcast to (N,); a state array copied (a later autoreset writes the
        state in place, and SyncVectorEnv's info never changes)."""
        owned, shape = _array_ids(self._st), self._mask.shape

        def own(value):
            if np.ndim(value) == 0:
                return np.array(np.broadcast_to(value, shape))
            return value.copy() if id(value) in owned else value

        return own

    @staticmethod
    def _rows(mask) -> list[int]:
        return np.flatnonzero(mask).tolist()

    # ------------------------------------------------------------------- reset

    def _reset_rows(self, mask: np.ndarray, options: dict) -> tuple:
        n = self.num_envs
        idx = np.flatnonzero(mask)
        start = self._start(idx, options)
        if self._st is None or mask.all():
            self._st = from_start(self._layout, start, single=False)
        else:
            assign(self._st, self._layout, idx, start)
        terms = transition.zero_terms(self.task, np.zeros(n))
        obs = self._observation()
        est = self._estimation
        if est is not None:
            full = est.filter is None or mask.all()
            est.reset(self._st, (int(self._seeds[0]), int(self._episodes[0]), n, 41),
                      rows=None if full else idx)
            obs = est.observe(self._st, NUMPY)
        values = transition.info(self.plant, self.task, self._st, terms,
                                 np.zeros(n, dtype=bool), NUMPY)
        if est is not None:
            values = est.add_info(self._st, values)
        if self._obs is not None and not mask.all():  # a partial reset: the others keep theirs
            obs = np.where(mask[:, None], obs, self._obs)
        self._obs = obs
        return obs, values

    def _start(self, idx: np.ndarray, options=None) -> dict:
        """Start values for sub-envs ``idx`` from their counter-based draws."""
        draws = EpisodeDraws(self._seeds[idx], self._episodes[idx],
                             block_slots=self._block_slots)
        self._episodes[idx] += np.uint64(1)
        return transition.start(self.plant, self.task, draws, options, rows=idx,
                                num_envs=self.num_envs)

    # ------------------------------------------------------------------- step

    def _advance(self, a: np.ndarray) -> Step:
        st, out = transition.step(self.plant, self.task, self._st, a,
                                  self.plant.draw_step_noise(self.np_random, self.num_envs),
                                  NUMPY, own_action=True, max_steps=self._max_steps,
                                  observe_truth=self._estimation is None)
        if out.diverged.any():
            transition.raise_diverged(self.plant, st, a)
        self._st = st  # an autoreset writes its rows in place
        est = self._estimation
        if est is not None:
            est.step(st)
            return Step(st, est.observe(st, NUMPY), out.reward, out.terminated, out.truncated,
                        out.terms, out.success, self._info_of(est.add_info(st, out.info)))
        return Step(st, self._stack(out.obs), out.reward, out.terminated, out.truncated,
                    out.terms, out.success, self._info_of(out.info))  # the autoreset writes it

    def _restart(self, rows: np.ndarray, s: Step, *, ended_before: bool) -> None:
        if rows.any():
            flags = (s.reward, s.success, s.terminated, s.truncated) if ended_before \
                else (s.success,)
            self._restart_rows(np.flatnonzero(rows), s.obs, s.info, s.terms, flags)

    def _finish(self, s: Step) -> None:
        self._obs = s.obs

    def _restart_rows(self, idx: np.ndarray, obs: np.ndarray, info: dict, terms,
                      flags) -> None:
        """Autoreset sub-envs ``idx``: new episodes, their observations written into ``obs``
        and their reset info into the rows of ``info``, and their rows of ``terms`` and
        ``flags`` (this step's fresh arrays) zeroed in place."""
        start = self._start(idx)
        assign(self._st, self._layout, idx, start)
        view = State()  # the new episodes alone, as a state of len(idx)
        view.__dict__.update({name: start.get(name) for name in self._layout.kinds}, **start)
        noise = self.plant.draw_sensor_noise(self.np_random, len(idx))
        fresh_obs = self._stack(transition.observe(self.plant, self.task, view, noise, NUMPY),
                                len(idx))
        if self._estimation is None:  # else the estimate's, below
            obs[idx] = fresh_obs
        for arr in (*terms, *flags):
            arr[idx] = 0
        k = len(idx)
        fresh = transition.info(self.plant, self.task, view,
                                transition.zero_terms(self.task, np.zeros(k)),
                                np.zeros(k, dtype=bool), NUMPY)
        for key, value in fresh.items():
            info[key][idx] = value
        est = self._estimation
        if est is not None:
            est.reset(self._st, None, rows=idx)
            obs[idx] = est.observe(self._st, NUMPY)[idx]
            for key, value in est.add_info(self._st, {}).items():
                info[key][idx] = value[idx]

    def _actions(self, actions) -> np.ndarray:
        """Actions as float64 (N, k); TypeError for a non-array or non-real values (None,
        strings, complex), a ValueError subclass for a bad shape; each names the shape."""
        if np.isscalar(actions) or actions is None:
            raise TypeError(f"actions must be an array of shape {self.action_space.shape} (one "
                            f"row per sub-env), got {type(actions).__name__} {actions!r}")
        return action_array(actions, self.action_space.shape, copy=True,  # clipped in place
                            name="actions")

    def _final_obs(self, done, obs) -> np.ndarray:
        """An (N,) object array as ``SyncVectorEnv``'s: the ended rows' last observation, None
        in the others."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = obs[i].copy()
        return final_obs

    def _stack(self, comps: tuple, rows: int | None = None) -> np.ndarray:
        obs = np.empty((rows or self.num_envs, len(comps)), dtype=np.float32)
        for j, c in enumerate(comps):
            obs[:, j] = c
        return obs

    def _observation(self) -> np.ndarray:
        noise = self.plant.draw_sensor_noise(self.np_random, self.num_envs)
        return self._stack(transition.observe(self.plant, self.task, self._st, noise, NUMPY))

    # ------------------------------------------------------------------- rendering

    def render(self):
        """``rgb_array``: a tuple of N frames (H, W, 3) uint8 (one renderer for all)."""
        if self._ready_renderer() is None:
            return None
        return tuple(self._frame(i) for i in range(self.num_envs))

    def close_extras(self, **kwargs):
        """Release the renderer, if any (also after a failed __init__, via __del__)."""
        if getattr(self, "_renderer", None) is not None:
            self._renderer.close()
            self._renderer = None


def _rowwise(mask: np.ndarray, value) -> np.ndarray:
    """The (N,) ``mask`` shaped to select rows of ``value`` ((N,) or (N, ...): the estimator's
    vectors and covariances)."""
    return mask.reshape(mask.shape + (1,) * (np.ndim(value) - 1))


def vector_doc(spec) -> str:
    """The docstring of the vector-env class of ``spec``'s id: a pointer to its single env's."""
    return (f"Vector form of :class:`rbenv.{spec.class_stem}Env` "
            f"(see :class:`AttitudeVectorEnv`).")


# One class per shipped id: its task entry and its documentation. rbenv/__init__.py names each
# where it registers the id (rbenv.envs.registry.register).
class SatelliteReorientVectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(reorient.SPEC)
    task_spec = reorient.SPEC


class SatelliteDetumbleVectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(detumble.SPEC)
    task_spec = detumble.SPEC


class SatelliteTrackVectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(track.SPEC)
    task_spec = track.SPEC


class SatelliteDesaturateVectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(desaturate.SPEC)
    task_spec = desaturate.SPEC


class SatelliteReorientV1VectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(reorient.SPEC_V1)
    task_spec = reorient.SPEC_V1


class SatelliteDetumbleV1VectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(detumble.SPEC_V1)
    task_spec = detumble.SPEC_V1


class SatelliteTrackV1VectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(track.SPEC_V1)
    task_spec = track.SPEC_V1


class SatelliteReorientV2VectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(reorient.SPEC_V2)
    task_spec = reorient.SPEC_V2


class SatelliteDesaturateV1VectorEnv(AttitudeVectorEnv):
    __doc__ = vector_doc(desaturate.SPEC_V1)
    task_spec = desaturate.SPEC_V1


def _array_ids(st) -> set:
    """The ids of the arrays that ``st`` holds (fields, and the components of vector fields)."""
    ids = set()
    for value in vars(st).values():
        if isinstance(value, tuple):
            ids.update(map(id, value))
        else:
            ids.add(id(value))
    return ids
