"""Scenes: frozen descriptions of a satellite, what is modelled, and the episode parameters.

A :class:`Scene` holds everything that does not change during an episode: the rigid body (mass
properties about the centre of mass, body axes), the thruster layout (body frame), the
propellant's specific impulse, which effects the step computes (translation, disturbance torque,
thruster faults, sensor noise), the integrator and the episode rules. Scenes are built in code
or read from TOML; the shipped ones live in ``rbenv/scenes/*.toml`` (:func:`list_scenes`).

TOML schema (SI units; every table except ``[body]`` and ``[thrusters]`` is optional and
defaults as in the dataclasses below; unknown keys are errors, so typos do not pass silently)::

    name = "my-sat"                # defaults to the file stem
    description = "..."
    sources = ["...", "..."]       # where the numbers come from

    [body]                         # exactly ONE of the three forms:
    shape = "box"                  # (1) one shape: "box" (size = [w, h, d] FULL extents, m)
    mass = 24.0                    #     or "cylinder" (radius, height, m; axis = body z);
    size = [0.2, 0.2, 0.3]         #     hollow = true: closed thin-walled shell
    # (2) parts = [{shape = "box" | "cylinder" | "point", mass, size | radius + height,
    #              position = [x, y, z] (centre of the part, m), hollow = false}, ...]
    #     composed with the parallel-axis theorem; parts are axis-aligned with the body
    # (3) mass = 24.0, inertia = [[...], [...], [...]] or [Ixx, Iyy, Izz] (kg·m², about
    #     the centre of mass), com = [x, y, z] (m, default origin)

    [thrusters]
    positions = [[x, y, z], ...]   # mount points, m, body axes (same origin as the parts)
    directions = [[x, y, z], ...]  # direction of the force on the body (normalised)
    max_force = 0.05               # N, a number or one per thruster
    isp = 65.0                     # s, specific impulse (fuel = impulse / (isp · g0))

    [physics]
    integrator = "rk4"             # a name in core.INTEGRATORS
    substeps = 1                   # integrator steps per control step
    control_dt = 0.5               # s, one env step; throttles are duty cycles over it
    translation = false            # also integrate the centre of mass under the net force

    [disturbance]                  # torque on the body, body frame, N·m
    model = "none"                 # "none" | "constant" | "random"
    torque = [0, 0, 0]             # constant: this torque, always
    bias_sigma = 1e-6              # random: per-axis Gaussian bias drawn at reset (held all
    noise_sigma = 0.0              #   episode) + per-axis white noise held per control step

    [faults]                       # thrusters stuck off (no thrust, no fuel)
    model = "none"                 # "none" | "random"
    p_reset = 0.0                  # each thruster fails at reset with this probability
    p_step = 0.0                   # each working thruster fails per control step (mid-episode)

    [sensor_noise]                 # applied to the observation only
    model = "none"                 # "none" | "gaussian"
    attitude = 0.0                 # rad, 1σ per axis of a small rotation of the measured attitude
    rate = 0.0                     # rad/s, 1σ per axis of the measured body rate

    [episode]
    duration = 80.0                # s (episode_steps = round(duration / control_dt))
    rate_limit = 0.1745            # rad/s: |ω| above it is loss of control (terminated)
    success_angle_deg = 1.0        # success: error < this ...
    success_rate = 0.01            # ... and |ω| < this (rad/s) ...
    hold_time = 2.0                # ... held for this long (s)
    max_initial_angle_deg = 180.0  # initial error ≤ this (180: attitude and target uniform)
    max_initial_rate = 0.02        # rad/s, initial tumble |ω| uniform in [0, this]

Every bad field raises :class:`rbenv.core.InvalidParameterError` (a ``ValueError``) naming the
field, the value and the rule; a thruster layout that cannot torque the body both ways about every
axis names the missing direction. Numbers are real ints or floats (``true`` is not 1, ``"1"`` is not
a number); flags are ``true``/``false``.

Documented bounds, so that every accepted scene steps to finite observations and rewards (the
checks live in :mod:`rbenv.core.validation`; the numbers are the module constants below):

===============================  ===================================================
field                            rule
===============================  ===================================================
scene file                       a regular UTF-8 file of at most 1 MiB (``MAX_SCENE_BYTES``)
body mass, part masses           1e-6 … 1e7 kg
sizes, radii, heights            > 0 and <= 1e3 m; positions and com within ±1e3 m
explicit inertia                 principal moments 1e-12 … 1e12 kg·m²
thrusters                        1 … 256 (``MAX_THRUSTERS``); max_force > 0 and <= 1e4 N
thrusters.isp                    1 … 1e5 s
physics.substeps                 1 … 1000 (``MAX_SUBSTEPS``)
physics.control_dt               1e-6 … 3600 s
episode.duration                 > 0 and <= 1e6 s, and at most 1e6 control steps
episode.rate_limit               1e-6 … 100 rad/s
episode.hold_time                0 … duration
disturbance torque and sigmas    within ±10 N·m
sensor_noise                     attitude 0 … π rad; rate 0 … 100 rad/s
orbit.residual_dipole            moment_B_Am2: 3 numbers within ±10 A·m²
orbit.drag, orbit.srp            area_m2 > 0 and <= 1e4 m²; cp_offset_B_m 3 numbers within
                                 ±100 m; cd > 0 … 10; density_scale > 0 … 1e3;
                                 reflectivity 0 … 1; epoch ISO 8601 UTC within a
                                 century of J2000.0
===============================  ===================================================
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from rbenv.core import INTEGRATORS, RigidBody
from rbenv.core import inertia as inertia_lib
from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError, RbenvValueError, describe
from rbenv.satellite.actuators import ACTUATORS
from rbenv.satellite.actuators.tables import bounded_array
from rbenv.satellite.estimation import Estimator
from rbenv.satellite.orbit import Orbit
from rbenv.satellite.randomization import Randomization
from rbenv.satellite.sensors import Magnetometer, StarTracker, SunSensors
from rbenv.satellite.usage import InvalidChoiceError, invalid_choice

__all__ = [
    "DEFAULT_SCENE",
    "Disturbance",
    "Episode",
    "Faults",
    "Physics",
    "Scene",
    "SensorNoise",
    "Sensors",
    "list_scenes",
    "load_scene",
    "mass_properties",
    "scene_table",
    "scene_variant",
]

DEFAULT_SCENE = "cubesat-12u"
# Documented caps (see the table in the module docstring).
MAX_SCENE_BYTES = 1 << 20
MAX_SUBSTEPS = 1000
MAX_EPISODE_STEPS = 1_000_000
_MASS = {"low": 1e-6, "high": 1e7}  # kg
_LENGTH = {"low": 0.0, "low_open": True, "high": 1e3}  # m, sizes
_COORD = 1e3  # m, |position| and |com| components
_MOMENT = (1e-12, 1e12)  # kg·m², explicit principal moments
_TORQUE = 10.0  # N·m, disturbance torques and sigmas (environmental torques are < 1e-3)


# --------------------------------------------------------------------------- field checks


def _number(path: str, value, *, low=None, high=None, low_open=False, integer=False):
    """``value`` as a float (or int) within bounds, else an error naming ``path``."""
    if integer:
        return check.integer(path, value, low=low, high=high, allow_integral_float=True)
    return check.number(path, value, low=low, high=high, low_open=low_open)


def _choice(path: str, value, options) -> str:
    return check.choice(path, value, options)


def _flag(path: str, value) -> bool:
    return check.flag(path, value)


# --------------------------------------------------------------------------- parameter groups


@dataclass(frozen=True)
class Physics:
    """How the dynamics are integrated: integrator, substeps per control step, control step (s)."""

    integrator: str = "rk4"
    substeps: int = 1
    control_dt: float = 0.5
    translation: bool = False

    def __post_init__(self):
        _choice("physics.integrator", self.integrator, sorted(INTEGRATORS))
        object.__setattr__(self, "substeps", _number("physics.substeps", self.substeps, low=1,
                                                      high=MAX_SUBSTEPS, integer=True))
        object.__setattr__(self, "control_dt", _number("physics.control_dt", self.control_dt,
                                                        low=1e-6, high=3600.0))
        _flag("physics.translation", self.translation)

    @property
    def h(self) -> float:
        """Integrator step in s: ``control_dt / substeps``."""
        return self.control_dt / self.substeps


@dataclass(frozen=True, eq=False)
class Disturbance:
    """Disturbance torque on the body, body frame, N·m: none, constant, or random per episode.

    ``random``: a bias with per-axis standard deviation ``bias_sigma`` drawn at reset and held
    for the episode (environmental torques barely change over a minute) plus, if
    ``noise_sigma > 0``, per-axis white noise redrawn each control step and held over it.
    """

    model: str = "none"
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_sigma: float = 0.0
    noise_sigma: float = 0.0

    def __post_init__(self):
        _choice("disturbance.model", self.model, ("none", "constant", "random"))
        torque = bounded_array("disturbance.torque", self.torque, (3,), bound=_TORQUE)
        bias = _number("disturbance.bias_sigma", self.bias_sigma, low=0.0, high=_TORQUE)
        noise = _number("disturbance.noise_sigma", self.noise_sigma, low=0.0, high=_TORQUE)
        _unused(self.model, "constant", "disturbance.torque", np.any(torque != 0.0))
        _unused(self.model, "random", "disturbance.bias_sigma", bias != 0.0)
        _unused(self.model, "random", "disturbance.noise_sigma", noise != 0.0)
        object.__setattr__(self, "torque", torque)
        object.__setattr__(self, "bias_sigma", bias)
        object.__setattr__(self, "noise_sigma", noise)


@dataclass(frozen=True)
class Faults:
    """Thrusters failing stuck-off: at reset with ``p_reset``, per control step with ``p_step``."""

    model: str = "none"
    p_reset: float = 0.0
    p_step: float = 0.0

    def __post_init__(self):
        _choice("faults.model", self.model, ("none", "random"))
        for name in ("p_reset", "p_step"):
            p = _number(f"faults.{name}", getattr(self, name), low=0.0, high=1.0)
            _unused(self.model, "random", f"faults.{name}", p != 0.0)
            object.__setattr__(self, name, p)


@dataclass(frozen=True)
class SensorNoise:
    """Gaussian measurement noise on the observation only, 1σ: attitude (rad), rate (rad/s) and
    the magnetometer (T, each body axis; a scene with magnetorquers observes the field)."""

    model: str = "none"
    attitude: float = 0.0
    rate: float = 0.0
    magnetometer: float = 0.0

    def __post_init__(self):
        _choice("sensor_noise.model", self.model, ("none", "gaussian"))
        for name, high in (("attitude", math.pi), ("rate", 100.0), ("magnetometer", 1e-3)):
            s = _number(f"sensor_noise.{name}", getattr(self, name), low=0.0, high=high)
            _unused(self.model, "gaussian", f"sensor_noise.{name}", s != 0.0)
            object.__setattr__(self, name, s)


@dataclass(frozen=True)
class Sensors:
    """Sensing as flown (opt-in): the attitude the policy sees is integrated from a gyro.

    ``attitude``: "true" (off: the observation's attitude and rate are the state's, or with
    ``[sensor_noise]``) or "gyro": the measured rate is ``ω + b + σ_n n`` and the attitude
    estimate moves with it from the true start, so it drifts from the truth by the integrated
    bias and noise: ``q_est = q ⊗ δ``, ``δ ← δ ⊗ exp((b + σ_n n)·dt)`` each control step.
    ``b`` is drawn per episode (``gyro_bias_sigma_dps`` 1σ per axis) and walks
    (``gyro_bias_walk_dps_sqrt_s``: σ of its change over 1 s). ``delay_steps`` (0 or 1): the
    observation shows the measurement of the previous control step. Rewards, success and
    failure use the true state. "estimator": the observation is the ``[estimator]``'s MEKF
    estimate (rbenv.satellite.estimation), fed by this gyro (bias ``gyro_bias_sigma_dps``,
    angle random walk ``gyro_noise_dps·√control_dt``, rate random walk
    ``gyro_bias_walk_dps_sqrt_s``) and the scene's attitude sensors.
    """

    attitude: str = "true"
    gyro_bias_sigma_dps: float = 0.0
    gyro_bias_walk_dps_sqrt_s: float = 0.0
    gyro_noise_dps: float = 0.0
    delay_steps: int = 0

    def __post_init__(self):
        _choice("sensors.attitude", self.attitude, ("true", "gyro", "estimator"))
        for name in ("gyro_bias_sigma_dps", "gyro_bias_walk_dps_sqrt_s", "gyro_noise_dps"):
            value = _number(f"sensors.{name}", getattr(self, name), low=0.0, high=100.0)
            if self.attitude != "estimator":
                _unused(self.attitude, "gyro", f"sensors.{name}", value != 0.0)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "delay_steps", _number("sensors.delay_steps",
                                                         self.delay_steps, low=0, high=1,
                                                         integer=True))

    @property
    def enabled(self) -> bool:
        """Whether the observation is sensed as flown (gyro attitude or a delay)."""
        return self.attitude == "gyro" or self.delay_steps > 0


@dataclass(frozen=True)
class Episode:
    """Episode rules: duration (s), loss-of-control rate, success thresholds, initial ranges."""

    duration: float = 80.0
    rate_limit: float = 0.1745
    success_angle_deg: float = 1.0
    success_rate: float = 0.01
    hold_time: float = 2.0
    max_initial_angle_deg: float = 180.0
    max_initial_rate: float = 0.02

    def __post_init__(self):
        checks = {
            "duration": {"low": 0.0, "low_open": True, "high": 1e6},
            "rate_limit": {"low": 1e-6, "high": 100.0},
            # v1 scales the errors by these thresholds: a subnormal one overflows to inf.
            "success_angle_deg": {"low": 1e-6, "high": 180.0},
            "success_rate": {"low": 1e-9},
            "hold_time": {"low": 0.0},
            "max_initial_angle_deg": {"low": 0.0, "high": 180.0},
            "max_initial_rate": {"low": 0.0},
        }
        for name, rule in checks.items():
            object.__setattr__(self, name, _number(f"episode.{name}", getattr(self, name), **rule))
        if self.hold_time > self.duration:
            raise InvalidParameterError(
                f"episode.hold_time must be <= episode.duration ({self.duration!r} s), got "
                f"{self.hold_time!r}"
            )
        if self.success_rate >= self.rate_limit:
            raise InvalidParameterError(
                f"episode.success_rate must be < episode.rate_limit ({self.rate_limit!r}), got "
                f"{self.success_rate!r}"
            )
        if self.max_initial_rate >= self.rate_limit:
            raise InvalidParameterError(
                f"episode.max_initial_rate must be < episode.rate_limit ({self.rate_limit!r}) so "
                f"that no episode starts out of control, got {self.max_initial_rate!r}"
            )


ESTIMATION_TABLES = {"star_tracker": StarTracker, "magnetometer": Magnetometer,
                     "sun_sensors": SunSensors, "estimator": Estimator}


def _check_estimator(scene) -> None:
    """The estimator's tables fit together: [estimator] with sensors.attitude = "estimator"
    and at least one attitude sensor; each sensor's inputs modelled."""
    for key, cls in ESTIMATION_TABLES.items():
        value = getattr(scene, key)
        if value is not None and not isinstance(value, cls):
            raise InvalidParameterError(f"{key} must be a {cls.__name__} or None, got "
                                        f"{type(value).__name__}")
    on = scene.sensors.attitude == "estimator"
    if on != (scene.estimator is not None):
        raise InvalidParameterError(
            f"sensors.attitude = {scene.sensors.attitude!r} and the [estimator] table go "
            'together: give both (attitude = "estimator") or neither')
    if not on:
        return
    if scene.sensors.delay_steps:
        raise InvalidParameterError(
            f"sensors.delay_steps = {scene.sensors.delay_steps} is not supported with the "
            "estimator; set it to 0")
    if scene.sensor_noise.model != "none":
        raise InvalidParameterError(
            f"sensor_noise.model = {scene.sensor_noise.model!r} and the estimator both shape "
            "the observation; the estimator's sensors carry their own noise: set "
            'sensor_noise.model = "none"')
    if scene.sensors.gyro_noise_dps == 0.0:
        raise InvalidParameterError(
            "sensors.gyro_noise_dps must be > 0 with the estimator (the filter's angle random "
            "walk), got 0.0")
    if scene.star_tracker is None and scene.magnetometer is None and scene.sun_sensors is None:
        raise InvalidParameterError(
            "[estimator] needs at least one attitude sensor table: [star_tracker], "
            "[magnetometer] or [sun_sensors]")
    if scene.magnetometer is not None and not (scene.orbit.enabled and
                                               scene.orbit.magnetic_field):
        raise InvalidParameterError(
            "[magnetometer] reads the orbit's field model: it needs [orbit] with "
            "magnetic_field = true")
    if scene.sun_sensors is not None and not scene.orbit.enabled:
        raise InvalidParameterError(
            "[sun_sensors] need the Sun's direction and the Earth's shadow: give the scene an "
            '[orbit] (model = "circular")')


