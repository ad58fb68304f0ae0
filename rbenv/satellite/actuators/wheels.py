"""Reaction wheels: rotors spun by motors about body-fixed axes, storing angular momentum.

An actuator of the plant (:mod:`rbenv.satellite.actuators.base`), configured by the scene table
``[wheels]``. Wheel i has a spin axis ĝ_i (body frame), a spin-axis inertia J_i, a motor torque
limit u_max and a speed limit Ω_max; Ω_i is its speed relative to the body. With
``G = [ĝ_1 … ĝ_n]`` and the absolute spin momenta ``h_i = J_i (Ω_i + ĝ_iᵀω)`` the bus obeys
(balanced wheels; Schaub's form, Basilisk's reactionWheelStateEffector)::

    I_RW ω̇ = −ω × (I_RW ω + G h) − G u + τ_ext,     ḣ_i = u_i,

where ``I_RW = I_sc − Σ J_i ĝ_i ĝ_iᵀ`` is the scene's whole-spacecraft inertia without the
rotors' spin inertia (the plant integrates with it) and ``u`` the net motor torque on the
wheels. The motor torque is internal: it moves momentum between bus and wheels, and the total
``I_RW ω + G h`` (in the world frame) changes only under external torque.

Command, applied in Basilisk's order: the motor torque is clipped to ±u_max; a torque that
speeds the wheel up is limited to ``(Ω_max − |Ω|) J/dt``, what brings it to the speed limit at
the end of the control step, so at the limit the motor cannot accelerate it further (u = 0,
Basilisk's rule, which checks only at the step's start and so overshoots by up to u·dt/J);
optional viscous and Coulomb friction ``−c_v Ω − τ_c sgn(Ω)`` add to it (each a number, or
``[low, high]`` drawn per episode as the as-flown effects below). Action modes: ``throttle``
(default: one entry per wheel, the motor torque as a fraction of u_max in [-1, 1]),
``torque`` (a body torque as a fraction of the per-axis authority, distributed by the
pseudo-inverse of G and scaled down as a whole when a wheel would exceed u_max) and
``acceleration`` (one entry per wheel, the commanded wheel acceleration Ω̇ as a fraction of the
flight software's clamp α_max, ``max_acceleration``; the motor torque that realizes it is
``u = J_eff α``, with ``J_eff = 1/(1/J + ĝᵀ I_RW⁻¹ ĝ)`` the inertia the relative speed sees)
and ``acceleration_lifted``, the same with the deadband's inverse, command shaping a flight
computer can do: with α_up the deadband's upper bound (the scene's ``deadband``, or the high
end of its range), a requested ``|α| < α_up/4`` is zero and any other is lifted to at least
α_up, ``α ← sign(α)·max(|α|, α_up)``, so that every command the policy sends moves the wheel
and a small one moves it by the finest step it can (:func:`lift_over_deadband`). As a flight
computer knows what it commanded, this mode also observes ``wheel_command``: the command of
the last step after the lift, α/α_max per wheel (0 at the start), since with a one-step
sensor delay the measured rates do not show it yet.

Wheels as flown (opt-in, each a ``[wheels]`` key; off by default, and then no step changes):
every command is first read as the wheel acceleration it asks for, ``α = u/J_eff`` (rad/s²);

* ``deadband`` α_db (rad/s², or ``deadband_rpm_s``): a command with |α| < α_db does nothing;
* ``realized_gain`` g: the wheel realizes g·α of what a command above the deadband asks;
* ``startup_delay_s`` T_d: after the first command above the deadband of an episode the
  wheels stay still for T_d (whole control steps: the realized command is zero on the steps
  that start less than T_d after it);
* ``speed_quantization_rpm`` q: the observed wheel speed is ``q·round(Ω/q)`` (the speed
  sensor's resolution); the physics uses the true speed.

Then the torque and speed limits below apply, as without them.

Effort: electrical power ``Σ|u_i Ω_i| + n·P_standby`` over its maximum; ``energy_J`` accounts
it. Observation part: ``wheel_speed`` Ω/Ω_max per wheel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rbenv.core import kernels as k
from rbenv.core import validation
from rbenv.core.backend import FLOAT, NUMPY
from rbenv.core.body import Wheels as Rotors
from rbenv.core.body import bus_inertia
from rbenv.core.errors import InvalidParameterError
from rbenv.satellite.actuators import tables
from rbenv.satellite.actuators.base import (
    ActuatorDefaults,
    Contribution,
    action_components,
    one_row,
)

__all__ = ["ACCELERATION_MODES", "Wheels", "lift_over_deadband", "make_wheels", "parse_wheels"]

MODES = ("throttle", "torque", "acceleration", "acceleration_lifted")
ACCELERATION_MODES = ("acceleration", "acceleration_lifted")  # commands in wheel acceleration
# acceleration_lifted: requests below this fraction of the deadband's upper bound are no
# command. A quarter held a scripted slew-and-hold law on innocube-3u at 0.15° (sensed, mean of
# 200 random slews) where a half (the nearest realizable command) held it at 0.23°.
LIFT_ZERO = 0.25
_RPM = 2.0 * math.pi / 60.0
_new = tuple.__new__
_ZERO = (0.0, 0.0, 0.0)  # the motor torque is internal: no external torque on the body


@dataclass(frozen=True, eq=False)
class WheelSet:
    """The scene's ``[wheels]`` table, validated (SI units; speeds in rad/s): the rotors
    (:class:`rbenv.core.Wheels`, the one model of their spin axes and inertia that
    :mod:`rbenv.core` steps too) and their motors, limits and non-idealities."""

    rotors: Rotors  # spin axes (n, 3, unit, body frame) and spin-axis inertias J_s (n,) kg·m²
    max_torque: np.ndarray  # (n,) N·m
    max_speed: np.ndarray  # (n,) rad/s
    # Each of viscous and coulomb: a float, or a (low, high) tuple drawn uniformly per episode.
    viscous: object = 0.0  # N·m·s/rad
    coulomb: object = 0.0  # N·m
    standby_power: float = 0.0  # W per wheel
    initial_speed: np.ndarray = None  # (n,) rad/s at the episode start
    random_speed: float = 0.0  # rad/s: ± uniform spread added per episode
    max_acceleration: float = 0.0  # rad/s², the command clamp of acceleration mode (0: none)
    # Each of the next three: a float, or a (low, high) tuple drawn uniformly per episode.
    deadband: object = 0.0  # rad/s²: commands below it do nothing
    realized_gain: object = 1.0  # realized / commanded acceleration above the deadband
    startup_delay_s: object = 0.0  # s: still after the episode's first command
    speed_quantum: float = 0.0  # rad/s: the speed sensor's resolution (0: exact)

    @property
    def as_flown(self) -> bool:
        """Whether any command non-ideality is on (deadband, gain or start-up delay)."""
        return bool(self.deadband or self.realized_gain != 1.0 or self.startup_delay_s)

    @property
    def friction_drawn(self) -> bool:
        """Whether the friction (viscous or Coulomb) is drawn per episode (a range)."""
        return isinstance(self.viscous, tuple) or isinstance(self.coulomb, tuple)

    @property
    def friction_ranges(self) -> tuple:
        """((low, high) of the viscous coefficient N·m·s/rad, of the Coulomb torque N·m):
        the per-episode draws' ranges (low == high: fixed)."""
        return tuple(v if isinstance(v, tuple) else (v, v)
                     for v in (self.viscous, self.coulomb))

    @property
    def deadband_up(self) -> float:
        """rad/s²: the deadband's upper bound (the high end of its range when drawn)."""
        d = self.deadband
        return float(d[1] if isinstance(d, tuple) else d)

    @property
    def flown_ranges(self) -> tuple:
        """((low, high) of deadband rad/s², realized gain, start-up delay s): the per-episode
        draws' ranges (low == high: fixed)."""
        return tuple(v if isinstance(v, tuple) else (v, v)
                     for v in (self.deadband, self.realized_gain, self.startup_delay_s))

    @property
    def n(self) -> int:
        return self.rotors.n

    @property
    def axes_B(self) -> np.ndarray:
        """(n, 3) unit spin axes, body frame."""
        return self.rotors.axes

    @property
    def inertia(self) -> np.ndarray:
        """(n,) kg·m², each rotor's spin-axis inertia J_s."""
        return self.rotors.inertia

    @property
    def spin_inertia_B(self) -> np.ndarray:
        """(3, 3) ``Σ J_i ĝ_i ĝ_iᵀ``, kg·m²: the rotors' share of the scene's inertia."""
        return self.rotors.spin_inertia

    def drawing(self) -> dict:
        """Keyword arguments of :class:`rbenv.envs.rendering.Renderer`: discs on the spin axes,
        their speed as a fraction of the limit."""
        return {"wheel_axes_B": self.axes_B, "wheel_max_speed": self.max_speed}


