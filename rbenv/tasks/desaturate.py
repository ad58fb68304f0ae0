"""Desaturate: hold the attitude while bringing the stored wheel momentum down.

``rbenv/SatelliteDesaturate-v0``. Reaction wheels absorb every disturbance torque, so their
momentum grows until it is dumped with an external torque: the magnetorquers' ``m × B`` or
the thrusters (the actuators-and-orbit reference note, §4). The episode starts near a fixed
target attitude (error Haar-uniform within the option ``max_initial_angle_deg``, 2°; rate up
to ``max_initial_rate_fraction``, 1 %, of the rate limit) with the wheels loaded: the wheel
speeds are ``Ω = f·Ω_max ⊙ d``, ``d`` a uniformly random unit vector of R^n (stream "task"),
``f`` the option ``initial_speed_fraction``.

Success: the stored momentum ``|G J Ω|`` (relative speeds, as Basilisk's
mtbMomentumManagement) below ``momentum_threshold_fraction`` of one wheel's largest momentum
``J Ω_max``, *and* the attitude error below the success angle and |ω| below the success rate,
held for the hold time. Failure: |ω| above the rate limit, or the attitude error above
``max_error_deg`` (the attitude was not held).

Refused (named error) on a scene without ``[wheels]``: there is no momentum to dump.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.backend import FLOAT
from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.actuators.magnetorquers import FIELD_SCALE_T
from rbenv.tasks.base import (
    Weights,
    conj,
    error_quaternion,
    option_table,
    restricted_haar_angle,
    unit,
)
from rbenv.tasks.reorient import Reorient
from rbenv.tasks.spec import TaskSpec


@dataclass(frozen=True)
class DesaturateWeights(Weights):
    """Reward weights (per control step; θ the attitude error, θ_f the failure angle,
    |h| the stored wheel momentum, h_0 its start ``f·J·Ω_max``: one wheel's largest momentum
    times the initial speed fraction f).

    attitude ``−w·min(θ/θ_f, 1)``; momentum ``−w·min(|h|/h_0, 1)``; progress
    ``w·(|h|_prev − |h|)/h_0`` (potential-based); effort ``−w·effort`` (the actuators' share of
    their full power or propellant rate); hold ``+w`` per step inside every threshold; failure
    ``−w`` once (rate limit, or θ > θ_f).
    """

    attitude: float = 1.0
    momentum: float = 0.2
    progress: float = 10.0
    effort: float = 0.05
    hold: float = 1.0
    failure: float = 25.0


@dataclass(frozen=True, eq=False)
class Desaturate(Reorient):
    """Hold a fixed attitude and unload the wheels (see the module docstring). Its
    observation, info, rendering and initial ranges are reorientation's."""

    name: ClassVar[str] = "desaturate"
    start_slots: ClassVar[int] = 24 + 32
    WeightsType: ClassVar[type] = DesaturateWeights
    state_fields: ClassVar[dict] = {"q_target_conj": "c4", "q_err": "c4", "angle": "f",
                                    "rate": "f", "momentum": "f", "hold": "i"}
    OPTIONS: ClassVar[dict] = {"initial_speed_fraction": 0.3,
                               "momentum_threshold_fraction": 0.1,
                               "max_error_deg": 20.0, "max_initial_angle_deg": 2.0,
                               "max_initial_rate_fraction": 0.01}

    weights: DesaturateWeights = DesaturateWeights()
    max_initial_angle: float = math.radians(2.0)  # rad
    max_initial_rate: float = 0.0  # rad/s
    initial_speed_fraction: float = 0.3  # of each wheel's Ω_max
    momentum_threshold: float = 0.0  # N·m·s, success below it
    momentum_scale: float = 1.0  # N·m·s, h_0 of the reward
    max_error: float = math.radians(20.0)  # rad, failure above it
    axes_B: np.ndarray = None  # (n, 3) wheel spin axes
    spin_inertia: np.ndarray = None  # (n,) kg·m²
    max_speed: np.ndarray = None  # (n,) rad/s
    axes: tuple = ()  # the spin axes as n 3-tuples of floats (the per-step path)
    spin: tuple = ()  # the spin inertias as n floats, kg·m²

    # ------------------------------------------------------------------- momentum

    def wheel_momentum_B(self, wheel_speed: tuple, start: tuple = (0.0, 0.0, 0.0)) -> tuple:
        """``start + G (J ⊙ Ω)``, N·m·s, body axes (3 components): the wheels' stored momentum
        added to ``start`` wheel by wheel; wheel_speed one component per wheel, rad/s (floats
        for one satellite, (N,) arrays for N; the wheels' state kind ``cn``)."""
        h = start
        for i, s in enumerate(wheel_speed):
            h = k.add(h, self.axes[i], self.spin[i] * s)
        return h

    def stored_momentum(self, wheel_speed: tuple, xp):
        """``|G (J ⊙ Ω)|``, N·m·s (:meth:`wheel_momentum_B`'s norm)."""
        h = self.wheel_momentum_B(wheel_speed)
        return xp.sqrt(k.dot(h, h))

    # ------------------------------------------------------------------- episode start

    def sample_start(self, draws) -> dict:
        """Target uniform on SO(3), error within the angle, a small tumble, loaded wheels.

        Stream "task": normals 0–3 target, 4–6 error axis, 7–9 rate direction, uniforms 20
        (error angle) and 21 (rate); normals 12… the wheel-speed direction in R^n.
        """
        xp = draws.xp
        g = draws.normal("task", 10)
        u = draws.uniform("task", 2, offset=20)
        q_target = k.qnormalize(g[0:4])
        theta = restricted_haar_angle(u[0], self.max_initial_angle, xp)
        q = k.qmul(q_target, k.exp(k.scale(unit(g[4:7], xp), theta)))
        d = draws.normal_array("task", len(self.spin_inertia), offset=24).T  # (m, n)
        d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
        return {"q": q, "omega_B": k.scale(unit(g[7:10], xp), self.max_initial_rate * u[1]),
                "q_target": q_target,
                "wheel_load": self.initial_speed_fraction * self.max_speed * d}

    def complete_start(self, start: dict, xp) -> None:
        # The plant's start holds the scene's wheel speeds; this task replaces them.
        load = np.asarray(start.pop("wheel_load"), dtype=float)  # (m, n)
        start["wheel_speed"] = tuple(load[0].tolist()) if xp is FLOAT else tuple(load.T)
        q_target_conj = conj(start.pop("q_target"))
        e, angle = error_quaternion(q_target_conj, start["q"], xp)
        w = start["omega_B"]
        speed = start["wheel_speed"]
        momentum = self.stored_momentum(speed, xp)
        start.update(q_target_conj=q_target_conj, q_err=e, angle=angle,
                     rate=xp.sqrt(k.dot(w, w)), momentum=momentum, hold=0 * angle)

    # ------------------------------------------------------------------- per step

    def evaluate(self, st, effort, xp):
        """Reward terms, success (all thresholds held) and failure (rate limit, lost hold)."""
        wt = self.weights
        st.q_err, angle = error_quaternion(st.q_target_conj, st.q, xp)
        w = st.omega_B
        st.rate = rate = xp.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        momentum = self.stored_momentum(st.wheel_speed, xp)
        inside = (angle < self.success_angle) & (rate < self.success_rate) & \
            (momentum < self.momentum_threshold)
        st.hold = xp.where(inside, st.hold + 1, 0)
        failure = (rate > self.rate_limit) | (angle > self.max_error)
        inv_h = 1.0 / self.momentum_scale
        terms = tuple.__new__(self.Terms, (
            -wt.attitude * xp.minimum(angle * (1.0 / self.max_error), 1.0),
            -wt.momentum * xp.minimum(momentum * inv_h, 1.0),
            wt.progress * inv_h * (st.momentum - momentum),
            -wt.effort * effort,
            wt.hold * inside,
            -wt.failure * failure,
        ))
        st.angle, st.momentum = angle, momentum
        return terms, st.hold >= self.hold_steps, failure