def _unused(model: str, needs: str, path: str, is_set) -> None:
    if is_set and model != needs:
        group = path.split(".")[0]
        key = "attitude" if group == "sensors" else "model"
        raise InvalidParameterError(
            f"{path} is set but {group}.{key} is {model!r}; it only applies to {key}={needs!r}"
        )


# --------------------------------------------------------------------------- the scene


@dataclass(frozen=True, eq=False)
class Scene:
    """A satellite and its task: everything fixed during an episode. Validated at construction.

    body: mass (kg) and inertia (kg·m², about the centre of mass, body axes). actuators: each
    actuator table (``[thrusters]``, ``[wheels]``, ...) as its module parsed it
    (:data:`rbenv.satellite.actuators.ACTUATORS`), at least one. The groups say what the step
    models; ``episode_steps`` is derived: ``round(duration / control_dt)``.
    """

    name: str
    body: RigidBody
    physics: Physics = field(default_factory=Physics)
    disturbance: Disturbance = field(default_factory=Disturbance)
    faults: Faults = field(default_factory=Faults)
    sensor_noise: SensorNoise = field(default_factory=SensorNoise)
    sensors: Sensors = field(default_factory=Sensors)
    episode: Episode = field(default_factory=Episode)
    description: str = ""
    sources: tuple = ()
    randomization: Randomization = field(default_factory=Randomization)
    tasks: dict = field(default_factory=dict)  # task name -> its option table (the task checks)
    # The actuator tables, parsed by their modules (rbenv.satellite.actuators): table name ->
    # parameters.
    actuators: dict = field(default_factory=dict)
    orbit: Orbit = field(default_factory=Orbit)
    # Attitude sensors and the estimator (rbenv.satellite.sensors, rbenv.satellite.estimation):
    # each None when the scene lacks its table.
    star_tracker: StarTracker | None = None
    magnetometer: Magnetometer | None = None
    sun_sensors: SunSensors | None = None
    estimator: Estimator | None = None

    def __post_init__(self):
        object.__setattr__(self, "randomization",
                           Randomization.from_mapping(self.randomization))
        object.__setattr__(self, "tasks", _task_tables(self.tasks))
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"name must be a non-empty string, got {self.name!r}")
        if not self.actuators:
            raise InvalidParameterError(
                f"a scene needs at least one actuator table, one of {sorted(_actuator_tables())}")
        for attr, cls in (("body", RigidBody), ("physics", Physics),
                          ("disturbance", Disturbance), ("faults", Faults),
                          ("sensor_noise", SensorNoise), ("sensors", Sensors),
                          ("episode", Episode), ("orbit", Orbit)):
            if not isinstance(getattr(self, attr), cls):
                raise InvalidParameterError(
                    f"{attr} must be a {cls.__name__}, got {type(getattr(self, attr)).__name__}"
                )
        object.__setattr__(self, "sources", _sources(self.sources))
        for task_name in self.tasks:  # per-task physics/episode overrides fail at load
            self.for_task(task_name)
        if not isinstance(self.description, str):
            raise InvalidParameterError(
                f"description must be a string, got {describe(self.description)}"
            )
        if self.sensor_noise.magnetometer and "magnetorquers" not in self.actuators:
            raise InvalidParameterError(
                f"sensor_noise.magnetometer = {self.sensor_noise.magnetometer!r} needs a "
                f"magnetometer to be noisy, but scene {self.name!r} observes no field; "
                "give it [magnetorquers] or set sensor_noise.magnetometer = 0")
        if self.sensors.enabled and self.sensor_noise.model != "none":
            raise InvalidParameterError(
                "sensors (attitude from a gyro, or a delay) and sensor_noise.model = "
                f"{self.sensor_noise.model!r} both shape the observation; give one of them")
        _check_estimator(self)
        steps = self.episode.duration / self.physics.control_dt
        if not steps <= MAX_EPISODE_STEPS or round(steps) < 1:
            raise InvalidParameterError(
                f"episode.duration ({self.episode.duration!r} s) must span between 1 and "
                f"{MAX_EPISODE_STEPS} control steps of physics.control_dt = "
                f"{self.physics.control_dt!r} s, got {steps:.6g}"
            )

    @property
    def episode_steps(self) -> int:
        """Control steps per episode: ``round(duration / control_dt)``."""
        return round(self.episode.duration / self.physics.control_dt)

    @property
    def hold_steps(self) -> int:
        """Consecutive control steps inside the success thresholds needed for success (≥ 1)."""
        return max(1, math.ceil(self.episode.hold_time / self.physics.control_dt - 1e-9))

    @property
    def thrusters(self):
        """The ``[thrusters]`` layout (:class:`rbenv.core.ThrusterLayout`), or None: a
        shorthand for ``actuators["thrusters"].layout``, which baselines and bounds read."""
        table = self.actuators.get("thrusters")
        return None if table is None else table.layout

    def with_randomization(self, randomize) -> Scene:
        """A copy with domain randomization replaced: a dict of sizes (overriding the scene's
        table), a :class:`rbenv.satellite.randomization.Randomization`, or False/None-like off."""
        if randomize is False:
            return dataclasses.replace(self, randomization=Randomization())
        if isinstance(randomize, dict):
            merged = {**dataclasses.asdict(self.randomization), **randomize}
            return dataclasses.replace(self, randomization=Randomization.from_mapping(merged))
        return dataclasses.replace(self, randomization=Randomization.from_mapping(randomize))

    def for_task(self, task_name: str) -> Scene:
        """The scene as ``task_name`` runs it: its ``[tasks.<name>.physics]`` and
        ``[tasks.<name>.episode]`` tables override the scene's (a magnetic detumble needs a
        longer step and episode than a wheel slew on the same satellite)."""
        table = self.tasks.get(task_name) or {}
        over = {key: table[key] for key in ("physics", "episode") if key in table}
        if not over:
            return self
        try:
            groups = {key: dataclasses.replace(getattr(self, key), **_checked(
                f"tasks.{task_name}.{key}", value, getattr(self, key)))
                for key, value in over.items()}
        except RbenvValueError as exc:
            raise type(exc)(f"tasks.{task_name}: {exc}") from None
        except TypeError as exc:
            raise InvalidParameterError(f"tasks.{task_name}: {exc}") from None
        # Outside the try: the copy checks every task's tables again, and an error there is
        # another task's, named by that task's own prefix.
        rest = {k: v for k, v in table.items() if k not in over}
        return dataclasses.replace(self, tasks={**self.tasks, task_name: rest}, **groups)

    def with_physics(self, integrator=None, control_dt=None, substeps=None) -> Scene:
        """A copy with some physics fields replaced (``None`` keeps the scene's value)."""
        changes = {k: v for k, v in (("integrator", integrator), ("control_dt", control_dt),
                                     ("substeps", substeps)) if v is not None}
        if not changes:
            return self
        return dataclasses.replace(self, physics=dataclasses.replace(self.physics, **changes))

    # ----------------------------------------------------------------------- construction

    @classmethod
    def from_dict(cls, data: dict, *, name: str | None = None) -> Scene:
        """Build a scene from a TOML-shaped dict (see the module docstring for the schema)."""
        if not isinstance(data, dict):
            raise InvalidParameterError(f"a scene must be a table (dict), got {describe(data)}")
        data = dict(data)
        tables = _actuator_tables()
        _check_keys("scene", data, {"name", "description", "sources", "body", "physics",
                                    "disturbance", "faults", "sensor_noise", "sensors", "episode",
                                    "randomization", "tasks", "orbit",
                                    *ESTIMATION_TABLES, *tables})
        scene_name = data.get("name", name)
        if "name" in data and (not isinstance(scene_name, str) or not scene_name):
            raise InvalidParameterError(
                f"name must be a non-empty string, got {describe(scene_name)}"
            )
        try:
            mass, com_B, inertia = mass_properties(_table(data, "body", required=True))
            body = RigidBody(mass=mass, inertia=inertia)
            actuators = {name: parse(_table(data, name), com_B)
                         for name, parse in tables.items() if name in data}
            groups = {}
            for key, group in (("physics", Physics), ("disturbance", Disturbance),
                               ("faults", Faults), ("sensor_noise", SensorNoise),
                               ("sensors", Sensors), ("episode", Episode), ("orbit", Orbit)):
                table = _table(data, key)
                _check_keys(key, table, {f.name for f in dataclasses.fields(group) if f.init})
                groups[key] = group(**table)
            for key, group in ESTIMATION_TABLES.items():
                if key in data:
                    table = _table(data, key)
                    _check_keys(key, table, {f.name for f in dataclasses.fields(group)
                                             if f.init})
                    groups[key] = group(**table)
            return cls(name=scene_name or "unnamed", body=body, actuators=actuators,
                       description=data.get("description", ""),
                       sources=data.get("sources", ()),
                       randomization=_table(data, "randomization"),
                       tasks=_table(data, "tasks"), **groups)
        except RbenvValueError as exc:
            raise type(exc)(f"scene {scene_name!r}: {exc}") from None

    @classmethod
    def from_toml(cls, path) -> Scene:
        """Read a scene from a TOML file (``name`` defaults to the file stem).

        ``base = "<shipped scene>"`` at the top of the file starts from that scene: its tables
        are merged field by field with the file's (the file wins), so a variant states only
        what it changes.
        """
        path = Path(path)
        data = _read_toml(path)
        if "base" in data:
            data = _with_base(data, path)
        return cls.from_dict(data, name=path.stem)