def parse_wheels(table: dict, com_B=None) -> WheelSet:
    """The ``[wheels]`` table: axes (list of [x, y, z]), inertia (kg·m²), max_torque (N·m),
    max_speed_rpm, and optional viscous (N·m·s/rad), coulomb (N·m), standby_power (W),
    initial_speed_rpm and random_speed_rpm (± uniform spread per episode); wheels as flown:
    max_acceleration and deadband (rad/s², or the same keys with ``_rpm_s``: RPM/s),
    realized_gain, startup_delay_s (s) and speed_quantization_rpm (rpm)."""
    tables.keys("wheels", table, {"axes", "inertia", "max_torque", "max_speed_rpm",
                                  "viscous", "coulomb", "standby_power", "initial_speed_rpm",
                                  "random_speed_rpm", *_FLOWN_KEYS},
                ("axes", "inertia", "max_torque", "max_speed_rpm"))
    axes = tables.axis_rows("wheels", table["axes"])  # normalised by the rotors
    n = len(axes)

    def per_wheel(key, low, high, scale=1.0):
        return tables.per_element("wheels", table, key, n, 0.0, low, high) * scale

    def scalar(key, high):
        return validation.number(f"wheels.{key}", table.get(key, 0.0), low=0.0, high=high)

    speed = per_wheel("max_speed_rpm", 1.0, 1e5, _RPM)
    start = per_wheel("initial_speed_rpm", -1e5, 1e5, _RPM)
    if np.any(np.abs(start) > speed):
        raise InvalidParameterError(
            "wheels.initial_speed_rpm must be within ±max_speed_rpm, got "
            f"{table['initial_speed_rpm']}")
    return WheelSet(rotors=Rotors(axes, per_wheel("inertia", 1e-9, 1e3)),
                    max_torque=per_wheel("max_torque", 1e-9, 1e3), max_speed=speed,
                    viscous=_ranged(table, "viscous", 0.0, low=0.0, high=1e3),
                    coulomb=_ranged(table, "coulomb", 0.0, low=0.0, high=1e3),
                    standby_power=scalar("standby_power", 1e4), initial_speed=start,
                    random_speed=scalar("random_speed_rpm", 1e5) * _RPM,
                    **_as_flown(table))


