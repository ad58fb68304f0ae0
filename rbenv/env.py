"""The single-satellite Gymnasium env: reorient to a random target attitude with thrusters."""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np

from core.errors import InvalidParameterError
from rbenv import task
from rbenv.task import FLOAT_OPS, OBS_SIZE, State

_ZERO_TERMS = (0.0,) * len(task.REWARD_TERMS)
RENDER_MODES = ("human", "rgb_array")


class SatelliteReorientEnv(gym.Env):
    """Reorient a satellite to a target attitude by firing body-fixed thrusters.

    Made by ``gym.make("rbenv/SatelliteReorient-v0", **kwargs)``; kwargs (all optional):
    ``scene`` (shipped name, TOML path or :class:`rbenv.Scene`; default ``"cubesat-12u"``),
    ``integrator``, ``control_dt`` (s), ``substeps`` (override the scene's physics),
    ``action_mode`` ("throttle" | "on_off" | "torque"), ``reward_weights`` (dict, see
    :class:`rbenv.task.RewardWeights`), ``max_initial_angle_deg`` and ``max_initial_rate``
    (rad/s; initial-condition ranges, e.g. for a curriculum), ``allocator`` (torque mode:
    "pinv" | "nnls" | "lp"), ``render_mode`` ("rgb_array" | "human").

    **Action** ``Box(-1, 1, (n,), float32)``, one entry per thruster: the throttle (duty cycle
    over the control step) is ``clip(a, 0, 1)``, so ``a ≤ 0`` is off; torque ``B @ u`` is
    held over the step. ``on_off``: ``a > 0`` fires at full throttle. ``torque``:
    ``Box(-1, 1, (3,))``, a body torque as a fraction of the per-axis authority (the weaker
    direction about each axis), turned into throttles by the allocator. Values outside [-1, 1]
    are clipped to the space; NaN raises ``ValueError``.

    **Observation** ``Box(-1, 1, (7,), float32)``:

    ====  ==========================================================================
    0     w of ``q_err = canonical(q_target* ⊗ q)`` (w ≥ 0); ``cos(θ/2)``, θ the error
    1–3   x, y, z of ``q_err``: ``sin(θ/2)·axis``, the axis in body (= target) axes
    4–6   body rates ``ω_B / rate_limit``, clipped to [-1, 1]
    ====  ==========================================================================

    With sensor noise the observation is built from the noisy measurement; rewards, success
    and termination always use the true state.

    **Reward** (per control step): the sum of the terms in ``info["reward_<name>"]``, see
    :class:`rbenv.task.RewardWeights`: attitude ``−0.2·θ/π``, rate ``−0.05·min(|ω|/L, 1)``, fuel
    ``−0.05·Σu_iF_i/ΣF_i``, progress ``10·(θ_prev − θ)/π``, hold ``+1`` per step inside the
    success thresholds, failure ``−25`` on loss of control (default weights).

    **Episode**: target and attitude uniform on SO(3) (or within ``max_initial_angle_deg``),
    tumble up to ``max_initial_rate``. ``terminated`` with ``info["is_success"] = True`` when
    θ < 1° and |ω| < 0.01 rad/s (scene values) for the scene's hold time; ``terminated``
    without success when |ω| exceeds the scene's rate limit; ``truncated`` at the scene's
    duration (and by ``TimeLimit`` through ``gym.make``).

    **Info**: ``attitude_error_deg``, ``rate_dps``, ``fuel_kg``, ``impulse_Ns``, ``time_s``,
    ``is_success``, ``reward_<term>`` for each term; ``speed_mps`` (centre-of-mass speed) when
    the scene models translation; ``failed_thrusters`` when it models faults.

    **Reset options**: ``{"q": (4,), "omega_B": (3,), "q_target": (4,)}`` replace the sampled
    start (the generator advances as usual), e.g. to start several envs from identical states.
    """

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 2}

    def __init__(self, scene=None, *, integrator=None, control_dt=None, substeps=None,
                 action_mode="throttle", reward_weights=None, max_initial_angle_deg=None,
                 max_initial_rate=None, allocator="pinv", render_mode=None):
        self.config = task.make_config(
            scene, integrator=integrator, control_dt=control_dt, substeps=substeps,
            action_mode=action_mode, reward_weights=reward_weights,
            max_initial_angle_deg=max_initial_angle_deg, max_initial_rate=max_initial_rate,
            allocator=allocator)
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise InvalidParameterError(
                f"render_mode must be None or one of {list(RENDER_MODES)}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        sc = self.config.scene
        self.metadata = {**type(self).metadata, "render_fps": 1.0 / sc.physics.control_dt}
        n_act = 3 if action_mode == "torque" else sc.n_thrusters
        self.action_space = gym.spaces.Box(-1.0, 1.0, (n_act,), np.float32)
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (OBS_SIZE,), np.float32)
        self._action_shape = (n_act,)
        self._max_steps = sc.episode_steps
        self._sensor_noise = sc.sensor_noise.model == "gaussian"
        self._dist_noise = sc.disturbance.model == "random" and sc.disturbance.noise_sigma > 0
        self._p_fault = sc.faults.p_step if sc.faults.model == "random" else 0.0
        self._st: State | None = None
        self._q_target: tuple | None = None
        self._renderer = None

    @property
    def scene(self):
        """The :class:`rbenv.Scene` in use (after option overrides)."""
        return self.config.scene

    def set_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None) -> None:
        """Change the initial-condition ranges from the next reset on (curriculum).

        max_initial_angle_deg in [0, 180]; max_initial_rate in rad/s, below the rate limit;
        None keeps the current value.
        """
        self.config = task.with_initial_ranges(self.config, max_initial_angle_deg,
                                               max_initial_rate)

    # ------------------------------------------------------------------- Gymnasium API

    def reset(self, *, seed=None, options=None):
        """Start an episode; see the class docstring for ``options``. Returns (obs, info)."""
        super().reset(seed=seed)
        cfg = self.config
        start = task.override_start(task.sample_episode(cfg, self.np_random), options)
        q_target = tuple(start["q_target"])
        bias = None if start["bias"] is None else tuple(start["bias"])
        st = State(q=tuple(start["q"]), w=tuple(start["omega_B"]),
                   q_target_conj=task.conj(q_target), hold=0, steps=0, fuel_kg=0.0,
                   impulse_Ns=0.0, bias=bias, health=start["health"], throttle=np.zeros(cfg.n))
        if cfg.scene.physics.translation:
            st.x, st.v = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        st.q_err, st.angle = task.error(FLOAT_OPS, st.q_target_conj, st.q)
        self._st, self._q_target = st, q_target
        obs = self._observation()
        info = task.info(cfg, FLOAT_OPS, st, _ZERO_TERMS, False)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        """One control step: (obs, reward: float, terminated: bool, truncated: bool, info)."""
        st = self._st
        if st is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        cfg = self.config
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self._action_shape:
            raise ValueError(f"action must have shape {self._action_shape}, got {a.shape}")
        u = task.throttle(cfg, a)
        rng = self._np_random
        if st.health is not None:
            if self._p_fault:
                st.health = st.health * (rng.random(cfg.n) >= self._p_fault)
            u = u * st.health
        st.throttle = u
        parts = task.wrench(cfg, u)
        if parts[3] != parts[3]:
            raise task.nan_action_error(a)
        noise = rng.standard_normal(3).tolist() if self._dist_noise else None
        task.physics_step(cfg, FLOAT_OPS, st, parts, noise)
        terms, reward, success, failure = task.evaluate(cfg, FLOAT_OPS, st,
                                                        parts[3] * cfg.inv_total_thrust)
        obs = self._observation()
        info = task.info(cfg, FLOAT_OPS, st, terms, success)
        if self.render_mode == "human":
            self.render()
        return obs, reward, success or failure, st.steps >= self._max_steps, info

    def _observation(self) -> np.ndarray:
        noise = self._np_random.standard_normal(6).tolist() if self._sensor_noise else None
        return np.array(task.observe(self.config, FLOAT_OPS, self._st, noise), dtype=np.float32)

    # ------------------------------------------------------------------- rendering

    def render(self):
        """``rgb_array``: an (H, W, 3) uint8 frame; ``human``: draw to a window, return None."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make()")
            return None
        if self._st is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        frame = self._frame()
        if self.render_mode == "human":
            self._renderer.show(frame)
            return None
        return frame

    def _frame(self) -> np.ndarray:
        st, cfg = self._st, self.config
        if self._renderer is None:
            from rbenv.rendering import Renderer

            sc = cfg.scene
            self._renderer = Renderer.for_scene(sc)
        w = st.w
        return self._renderer.frame(
            q=np.array(st.q), q_target=np.array(self._q_target), throttle=st.throttle,
            error_deg=float(np.degrees(st.angle)),
            rate_dps=float(np.degrees(np.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2))),
            time_s=st.steps * cfg.scene.physics.control_dt)

    def close(self):
        """Close the render window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_renderer"] = None  # a pygame surface/window does not pickle; re-created lazily
        return state