def scene_table(scene) -> dict:
    """The TOML-shaped dict of a shipped scene's name or a scene file's path (its ``base``
    merged in), to change and build with :meth:`Scene.from_dict` (see :func:`scene_variant`)."""
    text = str(scene)
    if isinstance(scene, (str, Path)) and text in list_scenes():
        with resources.as_file(_scene_dir() / f"{text}.toml") as path:
            data, name = _read_toml(path), text
    elif isinstance(scene, (str, Path)) and Path(scene).suffix == ".toml" \
            and Path(scene).exists():
        path = Path(scene)
        data, name = _read_toml(path), path.stem
    else:
        raise InvalidParameterError(
            f"scene must be a shipped name {list_scenes()} or a path to an existing .toml "
            f"file, got {scene!r}")
    if "base" in data:
        data = _with_base(data, Path(text))
    data.setdefault("name", name)
    return data


def scene_variant(scene, overrides: dict, name: str | None = None) -> Scene:
    """A scene with some keys changed: ``overrides`` maps a table to {key: value} (None
    removes the key, and an empty table with None as a whole, ``{"magnetorquers": None}``,
    removes the table), e.g. ``scene_variant("innocube-3u", {"wheels": {"deadband_rpm_s":
    None}})`` for innocube-3u without the deadband. Top-level keys take plain values."""
    data = scene_table(scene)
    if not isinstance(overrides, dict):
        raise InvalidParameterError(
            f"overrides must be a dict of table -> {{key: value}}, got {describe(overrides)}")
    for table, change in overrides.items():
        if change is None:
            data.pop(table, None)
        elif isinstance(change, dict) and isinstance(data.get(table, {}), dict):
            merged = {**data.get(table, {}), **change}
            data[table] = {k: v for k, v in merged.items() if v is not None}
        else:
            data[table] = change
    if name is not None:
        data["name"] = name
    return Scene.from_dict(data)


