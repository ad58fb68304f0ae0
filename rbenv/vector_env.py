"""Native NumPy vector env: N satellites stepped together by the same task and physics code."""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from core.errors import InvalidParameterError
from rbenv import task
from rbenv.task import ARRAY_OPS, OBS_SIZE, State


def _autoreset_mode(value) -> AutoresetMode:
    try:
        mode = AutoresetMode(value)
    except ValueError:
        raise InvalidParameterError(
            f"autoreset_mode must be AutoresetMode.NEXT_STEP or SAME_STEP (or their values "
            f"'NextStep', 'SameStep'), got {value!r}"
        ) from None
    if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        raise InvalidParameterError(f"autoreset_mode {mode} is not supported; use NEXT_STEP or "
                                    "SAME_STEP")
    return mode


class SatelliteReorientVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`rbenv.SatelliteReorientEnv` as one NumPy batch.

    Made by ``gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=N, **kwargs)`` with the same
    kwargs as the single env, plus ``max_episode_steps`` (``make_vec`` passes the registered
    value; the scene's own duration also applies, whichever is shorter) and
    ``autoreset_mode`` (``AutoresetMode.NEXT_STEP``, the default, or ``SAME_STEP``; stored in
    ``metadata["autoreset_mode"]`` of this instance). Observations, actions, rewards and
    termination are those of the single env: both call :mod:`rbenv.task` and the
    ``core.integrators`` kernels, here on (N,) arrays.

    Autoreset. NEXT_STEP: a sub-env that ended is reset by the following ``step``; its
    action is ignored, its reward is 0 and its flags are False, and its info is the reset
    info. SAME_STEP: the ending step returns the reset observation and reset info for that
    sub-env; its last observation is in ``info["final_obs"]`` (object array, masked by
    ``info["_final_obs"]``) and its last info in ``info["final_info"]`` (a dict of arrays with
    ``_key`` masks, masked by ``info["_final_info"]``), as ``gymnasium.vector.SyncVectorEnv``.

    Seeding. ``reset(seed=s)`` gives sub-env ``i`` its own generator seeded ``s + i`` (an int
    seed; or a list of N seeds), Gymnasium's convention for vector envs; all of a sub-env's
    episode starts come from it, in the order the single env draws them, so sub-env ``i``
    starts every episode exactly like ``SatelliteReorientEnv`` reset with seed ``s + i``.
    Per-step randomness (disturbance noise, sensor noise, mid-episode faults) is drawn for the
    whole batch from ``self.np_random`` (seeded with ``s``): with those models on, sub-envs are
    reproducible but no longer equal to single envs.

    Info: dict of (N,) arrays with a ``_key`` mask each (all True), keys as the single env.
    Reset options: ``{"q": (N, 4), "omega_B": (N, 3), "q_target": (N, 4)}`` as in the single
    env, row i for sub-env i.
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 2,
                "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, scene=None, *, integrator=None, control_dt=None,
                 substeps=None, action_mode="throttle", reward_weights=None,
                 max_initial_angle_deg=None, max_initial_rate=None, allocator="pinv",
                 max_episode_steps=None, autoreset_mode=AutoresetMode.NEXT_STEP,
                 render_mode=None):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) \
                or num_envs < 1:
            raise InvalidParameterError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        self.config = task.make_config(
            scene, integrator=integrator, control_dt=control_dt, substeps=substeps,
            action_mode=action_mode, reward_weights=reward_weights,
            max_initial_angle_deg=max_initial_angle_deg, max_initial_rate=max_initial_rate,
            allocator=allocator)
        if render_mode not in (None, "rgb_array"):
            raise InvalidParameterError(
                f"render_mode must be None or 'rgb_array' for the vector env, got {render_mode!r}"
            )
        sc = self.config.scene
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self._mode = _autoreset_mode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self._mode,
                         "render_fps": 1.0 / sc.physics.control_dt}
        n_act = 3 if action_mode == "torque" else sc.n_thrusters
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (n_act,), np.float32)
        self.single_observation_space = gym.spaces.Box(-1.0, 1.0, (OBS_SIZE,), np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        if max_episode_steps is not None and (isinstance(max_episode_steps, bool) or
                                              int(max_episode_steps) != max_episode_steps or
                                              max_episode_steps < 1):
            raise InvalidParameterError(
                f"max_episode_steps must be an integer >= 1 or None, got {max_episode_steps!r}"
            )
        steps = sc.episode_steps
        self._max_steps = steps if max_episode_steps is None else min(steps, max_episode_steps)
        self._sensor_noise = sc.sensor_noise.model == "gaussian"
        self._dist_noise = sc.disturbance.model == "random" and sc.disturbance.noise_sigma > 0
        self._p_fault = sc.faults.p_step if sc.faults.model == "random" else 0.0
        self._rngs: list | None = None
        self._st: State | None = None
        self._q_target = None
        self._prev_done = np.zeros(self.num_envs, dtype=bool)
        self._renderers = None

    @property
    def scene(self):
        """The :class:`rbenv.Scene` in use (after option overrides)."""
        return self.config.scene

    def set_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None) -> None:
        """Change the initial-condition ranges for every later episode start (curriculum).

        max_initial_angle_deg in [0, 180]; max_initial_rate in rad/s; None keeps the value.
        Sub-envs already running keep their episode; autoresets use the new ranges.
        """
        self.config = task.with_initial_ranges(self.config, max_initial_angle_deg,
                                               max_initial_rate)

    # ------------------------------------------------------------------- reset

    def reset(self, *, seed=None, options=None):
        """Reset every sub-env. seed: int (sub-env i gets s + i), list of N ints, or None."""
        n = self.num_envs
        if isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [int(s) for s in seed]
            if len(seeds) != n:
                raise InvalidParameterError(f"seed list must have {n} entries, got {len(seeds)}")
            super().reset(seed=seeds[0])
        else:
            super().reset(seed=seed)
            if seed is None and self._rngs is None:
                _, seed = seeding.np_random()
            seeds = None if seed is None else [int(seed) + i for i in range(n)]
        if seeds is not None:
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self._st = self._empty_state()
        self._reset_envs(np.arange(n), options)
        self._prev_done = np.zeros(n, dtype=bool)
        zero = np.zeros(n)
        terms = (zero,) * len(task.REWARD_TERMS)
        return self._observation(), self._info(terms, np.zeros(n, dtype=bool))

    def _empty_state(self) -> State:
        n, cfg = self.num_envs, self.config
        vec = lambda width: tuple(np.zeros(n) for _ in range(width))  # noqa: E731
        st = State(q=vec(4), w=vec(3), q_target_conj=vec(4), q_err=vec(4), angle=np.zeros(n),
                   hold=np.zeros(n, dtype=np.int64), steps=np.zeros(n, dtype=np.int64),
                   fuel_kg=np.zeros(n), impulse_Ns=np.zeros(n),
                   throttle=np.zeros((n, cfg.n)))
        sc = cfg.scene
        if sc.disturbance.model == "random":
            st.bias = vec(3)
        if sc.faults.model == "random":
            st.health = np.ones((n, cfg.n))
        if sc.physics.translation:
            st.x, st.v = vec(3), vec(3)
        self._q_target = np.zeros((n, 4))
        return st

    def _reset_envs(self, idx: np.ndarray, options=None) -> None:
        """Start new episodes in sub-envs ``idx`` (each from its own generator)."""
        cfg, st = self.config, self._st
        starts = [task.override_start(task.sample_episode(cfg, self._rngs[i]), options, i)
                  for i in idx.tolist()]
        q = np.array([s["q"] for s in starts])
        w = np.array([s["omega_B"] for s in starts])
        q_target = np.array([s["q_target"] for s in starts])
        self._q_target[idx] = q_target
        for j in range(4):
            st.q[j][idx] = q[:, j]
            st.q_target_conj[j][idx] = q_target[:, j] if j == 0 else -q_target[:, j]
        for j in range(3):
            st.w[j][idx] = w[:, j]
        if st.bias is not None:
            bias = np.array([s["bias"] for s in starts])
            for j in range(3):
                st.bias[j][idx] = bias[:, j]
        if st.health is not None:
            st.health[idx] = np.array([s["health"] for s in starts])
        if st.x is not None:
            for c in (*st.x, *st.v):
                c[idx] = 0.0
        for arr in (st.hold, st.steps, st.fuel_kg, st.impulse_Ns):
            arr[idx] = 0
        st.throttle[idx] = 0.0
        e, angle = task.error(ARRAY_OPS, tuple(c[idx] for c in st.q_target_conj),
                              tuple(c[idx] for c in st.q))
        for j in range(4):
            st.q_err[j][idx] = e[j]
        st.angle[idx] = angle

    # ------------------------------------------------------------------- step

    def step(self, actions):
        """Step all sub-envs. actions: (N, n) (torque mode (N, 3)). Returns batched results."""
        st = self._st
        if st is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        cfg, n = self.config, self.num_envs
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {a.shape}")
        u = task.throttle(cfg, a)
        rng = self.np_random
        if st.health is not None:
            if self._p_fault:
                st.health = st.health * (rng.random(st.health.shape) >= self._p_fault)
            u = u * st.health
        st.throttle = u
        parts = task.wrench(cfg, u)
        if np.isnan(parts[3]).any():
            raise task.nan_action_error(a)
        noise = tuple(rng.standard_normal((3, n))) if self._dist_noise else None
        task.physics_step(cfg, ARRAY_OPS, st, parts, noise)
        terms, reward, terminated, failure = task.evaluate(cfg, ARRAY_OPS, st,
                                                           parts[3] * cfg.inv_total_thrust)
        success = terminated
        terminated = terminated | failure
        truncated = st.steps >= self._max_steps
        extra = {}
        if self._mode is AutoresetMode.NEXT_STEP:
            if self._prev_done.any():
                idx = np.flatnonzero(self._prev_done)
                self._reset_envs(idx)
                terms, reward, success, terminated, truncated = _zero_rows(
                    idx, terms, reward, success, terminated, truncated)
            self._prev_done = terminated | truncated
        else:
            done = terminated | truncated
            if done.any():
                idx = np.flatnonzero(done)
                extra = self._final(done, self._observation(), self._info(terms, success))
                self._reset_envs(idx)
                terms, _, success, _, _ = _zero_rows(idx, terms, reward, success, terminated,
                                                     truncated)
        info = self._info(terms, success)
        info.update(extra)
        return self._observation(), reward, terminated, truncated, info

    def _final(self, done, obs, info) -> dict:
        """SAME_STEP: the finished sub-envs' last observation and info, masked by ``done``."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = obs[i]
        final_info = {}
        for key, value in info.items():
            if not key.startswith("_"):
                final_info[key] = np.where(done, value, np.zeros_like(value))
                final_info["_" + key] = done.copy()
        return {"final_obs": final_obs, "_final_obs": done.copy(), "final_info": final_info,
                "_final_info": done.copy()}

    def _observation(self) -> np.ndarray:
        noise = tuple(self.np_random.standard_normal((6, self.num_envs))) \
            if self._sensor_noise else None
        comps = task.observe(self.config, ARRAY_OPS, self._st, noise)
        obs = np.empty((self.num_envs, OBS_SIZE), dtype=np.float32)
        for j, c in enumerate(comps):
            obs[:, j] = c
        return obs

    def _info(self, terms, success) -> dict:
        values = task.info(self.config, ARRAY_OPS, self._st, terms, success)
        out = {}
        for key, value in values.items():
            out[key] = np.asarray(value)
            out["_" + key] = np.ones(self.num_envs, dtype=bool)
        return out

    # ------------------------------------------------------------------- rendering

    def render(self):
        """``rgb_array``: a tuple of N frames (H, W, 3) uint8 (one renderer per sub-env)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make_vec")
            return None
        if self._st is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        from rbenv.rendering import Renderer

        sc, st = self.config.scene, self._st
        if self._renderers is None:
            self._renderers = Renderer.for_scene(sc)
        info = task.info(self.config, ARRAY_OPS, st, (0.0,) * 6, False)
        q = np.stack(st.q, axis=1)
        return tuple(
            self._renderers.frame(q=q[i], q_target=self._q_target[i], throttle=st.throttle[i],
                                  error_deg=float(info["attitude_error_deg"][i]),
                                  rate_dps=float(info["rate_dps"][i]),
                                  time_s=float(info["time_s"][i]))
            for i in range(self.num_envs)
        )

    def close_extras(self, **kwargs):
        """Release the renderer, if any (also after a failed __init__, via __del__)."""
        if getattr(self, "_renderers", None) is not None:
            self._renderers.close()
            self._renderers = None

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_renderers"] = None
        return state


def _zero_rows(idx, terms, reward, success, terminated, truncated):
    """Copies with rows ``idx`` zeroed: the reset rows of an autoreset step."""
    rows = np.zeros(len(reward), dtype=bool)
    rows[idx] = True
    terms = tuple(np.where(rows, 0.0, t) for t in terms)
    reward, success = reward.copy(), success.copy()
    terminated, truncated = terminated.copy(), truncated.copy()
    reward[idx] = 0.0
    success[idx] = terminated[idx] = truncated[idx] = False
    return terms, reward, success, terminated, truncated
