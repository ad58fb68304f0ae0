"""Single-satellite Gymnasium envs: a thin adapter over :mod:`rbenv.transition`.

One class, :class:`AttitudeEnv`, serves every task; each registered id has a subclass that
names its task and carries its documentation (``SatelliteReorientEnv``,
``SatelliteDetumbleEnv``, ``SatelliteTrackEnv``). The state is held as Python floats, so a step
costs tens of nanoseconds per arithmetic operation and no NumPy call in the physics.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np

from core.backend import FLOAT
from rbenv import transition
from rbenv.adapter import ENV_OPTIONS, TaskAdapter, action_array
from rbenv.draws import EpisodeDraws
from rbenv.plant import NO_NOISE
from rbenv.state import from_start

RENDER_MODES = ("human", "rgb_array")


def unknown_options(owner: str, unknown: dict, valid) -> None:
    """Raise the TypeError of an unexpected keyword (as Python does), naming the valid ones."""
    bad = ", ".join(repr(k) for k in sorted(unknown))
    raise TypeError(f"{owner} got unexpected option(s) {bad}; the valid options are "
                    f"{', '.join(sorted(valid))}")


class AttitudeEnv(TaskAdapter, gym.Env):
    """A satellite, its thrusters and one task, as a Gymnasium env (see the subclasses)."""

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 2}

    def __init__(self, scene=None, *, integrator=None, control_dt=None, substeps=None,
                 action_mode="throttle", reward_weights=None, max_initial_angle_deg=None,
                 max_initial_rate=None, allocator="pinv", randomize=None, task_options=None,
                 render_mode=None, compiled=False, **unknown):
        if unknown:
            unknown_options(type(self).__name__, unknown, (*ENV_OPTIONS, "render_mode"))
        options = {name: value for name, value in locals().items() if name in ENV_OPTIONS}
        self.action_space, self.observation_space = self._setup(options, render_mode,
                                                                RENDER_MODES)
        self.metadata = {**type(self).metadata, "render_fps": 1.0 / self.plant.control_dt}
        self._max_steps = self.plant.scene.episode_steps
        self._seed_key: int | None = None
        self._episode = 0
        self._st = None
        self._renderer = None

    # ------------------------------------------------------------------- Gymnasium API

    def reset(self, *, seed=None, options=None):
        """Start an episode; ``options`` replace parts of the sampled start (see the task)."""
        super().reset(seed=seed)
        if seed is not None:
            self._seed_key, self._episode = int(seed) % 2**64, 0
        elif self._seed_key is None:
            self._seed_key = int(self.np_random.integers(2**63))
        draws = EpisodeDraws(self._seed_key, self._episode, single=True,
                             block_slots=self._block_slots)
        self._episode += 1
        start = transition.start(self.plant, self.task, draws, options)
        self._st = st = from_start(self._kinds, start, single=True)
        noise = self.plant.draw_sensor_noise(self._np_random, None)
        obs = np.array(transition.observe(self.plant, self.task, st, noise, FLOAT), np.float32)
        info = transition.info(self.plant, self.task, st, transition.zero_terms(self.task),
                               False, FLOAT)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        """One control step: (obs, reward: float, terminated: bool, truncated: bool, info)."""
        st = self._st
        if st is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        plant = self.plant
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            a = None
        if a is None or a.shape != plant.action_shape:
            action_array(action, plant.action_shape)  # raises the named error
        noise = plant.draw_step_noise(self._np_random, None) if plant.noisy else NO_NOISE
        out = transition.step(plant, self.task, st, a, noise, FLOAT)
        if self.render_mode == "human":
            self.render()
        terminated = bool(out.failure or (out.success and self.task.success_terminates))
        return (np.array(out.obs, dtype=np.float32), out.reward, terminated,
                st.steps >= self._max_steps, out.info)

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


class SatelliteReorientEnv(AttitudeEnv):
    """Reorient a satellite to a target attitude by firing body-fixed thrusters.

    Made by ``gym.make("rbenv/SatelliteReorient-v0", **kwargs)``.

    **Arguments** (all optional):

    =======================  ===================  ==============================================
    argument                 default              meaning
    =======================  ===================  ==============================================
    ``scene``                ``"cubesat-12u"``    shipped name, TOML path or :class:`rbenv.Scene`
    ``integrator``           scene's              a name in ``core.INTEGRATORS``
    ``control_dt``           scene's              s, one env step
    ``substeps``             scene's              integrator steps per control step
    ``action_mode``          ``"throttle"``       ``"throttle"``, ``"on_off"`` or ``"torque"``
    ``reward_weights``       see below            dict overriding the reward weights
    ``max_initial_angle_deg``  scene's (180)      initial error within this angle (curriculum)
    ``max_initial_rate``     scene's              rad/s, initial tumble up to this
    ``allocator``            ``"pinv"``           torque mode: ``"pinv"``, ``"nnls"``, ``"lp"``
    ``randomize``            scene's (off)        dict of domain-randomization sizes, or False
    ``task_options``         None                 unused by this task
    ``render_mode``          None                 ``"rgb_array"`` or ``"human"``
    ``compiled``             False                True: the integrator runs numba-compiled
                                                  (extra ``rbenv[fast]``; same results bit for
                                                  bit; a few seconds of compilation at the
                                                  first step; not with randomized inertia)
    =======================  ===================  ==============================================

    **Action** ``Box(-1, 1, (n,), float32)``, one entry per thruster: the throttle (duty cycle
    over the control step) is ``clip(a, 0, 1)``, so ``a ≤ 0`` is off. ``on_off``: ``a > 0``
    fires at full throttle. ``torque``: ``Box(-1, 1, (3,))``, a body torque as a fraction of
    the per-axis authority, turned into throttles by the allocator. Values outside [-1, 1] are
    clipped; NaN raises ``ValueError``.

    **Observation** ``Box(-1, 1, (7,), float32)``, ``observation_structure``
    ``{"q_err": 4, "omega_B": 3}``: the canonical error quaternion ``q_target* ⊗ q`` (w ≥ 0;
    its vector part is ``sin(θ/2)·axis`` in body axes), then ``ω_B / rate_limit`` clipped to
    [-1, 1]. With sensor noise it is built from the noisy measurement; rewards, success and
    termination always use the true state.

    **Reward**: the sum of ``info["reward_<term>"]``: attitude ``−0.2·θ/π``, rate
    ``−0.05·min(|ω|/L, 1)``, fuel ``−0.05·Σu_iF_i/ΣF_i``, progress ``10·(θ_prev − θ)/π``, hold
    ``+1`` per step inside the success thresholds, failure ``−25`` on loss of control, and
    precision ``+w·θ_s/(θ_s + θ)`` (θ_s the success angle; weight 0 unless
    ``reward_weights={"precision": w}``: a steep pull over the last degrees).

    **Episode end**: ``terminated`` with ``info["is_success"] = True`` when θ < 1° and
    |ω| < 0.01 rad/s (scene values) are held for the scene's hold time; ``terminated`` without
    success when |ω| exceeds the rate limit; ``truncated`` at the scene's duration.

    **Info**: ``attitude_error_deg``, ``rate_dps``, ``fuel_kg``, ``impulse_Ns``, ``time_s``,
    ``is_success``, ``reward_<term>``; ``speed_mps`` with translation; ``failed_thrusters``
    with faults.

    **Reset options**: ``{"q": (4,), "omega_B": (3,), "q_target": (4,)}`` replace the sampled
    start. **Seeding**: episode ``e`` after ``reset(seed=s)`` is a pure function of (s, e)
    (:mod:`rbenv.draws`).

    **Version History**

    * v0: first release. Episode starts are counter-based draws (since rbenv 0.2; rbenv 0.1
      drew them from ``np_random``, so seeded episodes differ between the two). rbenv 0.2 adds
      the ``precision`` reward term, weight 0 by default: default rewards are unchanged to the
      last bit, and ``info`` gains ``reward_precision``.
    """

    task_name: ClassVar[str] = "reorient"


class SatelliteDetumbleEnv(AttitudeEnv):
    """Stop a tumbling satellite with thrusters, spending as little propellant as possible.

    Made by ``gym.make("rbenv/SatelliteDetumble-v0", **kwargs)``; arguments as
    :class:`SatelliteReorientEnv`, with ``max_initial_rate`` (rad/s) the largest initial
    tumble and ``task_options`` a dict overriding the scene's ``[tasks.detumble]`` table
    (``min_rate_fraction``, ``max_rate_fraction``: the initial |ω| is uniform between these
    fractions of the rate limit, about a uniformly random axis).

    **Action**: as the reorientation env. **Observation** ``Box(-1, 1, (3,), float32)``,
    ``{"omega_B": 3}``: ``ω_B / rate_limit``, clipped.

    **Reward**: rate ``−0.2·|ω|/L``, progress ``10·(|ω|_prev − |ω|)/L``, fuel
    ``−0.5·Σu_iF_i/ΣF_i``, hold ``+1`` per step below the success rate, failure ``−25`` on
    loss of control (``reward_weights`` overrides these).

    **Episode end**: ``terminated`` with success when |ω| < ``success_rate`` is held for the
    hold time; ``terminated`` without success when |ω| > rate limit; ``truncated`` at the
    scene's duration. **Info**: ``rate_dps``, ``fuel_kg``, ``impulse_Ns``, ``time_s``,
    ``is_success``, ``reward_<term>``. **Reset options**: ``{"q": (4,), "omega_B": (3,)}``.

    **Version History**

    * v0: first release.
    """

    task_name: ClassVar[str] = "detumble"


class SatelliteTrackEnv(AttitudeEnv):
    """Follow a target attitude that turns at a constant rate, as a pointing spacecraft does.

    Made by ``gym.make("rbenv/SatelliteTrack-v0", **kwargs)``; arguments as
    :class:`SatelliteReorientEnv`; ``task_options`` overrides the scene's ``[tasks.track]``
    table: ``max_target_rate`` (rad/s, the target turns about a random world-fixed axis at a
    rate uniform up to this), ``max_initial_angle_deg`` (initial tracking error),
    ``min_track_fraction`` (success threshold, below).

    **Observation** ``Box(-1, 1, (10,), float32)``, ``{"q_err": 4, "omega_err_B": 3,
    "omega_target_B": 3}``: the canonical error quaternion to the *moving* target, the rate
    error ``ω_B − ω_target_B`` and the target's rate in body axes, both divided by the rate
    limit and clipped.

    **Reward**: attitude ``−0.2·θ/π``, rate ``−0.05·min(|ω − ω_t|/L, 1)``, fuel
    ``−0.05·Σu_iF_i/ΣF_i``, progress ``10·(θ_prev − θ)/π``, on-target ``+1`` per step with
    θ < success angle and |ω − ω_t| < success rate, failure ``−25``.

    **Episode end**: the episode runs to the scene's duration (``truncated``) unless control is
    lost (``terminated``). ``info["is_success"]`` is True on the last step when the satellite
    was on target for at least ``min_track_fraction`` (default 0.9) of the steps in the second
    half of the episode: success is a property of the tracking over time, not of the end.
    **Info**: ``attitude_error_deg``, ``rate_error_dps``, ``track_fraction``, plant values,
    ``reward_<term>``. **Reset options**: ``{"q": (4,), "omega_B": (3,), "q_target": (4,),
    "omega_target_W": (3,)}``.

    **Version History**

    * v0: first release.
    """

    task_name: ClassVar[str] = "track"