def _read_toml(path: Path) -> dict:
    """The parsed TOML of a scene file (regular file, size-capped, UTF-8), named errors."""
    toml = _tomllib()
    raw = check.read_regular_file("scene file", path, max_bytes=MAX_SCENE_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidParameterError(
            f"scene file {str(path)!r} must be UTF-8 text; byte {exc.start} is not "
            f"({exc.reason})"
        ) from None
    try:
        return toml.loads(text)
    except toml.TOMLDecodeError as exc:
        raise InvalidParameterError(f"scene file {str(path)!r} is not valid TOML: {exc}") \
            from None
    except RecursionError:
        raise InvalidParameterError(
            f"scene file {str(path)!r} nests arrays or tables too deeply to parse"
        ) from None


def _with_base(data: dict, path: Path) -> dict:
    """``data`` laid over the shipped scene named by its ``base`` key (one level only)."""
    data = dict(data)
    name = check.choice(f"scene file {str(path)!r}: base", data.pop("base"), list_scenes())
    with resources.as_file(_scene_dir() / f"{name}.toml") as base_path:
        base = _read_toml(base_path)
    if "base" in base:
        raise InvalidParameterError(f"shipped scene {name!r} has a base itself; a variant "
                                    "may only build on a scene without one")
    base.pop("name", None)
    for key, value in data.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            base[key] = {**base[key], **value}
        else:
            base[key] = value
    return base


def _task_tables(tables) -> dict:
    """``[tasks.<name>]`` tables: a dict of dicts (each task validates its own fields)."""
    if not isinstance(tables, dict) or not all(isinstance(v, dict) for v in tables.values()):
        raise InvalidParameterError(
            f"tasks must be a table of per-task tables ([tasks.detumble], ...), got {tables!r}")
    return {str(name): dict(table) for name, table in tables.items()}


def _tomllib():
    """The TOML reader: stdlib ``tomllib`` (3.11+), else the ``tomli`` backport."""
    try:
        import tomllib
    except ModuleNotFoundError:
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise ImportError(
                "reading rbenv scene files needs a TOML parser: Python >= 3.11 has tomllib; "
                "on Python 3.10 run `pip install tomli`"
            ) from None
    return tomllib


def _checked(path: str, table, group) -> dict:
    """A per-task override table of a parameter group: a dict of its field names."""
    if not isinstance(table, dict):
        raise InvalidParameterError(f"{path} must be a table, got {describe(table)}")
    _check_keys(path, table, {f.name for f in dataclasses.fields(group) if f.init})
    return table


def _actuator_tables() -> dict:
    """Scene table name → parser of every registered actuator (rbenv.satellite.actuators)."""
    return {name: entry.parse for name, entry in ACTUATORS.items() if entry.parse is not None}


def _table(data: dict, key: str, required: bool = False) -> dict:
    value = data.get(key)
    if value is None:
        if required:
            raise InvalidParameterError(f"[{key}] table is required")
        return {}
    if not isinstance(value, dict):
        raise InvalidParameterError(f"{key} must be a table, got {value!r}")
    return dict(value)


def _sources(sources) -> tuple:
    if isinstance(sources, str) or not isinstance(sources, (list, tuple)) or not all(
        isinstance(x, str) for x in sources
    ):
        raise InvalidParameterError(f"sources must be a list of strings, got {describe(sources)}")
    return tuple(sources)


def _check_keys(path: str, table: dict, allowed: set) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InvalidParameterError(
            f"{path} has unknown field(s) {unknown}; allowed: {sorted(allowed)}"
        )


# --------------------------------------------------------------------------- mass properties


def mass_properties(body: dict) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), centre of mass (m, (3,)) and inertia about it (kg·m², (3, 3)) of a [body] table.

    Exactly one form: ``shape`` (one box or cylinder at the origin), ``parts`` (point masses,
    boxes and cylinders composed with the parallel-axis theorem) or ``inertia`` (explicit).
    """
    forms = [k for k in ("shape", "parts", "inertia") if k in body]
    if len(forms) != 1:
        raise InvalidParameterError(
            f"body must give exactly one of 'shape', 'parts' or 'inertia', got {forms or 'none'}"
        )
    form = forms[0]
    if form == "shape":
        mass, inertia = _part_inertia("body", body, allow_point=False)
        return mass, np.zeros(3), inertia
    if form == "parts":
        _check_keys("body", body, {"parts"})
        return _compose(body["parts"])
    _check_keys("body", body, {"mass", "inertia", "com"})
    mass = _number("body.mass", body.get("mass"), **_MASS)
    raw = check.finite_array("body.inertia", body["inertia"])
    inertia = np.diag(raw) if raw.shape == (3,) else bounded_array("body.inertia", raw, (3, 3))
    moments = np.linalg.eigvalsh(inertia_lib.validate(inertia, name="body.inertia"))
    if moments[0] < _MOMENT[0] or moments[-1] > _MOMENT[1]:
        raise InvalidParameterError(
            f"body.inertia principal moments must lie in [{_MOMENT[0]:g}, {_MOMENT[1]:g}] kg·m², "
            f"got {describe(moments)}"
        )
    com = bounded_array("body.com", body.get("com", [0.0, 0.0, 0.0]), (3,), bound=_COORD)
    return mass, np.array(com), np.array(inertia, dtype=float)


def _part_inertia(path: str, part: dict, allow_point: bool) -> tuple[float, np.ndarray]:
    """Mass and inertia about the part's own centre (body axes) of one shape table."""
    shapes = ("box", "cylinder", "point") if allow_point else ("box", "cylinder")
    shape = _choice(f"{path}.shape", part.get("shape"), shapes)
    keys = {"box": {"size", "hollow"}, "cylinder": {"radius", "height", "hollow"}, "point": set()}
    _check_keys(path, part, {"shape", "mass"} | keys[shape] | ({"position"} if allow_point
                                                                  else set()))
    mass = _number(f"{path}.mass", part.get("mass"), **_MASS)
    hollow = _flag(f"{path}.hollow", part.get("hollow", False))
    if shape == "point":
        return mass, np.zeros((3, 3))
    if shape == "box":
        size = bounded_array(f"{path}.size", part.get("size"), (3,), bound=_LENGTH["high"])
        if (size <= 0).any():
            raise InvalidParameterError(f"{path}.size must be > 0 m, got {describe(size)}")
        return mass, (inertia_lib.hollow_box if hollow else inertia_lib.solid_box)(mass, size)
    radius = _number(f"{path}.radius", part.get("radius"), **_LENGTH)
    height = _number(f"{path}.height", part.get("height"), **_LENGTH)
    if hollow:
        return mass, inertia_lib.hollow_cylinder(mass, radius, height)
    return mass, inertia_lib.solid_cylinder(mass, radius, height)