@dataclass(frozen=True, eq=False)
class DesaturateV1(Desaturate):
    """Desaturate with the wheels' attitude hold in the loop: the policy commands the rods.

    v0's starts, reward, success and failure, episode for episode; the action's meaning
    changes, and the observation adds ``dump_B`` (:meth:`observe`). Every control step,
    before the actuators, :meth:`command` replaces the wheel entries of the action by the
    inner loop's motor torques (the law of ``WheelHoldPD`` with the rods' torque fed forward,
    as the ``unload`` baseline commands them) and keeps the rod entries, the dipole
    fractions the policy chose. Attitude hold stays the classical inner loop; the policy is
    the momentum-management law.

    The inner loop, from the true state of the step's start (body axes, SI):
    ``τ = −I c (ω − ω_c) + ω × (I ω + h_w) − m × B`` with ``ω_c = −(k/c) q_v`` capped at
    ``hold_max_rate``, ``k = 2 ω_n²``, ``c = 2 ω_n`` (ζ = 1), ``ω_n = min(0.3, 0.2/dt)`` rad/s,
    h_w = G J Ω the wheels' stored momentum, m the rods' commanded dipole (nominal axes and
    strengths) and B the field now; the motor torques ``u = −G⁺ τ``, scaled down as a whole
    where one exceeds its limit. q_v is the vector part of the canonical error quaternion
    (w ≥ 0): the episode fails above ``max_error_deg`` (< 180°), so no sign hysteresis is
    needed.
    """

    name: ClassVar[str] = "desaturate_v1"
    scene_table: ClassVar[str] = "desaturate"
    inner_loop: ClassVar[bool] = True  # command() closes the wheel loop
    observation_structure: ClassVar[dict] = {"q_err": 4, "omega_B": 3, "dump_B": 3}

    hold_stiffness: float = 0.0  # k, 1/s²
    hold_damping: float = 0.0  # c, 1/s
    hold_max_rate: float = 0.0  # rad/s, the cap on the commanded rate ω_c
    inertia_rows: tuple = ()  # the body's nominal inertia, 3 rows of 3 floats, kg·m²
    wheel_pinv_rows: tuple = ()  # G⁺, n rows of 3 floats (1/1: body torque → motor torques)
    wheel_max_torque: tuple = ()  # n floats, N·m
    wheel_columns: tuple = ()  # the wheel entries' indices in the action
    rod_dipoles: tuple = ()  # rows μ_max,i ĝ_i (A·m², body axes), one per rod
    rod_columns: tuple = ()  # the rod entries' indices in the action

    def observation_scale(self) -> dict:
        return {**super().observation_scale(), "dump_B": self.momentum_scale * FIELD_SCALE_T}

    def observe(self, st, q, w, xp) -> tuple:
        """v0's (q_err 4, ω_B/L 3), then ``dump_B`` (3): ``(h_w × B)/(h_0 · 50 µT)`` clipped
        to [-1, 1], h_w the wheels' stored momentum and B the field (true values, as the inner
        loop's): the direction of the cross-product law's dipole, ``m ∝ h_w × B``, whose
        torque ``m × B`` takes momentum out of the wheels."""
        h = self.wheel_momentum_B(st.wheel_speed)
        d = k.scale(k.cross(h, st.field_B_T), 1.0 / (self.momentum_scale * FIELD_SCALE_T))
        clip = xp.clip
        return (*super().observe(st, q, w, xp), clip(d[0], -1.0, 1.0), clip(d[1], -1.0, 1.0),
                clip(d[2], -1.0, 1.0))

    def hold_torque_B(self, st, xp) -> tuple:
        """The inner loop's body-torque demand before the feedforward, N·m (3 components):
        ``−I c (ω − ω_c) + ω × (I ω + h_w)``."""
        w = st.omega_B
        e = st.q_err
        gain = self.hold_stiffness / self.hold_damping
        wc = (-gain * e[1], -gain * e[2], -gain * e[3])
        speed = xp.sqrt(k.dot(wc, wc))
        cap = xp.minimum(1.0, self.hold_max_rate / xp.maximum(speed, 1e-300))
        dw = k.sub(w, k.scale(wc, cap))
        i_rows = self.inertia_rows
        i_dw = tuple([k.dot(row, dw) for row in i_rows])
        h = self.wheel_momentum_B(st.wheel_speed, tuple([k.dot(row, w) for row in i_rows]))
        return k.add(k.scale(i_dw, -self.hold_damping), k.cross(w, h))

    def command(self, st, action, xp):
        """The plant's action for the policy's ``action`` ((n,) or (N, n), v0's layout): the
        rod entries as given, the wheel entries the inner loop's torques over their limits
        (a copy; the policy's wheel entries are not read)."""
        # torch tensors too: the torch env refuses v1, but transition.step runs on tensors
        a = action.clone() if hasattr(action, "clone") else np.array(action, dtype=np.float64)
        clip = xp.clip
        rods = [clip(a[..., j], -1.0, 1.0) for j in self.rod_columns]
        if xp is FLOAT:
            rods = [float(r) for r in rods]
        m_B = k.scale(self.rod_dipoles[0], rods[0])
        for dipole, r in zip(self.rod_dipoles[1:], rods[1:], strict=True):
            m_B = k.add(m_B, dipole, r)
        tau = k.sub(self.hold_torque_B(st, xp), k.cross(m_B, st.field_B_T))
        u = [-k.dot(row, tau) for row in self.wheel_pinv_rows]
        ratio = abs(u[0]) / self.wheel_max_torque[0]
        for ui, u_max in zip(u[1:], self.wheel_max_torque[1:], strict=True):
            ratio = xp.maximum(ratio, abs(ui) / u_max)
        scale = 1.0 / xp.maximum(ratio, 1.0)
        for j, ui, u_max in zip(self.wheel_columns, u, self.wheel_max_torque, strict=True):
            a[..., j] = ui * scale / u_max
        return a


