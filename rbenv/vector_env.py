"""Native NumPy vector envs: N satellites stepped by the same transition as the single env.

:class:`AttitudeVectorEnv` is the thin ``gymnasium.vector.VectorEnv`` adapter over
:mod:`rbenv.transition` with (N,) arrays; each registered id has a subclass naming its task, set
as the id's ``vector_entry_point``.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from rbenv import transition
from rbenv.adapter import TaskAdapter, action_array, backend_twin
from rbenv.core import validation
from rbenv.core.backend import NUMPY
from rbenv.core.errors import InvalidParameterError
from rbenv.draws import EpisodeDraws, check_seed
from rbenv.env import unknown_options
from rbenv.options import ENV_OPTIONS
from rbenv.state import State, assign, from_start

_MODES = {mode.value: mode for mode in AutoresetMode}


def _autoreset_mode(value) -> AutoresetMode:
    mode = value if isinstance(value, AutoresetMode) else _MODES.get(value)
    if mode is None:
        raise InvalidParameterError(
            f"autoreset_mode must be an AutoresetMode (NEXT_STEP, SAME_STEP or DISABLED) or one "
            f"of their values {sorted(_MODES)}, got {value!r}")
    return mode


class AttitudeVectorEnv(TaskAdapter, VectorEnv):
    """``num_envs`` copies of a single :class:`rbenv.env.AttitudeEnv` as one NumPy batch.

    Made by ``gym.make_vec(ENV_ID, num_envs=N, **kwargs)`` with the single env's kwargs plus
    ``max_episode_steps`` (``make_vec`` passes the registered value; the scene's duration also
    applies, whichever is shorter), ``autoreset_mode``, and ``compiled`` (True: step with the
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
    seed ``s + i``, episode by episode (:mod:`rbenv.draws`), so scripted and learned policies
    meet identical episodes. ``np_random_seed`` is the tuple of the sub-envs' seeds. Per-step
    randomness (sensor and disturbance noise, mid-episode faults) is drawn for the whole batch
    from ``self.np_random``: with those models on, sub-envs are reproducible but their noise is
    not the single env's.

    **Info**: a dict of (N,) arrays with a ``_key`` mask each, keys as the single env.
    **Reset options**: as the single env with a leading num_envs axis, row i for sub-env i.
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 2,
                                "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __new__(cls, *args, backend="numpy", **kwargs):
        """``backend="torch"`` makes the torch-native env instead (:mod:`rbenv.torch_env`,
        needs torch); "numpy" (default) this one."""
        twin = backend_twin(cls, backend)
        return super().__new__(cls) if twin is None else twin(*args, **kwargs)

    def __init__(self, num_envs: int = 1, scene=None, *, integrator=None, control_dt=None,
                 substeps=None, action_mode="throttle", reward_weights=None,
                 max_initial_angle_deg=None, max_initial_rate=None, allocator="pinv",
                 randomize=None, task_options=None, max_episode_steps=None,
                 autoreset_mode=AutoresetMode.NEXT_STEP, render_mode=None, compiled=False,
                 backend="numpy", **unknown):
        if unknown:
            unknown_options(type(self).__name__, unknown,
                            (*ENV_OPTIONS, "num_envs", "max_episode_steps", "autoreset_mode",
                             "render_mode", "backend"))
        options = {name: value for name, value in locals().items() if name in ENV_OPTIONS}
        self.num_envs = validation.count("num_envs", num_envs, low=1, high=2**24)
        self.single_action_space, self.single_observation_space = self._setup(
            options, render_mode, ("rgb_array",))
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode,
                         "render_fps": 1.0 / self.plant.control_dt}
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._max_steps = self._episode_steps(max_episode_steps)
        self._seeds: np.ndarray | None = None
        self._episodes = np.zeros(self.num_envs, dtype=np.uint64)
        self._st = None
        self._obs = None
        self._prev_done = np.zeros(self.num_envs, dtype=bool)
        self._mask = np.ones(self.num_envs, dtype=bool)
        self._mask.setflags(write=False)
        self._renderer = None

    @property
    def np_random_seed(self) -> tuple:
        """The seed of each sub-env's episode starts (as ``SyncVectorEnv``: one per sub-env)."""
        return () if self._seeds is None else tuple(int(s) for s in self._seeds)

    # ------------------------------------------------------------------- reset

    def reset(self, *, seed=None, options=None):
        """Reset sub-envs: all, or those of ``options["reset_mask"]`` (an (N,) bool array).

        seed: an int (sub-env i gets s + i), a list of N ints, or None.
        """
        n = self.num_envs
        options = dict(options or {})
        mask = self._reset_mask(options.pop("reset_mask", None))
        seeds = self._seed_list(seed)
        super().reset(seed=None if seeds is None else int(seeds[0]))
        if seeds is not None:
            self._seeds = np.array(seeds, dtype=np.uint64) if self._seeds is None or mask.all() \
                else np.where(mask, np.array(seeds, dtype=np.uint64), self._seeds)
            self._episodes[mask] = 0
        elif self._seeds is None:
            base = int(self.np_random.integers(2**62))
            self._seeds = np.arange(base, base + n, dtype=np.uint64)
        idx = np.flatnonzero(mask)
        start = self._start(idx, options)
        if self._st is None or mask.all():
            self._st = from_start(self._layout, start, single=False)
        else:
            assign(self._st, self._layout, idx, start)
        self._prev_done[idx] = False
        terms = transition.zero_terms(self.task, np.zeros(n))
        obs = self._observation()
        info = self._info(terms, np.zeros(n, dtype=bool))
        if self._obs is not None and not mask.all():  # a partial reset (DISABLED mode)
            obs = np.where(mask[:, None], obs, self._obs)
            info.update({key: mask for key in info if key.startswith("_")})
        self._obs = obs
        return obs, info

    def _seed_list(self, seed):
        if seed is None:
            return None
        if isinstance(seed, (list, tuple, np.ndarray)):
            if len(seed) != self.num_envs:
                raise InvalidParameterError(
                    f"seed list must have num_envs = {self.num_envs} entries, got {len(seed)}")
            return [check_seed(s, f"seed[{i}]") for i, s in enumerate(seed)]
        s = check_seed(seed)
        return [s + i for i in range(self.num_envs)]

    def _reset_mask(self, mask) -> np.ndarray:
        """The (N,) bool mask of ``options["reset_mask"]``, checked in Gymnasium's order and
        with its exception types (``SyncVectorEnv.reset``): not a NumPy array or not bool ->
        TypeError; wrong shape or all False -> ValueError. Remembers a partial mask for the
        reset's :meth:`_info`, which zeroes the other rows as ``SyncVectorEnv`` does."""
        self._info_rows = None
        if mask is None:
            return np.ones(self.num_envs, dtype=bool)
        rule = f"options['reset_mask'] must be a NumPy bool array of shape ({self.num_envs},)"
        if not isinstance(mask, np.ndarray):
            raise TypeError(f"{rule} with at least one True, got {validation.show(mask)} of "
                            f"type {type(mask).__name__}")
        if mask.shape != (self.num_envs,):
            raise InvalidParameterError(f"{rule}, got shape {mask.shape}")
        if mask.dtype != np.bool_:
            raise TypeError(f"{rule}, got dtype {mask.dtype}")
        if not mask.any():
            raise InvalidParameterError(f"options['reset_mask'] must contain at least one True "
                                        f"(a sub-env to reset), got {mask.tolist()}")
        if self._st is None and not mask.all():
            raise gym.error.ResetNeeded("the first reset must reset every sub-env (no mask)")
        self._info_rows = None if mask.all() else mask.copy()
        return mask.copy()

    def _start(self, idx: np.ndarray, options=None) -> dict:
        """Start values for sub-envs ``idx`` from their counter-based draws."""
        draws = EpisodeDraws(self._seeds[idx], self._episodes[idx],
                             block_slots=self._block_slots)
        self._episodes[idx] += np.uint64(1)
        return transition.start(self.plant, self.task, draws, options, rows=idx,
                                num_envs=self.num_envs)

    # ------------------------------------------------------------------- step

    def step(self, actions):
        """Step all sub-envs. actions: (N, n) (torque mode (N, 3)). Returns batched results."""
        st = self._st
        if st is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        a = self._actions(actions)
        if self.autoreset_mode is AutoresetMode.DISABLED and self._prev_done.any():
            raise gym.error.ResetNeeded(
                f"sub-envs {np.flatnonzero(self._prev_done).tolist()} have ended; with "
                "autoreset_mode DISABLED reset them with reset(options={'reset_mask': mask}) "
                "before the next step")
        st, out = transition.step(self.plant, self.task, st, a,
                                  self.plant.draw_step_noise(self.np_random, self.num_envs),
                                  NUMPY, own_action=True)
        if out.diverged.any():
            transition.raise_diverged(self.plant, st, a)
        self._st = st
        terms, reward, success = out.terms, out.reward, out.success
        terminated = out.failure | (success & self.task.success_terminates)
        truncated = st.steps >= self._max_steps
        obs, extra = self._stack(out.obs), {}
        flags = (reward, success, terminated, truncated)
        mode = self.autoreset_mode
        if mode is AutoresetMode.NEXT_STEP:
            if self._prev_done.any():
                self._restart(np.flatnonzero(self._prev_done), obs, terms, flags)
            self._prev_done = terminated | truncated
        elif mode is AutoresetMode.DISABLED:
            self._prev_done = terminated | truncated
        elif mode is AutoresetMode.SAME_STEP:
            done = terminated | truncated
            if done.any():
                extra = self._final(done, obs, self._info(terms, success))
                self._restart(np.flatnonzero(done), obs, terms, (success,))
        info = self._info(terms, success)
        info.update(extra)
        self._obs = obs
        return obs, reward, terminated, truncated, info

    def _restart(self, idx: np.ndarray, obs: np.ndarray, terms, flags) -> None:
        """Autoreset sub-envs ``idx``: new episodes, their observations written into ``obs``,
        and their rows of ``terms`` and ``flags`` (this step's fresh arrays) zeroed in place."""
        start = self._start(idx)
        assign(self._st, self._layout, idx, start)
        view = State()
        view.__dict__.update(start)  # the new episodes alone, as a state of len(idx)
        noise = self.plant.draw_sensor_noise(self.np_random, len(idx))
        obs[idx] = self._stack(transition.observe(self.plant, self.task, view, noise, NUMPY),
                               len(idx))
        for arr in (*terms, *flags):
            arr[idx] = 0

    def _actions(self, actions) -> np.ndarray:
        """Actions as float64 (N, k); TypeError for a non-array or non-real values (None,
        strings, complex), a ValueError subclass for a bad shape; each names the shape."""
        self._info_rows = None  # a step's info covers every sub-env
        if np.isscalar(actions) or actions is None:
            raise TypeError(f"actions must be an array of shape {self.action_space.shape} (one "
                            f"row per sub-env), got {type(actions).__name__} {actions!r}")
        return action_array(actions, self.action_space.shape, copy=True,  # clipped in place
                            name="actions")

    def _final(self, done, obs, info) -> dict:
        """SAME_STEP: the finished sub-envs' last observation and info, masked by ``done``."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = obs[i].copy()
        final_info = {}
        for key, value in info.items():
            if not key.startswith("_"):
                final_info[key] = np.where(done, value, np.zeros_like(value))
                final_info["_" + key] = done.copy()
        return {"final_obs": final_obs, "_final_obs": done.copy(), "final_info": final_info,
                "_final_info": done.copy()}

    def _stack(self, comps: tuple, rows: int | None = None) -> np.ndarray:
        obs = np.empty((rows or self.num_envs, len(comps)), dtype=np.float32)
        for j, c in enumerate(comps):
            obs[:, j] = c
        return obs

    def _observation(self) -> np.ndarray:
        noise = self.plant.draw_sensor_noise(self.np_random, self.num_envs)
        return self._stack(transition.observe(self.plant, self.task, self._st, noise, NUMPY))

    def _info(self, terms, success) -> dict:
        """Info of every sub-env, or, in a partial reset (the mask :meth:`_reset_mask` kept),
        of the reset ones only: the other rows hold zeros and ``_key`` is False there, as
        ``SyncVectorEnv`` builds it from the sub-envs it reset."""
        rows = getattr(self, "_info_rows", None)
        self._info_rows = None
        values = transition.info(self.plant, self.task, self._st, terms, success, NUMPY)
        out, mask = {}, self._mask if rows is None else rows
        owned = _array_ids(self._st)
        for key, value in values.items():
            if np.ndim(value) == 0:
                value = np.array(np.broadcast_to(value, mask.shape))
            elif id(value) in owned:  # the state's own array, which a later autoreset
                value = value.copy()  # overwrites in place (SyncVectorEnv's info never changes)
            out[key] = value if rows is None else np.where(rows, value, np.zeros_like(value))
            out["_" + key] = mask
        return out

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


def vector_env_class(spec) -> type:
    """The vector-env class of a registry entry (:mod:`rbenv.registry`), e.g.
    ``SatelliteReorientVectorEnv``: :class:`AttitudeVectorEnv` naming the entry's task. It is
    made once per entry and kept in this module, so it pickles by reference."""
    name = spec.class_stem + "VectorEnv"
    cls = globals().get(name)
    if cls is None or cls.task_name != spec.name:
        doc = (f"Vector form of :class:`rbenv.{spec.class_stem}Env` (see "
               ":class:`AttitudeVectorEnv`).")
        cls = type(name, (AttitudeVectorEnv,), {"task_name": spec.name, "__doc__": doc,
                                                "__module__": __name__, "__qualname__": name})
        globals()[name] = cls
    return cls


def _array_ids(st) -> set:
    """The ids of the arrays that ``st`` holds (fields, and the components of vector fields)."""
    ids = set()
    for value in vars(st).values():
        if isinstance(value, tuple):
            ids.update(map(id, value))
        else:
            ids.add(id(value))
    return ids