_FLOWN_KEYS = ("max_acceleration", "max_acceleration_rpm_s", "deadband", "deadband_rpm_s",
               "realized_gain", "startup_delay_s", "speed_quantization_rpm")


def _acceleration(table: dict, key: str) -> float:
    """``wheels.<key>`` in rad/s², given as ``key`` (rad/s²) or ``key_rpm_s`` (RPM/s)."""
    given = [k for k in (key, f"{key}_rpm_s") if k in table]
    if len(given) > 1:
        raise InvalidParameterError(
            f"wheels gives both {given[0]} (rad/s^2) and {given[1]} (RPM/s); give one")
    if not given:
        return 0.0
    value = validation.number(f"wheels.{given[0]}", table[given[0]], low=0.0, high=1e6)
    return value * (_RPM if given[0].endswith("_rpm_s") else 1.0)


def _ranged(table: dict, key: str, default: float, scale: float = 1.0, **rule):
    """``wheels.<key>``: a number, or [low, high] drawn uniformly per episode (a tuple)."""
    value = table.get(key, default)
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise InvalidParameterError(
                f"wheels.{key} must be a number or [low, high], got {value!r}")
        low, high = (validation.number(f"wheels.{key}[{i}]", v, **rule) * scale
                     for i, v in enumerate(value))
        if low > high:
            raise InvalidParameterError(
                f"wheels.{key} = {value!r} must have low <= high")
        return (low, high) if low < high else low
    return validation.number(f"wheels.{key}", value, **rule) * scale


