"""Reorient: turn from a random attitude to a fixed random target and hold it there.

``rbenv/SatelliteReorient-v0``. The target is uniform on SO(3); the error rotation
``q_target* ⊗ q`` is Haar-uniform within ``max_initial_angle_deg`` (180°: the attitude is an
independent uniform rotation) and the body starts tumbling at up to ``max_initial_rate``.
Success: error < ``success_angle_deg`` and |ω| < ``success_rate`` held for ``hold_time``
(scene values); failure: |ω| > ``rate_limit``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.envs.options import options_table
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
class ReorientWeights(Weights):
    """Reward weights (per control step; θ the error, ω the body rate, L the rate limit).

    attitude ``−w·θ/π``; rate ``−w·min(|ω|/L, 1)``; fuel ``−w·Σu_iF_i/ΣF_i``; progress
    ``w·(θ_prev − θ)/π`` (potential-based shaping); hold ``+w`` per step inside the success
    thresholds; failure ``−w`` once, on loss of control; precision ``+w·θ_s/(θ_s + θ)`` with
    θ_s the success angle (off by default: a steep pull over the last degrees, for learners
    that stop a few degrees short when the linear attitude term is all that is left).
    """

    attitude: float = 0.2
    rate: float = 0.05
    fuel: float = 0.05
    progress: float = 10.0
    hold: float = 1.0
    failure: float = 25.0
    precision: float = 0.0


def initial_ranges(scene, max_angle_deg=None, max_rate=None) -> tuple[float, float]:
    """Validated (max initial angle in rad, max initial rate in rad/s); None: scene default."""
    ep = scene.episode
    deg = ep.max_initial_angle_deg if max_angle_deg is None else max_angle_deg
    rate = ep.max_initial_rate if max_rate is None else max_rate
    deg = validation.number("max_initial_angle_deg", deg, low=0.0, high=180.0)
    rate = validation.number("max_initial_rate (rad/s, below the rate limit)", rate, low=0.0,
                             high=ep.rate_limit, high_open=True)
    return math.radians(deg), rate


@dataclass(frozen=True, eq=False)
class Reorient(Task):
    """Turn to a fixed target attitude and hold it (see the module docstring)."""

    name: ClassVar[str] = "reorient"
    observation_structure: ClassVar[dict] = {"q_err": 4, "omega_B": 3}
    start_slots: ClassVar[int] = 24
    error_info_key: ClassVar[str] = "attitude_error_deg"
    WeightsType: ClassVar[type] = ReorientWeights
    state_fields: ClassVar[dict] = {"q_target_conj": "c4", "q_err": "c4", "angle": "f",
                                    "rate": "f", "hold": "i"}
    reset_options: ClassVar[dict] = {"q": 4, "omega_B": 3, "q_target": 4}

    weights: ReorientWeights = ReorientWeights()
    max_initial_angle: float = math.pi  # rad
    max_initial_rate: float = 0.02  # rad/s

    def observation_scale(self) -> dict:
        return {"q_err": 1.0, "omega_B": self.rate_limit}

    def with_initial_ranges(self, max_initial_angle_deg=None, max_initial_rate=None):
        deg = math.degrees(self.max_initial_angle) if max_initial_angle_deg is None \
            else max_initial_angle_deg
        rate = self.max_initial_rate if max_initial_rate is None else max_initial_rate
        angle, rate = initial_ranges(self.plant.scene, deg, rate)
        return replace(self, max_initial_angle=angle, max_initial_rate=rate)

    # ------------------------------------------------------------------- episode start

    def sample_start(self, draws) -> dict:
        """Target uniform on SO(3); error Haar-uniform within the angle; tumble up to the rate.

        Stream "task" (two uniform slots per normal): normals 0–3 target, 4–6 rate direction,
        uniform 14 rate magnitude; then the error: normals 8–11 (uniform on SO(3), the
        full-angle case) or normals 8–10 (axis) and uniform 22 (angle). Normal k depends on
        slots 2k and 2k + 1 alone, so all twelve come from one request (7 and 11 go unused).
        """
        xp = draws.xp
        g = draws.normal("task", 12)
        (u_rate,) = draws.uniform("task", 1, offset=14)
        q_target = k.qnormalize(g[0:4])
        omega_B = k.scale(unit(g[4:7], xp), self.max_initial_rate * u_rate)
        if self.max_initial_angle >= math.pi:
            error = k.qnormalize(g[8:12])
        else:
            (u_angle,) = draws.uniform("task", 1, offset=22)
            theta = restricted_haar_angle(u_angle, self.max_initial_angle, xp)
            error = k.exp(k.scale(unit(g[8:11], xp), theta))
        return {"q": k.qmul(q_target, error), "omega_B": omega_B, "q_target": q_target}

    def complete_start(self, start: dict, xp) -> None:
        q_target_conj = conj(start.pop("q_target"))
        e, angle = error_quaternion(q_target_conj, start["q"], xp)
        w = start["omega_B"]
        start.update(q_target_conj=q_target_conj, q_err=e, angle=angle,
                     rate=xp.sqrt(k.dot(w, w)), hold=0 * angle)

    # ------------------------------------------------------------------- per step

    def observe(self, st, q, w, xp) -> tuple:
        """Canonical q_err (4), then ω_B / rate_limit clipped to [-1, 1] (3)."""
        e = st.q_err if q is st.q else error_quaternion(st.q_target_conj, q, xp)[0]
        s = self.inv_rate_limit
        clip = xp.clip
        return (*e, clip(w[0] * s, -1.0, 1.0), clip(w[1] * s, -1.0, 1.0),
                clip(w[2] * s, -1.0, 1.0))

    def _update_errors(self, st, xp) -> tuple:
        """Set q_err, rate and the hold counter of ``st`` after a step; returns (angle (rad),
        rate (rad/s), inside the thresholds, failure: |ω| > rate limit)."""
        st.q_err, angle = error_quaternion(st.q_target_conj, st.q, xp)
        w = st.omega_B
        st.rate = rate = xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        inside = (angle < self.success_angle) & (rate < self.success_rate)
        st.hold = xp.where(inside, st.hold + 1, 0)
        return angle, rate, inside, rate > self.rate_limit

    def evaluate(self, st, effort, xp):
        """Reward terms, success (thresholds held) and failure (|ω| > rate limit)."""
        wt = self.weights
        angle, rate, inside, failure = self._update_errors(st, xp)
        terms = tuple.__new__(self.Terms, (
            -wt.attitude * _INV_PI * angle,
            -wt.rate * xp.minimum(rate * self.inv_rate_limit, 1.0),
            -wt.fuel * effort,
            wt.progress * _INV_PI * (st.angle - angle),
            wt.hold * inside,
            -wt.failure * failure,
            # Last, so that with weight 0 the reward is the same sum to the last bit.
            wt.precision * self.success_angle / (self.success_angle + angle)
            if wt.precision else 0.0 * angle,
        ))
        st.angle = angle
        return terms, st.hold >= self.hold_steps, failure

    def info(self, st, xp) -> dict:
        """attitude_error_deg and rate_dps."""
        return {"attitude_error_deg": st.angle * _DEG, "rate_dps": st.rate * _DEG}

    def target(self, st) -> tuple:
        """The target quaternion (4 components), for rendering."""
        c = st.q_target_conj
        return (c[0], -c[1], -c[2], -c[3])

    def error_angle(self, st):
        return st.angle


@dataclass(frozen=True, eq=False)
class ReorientV1(v1.V1Decode, Reorient):
    """Reorient, v1 observation and reward (:mod:`rbenv.tasks.v1`); same episodes as v0."""

    name: ClassVar[str] = "reorient_v1"
    scene_table: ClassVar[str] = "reorient"
    observation_structure: ClassVar[dict] = {"rot6_err": 6, "attitude_fine": 3, "omega_B": 3,
                                             "omega_fine": 3}
    WeightsType: ClassVar[type] = v1.V1Weights

    weights: v1.V1Weights = v1.V1Weights()

    def observation_scale(self) -> dict:
        return {"rot6_err": 1.0, "attitude_fine": 1.0, "omega_B": self.rate_limit,
                "omega_fine": 1.0}

    def observe(self, st, q, w, xp) -> tuple:
        """rot6(q_err) (6), fine(θ·axis, θ, θ_s) (3), ω_B/L clipped (3), fine(ω, |ω|, ω_s) (3)."""
        e, angle = (st.q_err, st.angle) if q is st.q else \
            error_quaternion(st.q_target_conj, q, xp)
        return (*v1.rot6(e), *v1.axis_angle_fine(e, angle, self.success_angle, xp),
                *v1.rate_features(w, self.inv_rate_limit, self.success_rate, xp))

    def evaluate(self, st, effort, xp):
        """v1 terms (error ψ(θ), rate ψ(|ω|), progress on ψ(θ)), success, failure."""
        prev = st.angle
        angle, rate, _, failure = self._update_errors(st, xp)
        success = st.hold >= self.hold_steps
        drop = v1.log_scale_drop(prev, angle, self.success_angle, math.pi, xp)
        psi = v1.log_scale(angle, self.success_angle, math.pi, xp)
        psi_rate = v1.log_scale(xp.minimum(rate, self.rate_limit), self.success_rate,
                                self.rate_limit, xp)
        st.angle = angle
        return v1.terms(self.weights, drop, psi, psi_rate, effort, success, failure), \
            success, failure


@dataclass(frozen=True)
class ReorientV2Weights(Weights):
    """Reorient-v2 reward weights: v1's terms (:class:`rbenv.tasks.v1.V1Weights`) and a time
    cost, each a number ≥ 0 (sign in the term).

    ``time``: ``−w`` every control step until the episode ends, so the return counts the
    steps to success. ``fuel``: ``−w·Σu_iF_i/ΣF_i`` per step, the trade knob: a gram of
    propellant costs as much as ``(fuel/time)·steps_per_g`` control steps, where
    ``steps_per_g`` is the number of full-effort steps in a gram (2.12 on cubesat-12u, whose
    twelve 50 mN thrusters at Isp 65 s burn 0.471 g in a 0.5 s step at full throttle): with
    time 0.1, the default 1.5 prices a gram at 32 steps (15.9 s). ``progress`` is v1's
    potential-based shaping, 2.5× stronger: with 10, PPO stalled at 0–44 % success on fuel
    weights of 1.5 and more (it learned to save propellant before it learned to slew). The
    error and rate terms of v1 are off: a slew at the rate limit is what a fast policy flies.
    With the discount of the shipped PPO (0.98) the success pay arriving sooner also prices
    time, so measured settle times move less with the knob than this price says
    (docs/results.md, "The time–propellant trade").
    """

    error: float = 0.0
    rate: float = 0.0
    fuel: float = 1.5
    progress: float = 25.0
    success: float = 20.0
    failure: float = 25.0
    time: float = 0.1


@dataclass(frozen=True, eq=False)
class ReorientV2(ReorientV1):
    """Reorient, v1 observation, v1 reward plus a time cost (:class:`ReorientV2Weights`)."""

    name: ClassVar[str] = "reorient_v2"
    WeightsType: ClassVar[type] = ReorientV2Weights

    weights: ReorientV2Weights = ReorientV2Weights()

    def evaluate(self, st, effort, xp):
        """v1's terms and success/failure, then the time cost ``−w_time`` of the step."""
        terms, success, failure = super().evaluate(st, effort, xp)
        time = 0.0 * st.angle - self.weights.time
        return tuple.__new__(self.Terms, (*terms, time)), success, failure