# The wheels' attitude hold of a magnetic desaturation, shared by Desaturate-v1's inner loop
# and the WheelHoldPD and Unload baselines: its cap on the commanded rate, a fraction of the
# scene's rate limit.
HOLD_MAX_RATE_FRACTION = 0.1


def hold_natural_frequency(control_dt: float) -> float:
    """ω_n of the wheels' attitude hold, rad/s, at a control step of ``control_dt`` s:
    ``min(0.3, 0.2/dt)``, so that the damping per step ``c·dt = 2ζω_n·dt`` stays at 0.4
    (ζ = 1), well inside the discrete limit of 2, at a magnetic desaturation's 10 s step."""
    return min(0.3, 0.2 / control_dt)


def make_desaturate(plant, reward_weights=None, max_initial_angle_deg=None,
                    max_initial_rate=None, task_options=None) -> Desaturate:
    """The desaturation task on ``plant`` (options: scene ``[tasks.desaturate]``, then
    ``task_options``); a scene without wheels is refused by name."""
    return _make(Desaturate, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options, {})


def make_desaturate_v1(plant, reward_weights=None, max_initial_angle_deg=None,
                       max_initial_rate=None, task_options=None) -> DesaturateV1:
    """The v1 desaturation task (options as :func:`make_desaturate`); it needs the rods
    (``[magnetorquers]``) and the throttle action mode (the inner loop commands torques)."""
    _check_wheels(plant)
    rods = plant.actuator("magnetorquers")
    if rods is None:
        raise InvalidParameterError(
            f"rbenv/SatelliteDesaturate-v1 commands magnetorquers, but scene "
            f"{plant.scene.name!r} has no [magnetorquers] table; use cubesat-6u-rw")
    if plant.action_mode != "throttle":
        raise InvalidParameterError(
            f"action_mode must be 'throttle' for rbenv/SatelliteDesaturate-v1 (its inner loop "
            f"commands the wheels' motor torques), got {plant.action_mode!r}")
    wheels = plant.actuator("wheels")
    nat = hold_natural_frequency(plant.control_dt)
    inertia = plant.scene.body.inertia

    def columns(act):
        s = plant.action_slices[plant.actuators.index(act)]
        return tuple(range(s.start, s.stop))

    extra = {"hold_stiffness": 2.0 * nat * nat, "hold_damping": 2.0 * nat,
             "hold_max_rate": HOLD_MAX_RATE_FRACTION * plant.scene.episode.rate_limit,
             "inertia_rows": tuple(tuple(float(c) for c in row) for row in inertia),
             "wheel_pinv_rows": wheels.pinv_rows, "wheel_max_torque": wheels.max_torque,
             "wheel_columns": columns(wheels), "rod_dipoles": rods.dipoles,
             "rod_columns": columns(rods)}
    return _make(DesaturateV1, plant, reward_weights, max_initial_angle_deg, max_initial_rate,
                 task_options, extra)