def _as_flown(table: dict) -> dict:
    """The wheels-as-flown fields of :class:`WheelSet` from the ``[wheels]`` table."""
    if "deadband" in table and "deadband_rpm_s" in table:
        _acceleration(table, "deadband")  # the error naming both
    db_key = "deadband" if "deadband" in table else "deadband_rpm_s"
    return {"max_acceleration": _acceleration(table, "max_acceleration"),
            "deadband": _ranged(table, db_key, 0.0, _RPM if db_key.endswith("_rpm_s")
                                else 1.0, low=0.0, high=1e6),
            "realized_gain": _ranged(table, "realized_gain", 1.0, low=0.0, high=10.0,
                                     low_open=True),
            "startup_delay_s": _ranged(table, "startup_delay_s", 0.0, low=0.0, high=1e6),
            "speed_quantum": validation.number("wheels.speed_quantization_rpm",
                                               table.get("speed_quantization_rpm", 0.0),
                                               low=0.0, high=1e5) * _RPM}


@dataclass(frozen=True, eq=False)
class Wheels(ActuatorDefaults):
    """The scene's reaction wheels in an action mode, precomputed for the per-step path."""

    scene_table: ClassVar[str] = "wheels"
    info_keys: ClassVar[tuple] = ("wheel_energy_J", "wheel_momentum_Nms")
    needs_account: ClassVar[bool] = True
    stores_momentum: ClassVar[bool] = True
    start_stream: ClassVar[str] = "wheels"

    wheels: WheelSet
    control_dt: float  # s
    spacecraft_inertia: np.ndarray  # (3, 3) kg·m², the whole spacecraft's (rotors included)
    action_mode: str = "throttle"
    n: int = field(init=False)
    action_shape: tuple = field(init=False)
    action_bounds: tuple = field(init=False, repr=False)
    torque_authority: np.ndarray = field(init=False, repr=False)  # (3,) N·m per unit action
    pinv: np.ndarray = field(init=False, repr=False)  # (3, n): motor torques of a body torque
    max_power: float = field(init=False)  # W
    inv_max_power: float = field(init=False)  # 1/W
    axes: tuple = field(init=False, repr=False)  # n spin axes, 3-tuples of floats
    inertia: tuple = field(init=False, repr=False)  # n floats, kg·m²
    inv_max_speed: tuple = field(init=False, repr=False)  # n floats, s/rad
    max_speed: tuple = field(init=False, repr=False)  # n floats, rad/s
    max_torque: tuple = field(init=False, repr=False)  # n floats, N·m
    headroom: tuple = field(init=False, repr=False)  # n floats J/dt, N·m per rad/s of room
    inv_max_torque: tuple = field(init=False, repr=False)  # n floats, 1/(N·m)
    pinv_rows: tuple = field(init=False, repr=False)  # n rows of G⁺ (3-tuples)
    authority: tuple | None = field(init=False, repr=False)  # torque_authority as floats
    standby: float = field(init=False)  # W, all wheels
    eff_inertia: tuple = field(init=False, repr=False)  # n floats J_eff, kg·m²
    state_fields: dict = field(init=False, repr=False)
    observation_structure: dict = field(init=False, repr=False)
    start_slots: int = field(init=False)
    friction_drawn: bool = field(init=False)  # the friction is drawn per episode (a range)
    # wheel_speed (rad/s, each wheel's speed relative to the body); with wheels as flown
    # wheel_clock_s (s since the first command, −1: not yet commanded, the default), so that
    # a start in mid-run is past the start-up delay.
    reset_options: dict = field(init=False, repr=False)

    def __post_init__(self):
        validation.choice("action_mode (wheels)", self.action_mode, MODES)
        ws = self.wheels
        g = ws.axes_B  # (n, 3)
        if np.linalg.matrix_rank(g) < 3 and self.action_mode == "torque":
            raise InvalidParameterError(
                "action_mode 'torque' needs wheel axes that span 3 dimensions; got rank "
                f"{np.linalg.matrix_rank(g)}")
        if self.action_mode in ACCELERATION_MODES and not ws.max_acceleration:
            raise InvalidParameterError(
                f"action_mode {self.action_mode!r} needs the command clamp "
                "wheels.max_acceleration (rad/s^2) or wheels.max_acceleration_rpm_s (RPM/s) in "
                "the scene, got neither")
        if self.action_mode == "acceleration_lifted" and not ws.deadband:
            raise InvalidParameterError(
                "action_mode 'acceleration_lifted' lifts commands over the wheels' deadband: it "
                "needs wheels.deadband (rad/s^2) or wheels.deadband_rpm_s (RPM/s) in the scene, "
                "got none")
        shape = (3,) if self.action_mode == "torque" else (ws.n,)
        low, high = -np.ones(shape), np.ones(shape)
        for arr in (low, high):
            arr.setflags(write=False)
        pinv = np.linalg.pinv(g.T)  # (n, 3): u = −pinv τ gives the body torque τ (−G u = τ)
        lifted = self.action_mode == "acceleration_lifted"
        inv_bus = np.linalg.inv(bus_inertia(self.spacecraft_inertia, ws.spin_inertia_B))  # I_RW⁻¹
        # Authority per axis: the largest body torque along it with every |u_i| <= u_max.
        col = np.abs(pinv)
        authority = np.array([np.min(ws.max_torque[col[:, a] > 0] / col[col[:, a] > 0, a])
                              for a in range(3)]) if self.action_mode == "torque" else None
        values = {"n": ws.n, "action_shape": shape, "action_bounds": (low, high),
                  "torque_authority": authority, "pinv": pinv,
                  "max_power": float(np.sum(ws.max_torque * ws.max_speed)
                                     + ws.n * ws.standby_power),
                  # wheel_speed: Ω relative to the body, rad/s. wheel_torque: the net motor
                  # torque of the last step, N·m. wheel_momentum: absolute spin momenta
                  # J (Ω + ĝᵀω) at the start of the last step, N·m·s. wheel_energy_J: cumulative.
                  # One component per wheel.
                  # wheel_clock_s (start-up delay only): seconds since the episode's first
                  # command above the deadband, −1 before it.
                  # wheel_flown (wheels as flown): this episode's (deadband rad/s², realized
                  # gain, start-up delay s).
                  # wheel_friction (friction drawn per episode): this episode's (viscous
                  # N·m·s/rad, Coulomb N·m).
                  # wheel_command (acceleration_lifted only): the last step's command after
                  # the lift, α/α_max per wheel.
                  "state_fields": {"wheel_speed": "cn", "wheel_torque": "cn",
                                   "wheel_momentum": "cn", "wheel_energy_J": "f",
                                   **({"wheel_clock_s": "f", "wheel_flown": "c3"}
                                      if ws.as_flown else {}),
                                   **({"wheel_friction": "cn"} if ws.friction_drawn else {}),
                                   **({"wheel_command": "cn"} if lifted else {})},
                  # Per-wheel constants as Python floats (components multiply them).
                  "axes": tuple(tuple(float(c) for c in g_i) for g_i in g),
                  "inertia": tuple(float(j) for j in ws.inertia),
                  "inv_max_speed": tuple(1.0 / float(v) for v in ws.max_speed),
                  "max_speed": tuple(float(v) for v in ws.max_speed),
                  "max_torque": tuple(float(v) for v in ws.max_torque),
                  # J_eff/dt: a wheel's relative speed moves by u·dt (1/J + ĝᵀ I_RW⁻¹ ĝ), the
                  # bus turning the other way; J_eff = 1/(1/J + ĝᵀ I_RW⁻¹ ĝ).
                  "headroom": tuple(float(1.0 / (1.0 / j + g_i @ inv_bus @ g_i)) / self.control_dt
                                    for j, g_i in zip(ws.inertia, g, strict=True)),
                  "inv_max_torque": tuple(1.0 / float(v) for v in ws.max_torque),
                  # J_eff per wheel, kg·m²: u = J_eff α realizes the relative acceleration α.
                  "eff_inertia": tuple(float(1.0 / (1.0 / j + g_i @ inv_bus @ g_i))
                                       for j, g_i in zip(ws.inertia, g, strict=True)),
                  "pinv_rows": tuple(tuple(float(c) for c in row) for row in pinv),
                  "authority": None if authority is None else tuple(authority.tolist()),
                  "standby": float(ws.n * ws.standby_power),
                  "observation_structure": {"wheel_speed": ws.n,
                                            **({"wheel_command": ws.n} if lifted else {})},
                  "start_slots": (ws.n if ws.random_speed else 0) + (3 if ws.as_flown else 0)
                  + (2 if ws.friction_drawn else 0),
                  "friction_drawn": ws.friction_drawn,
                  "reset_options": {"wheel_speed": ws.n,
                                    **({"wheel_clock_s": 1} if ws.as_flown else {})}}
        values["inv_max_power"] = 1.0 / values["max_power"]
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @property
    def spin_inertia_B(self) -> np.ndarray:
        return self.wheels.spin_inertia_B

    # ------------------------------------------------------------------- command

    def command(self, a, in_place: bool = False, xp=NUMPY) -> tuple:
        """Motor torques (N·m), one component per wheel, from the action (clipped to [-1, 1];
        torque mode: ``u = −G⁺ τ``, scaled down as a whole where a wheel would exceed u_max)."""
        c = action_components(a, xp)
        clip = xp.clip
        if self.action_mode == "throttle":
            return tuple([clip(ci, -1.0, 1.0) * self.max_torque[i] for i, ci in enumerate(c)])
        if self.action_mode == "acceleration":  # u = J_eff α, α clamped to ±α_max
            a_max, j = self.wheels.max_acceleration, self.eff_inertia
            return tuple([clip(ci, -1.0, 1.0) * (a_max * j[i]) for i, ci in enumerate(c)])
        if self.action_mode == "acceleration_lifted":  # α lifted over the deadband, u = J_eff α
            a_max, j, up = self.wheels.max_acceleration, self.eff_inertia, self.wheels.deadband_up
            return tuple([lift_over_deadband(clip(ci, -1.0, 1.0) * a_max, up, xp) * j[i]
                          for i, ci in enumerate(c)])
        tau = tuple(clip(ci, -1.0, 1.0) * self.authority[j] for j, ci in enumerate(c))
        u = tuple(-k.dot(self.pinv_rows[i], tau) for i in range(self.n))
        ratio = abs(u[0]) * self.inv_max_torque[0]
        for i in range(1, self.n):
            ratio = xp.maximum(ratio, abs(u[i]) * self.inv_max_torque[i])
        scale = 1.0 / xp.maximum(ratio, 1.0)
        return tuple(ui * scale for ui in u)

    # ------------------------------------------------------------------- per step
    # Per-wheel quantities are components, one per wheel (floats for one satellite, (N,)
    # arrays for N), as vectors are in core.kernels: one satellite steps at float speed.

    def actuate(self, st, u: tuple, noise, xp) -> Contribution:
        """Saturation and friction on the motor torques ``u`` (components); the wheels'
        momentum and its rate for the integrator; electrical power."""
        ws = self.wheels
        speed, w = st.wheel_speed, st.omega_B
        where, clip, maximum = xp.where, xp.clip, xp.maximum
        if self.action_mode == "acceleration_lifted":  # what the flight computer commanded
            st.wheel_command = tuple([c * (1.0 / (ws.max_acceleration * self.eff_inertia[i]))
                                      for i, c in enumerate(u)])
        if ws.as_flown:
            u = self._as_flown(st, u, xp)
        u = tuple([clip(c, -self.max_torque[i], self.max_torque[i]) for i, c in enumerate(u)]) \
            if self.action_mode in ACCELERATION_MODES else u
        model = st.model  # domain randomization: this episode's axes and motor gains
        axes = self.axes if model is None or model.wheel_axes_c is None else model.wheel_axes_c
        gain = None if model is None else model.wheel_torque_c
        power, limited, h = self.standby, [], []
        for i in range(self.n):  # a few wheels; each value a float or an (N,) array
            s, c = speed[i], u[i]
            # A torque that speeds the wheel up is limited to what reaches Ω_max at the end
            # of the step (zero at the limit: Basilisk's rule, without its one-step overshoot).
            head = maximum((self.max_speed[i] - abs(s)) * self.headroom[i], 0.0)
            c = where(s * c >= 0.0, clip(c, -head, head), c)
            if gain is not None:  # the motor realizes this multiple of the firmware's torque
                c = c * gain[i]
            power = power + abs(c * s)
            limited.append(c)
            h.append(self.inertia[i] * (s + k.dot(axes[i], w)))
        u, h = tuple(limited), tuple(h)
        if self.friction_drawn:  # this episode's (viscous, Coulomb), drawn at the start
            viscous, coulomb = st.wheel_friction
            u = tuple([c - viscous * s - coulomb * xp.sign(s)
                       for s, c in zip(speed, u, strict=True)])
        elif ws.viscous or ws.coulomb:
            u = tuple([c - ws.viscous * s - ws.coulomb * xp.sign(s)
                       for s, c in zip(speed, u, strict=True)])
        st.wheel_momentum, st.wheel_torque = h, u
        st.wheel_energy_J = st.wheel_energy_J + power * self.control_dt
        return _new(Contribution, (_ZERO, None, self._body(h, axes), self._body(u, axes),
                                   power * self.inv_max_power, None))

    def _as_flown(self, st, u: tuple, xp) -> tuple:
        """The motor torques the wheels realize of commanded ``u`` (components): zero below the
        deadband (|u/J_eff| < α_db), ``realized_gain`` times the command above it, and zero
        on the steps that start within ``startup_delay_s`` of the episode's first command."""
        where = xp.where
        deadband, gain, delay = st.wheel_flown
        u = tuple([where(abs(c) < deadband * self.eff_inertia[i], 0.0 * c, c * gain)
                   for i, c in enumerate(u)])
        clock = st.wheel_clock_s
        commanded = u[0] != 0.0
        for c in u[1:]:
            commanded = commanded | (c != 0.0)
        clock = where((clock < 0.0) & commanded, 0.0 * clock, clock)
        waiting = clock < delay - 1e-9 * self.control_dt
        st.wheel_clock_s = where(clock < 0.0, clock, clock + self.control_dt)
        return tuple([where(waiting, 0.0 * c, c) for c in u])

    def account(self, st, contribution: Contribution, dt: float, xp) -> None:
        """After the physics: ``h ← h + u·dt`` (exact: u is held) and Ω = h/J − ĝᵀω."""
        w, model = st.omega_B, st.model
        axes = self.axes if model is None or model.wheel_axes_c is None else model.wheel_axes_c
        h = tuple([hi + ui * dt for hi, ui in zip(st.wheel_momentum, st.wheel_torque,
                                                  strict=True)])
        st.wheel_momentum = h
        st.wheel_speed = tuple([h[i] / self.inertia[i] - k.dot(axes[i], w)
                                for i in range(self.n)])

    def _axes(self, st) -> tuple:
        """The spin axes of this episode (components): the scene's, or the randomized."""
        model = st.model
        return self.axes if model is None or model.wheel_axes_c is None else model.wheel_axes_c

    def _body(self, x: tuple, axes: tuple | None = None) -> tuple:
        """``G x``: per-wheel values along their axes (``axes``, default the scene's),
        summed: 3 body components."""
        axes = self.axes if axes is None else axes
        out = k.scale(axes[0], x[0])
        for i in range(1, self.n):
            out = k.add(out, axes[i], x[i])
        return out

    # ------------------------------------------------------------------- start, sensing

    def sample_start(self, draws) -> dict:
        """Initial speeds (the scene's, plus a uniform ± random_speed spread from stream
        "wheels"), zero torque and energy; the as-flown draws (3 uniforms) and the friction
        draws (2 uniforms) follow in the same stream, each block only when on."""
        m, ws = draws.n, self.wheels
        speed = np.broadcast_to(ws.initial_speed, (m, ws.n)).copy()
        if ws.random_speed:
            u = draws.uniform_array("wheels", ws.n)
            speed = speed + ws.random_speed * (2.0 * u.T - 1.0)
            speed = np.clip(speed, -ws.max_speed, ws.max_speed)
        zero = draws.xp.zeros(m)
        zeros = tuple(zero for _ in range(ws.n))
        speeds = tuple(speed[0].tolist()) if draws.xp is FLOAT else tuple(speed.T)
        out = {"wheel_speed": speeds, "wheel_torque": zeros, "wheel_momentum": zeros,
               "wheel_energy_J": zero}
        if self.action_mode == "acceleration_lifted":
            out["wheel_command"] = zeros
        if ws.as_flown:
            out["wheel_clock_s"] = zero - 1.0
            u = draws.uniform("wheels", 3, offset=ws.n if ws.random_speed else 0)
            out["wheel_flown"] = tuple(lo + (hi - lo) * ui if hi > lo else zero + lo
                                       for (lo, hi), ui in zip(ws.flown_ranges, u, strict=True))
        if ws.friction_drawn:  # the next two slots, after the speeds' and the flown draws
            u = draws.uniform("wheels", 2, offset=(ws.n if ws.random_speed else 0)
                              + (3 if ws.as_flown else 0))
            out["wheel_friction"] = tuple(lo + (hi - lo) * ui if hi > lo else zero + lo
                                          for (lo, hi), ui in zip(ws.friction_ranges, u,
                                                                  strict=True))
        return out

    def observe(self, st, xp, sensed=None) -> tuple:
        """Ω_i / Ω_max,i, clipped to [-1, 1], one component per wheel (Ω quantized to the
        speed sensor's resolution, where the scene gives one); then, in action mode
        ``acceleration_lifted``, the last step's command α/α_max per wheel."""
        clip, inv = xp.clip, self.inv_max_speed
        speed, quantum = st.wheel_speed, self.wheels.speed_quantum
        if st.model is not None and st.model.wheel_speed_c is not None:  # the sensor's scale
            speed = tuple([s * g for s, g in zip(speed, st.model.wheel_speed_c, strict=True)])
        if quantum:
            speed = tuple([xp.round(s * (1.0 / quantum)) * quantum for s in speed])
        out = tuple([clip(s * inv[i], -1.0, 1.0) for i, s in enumerate(speed)])
        return out + tuple(st.wheel_command) if self.action_mode == "acceleration_lifted" \
            else out

    def check_start(self, start: dict) -> None:
        """Refuse a start whose wheel speeds exceed the wheels' limits (named error)."""
        if isinstance(start.get("wheel_clock_s"), tuple):  # a reset option: one component
            start["wheel_clock_s"] = start["wheel_clock_s"][0]
        speed = np.abs(np.asarray(start["wheel_speed"], dtype=float).reshape(self.n, -1))
        limit = np.asarray(self.max_speed)[:, None]
        if np.any(speed > limit * (1.0 + 1e-12)):
            i = int(np.argwhere(speed > limit * (1.0 + 1e-12))[0][0])
            raise InvalidParameterError(
                f"reset options['wheel_speed'][{i}] must be within ±{limit[i, 0]:.6g} rad/s "
                f"(the wheel's max_speed_rpm), got {speed[i].max():.6g} in magnitude")

    def render_values(self, st, index: int | None) -> dict:
        """Each wheel's speed relative to the body, rad/s (spinning discs)."""
        return {"wheel_speed": one_row(st.wheel_speed, index)}

    def info(self, st, xp, out: dict) -> None:
        """wheel_energy_J (cumulative) and wheel_momentum_Nms (|G J Ω|, the stored momentum
        relative to the bus)."""
        h = self._body([self.inertia[i] * s for i, s in enumerate(st.wheel_speed)],
                       self._axes(st))
        out["wheel_energy_J"] = st.wheel_energy_J
        out["wheel_momentum_Nms"] = xp.sqrt(k.dot(h, h))




def lift_over_deadband(alpha, alpha_up: float, xp=NUMPY):
    """The deadband's inverse (``action_mode="acceleration_lifted"``): a requested wheel
    acceleration ``alpha`` (rad/s², a float or an array) below ``LIFT_ZERO·alpha_up`` in
    magnitude is zero, any other is ``sign(alpha)·max(|alpha|, alpha_up)``, when commands below
    ``alpha_up`` (> 0, rad/s²) do nothing: the smallest request moves the wheel by the finest
    step it can, and a policy's output near zero is still no command."""
    mag = abs(alpha)
    return xp.where(mag < LIFT_ZERO * alpha_up, 0.0 * alpha,
                    xp.sign(alpha) * xp.maximum(mag, alpha_up))


def make_wheels(scene, action_mode: str = "throttle", allocator: str = "pinv") -> Wheels:
    """The scene's wheels (its ``[wheels]`` table) in an action mode (``allocator`` is the
    thrusters' option: wheels always use the pseudo-inverse)."""
    return Wheels(wheels=scene.actuators["wheels"], control_dt=scene.physics.control_dt,
                  spacecraft_inertia=scene.body.inertia, action_mode=action_mode)