def _make(cls, plant, reward_weights, max_initial_angle_deg, max_initial_rate, task_options):
    option_table(plant.scene, cls, task_options)  # it takes none: unknown names raise
    angle, rate = initial_ranges(plant.scene, max_initial_angle_deg, max_initial_rate)
    return cls(plant=plant, weights=cls.WeightsType.from_mapping(reward_weights),
               max_initial_angle=angle, max_initial_rate=rate)


def make_reorient(plant, reward_weights=None, max_initial_angle_deg=None,
                  max_initial_rate=None, task_options=None) -> Reorient:
    """The reorientation task on ``plant`` with validated options (None: scene defaults)."""
    return _make(Reorient, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def make_reorient_v1(plant, reward_weights=None, max_initial_angle_deg=None,
                     max_initial_rate=None, task_options=None) -> ReorientV1:
    """The v1 reorientation task (options as :func:`make_reorient`)."""
    return _make(ReorientV1, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


def make_reorient_v2(plant, reward_weights=None, max_initial_angle_deg=None,
                     max_initial_rate=None, task_options=None) -> ReorientV2:
    """The v2 reorientation task (options as :func:`make_reorient`)."""
    return _make(ReorientV2, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options)


ENV_DOC = """Reorient a satellite to a target attitude by firing body-fixed thrusters.

    Made by ``gym.make("rbenv/SatelliteReorient-v0", **kwargs)``.

    **Arguments** (all optional; :class:`rbenv.envs.options.EnvOptions`):

OPTIONS_TABLE

    **Action** ``Box(-1, 1, (n,), float32)``, one entry per thruster: the throttle (duty cycle
    over the control step) is ``clip(a, 0, 1)``, so ``a ≤ 0`` is off. ``on_off``: ``a > 0``
    fires at full throttle. ``torque``: ``Box(-1, 1, (3,))``, a body torque as a fraction of
    the per-axis authority, turned into throttles by the allocator. ``acceleration`` (wheels):
    one entry per wheel, the wheel acceleration as a fraction of the scene's command clamp
    (``innocube-3u``); ``acceleration_lifted``: the same, lifted over the wheels' deadband (a
    request below a quarter of its upper bound is none, any other at least that bound), and
    the observation adds ``wheel_command``, the last step's command after the lift. Values
    outside [-1, 1] are clipped; NaN raises ``ValueError``.

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
    start; with wheels also ``"wheel_speed": (n,)`` (rad/s) and, with wheels as flown,
    ``"wheel_clock_s": (1,)`` (s since their first command; −1 before it). With ``[sensors]``
    the observation is the gyro-integrated, delayed measurement and info adds
    ``sensed_attitude_error_deg``. **Seeding**: episode ``e`` after ``reset(seed=s)`` is a
    pure function of (s, e) (:mod:`rbenv.satellite.draws`).

    **Version History**

    * v0, orbit torques evaluated where they act (a physics fix, same version): on a scene
      with an orbit (``cubesat-6u-rw``) the gravity gradient and the rods' ``m × B`` (the
      field fixed in inertial axes, the dipole command held) are evaluated at every
      integrator stage instead of held over the substep in body axes, so its episodes
      change: with idle wheels and random rod commands (seed 1,000,000) the attitude moves
      by 2.3e-5 rad after its 80 s. Scenes without an orbit are bit-identical.
    * v0: first release. Episode starts are counter-based draws (since rbenv 0.2; rbenv 0.1
      drew them from ``np_random``, so seeded episodes differ between the two). rbenv 0.2 adds
      the ``precision`` reward term, weight 0 by default: default rewards are unchanged to the
      last bit, and ``info`` gains ``reward_precision``.
    """.replace("OPTIONS_TABLE", options_table())

# The env entry: registered by rbenv/__init__.py (rbenv.envs.registry); trained with the settings
# of rbenv.agents.settings.
SPEC = TaskSpec(env_id="rbenv/SatelliteReorient-v0", task=Reorient, make=make_reorient,
                env_doc=ENV_DOC)

ENV_DOC_V1 = """Reorient a satellite to a target attitude (v1 observation and reward).

    Made by ``gym.make("rbenv/SatelliteReorient-v1", **kwargs)``; arguments, action, episode
    end, info and reset options as ``rbenv/SatelliteReorient-v0`` (:class:`SatelliteReorientEnv`),
    and the same episodes for the same seed.

    **Arguments** (all optional; :class:`rbenv.envs.options.EnvOptions`):

OPTIONS_TABLE

    **Observation** ``Box(-1, 1, (15,), float32)``, ``observation_structure``
    ``{"rot6_err": 6, "attitude_fine": 3, "omega_B": 3, "omega_fine": 3}``: the first two
    columns of the error rotation R(q_target* ⊗ q) (continuous in the attitude); the error as
    an axis-angle vector θ·axis scaled by 1/(θ_s + θ) (length 1/2 at the 1° threshold θ_s);
    ``ω_B / rate_limit`` clipped; ``ω_B / (ω_s + |ω|)`` (length 1/2 at the success rate).

    **Reward** (:mod:`rbenv.tasks.v1`; ``ψ(x) = log(1 + x/x_s)/log(1 + x_max/x_s)``): error
    ``−0.1·ψ(θ)``, rate ``−0.05·ψ(|ω|)``, fuel ``−1.0·Σu_iF_i/ΣF_i``, progress
    ``10·(ψ(θ_prev) − ψ(θ))``, success ``+20`` once when the hold completes, failure ``−25``
    on loss of control (``reward_weights`` overrides these). Nothing is paid for staying inside
    the thresholds: the episode's success pays more than any hovering can.

    """.replace("OPTIONS_TABLE", options_table()) + v1.version_history(
        "rbenv/SatelliteReorient-v0")

SPEC_V1 = TaskSpec(env_id="rbenv/SatelliteReorient-v1", task=ReorientV1, make=make_reorient_v1,
                   env_doc=ENV_DOC_V1)

ENV_DOC_V2 = """Reorient a satellite to a target attitude, paying for time and propellant.

    Made by ``gym.make("rbenv/SatelliteReorient-v2", **kwargs)``; arguments, observation,
    action, episode end, info and reset options as ``rbenv/SatelliteReorient-v1``, and the
    same episodes for the same seed.

    **Arguments** (all optional; :class:`rbenv.envs.options.EnvOptions`):

OPTIONS_TABLE

    **Reward** (:class:`rbenv.tasks.reorient.ReorientV2Weights`; ψ as in v1): time ``−0.1``
    every control step, fuel ``−1.5·Σu_iF_i/ΣF_i``, progress ``25·(ψ(θ_prev) − ψ(θ))``,
    success ``+20`` once when the hold completes, failure ``−25`` on loss of control; v1's
    error and rate terms are there with weight 0 (``reward_weights`` overrides any of these).
    Up to the shaping, which telescopes, the return is ``−(0.1·steps + 1.5·Σ effort)`` plus
    the success pay: the time to settle and the propellant on one scale.

    **The trade**: ``reward_weights={"fuel": w}`` sets the price of propellant in time. With
    the time weight 0.1 a gram costs ``(w/0.1)·steps_per_g`` control steps, ``steps_per_g``
    the full-effort steps in a gram (cubesat-12u: 2.12 at 0.5 s, so a gram is priced at
    10.6·w s; the default 1.5 at 15.9 s). Measured with PPO (2 M steps, 500 held-out
    episodes, docs/results.md): 0.5 and 1.0 spend 1.88–2.00 g at 20.5–21.0 s, 1.5 spends
    1.51–1.70 g at 20.5–21.0 s, 3.0 slows to 31.5 s and 1.10 g (98 % success).

    **Version History**

    * v2: the time–propellant trade made explicit: a time cost per control step
      until the episode ends replaces v1's error and rate terms (weights 0; ``error`` pushed
      little at the end of a slew and ``rate`` taxed a fast one), the fuel weight, now the
      one trade knob, defaults to 1.5, and the progress shaping weighs 25 (v1: 10).
      Observation, physics, starts, success and failure are v1's, episode for episode.
    * v1: see ``rbenv/SatelliteReorient-v1``.
    * v0: see ``rbenv/SatelliteReorient-v0``.
    """.replace("OPTIONS_TABLE", options_table())

SPEC_V2 = TaskSpec(env_id="rbenv/SatelliteReorient-v2", task=ReorientV2, make=make_reorient_v2,
                   env_doc=ENV_DOC_V2)