def _check_wheels(plant) -> None:
    if plant.actuator("wheels") is None:
        raise InvalidParameterError(
            f"task 'desaturate' unloads reaction wheels, but scene {plant.scene.name!r} has "
            "no [wheels] table; use a scene with wheels (cubesat-6u-rw, cubesat-12u-rw)")


def _make(cls, plant, reward_weights, max_initial_angle_deg, max_initial_rate, task_options,
          extra: dict) -> Desaturate:
    opts = option_table(plant.scene, cls, task_options)
    _check_wheels(plant)
    wheels = plant.actuator("wheels")
    ws = wheels.wheels
    frac = validation.number("tasks.desaturate.initial_speed_fraction",
                             opts["initial_speed_fraction"], low=0.0, high=1.0)
    thr = validation.number("tasks.desaturate.momentum_threshold_fraction",
                            opts["momentum_threshold_fraction"], low=0.0, high=1.0,
                            low_open=True)
    fail = validation.number("tasks.desaturate.max_error_deg", opts["max_error_deg"],
                             low=0.0, high=180.0, low_open=True)
    deg = validation.number("tasks.desaturate.max_initial_angle_deg",
                            opts["max_initial_angle_deg"], low=0.0, high=fail)
    rate = validation.number("tasks.desaturate.max_initial_rate_fraction",
                             opts["max_initial_rate_fraction"], low=0.0, high=1.0,
                             high_open=True)
    h_wheel = float(np.min(ws.inertia * ws.max_speed))  # one wheel's largest momentum
    task = cls(plant=plant, weights=DesaturateWeights.from_mapping(reward_weights),
                      initial_speed_fraction=frac, momentum_threshold=thr * h_wheel,
                      momentum_scale=max(frac, thr) * h_wheel, max_error=math.radians(fail),
                      max_initial_angle=math.radians(deg),
                      max_initial_rate=rate * plant.scene.episode.rate_limit,
                      axes_B=ws.axes_B, spin_inertia=ws.inertia, max_speed=ws.max_speed,
                      axes=tuple(tuple(float(c) for c in g) for g in ws.axes_B),
                      spin=tuple(float(j) for j in ws.inertia), **extra)
    if task.success_angle >= task.max_error:
        raise InvalidParameterError(
            f"tasks.desaturate.max_error_deg must exceed the success angle "
            f"{math.degrees(task.success_angle):g} deg, got {fail!r}")
    return task.with_initial_ranges(max_initial_angle_deg, max_initial_rate)