def _compose(parts) -> tuple[float, np.ndarray, np.ndarray]:
    if not isinstance(parts, list) or not parts:
        raise InvalidParameterError(f"body.parts must be a non-empty list of tables, got {parts!r}")
    masses, positions, inertias = [], [], []
    for i, part in enumerate(parts):
        path = f"body.parts[{i}]"
        if not isinstance(part, dict):
            raise InvalidParameterError(f"{path} must be a table, got {part!r}")
        m, inertia = _part_inertia(path, part, allow_point=True)
        masses.append(m)
        positions.append(bounded_array(f"{path}.position", part.get("position"), (3,),
                                       bound=_COORD))
        inertias.append(inertia)
    total = float(sum(masses))
    com = sum(m * p for m, p in zip(masses, positions, strict=True)) / total
    inertia = sum(inertia_lib.parallel_axis(J, m, p - com)
                  for m, p, J in zip(masses, positions, inertias, strict=True))
    return total, np.asarray(com, dtype=float), inertia


# --------------------------------------------------------------------------- registry


def _scene_dir():
    return resources.files("rbenv") / "scenes"


def list_scenes() -> list[str]:
    """Names of the scenes shipped with rbenv (``rbenv/scenes/*.toml``), sorted."""
    return sorted(p.name[:-5] for p in _scene_dir().iterdir() if p.name.endswith(".toml"))


def load_scene(scene=DEFAULT_SCENE) -> Scene:
    """A :class:`Scene` from a shipped name, a path to a TOML file, or a Scene (returned as is)."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, Path)):
        text = str(scene)
        if text in list_scenes():
            with resources.as_file(_scene_dir() / f"{text}.toml") as path:
                return Scene.from_toml(path)
        path = Path(scene)
        if path.suffix == ".toml" and path.exists():
            return Scene.from_toml(path)
        if path.suffix == ".toml":
            raise InvalidChoiceError("scene", text, f"scene file {text!r} does not exist")
        raise invalid_choice("scene", text, list_scenes(), what="a shipped name:",
                             extra="or give a path to an existing .toml file or a rbenv.Scene")
    raise InvalidParameterError(
        f"scene must be a name, a path or a rbenv.Scene, got {type(scene).__name__}"
    )
