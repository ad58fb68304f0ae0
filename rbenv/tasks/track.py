"""Track: keep pointing at a target attitude that turns at a constant rate.

``rbenv/SatelliteTrack-v0``. The target frame turns about a world-fixed axis at a constant rate
``Ω_W`` (uniform direction, magnitude uniform up to the task option
``max_target_rate_fraction`` × the rate limit), as the local orbital frame of a nadir-pointing
spacecraft or the line of sight to a ground target does. Its attitude
after ``t`` seconds is ``exp(Ω_W t) ⊗ q_target(0)``, exact; seen from the body its rate is
``ω_t_B = Rᵀ Ω_W`` and that rate changes at ``d(ω_t_B)/dt = ω_t_B × ω_B``.

With the option ``target = "nadir"`` the target is instead the local-vertical frame (LVLH,
CCSDS) of the scene's circular orbit: body z to nadir, body y to the negative orbit normal,
body x along track; it turns at ``Ω_W = n ĥ`` (n the mean motion, ĥ the orbit normal), which
is ``[0, −n, 0]`` in its own axes, from its attitude at the episode start (the actuators-and-
orbit reference note, §6). That is the same constant-rate motion, so nothing else changes. A
scene without an orbit refuses it by name.

The episode starts within ``max_initial_angle_deg`` of the target, tumbling at up to the scene's
``max_initial_rate``, and always runs to the scene's duration unless control is lost. Rewards
accrue for tracking at every step; ``is_success`` (on the last step) requires the satellite to
be on target (error < success angle, |ω − ω_t_B| < success rate) for at least
``min_track_fraction`` of the steps in the second half of the episode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
from rbenv.core.quaternion import from_matrix
from rbenv.tasks import v1
from rbenv.tasks.base import (
    _DEG,
    Task,
    Weights,
    conj,
    error_quaternion,
    option_table,
    restricted_haar_angle,
    unit,
)
from rbenv.tasks.spec import TaskSpec

_INV_PI = 1.0 / math.pi


@dataclass(frozen=True)
class TrackWeights(Weights):
    """Reward weights (per control step; θ the error to the moving target, e_ω = ω − ω_t_B).

    attitude ``−w·θ/π``; rate ``−w·min(|e_ω|/L, 1)``; fuel ``−w·Σu_iF_i/ΣF_i``; progress
    ``w·(θ_prev − θ)/π``; on_target ``+w`` per step on target; failure ``−w`` once.
    """

    attitude: float = 0.2
    rate: float = 0.05
    fuel: float = 0.05
    progress: float = 10.0
    on_target: float = 1.0
    failure: float = 25.0


@dataclass(frozen=True, eq=False)
class Track(Task):
    """Follow a target turning at a constant rate (see the module docstring)."""

    name: ClassVar[str] = "track"
    observation_structure: ClassVar[dict] = {"q_err": 4, "omega_err_B": 3, "omega_target_B": 3}
    start_slots: ClassVar[int] = 29
    error_info_key: ClassVar[str] = "attitude_error_deg"
    WeightsType: ClassVar[type] = TrackWeights
    success_terminates: ClassVar[bool] = False
    moving_target: ClassVar[bool] = True
    state_fields: ClassVar[dict] = {"q_target_conj": "c4", "q_step_conj": "c4",
                                    "omega_target_W": "c3", "omega_target_B": "c3",
                                    "q_err": "c4", "angle": "f", "rate": "f", "rate_error": "f",
                                    "on_steps": "i"}
    reset_options: ClassVar[dict] = {"q": 4, "omega_B": 3, "q_target": 4, "omega_target_W": 3}
    OPTIONS: ClassVar[dict] = {"max_target_rate_fraction": 0.3, "max_initial_angle_deg": 30.0,
                               "min_track_fraction": 0.9, "target": "random"}

    weights: TrackWeights = TrackWeights()
    max_target_rate: float = 0.0  # rad/s
    max_initial_angle: float = math.radians(30.0)  # rad
    max_initial_rate: float = 0.0  # rad/s
    min_track_fraction: float = 0.9
    # Nadir pointing: (q_target(0) as 4 floats, Ω_W as 3 floats, rad/s), or None (random).
    nadir: tuple | None = None

    @property
    def episode_steps(self) -> int:
        """Control steps in an episode (the scene's duration)."""
        return self.plant.scene.episode_steps

    @property
    def scored_from(self) -> int:
        """Steps after which on-target steps count towards success (the second half)."""
        return self.episode_steps // 2

    def observation_scale(self) -> dict:
        L = self.rate_limit
        return {"q_err": 1.0, "omega_err_B": L, "omega_target_B": L}

    def with_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None):
        deg = math.degrees(self.max_initial_angle) if max_initial_angle_deg is None \
            else validation.number("max_initial_angle_deg", max_initial_angle_deg, low=0.0,
                                   high=180.0)
        rate = self.max_initial_rate if max_initial_rate is None else validation.number(
            "max_initial_rate", max_initial_rate, low=0.0, high=self.rate_limit,
            high_open=True)
        return replace(self, max_initial_angle=math.radians(deg), max_initial_rate=rate)

    # ------------------------------------------------------------------- episode start

    def sample_start(self, draws) -> dict:
        """Stream "task": normals 0–3 target, 4–6 error axis, 7–9 tumble direction, 10–12
        target-rate axis; uniforms 26 (error angle), 27 (tumble), 28 (target rate)."""
        xp = draws.xp
        g = draws.normal("task", 13)
        u = draws.uniform("task", 3, offset=26)
        q_target = k.qnormalize(g[0:4])
        omega_target_W = k.scale(unit(g[10:13], xp), self.max_target_rate * u[2])
        if self.nadir is not None:  # the same draws, the target replaced by the LVLH frame
            zero = 0.0 * u[0]
            q_target = tuple(c + zero for c in self.nadir[0])
            omega_target_W = tuple(c + zero for c in self.nadir[1])
        theta = restricted_haar_angle(u[0], self.max_initial_angle, xp)
        q = k.qmul(q_target, k.exp(k.scale(unit(g[4:7], xp), theta)))
        return {"q": q, "omega_B": k.scale(unit(g[7:10], xp), self.max_initial_rate * u[1]),
                "q_target": q_target, "omega_target_W": omega_target_W}

    def complete_start(self, start: dict, xp) -> None:
        q_target_conj = conj(start.pop("q_target"))
        step = k.exp(k.scale(start["omega_target_W"], self.plant.control_dt))
        e, angle = error_quaternion(q_target_conj, start["q"], xp)
        w_t = k.rotate_inverse(start["q"], start["omega_target_W"])
        w = start["omega_B"]
        e_w = (w[0] - w_t[0], w[1] - w_t[1], w[2] - w_t[2])
        start.update(q_target_conj=q_target_conj, q_step_conj=conj(step), q_err=e,
                     angle=angle, omega_target_B=w_t, rate_error=xp.sqrt(k.dot(e_w, e_w)),
                     rate=xp.sqrt(k.dot(w, w)),
                     on_steps=0 * angle)

    # ------------------------------------------------------------------- per step

    def advance_target(self, st) -> None:
        """``q_target ← exp(Ω_W dt) ⊗ q_target`` (as conjugates), renormalised."""
        st.q_target_conj = k.qnormalize(k.qmul(st.q_target_conj, st.q_step_conj))

    def observe(self, st, q, w, xp) -> tuple:
        """q_err (4), (ω − ω_t_B)/L (3) and ω_t_B/L (3), rates clipped to [-1, 1]."""
        if q is st.q:
            e, w_t = st.q_err, st.omega_target_B
        else:  # a noisy measurement
            e = error_quaternion(st.q_target_conj, q, xp)[0]
            w_t = k.rotate_inverse(q, st.omega_target_W)
        s = self.inv_rate_limit
        clip = xp.clip
        return (*e, *(clip((w[i] - w_t[i]) * s, -1.0, 1.0) for i in range(3)),
                *(clip(w_t[i] * s, -1.0, 1.0) for i in range(3)))

    def _update_errors(self, st, xp) -> tuple:
        """After a step: set q_err, ω_t_B, rate error, rate and the on-target count of ``st``
        (not ``st.angle``, still the error before the step); returns (angle (rad), rate error
        (rad/s), on target, failure: |ω| > rate limit, success: the last step, on target
        long enough)."""
        st.q_err, angle = error_quaternion(st.q_target_conj, st.q, xp)
        w = st.omega_B
        st.omega_target_B = w_t = k.rotate_inverse(st.q, st.omega_target_W)
        e0, e1, e2 = w[0] - w_t[0], w[1] - w_t[1], w[2] - w_t[2]
        st.rate_error = rate_err = xp.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        st.rate = rate = xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        on = (angle < self.success_angle) & (rate_err < self.success_rate)
        st.on_steps = st.on_steps + (on & (st.steps > self.scored_from))
        scored = self.episode_steps - self.scored_from
        success = (st.steps >= self.episode_steps) & \
            (st.on_steps >= self.min_track_fraction * scored)
        return angle, rate_err, on, rate > self.rate_limit, success

    def evaluate(self, st, effort, xp):
        wt = self.weights
        angle, rate_err, on, failure, success = self._update_errors(st, xp)
        terms = tuple.__new__(self.Terms, (
            -wt.attitude * _INV_PI * angle,
            -wt.rate * xp.minimum(rate_err * self.inv_rate_limit, 1.0),
            -wt.fuel * effort,
            wt.progress * _INV_PI * (st.angle - angle),
            wt.on_target * on,
            -wt.failure * failure,
        ))
        st.angle = angle
        return terms, success, failure

    def info(self, st, xp) -> dict:
        """attitude_error_deg, rate_dps, rate_error_dps and track_fraction (the on-target
        share so far of the scored second half)."""
        scored = xp.maximum(st.steps - self.scored_from, 1)
        return {"attitude_error_deg": st.angle * _DEG,
                "rate_dps": st.rate * _DEG,
                "rate_error_dps": st.rate_error * _DEG,
                "track_fraction": st.on_steps / scored}

    def target(self, st) -> tuple:
        c = st.q_target_conj
        return (c[0], -c[1], -c[2], -c[3])

    def error_angle(self, st):
        return st.angle