ENV_DOC = """Hold a satellite's attitude while unloading its reaction wheels' momentum.

    Made by ``gym.make("rbenv/SatelliteDesaturate-v0", **kwargs)``; arguments as
    :class:`SatelliteReorientEnv`; the scene (default ``"cubesat-6u-rw"``) must have
    ``[wheels]``.
    ``task_options`` overrides the scene's ``[tasks.desaturate]`` table:
    ``initial_speed_fraction`` (0.3: each wheel starts at this fraction of its speed limit
    along a random direction of wheel-speed space), ``momentum_threshold_fraction`` (0.1:
    success below this fraction of one wheel's largest momentum J·Ω_max),
    ``max_error_deg`` (20: the attitude hold is lost above it), ``max_initial_angle_deg`` (2)
    and ``max_initial_rate_fraction`` (0.01 of the rate limit): the start near the target.

    **Action**: every actuator of the scene (wheels, then magnetorquers or thrusters).
    **Observation** ``{"q_err": 4, "omega_B": 3}`` as the reorientation env, then the
    actuators' parts (``wheel_speed`` Ω/Ω_max, ``field_B`` the magnetometer).

    **Reward**: attitude ``−1·min(θ/θ_f, 1)``, momentum ``−0.2·min(|h|/h_0, 1)``, progress
    ``10·(|h|_prev − |h|)/h_0``, effort ``−0.05·effort``, hold ``+1`` per step inside every
    threshold, failure ``−25`` (h_0 = initial_speed_fraction·J·Ω_max).

    **Episode end**: ``terminated`` with success when |h| < threshold, θ < success angle and
    |ω| < success rate are held for the hold time; ``terminated`` without success above the
    rate limit or ``max_error_deg``; ``truncated`` at the scene's duration
    (``[tasks.desaturate.episode]``). **Info**: ``attitude_error_deg``, ``rate_dps``,
    ``wheel_momentum_Nms``, energy, ``is_success``, ``reward_<term>``.
    **Reset options**: ``{"q": (4,), "omega_B": (3,), "q_target": (4,)}``.

    **Version History**

    * v0, orbit torques evaluated where they act (a physics fix, same version): on a scene
      with an orbit (``cubesat-6u-rw``) the gravity gradient and the rods' ``m × B`` (the
      field fixed in inertial axes, the dipole command held) are evaluated at every
      integrator stage instead of held over the substep in body axes, so its episodes
      change: with idle wheels and random rod commands (seed 1,000,000) the attitude moves
      by 8e-4 rad after 230 s at 10 s × 4. Scenes without an orbit are bit-identical.
    * v0: first release.
    """

# The env entry: registered by rbenv/__init__.py (rbenv.envs.registry); trained with the settings
# of rbenv.agents.settings. Episodes are longer than the other tasks' 160 steps: magnetic
# unloading takes a good part of an orbit.
SPEC = TaskSpec(env_id="rbenv/SatelliteDesaturate-v0", task=Desaturate, make=make_desaturate,
                max_episode_steps=300, env_doc=ENV_DOC, default_scene="cubesat-6u-rw",
                needs=("wheels",))

ENV_DOC_V1 = """Hold a satellite's attitude while its policy unloads the wheels with the rods.

    Made by ``gym.make("rbenv/SatelliteDesaturate-v1", **kwargs)``; arguments, reward,
    episode end, info and reset options as ``rbenv/SatelliteDesaturate-v0``
    (:class:`SatelliteDesaturateEnv`), and the same episodes for the same seed. The scene
    (default ``"cubesat-6u-rw"``) must have ``[wheels]`` and ``[magnetorquers]``;
    ``action_mode`` must be ``"throttle"``. ``task_options`` as v0's: ``initial_speed_fraction``,
    ``momentum_threshold_fraction``, ``max_error_deg``, ``max_initial_angle_deg`` and
    ``max_initial_rate_fraction``.

    **Action** ``Box(-1, 1, (n_wheels + n_rods,), float32)``, v0's layout: the rod entries
    are the dipole fractions the policy commands (clipped to [-1, 1]). The wheel entries are
    not read: the wheels are driven by the classical inner loop that holds the attitude, the
    ``WheelHoldPD`` law with the rods' torque fed forward (:class:`DesaturateV1`):
    ``τ = −I c (ω − ω_c) + ω × (I ω + h_w) − m × B``, ``ω_c = −(k/c) q_v`` capped at 0.1 of
    the rate limit, ``k = 2 ω_n²``, ``c = 2 ω_n``, ``ω_n = min(0.3, 0.2/dt)`` rad/s; motor
    torques ``u = −G⁺ τ``, scaled down as a whole at a wheel's limit. A zero action holds the
    attitude and unloads nothing; the ``unload`` baseline's rod law unloads.

    **Observation** ``Box(-1, 1, (16,), float32)`` on cubesat-6u-rw: v0's ``q_err`` 4 and
    ``omega_B`` 3, then ``dump_B`` 3, ``(h_w × B)/(h_0 · 50 µT)`` clipped (h_w the wheels'
    stored momentum, B the field, both true values as the inner loop's; h_0 the start's
    momentum): the direction of the cross-product law's dipole, the product a network would
    otherwise have to learn; then the actuators' ``wheel_speed`` and ``field_B`` as v0.

    **Version History**

    * v1: the policy commands the magnetorquers and the wheels hold the attitude in the
      loop; the observation adds ``dump_B``. On v0 the policy drives the wheels too, and one
      wheel at full torque for a 10 s step turns cubesat-6u-rw's bus by three times the rate
      limit: PPO lost the attitude on every episode (0 % on 3 seeds, docs/results.md).
      Physics, starts, reward, success and failure are v0's, episode for episode.
    * v0: see ``rbenv/SatelliteDesaturate-v0``.
    """

SPEC_V1 = TaskSpec(env_id="rbenv/SatelliteDesaturate-v1", task=DesaturateV1,
                   make=make_desaturate_v1, max_episode_steps=300, env_doc=ENV_DOC_V1,
                   default_scene="cubesat-6u-rw", needs=("wheels", "magnetorquers"))