def lvlh_target(orbit) -> tuple:
    """The LVLH frame (CCSDS) of a circular orbit at the episode start and its rate.

    ``ẑ_L = −r̂`` (nadir), ``ŷ_L = −ĥ`` (ĥ the orbit normal), ``x̂_L = ŷ_L × ẑ_L`` (along
    track); returns (q_NL as 4 floats, body→world, scalar first; ``Ω_W = n ĥ`` as 3 floats,
    rad/s). Reference note §6.
    """
    r_hat = np.array(orbit.direction_N(0.0, math))
    h_hat = np.cross(orbit.p_hat, orbit.q_hat)
    z, y = -r_hat, -h_hat
    R = np.column_stack([np.cross(y, z), y, z])
    q = from_matrix(R)
    return (tuple(float(c) for c in q),
            tuple(float(c) for c in orbit.mean_motion * h_hat))


@dataclass(frozen=True)
class TrackV1Weights(v1.V1Weights):
    """v1 weights of track: fuel 2.5 (PPO, 1 M steps: 100 % at 1.22x the PD's propellant;
    2.0: 100 % at 1.38x; 3.0: 97.6 % at 0.82x; benchmarks/results/rl/v1)."""

    fuel: float = 2.5


@dataclass(frozen=True, eq=False)
class TrackV1(v1.V1Decode, Track):
    """Track, v1 observation and reward (:mod:`rbenv.tasks.v1`); same episodes as v0."""

    name: ClassVar[str] = "track_v1"
    scene_table: ClassVar[str] = "track"
    observation_structure: ClassVar[dict] = {"rot6_err": 6, "attitude_fine": 3,
                                             "omega_err_B": 3, "omega_err_fine": 3,
                                             "omega_target_B": 3}
    WeightsType: ClassVar[type] = TrackV1Weights

    weights: TrackV1Weights = TrackV1Weights()

    def observation_scale(self) -> dict:
        L = self.rate_limit
        return {"rot6_err": 1.0, "attitude_fine": 1.0, "omega_err_B": L, "omega_err_fine": 1.0,
                "omega_target_B": L}

    def observe(self, st, q, w, xp) -> tuple:
        """rot6(q_err) (6), fine(θ·axis) (3), (ω − ω_t_B)/L clipped (3), fine(ω − ω_t_B) (3),
        ω_t_B/L clipped (3)."""
        if q is st.q:
            e, angle, w_t = st.q_err, st.angle, st.omega_target_B
        else:  # a noisy measurement
            e, angle = error_quaternion(st.q_target_conj, q, xp)
            w_t = k.rotate_inverse(q, st.omega_target_W)
        s = self.inv_rate_limit
        clip = xp.clip
        e_w = (w[0] - w_t[0], w[1] - w_t[1], w[2] - w_t[2])
        return (*v1.rot6(e), *v1.axis_angle_fine(e, angle, self.success_angle, xp),
                *v1.rate_features(e_w, s, self.success_rate, xp),
                *(clip(w_t[i] * s, -1.0, 1.0) for i in range(3)))

    def evaluate(self, st, effort, xp):
        """v1 terms (error ψ(θ), rate ψ(|ω − ω_t|), progress on ψ(θ)); success is paid on
        the last step when the episode succeeds."""
        prev = st.angle
        angle, rate_err, _, failure, success = self._update_errors(st, xp)
        drop = v1.log_scale_drop(prev, angle, self.success_angle, math.pi, xp)
        psi = v1.log_scale(angle, self.success_angle, math.pi, xp)
        psi_rate = v1.log_scale(xp.minimum(rate_err, self.rate_limit), self.success_rate,
                                self.rate_limit, xp)
        st.angle = angle
        return v1.terms(self.weights, drop, psi, psi_rate, effort, success, failure), \
            success, failure


def make_track(plant, reward_weights=None, max_initial_angle_deg=None, max_initial_rate=None,
               task_options=None) -> Track:
    """The tracking task on ``plant`` (options: scene ``[tasks.track]``, then task_options)."""
    return _make(Track, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def make_track_v1(plant, reward_weights=None, max_initial_angle_deg=None,
                  max_initial_rate=None, task_options=None) -> TrackV1:
    """The v1 tracking task (options as :func:`make_track`)."""
    return _make(TrackV1, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def _make(cls, plant, reward_weights, max_initial_angle_deg, max_initial_rate, task_options):
    opts = option_table(plant.scene, cls, task_options)
    limit = plant.scene.episode.rate_limit
    frac = validation.number("tasks.track.max_target_rate_fraction",
                             opts["max_target_rate_fraction"], low=0.0, high=0.9)
    deg = validation.number("tasks.track.max_initial_angle_deg", opts["max_initial_angle_deg"],
                            low=0.0, high=180.0)
    share = validation.number("tasks.track.min_track_fraction", opts["min_track_fraction"],
                              low=0.0, high=1.0)
    target = validation.choice("tasks.track.target", opts["target"], ("random", "nadir"))
    nadir = None
    if target == "nadir":
        orbit = plant.scene.orbit
        if not orbit.enabled:
            raise InvalidParameterError(
                f"tasks.track.target = 'nadir' points at the local vertical of the scene's "
                f"orbit, but scene {plant.scene.name!r} has none ([orbit] model = 'none'); "
                "give it an [orbit] table or use target = 'random'")
        nadir = lvlh_target(orbit)
    task = cls(plant=plant, weights=cls.WeightsType.from_mapping(reward_weights),
               max_target_rate=frac * limit, max_initial_angle=math.radians(deg),
               max_initial_rate=plant.scene.episode.max_initial_rate,
               min_track_fraction=share, nadir=nadir)
    return task.with_initial_ranges(max_initial_angle_deg, max_initial_rate)


ENV_DOC = """Follow a target attitude that turns at a constant rate, as a pointing spacecraft does.

    Made by ``gym.make("rbenv/SatelliteTrack-v0", **kwargs)``; arguments as
    :class:`SatelliteReorientEnv`; ``task_options`` overrides the scene's ``[tasks.track]``
    table: ``max_target_rate_fraction`` (the target turns about a random world-fixed axis at a
    rate uniform up to this), ``max_initial_angle_deg`` (initial tracking error),
    ``min_track_fraction`` (success threshold, below), ``target`` (``"random"``, default,
    or ``"nadir"``: the LVLH frame of the scene's orbit, turning at ``[0, −n, 0]`` in its
    own axes; refused on a scene without an orbit).

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

    * v0, orbit torques evaluated where they act (a physics fix, same version): on a scene
      with an orbit (``cubesat-6u-rw``) the gravity gradient and the rods' ``m × B`` (the
      field fixed in inertial axes, the dipole command held) are evaluated at every
      integrator stage instead of held over the substep in body axes, so its episodes
      change: with idle wheels and random rod commands (seed 1,000,000) the attitude moves
      by 1.7e-5 rad after its 80 s. Scenes without an orbit are bit-identical.
    * v0: first release.
    """

# The env entry: registered by rbenv/__init__.py (rbenv.envs.registry); trained with the settings
# of rbenv.agents.settings.
SPEC = TaskSpec(env_id="rbenv/SatelliteTrack-v0", task=Track, make=make_track, env_doc=ENV_DOC)

ENV_DOC_V1 = """Follow a target attitude turning at a constant rate (v1 observation and reward).

    Made by ``gym.make("rbenv/SatelliteTrack-v1", **kwargs)``; arguments, action, episode end,
    success, info and reset options as ``rbenv/SatelliteTrack-v0``, and the same episodes for
    the same seed; ``task_options`` as v0's (``max_target_rate_fraction``,
    ``max_initial_angle_deg``, ``min_track_fraction``, ``target``, read from the scene's
    ``[tasks.track]`` table).

    **Observation** ``Box(-1, 1, (18,), float32)``, ``observation_structure``
    ``{"rot6_err": 6, "attitude_fine": 3, "omega_err_B": 3, "omega_err_fine": 3,
    "omega_target_B": 3}``: two columns of the error rotation to the moving target; the
    axis-angle error scaled by 1/(θ_s + θ); the rate error ``ω_B − ω_t_B`` over the rate limit
    (clipped) and over ``ω_s + |ω_B − ω_t_B|``; the target's rate over the rate limit.

    **Reward** (:mod:`rbenv.tasks.v1`): error ``−0.1·ψ(θ)``, rate ``−0.05·ψ(|ω − ω_t|)``, fuel
    ``−2.5·Σu_iF_i/ΣF_i``, progress ``10·(ψ(θ_prev) − ψ(θ))``, success ``+20`` once, on the last
    step of a successful episode, failure ``−25``. v0's per-step on-target pay is gone: the
    steep error term pays for staying on target, and success for doing so long enough.

    """ + v1.version_history("rbenv/SatelliteTrack-v0")

SPEC_V1 = TaskSpec(env_id="rbenv/SatelliteTrack-v1", task=TrackV1, make=make_track_v1,
                   env_doc=ENV_DOC_V1)
