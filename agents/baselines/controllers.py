"""Scripted attitude controllers with SB3's ``predict`` interface.

Both laws read only the observation (canonical error quaternion ``q_err = q_target* ⊗ q`` and
``ω_B / rate_limit``), turn a body-torque demand into thruster throttles through an allocator,
and are built from an env so they use its scene's inertia and thruster layout. ``predict``
takes one observation (7,) or a batch (N, 7) and returns ``(actions, state)`` like an SB3 model,
so one evaluation routine serves scripted and learned policies. ``state`` carries the sign
memory of the unwinding hysteresis; pass it back on the next call (and ``episode_start`` to
forget it), exactly as for a recurrent SB3 policy.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np
from rbenv.agents import settings
from rbenv.core.errors import InvalidParameterError
from rbenv.core.vec import cross

from rbenv.envs import registry
from rbenv.satellite.actuators import Magnetorquers
from rbenv.satellite.actuators.magnetorquers import FIELD_SCALE_T
from rbenv.satellite.actuators.wheels import ACCELERATION_MODES
from rbenv.satellite.allocation import axis_authority, make_allocator
from rbenv.satellite.plant import Plant
from rbenv.tasks import Task
from rbenv.tasks.desaturate import HOLD_MAX_RATE_FRACTION, hold_natural_frequency


def env_parts(env) -> tuple[Plant, Task]:
    """The (plant, task) of a single env, vector env, wrapped env or SB3 adapter."""
    for candidate in (env, getattr(env, "unwrapped", None), getattr(env, "venv", None),
                      getattr(getattr(env, "venv", None), "unwrapped", None)):
        plant, task = getattr(candidate, "plant", None), getattr(candidate, "task", None)
        if isinstance(plant, Plant) and isinstance(task, Task):
            return plant, task
    raise TypeError(f"cannot find an rbenv plant and task on {type(env).__name__}")


@dataclass(frozen=True, eq=False)
class _TorqueController:
    """Shared plumbing: observation → named quantities, torque demand → action.

    The observation is decoded by name through the task (``task.decode``), so the same law
    serves any task whose observation carries what it needs; the thresholds and limits it uses
    come from the task and the scene, never from literals.
    """

    plant: Plant
    task: Task
    allocator_name: str = "pinv"
    hysteresis: float = 0.05  # |w| of q_err below which the rotation direction is kept
    inertia: np.ndarray = field(init=False, repr=False)
    allocate: object = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "inertia", self.plant.scene.body.inertia)
        thrusters = self.plant.scene.thrusters
        allocate = None if thrusters is None else make_allocator(self.allocator_name,
                                                                  thrusters.torque_matrix_B)
        object.__setattr__(self, "allocate", allocate)

    @property
    def config(self) -> Plant:
        """The plant (kept under its earlier name)."""
        return self.plant

    @classmethod
    def from_env(cls, env, **kwargs):
        """Controller for ``env`` (single, vector or wrapped), from its scene and task."""
        plant, task = env_parts(env)
        return cls(plant, task, **kwargs)

    def _continuous_sign(self, q_err: np.ndarray, state, episode_start) -> np.ndarray:
        """q_err (N, 4) with the sign kept continuous with the last step (hysteresis)."""
        if state is None:
            return q_err
        prev = np.asarray(state, dtype=float).reshape(q_err.shape)
        if episode_start is not None:
            prev = np.where(np.asarray(episode_start, bool).reshape(-1, 1), 0.0, prev)
        # Keep the sign continuous with the last step unless the short way round is clearly
        # shorter (|w| > hysteresis): a canonical q_err flips sign at w = 0, and following
        # every flip chatters near 180° (Mayhew, Sanfelice & Teel 2011).
        flip = (np.sum(q_err * prev, axis=1) < 0) & (q_err[:, 0] < self.hysteresis)
        return np.where(flip[:, None], -q_err, q_err)

    def _act(self, torque_B: np.ndarray) -> np.ndarray:
        """Action for the env's action mode from a torque demand (N, 3) in N·m: the slice of
        the actuator that takes body torques (wheels, else thrusters); others get zero."""
        plant = self.plant
        if len(plant.actuators) == 1:
            return self._act_one(torque_B)
        driver = plant.actuator("wheels") or plant.actuator("thrusters")
        out = np.zeros((len(torque_B), plant.action_shape[0]), np.float32)
        out[:, plant.action_slices[plant.actuators.index(driver)]] = self._act_one(torque_B)
        return out

    def _act_one(self, torque_B: np.ndarray) -> np.ndarray:
        plant = self.plant
        if plant.action_mode == "torque":
            return np.clip(torque_B / plant.torque_authority, -1.0, 1.0).astype(np.float32)
        if plant.action_mode in ACCELERATION_MODES:  # α = u/J_eff of the motor torques u = −G⁺τ
            wheels = plant.actuator("wheels")
            alpha = -(torque_B @ wheels.pinv.T) / np.asarray(wheels.eff_inertia)
            a = alpha / wheels.wheels.max_acceleration
            scale = np.maximum(np.abs(a).max(axis=-1, keepdims=True), 1.0)
            return (a / scale).astype(np.float32)
        if plant.action_mode != "throttle":
            raise ValueError(
                f"scripted controllers drive action_mode 'throttle', 'torque' or "
                f"'acceleration', got {plant.action_mode!r}"
            )
        wheels = plant.actuator("wheels")
        if wheels is not None:  # reaction wheels (they drive, thrusters or not): −G u = τ
            u = -(torque_B @ wheels.pinv.T) / wheels.wheels.max_torque
            scale = np.maximum(np.abs(u).max(axis=-1, keepdims=True), 1.0)
            return (u / scale).astype(np.float32)
        return self.allocate(torque_B).astype(np.float32)  # throttle = action on [0, 1]

    def control(self, obs: dict, state, episode_start):
        """Torque demand (N, 3) N·m and the new recurrent state from decoded observations."""
        q_err = self._continuous_sign(obs["q_err"], state, episode_start)
        return self.torque(q_err, obs["omega_B"]), q_err.astype(np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3-style ``(actions, state)`` for observations (size,) or (N, size)."""
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        decoded = self.task.decode(obs.reshape(-1, obs.shape[-1]))
        torque, new_state = self.control(decoded, state, episode_start)
        action = self._act(torque)
        if single:
            return action[0], None if new_state is None else new_state[0]
        return action, new_state

    def torque(self, q_err: np.ndarray, omega_B: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def gyroscopic(self, omega_B: np.ndarray) -> np.ndarray:
        """``ω × Iω`` (N, 3) N·m, the term the feedback cancels."""
        return cross(omega_B, omega_B @ self.inertia.T)


@dataclass(frozen=True, eq=False)
class QuaternionPD(_TorqueController):
    """Quaternion-feedback PD (Wie, Weiss & Arapostathis 1989) with a slew-rate limit.

    ``τ = −I·c·(ω − ω_c) + ω × Iω`` with ``ω_c = −(k/c)·sgn(q0)·q_v`` capped at ``max_rate``
    (the rate-limited eigenaxis form of Wie & Lu 1995): a PD ``τ = −I(k q_v + c ω)`` near the
    target, a coast at ``max_rate`` about the eigenaxis far from it. Gains from natural
    frequency and damping: ``k = 2ωn²``, ``c = 2ζωn`` (small angle: θ̈ + cθ̇ + (k/2)θ = 0).
    Uses only the observation; the sign of q0 comes from ``state`` with hysteresis.
    """

    natural_frequency: float = 0.3  # rad/s
    damping: float = 1.0
    max_rate: float | None = None  # rad/s; default 0.5 × the scene's rate limit

    def torque(self, q_err, omega_B):
        k = 2.0 * self.natural_frequency**2
        c = 2.0 * self.damping * self.natural_frequency
        max_rate = self.max_rate or 0.5 * self.task.rate_limit
        omega_c = -(k / c) * q_err[:, 1:]
        speed = np.linalg.norm(omega_c, axis=1, keepdims=True)
        omega_c = omega_c * np.minimum(1.0, max_rate / np.maximum(speed, 1e-300))
        return -c * (omega_B - omega_c) @ self.inertia.T + self.gyroscopic(omega_B)



@dataclass(frozen=True, eq=False)
class EigenaxisBangBang(_TorqueController):
    """Rate-limited time-optimal eigenaxis slew, with a PD capture near the target.

    Far from the target the commanded rate about the eigenaxis follows the bang-bang
    switching curve ``ω_c = −min(ω_max, √(2 α θ))·ê`` (full acceleration, coast at ω_max,
    full deceleration; corrected for the torque being held over a control step), tracked by a
    deadbeat loop that saturates the thrusters far from the curve; within
    ``capture_deg`` it hands over to :class:`QuaternionPD` so the final approach does not
    chatter. ``α`` is a fraction ``margin`` of the smallest per-axis angular acceleration the
    thrusters can give (torque authority / inertia).
    """

    max_rate: float | None = None  # rad/s; default 0.6 × the scene's rate limit
    margin: float = 0.85
    capture_deg: float = 3.0
    pd: QuaternionPD = field(init=False, repr=False)
    alpha: float = field(init=False)

    def __post_init__(self):
        super().__post_init__()
        if self.plant.scene.thrusters is None:
            raise NotApplicable(f"bangbang plans with the thrusters' authority; scene "
                                f"{self.plant.scene.name!r} has none")
        authority = axis_authority(self.plant.scene.thrusters.torque_matrix_B)
        I_axes = np.diag(self.inertia)
        object.__setattr__(self, "alpha", self.margin * float(np.min(authority / I_axes)))
        object.__setattr__(self, "pd", QuaternionPD(self.plant, self.task,
                                                    self.allocator_name, self.hysteresis))

    def torque(self, q_err, omega_B):
        max_rate = self.max_rate or 0.6 * self.task.rate_limit
        s = np.linalg.norm(q_err[:, 1:], axis=1)
        theta = 2.0 * np.arctan2(s, q_err[:, 0])
        axis = q_err[:, 1:] / np.maximum(s, 1e-300)[:, None]
        # Discrete switching curve: the fastest rate from which full deceleration, applied in
        # steps of dt, still stops at the target: ω = −αdt/2 + √((αdt/2)² + 2αθ).
        half = 0.5 * self.alpha * self.plant.control_dt
        speed = np.minimum(max_rate, np.sqrt(half * half + 2.0 * self.alpha * theta) - half)
        omega_c = -speed[:, None] * axis
        # Deadbeat tracking for a torque held over one control step: remove the rate error in
        # one step (gain·dt = 1); gain·dt = 2 is the discrete stability limit and chatters.
        gain = 1.0 / self.plant.control_dt
        tau = -gain * (omega_B - omega_c) @ self.inertia.T + self.gyroscopic(omega_B)
        near = theta < math.radians(self.capture_deg)
        if near.any():
            tau[near] = self.pd.torque(q_err[near], omega_B[near])
        return tau



@dataclass(frozen=True, eq=False)
class RateDamping(_TorqueController):
    """Detumble by rate damping: ``τ = −(g/dt)·I ω + ω × Iω``, saturated by the allocator.

    ``g`` is the fraction of the rate removed per control step when the thrusters are not
    saturated (``g = 1`` is deadbeat; 0.5 halves the rate each step and does not chatter
    against the success threshold). Reads only ``omega_B`` from the observation.
    """

    gain: float = 0.5

    def control(self, obs, state, episode_start):
        omega_B = obs["omega_B"]
        c = self.gain / self.plant.control_dt
        return -c * omega_B @ self.inertia.T + self.gyroscopic(omega_B), None


@dataclass(frozen=True, eq=False)
class TrackingPD(_TorqueController):
    """Quaternion PD on the error to a moving target, with feedforward of its rate and
    acceleration.

    ``τ = I(−c(e_ω − ω_c) + ω_t × ω) + ω × Iω`` where ``e_ω = ω − ω_t`` is the rate error,
    ``ω_t`` the target's rate in body axes (both observed) and ``ω_c = −(k/c)·q_v`` the
    commanded relative rate, capped at ``max_rate``. ``ω_t × ω`` is the derivative of ``ω_t``
    seen from the turning body: the acceleration feedforward. Gains ``k = 2ωn²``,
    ``c = 2ζωn`` as :class:`QuaternionPD`.
    """

    natural_frequency: float = 0.4  # rad/s
    damping: float = 1.0
    max_rate: float | None = None  # rad/s; default 0.3 × the scene's rate limit

    def control(self, obs, state, episode_start):
        q_err = self._continuous_sign(obs["q_err"], state, episode_start)
        e_w, w_t = obs["omega_err_B"], obs["omega_target_B"]
        omega_B = e_w + w_t
        k = 2.0 * self.natural_frequency**2
        c = 2.0 * self.damping * self.natural_frequency
        max_rate = self.max_rate or 0.3 * self.task.rate_limit
        omega_c = -(k / c) * q_err[:, 1:]
        speed = np.linalg.norm(omega_c, axis=1, keepdims=True)
        omega_c = omega_c * np.minimum(1.0, max_rate / np.maximum(speed, 1e-300))
        alpha = -c * (e_w - omega_c) + cross(w_t, omega_B)
        return alpha @ self.inertia.T + self.gyroscopic(omega_B), q_err.astype(np.float32)


@dataclass(frozen=True)
class ZeroPolicy:
    """Never fires: the uncontrolled baseline (action −1 = all thrusters off)."""

    action_size: int

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation)
        shape = (self.action_size,) if obs.ndim == 1 else (obs.shape[0], self.action_size)
        return np.full(shape, -1.0, dtype=np.float32), state


@dataclass
class RandomPolicy:
    """Uniform random actions from a seeded generator: the no-skill baseline."""

    action_size: int
    seed: int = 0
    rng: np.random.Generator = field(init=False)

    def __post_init__(self):
        self.rng = np.random.default_rng(self.seed)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation)
        shape = (self.action_size,) if obs.ndim == 1 else (obs.shape[0], self.action_size)
        return self.rng.uniform(-1.0, 1.0, shape).astype(np.float32), state


class NotApplicable(InvalidParameterError):
    """A scripted baseline that the scene's actuators cannot run (B-dot without rods, ...); a
    named input error, so ``rbenv evaluate`` prints it as one line."""


def applicable_baselines(env_id: str, scene=None, env_kwargs=None) -> list:
    """The names of ``env_id``'s registered baselines that run on ``scene``, less those run
    only when named (a class with ``on_request = True``: the MPC, which needs its extra and
    far more compute than a scripted law)."""
    if scene is not None and not registry.get(env_id).runs_on(scene):
        return []  # the task itself cannot run there (desaturation without wheels)
    env = gym.make(env_id, scene=scene, **(env_kwargs or {}))
    try:
        names = []
        for name, cls in BASELINES[env.unwrapped.task.name].items():
            if getattr(cls, "on_request", False):
                continue
            try:
                cls.from_env(env)
            except NotApplicable:
                continue
            names.append(name)
        return names
    finally:
        env.close()


@dataclass(frozen=True, eq=False)
class BDot:
    """B-dot detumbling with magnetorquers: ``m = (k/|B|²) ω × B``, saturated per rod.

    The normalised-field law of Avanzini & Giulietti (JGCD 35(4), 2012): with ``ω × B`` for
    −Ḃ_B (the field's own turn along the orbit is slow next to a tumble), the torque
    ``m × B = −(k/|B|²)|B|² ω⊥`` only ever removes kinetic energy. Their quasi-minimum-time
    gain is ``k = 2n(1 + sin ξ_m) J_min`` (N·m·s; n the mean motion, ξ_m the orbit's
    inclination to the geomagnetic equator, J_min the smallest principal inertia). Reads ω and
    the magnetometer from the observation; drives the ``[magnetorquers]`` slice of the action
    and leaves every other actuator at zero.
    """

    plant: Plant
    task: Task
    gain: float = field(init=False)  # N·m·s
    rods: object = field(init=False, repr=False)
    slices: tuple = field(init=False, repr=False)

    def __post_init__(self):
        rods = next((a for a in self.plant.actuators if isinstance(a, Magnetorquers)), None)
        if rods is None:
            raise NotApplicable(f"bdot needs magnetorquers; scene {self.plant.scene.name!r} "
                                "has none")
        orbit = self.plant.scene.orbit
        tilt = math.degrees(math.acos(29350.0 / 29733.0))  # IGRF-14 2025.0 dipole tilt, 9.2°
        xi = math.radians(abs(orbit.inclination_deg - tilt))
        j_min = float(np.linalg.eigvalsh(self.plant.body.inertia).min())
        object.__setattr__(self, "gain", 2.0 * orbit.mean_motion * (1.0 + math.sin(xi)) * j_min)
        object.__setattr__(self, "rods", rods)
        task_size = self.task.observation_size()
        start = task_size
        where = {}
        for act in self.plant.actuators:
            for name, width in act.observation_structure.items():
                where[name] = slice(start, start + width)
                start += width
        object.__setattr__(self, "slices", (self.task.observation_slices()["omega_B"],
                                            where["field_B"]))

    @classmethod
    def from_env(cls, env):
        plant, task = env_parts(env)
        return cls(plant, task)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3-style ``(actions, state)`` for observations (size,) or (N, size)."""
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        w = obs[:, self.slices[0]] * self.task.rate_limit
        b = obs[:, self.slices[1]] * FIELD_SCALE_T
        m = self.gain * cross(w, b) / np.maximum(np.sum(b * b, axis=1, keepdims=True), 1e-18)
        mu = m @ np.linalg.pinv(self.rods.dipole_matrix)  # rod fractions, (N, n)
        mu = mu / np.maximum(np.abs(mu).max(axis=1, keepdims=True), 1.0)
        out = np.zeros((len(obs), self.plant.action_shape[0]), np.float32)
        out[:, self.plant.action_slices[self.plant.actuators.index(self.rods)]] = mu
        return (out[0], state) if single else (out, state)


def _full_slices(plant: Plant, task: Task) -> dict:
    """name → slice of the whole observation: the task's parts, then the actuators'."""
    where = dict(task.observation_slices())
    start = task.observation_size()
    for act in plant.actuators:
        for name, width in act.observation_structure.items():
            where[name] = slice(start, start + width)
            start += width
    return where


@dataclass(frozen=True, eq=False)
class WheelHoldPD(QuaternionPD):
    """Hold the target attitude through the reaction wheels; nothing else acts.

    :class:`QuaternionPD` on the wheel slice of the action, with its gains scaled to the
    control step (``ω_n = min(0.3, 0.2/dt)`` rad/s, so the damping per step ``c·dt = 2ζω_n dt``
    stays at 0.4, well inside the discrete limit of 2, at the 10 s step of a magnetic
    desaturation) and the wheels' momentum in the gyroscopic term: ``τ = −I c (ω − ω_c) +
    ω × (I ω + h_w)``, h_w = G J Ω from the observed wheel speeds. It never unloads: the
    momentum only moves between wheels and bus (the Desaturate task's floor).
    """

    slices: dict = field(init=False, repr=False)
    wheels: object = field(init=False, repr=False)

    def __post_init__(self):
        super().__post_init__()
        wheels = self.plant.actuator("wheels")
        if wheels is None:
            raise NotApplicable(f"{type(self).__name__} needs reaction wheels; scene "
                                f"{self.plant.scene.name!r} has none")
        object.__setattr__(self, "wheels", wheels)
        object.__setattr__(self, "slices", _full_slices(self.plant, self.task))
        if self.max_rate is None:
            object.__setattr__(self, "max_rate", HOLD_MAX_RATE_FRACTION * self.task.rate_limit)
        nat = hold_natural_frequency(self.plant.control_dt)
        object.__setattr__(self, "natural_frequency", nat)

    def wheel_momentum_B(self, obs: np.ndarray) -> np.ndarray:
        """h_w = G (J ⊙ Ω) (N, 3) N·m·s from the observed wheel speeds (relative, Ω/Ω_max)."""
        ws = self.wheels.wheels
        speed = obs[:, self.slices["wheel_speed"]] * ws.max_speed
        return (speed * ws.inertia) @ ws.axes_B

    def hold_torque(self, obs: np.ndarray, state, episode_start):
        """The wheels' body-torque demand (N, 3) N·m and the recurrent state."""
        decoded = self.task.decode(obs[:, :self.task.observation_size()])
        q_err = self._continuous_sign(decoded["q_err"], state, episode_start)
        omega_B = decoded["omega_B"]
        tau = self.torque(q_err, omega_B) + cross(omega_B, self.wheel_momentum_B(obs))
        return tau, q_err.astype(np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        tau, new_state = self.hold_torque(obs, state, episode_start)
        # A task with the wheel loop inside (Desaturate-v1) holds the attitude itself and
        # does not read the wheel entries: zero there, the env's own hold acts.
        action = np.zeros((len(obs), self.plant.action_shape[0]), np.float32) \
            if self.task.inner_loop else self._act(tau)
        return (action[0], new_state[0]) if single else (action, new_state)


@dataclass(frozen=True, eq=False)
class Unload(WheelHoldPD):
    """Momentum unloading while the wheels hold the attitude (reference note §4).

    With magnetorquers, the cross-product law of Basilisk's mtbMomentumManagementSimple,
    ``m = K_p (h_w × B)/|B|²`` (A·m²), which produces ``τ = m × B = −K_p h_w⊥`` (the part of
    h_w across B): the external torque takes momentum out of the wheels. The dipole goes to
    the rods by the pseudo-inverse of their axes and is scaled down as a whole at a rod's
    limit (the torque keeps its direction). Without rods, the thrusters give
    ``τ = −(g/dt) h_w`` through the allocator (thruster dumping). In both cases the
    external torque actually produced is fed forward into the wheel command (mtbFeedforward):
    the wheels make ``τ_hold − τ_ext``, so the attitude loop does not fight the dump and the
    wheels absorb exactly what leaves the satellite. ``K_p`` = 0.003 1/s (Basilisk's
    example); ``g`` = 0.2 (a fifth of the momentum per control step).
    """

    gain: float = 0.003  # 1/s, K_p of the magnetic law
    dump_fraction: float = 0.2  # of h_w per control step, thrusters
    rods: object = field(init=False, repr=False)
    rod_pinv: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        super().__post_init__()
        rods = next((a for a in self.plant.actuators if isinstance(a, Magnetorquers)), None)
        if rods is None and self.plant.actuator("thrusters") is None:
            raise NotApplicable(f"unload needs magnetorquers or thrusters; scene "
                                f"{self.plant.scene.name!r} has neither")
        object.__setattr__(self, "rods", rods)
        object.__setattr__(self, "rod_pinv",
                           None if rods is None else np.linalg.pinv(rods.dipole_matrix))

    def dipole_fractions(self, h_w: np.ndarray, b: np.ndarray, gain: float) -> np.ndarray:
        """The rods' fractions (N, n) of the cross-product law's dipole ``gain (h_w × B)/|B|²``
        (h_w N·m·s and B T, (N, 3) body axes; gain 1/s), by the pseudo-inverse of the rods'
        axes, before any limit."""
        m = gain * cross(h_w, b) / np.maximum(np.sum(b * b, axis=1, keepdims=True), 1e-18)
        return m @ self.rod_pinv

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        tau, new_state = self.hold_torque(obs, state, episode_start)
        h_w = self.wheel_momentum_B(obs)
        plant = self.plant
        out = np.zeros((len(obs), plant.action_shape[0]), np.float32)
        if self.rods is not None:
            b = obs[:, self.slices["field_B"]] * FIELD_SCALE_T
            mu = self.dipole_fractions(h_w, b, self.gain)
            mu = mu / np.maximum(np.abs(mu).max(axis=1, keepdims=True), 1.0)
            mu = mu.astype(np.float32)  # what the env receives
            tau_ext = cross(mu.astype(float) @ self.rods.dipole_matrix, b)
            out[:, plant.action_slices[plant.actuators.index(self.rods)]] = mu
        else:
            thr = plant.actuator("thrusters")
            demand = -(self.dump_fraction / plant.control_dt) * h_w
            throttle = self.allocate(demand).astype(np.float32)
            tau_ext = throttle.astype(float) @ plant.scene.thrusters.torque_matrix_B.T
            out[:, plant.action_slices[plant.actuators.index(thr)]] = throttle
        if not self.task.inner_loop:  # else the env's hold (the same law) drives the wheels
            wheel_action = self._act(tau - tau_ext)
            idx = plant.action_slices[plant.actuators.index(self.wheels)]
            out[:, idx] = wheel_action[:, idx]
        return (out[0], new_state[0]) if single else (out, new_state)


_RPM_S = 2.0 * math.pi / 60.0  # rad/s² per RPM/s


@dataclass(frozen=True, eq=False)
class InnoCubePD:
    """InnoCube's flight PD (data README; fits the logged commands to their rounding), per axis
    in wheel acceleration::

        α_cmd (RPM/s) = clip(−k_p·sign(δq_s)·δq_v − k_d·(1 + δq_vᵀδq_v)·ω, ±clamp)

    δq the error quaternion ``q_target* ⊗ q`` (scalar δq_s, vector δq_v), ω the body rate
    (rad/s). A positive command turns the bus about +axis, as in flight (the logged wheel speed
    runs opposite to the wheel's momentum). It drives ``action_mode="acceleration"`` (or
    "throttle", as the motor torque J_eff·α) on a scene whose wheels lie along the body axes in
    order (±x, ±y, ±z) and give the command clamp (innocube-3u); magnetorquers get zero.
    Gains and clamp are fields: ``InnoCubePD.from_env(env, kp=(...), clamp_rpm_s=...)``.
    """

    plant: Plant
    task: Task
    kp: tuple = (670.0, 670.0, 134.0)  # RPM/s per unit of δq_v
    kd: tuple = (2500.0, 2500.0, 500.0)  # RPM/s per rad/s
    clamp_rpm_s: float = 100.0  # the flight software's command clamp
    scale: np.ndarray = field(init=False, repr=False)  # (3,) action per RPM/s of each axis
    wheel_slice: slice = field(init=False, repr=False)

    def __post_init__(self):
        plant, wheels = self.plant, self.plant.actuator("wheels")
        if wheels is None or plant.action_mode not in (*ACCELERATION_MODES, "throttle") \
                or not wheels.wheels.max_acceleration:
            raise NotApplicable(
                f"innocube-pd commands wheel accelerations: it needs [wheels] with a command "
                f"clamp (max_acceleration_rpm_s) and action_mode 'acceleration' (or "
                f"'throttle'), got scene {plant.scene.name!r} with "
                f"action_mode={plant.action_mode!r}")
        axes = wheels.wheels.axes_B
        if axes.shape != (3, 3) or not np.allclose(np.abs(axes), np.eye(3)):
            raise NotApplicable(
                "innocube-pd needs three wheels along the body axes x, y, z in that order, got "
                f"axes {axes.tolist()}")
        for name in ("kp", "kd"):
            object.__setattr__(self, name, np.broadcast_to(
                np.asarray(getattr(self, name), dtype=float), (3,)).copy())
        # −G u = τ: wheel i along ĝ_i = −e_i makes +e_i torque from a positive command.
        # Action per RPM/s: of the clamp (acceleration mode), or the motor torque J_eff·α as a
        # fraction of u_max (throttle mode).
        sign = -np.diag(axes)
        per = _RPM_S / wheels.wheels.max_acceleration \
            if plant.action_mode in ACCELERATION_MODES \
            else _RPM_S * np.asarray(wheels.eff_inertia) / wheels.wheels.max_torque
        object.__setattr__(self, "scale", sign * per)
        object.__setattr__(self, "wheel_slice",
                           plant.action_slices[plant.actuators.index(wheels)])

    @classmethod
    def from_env(cls, env, **kwargs):
        """The flight PD for ``env`` (single, vector or wrapped)."""
        plant, task = env_parts(env)
        return cls(plant, task, **kwargs)

    def command_rpm_s(self, q_err: np.ndarray, omega_B: np.ndarray) -> np.ndarray:
        """(N, 3) commanded wheel accelerations, RPM/s, from δq (N, 4) and ω (N, 3) rad/s."""
        qv = q_err[:, 1:]
        sign = np.where(q_err[:, :1] < 0.0, -1.0, 1.0)
        cmd = -self.kp * sign * qv - self.kd * (1.0 + np.sum(qv * qv, axis=1,
                                                             keepdims=True)) * omega_B
        return np.clip(cmd, -self.clamp_rpm_s, self.clamp_rpm_s)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3-style ``(actions, None)`` for observations (size,) or (N, size)."""
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        decoded = self.task.decode(obs[:, :self.task.observation_size()])
        cmd = self.command_rpm_s(decoded["q_err"], decoded["omega_B"])
        out = np.zeros((len(obs), self.plant.action_shape[0]), np.float32)
        out[:, self.wheel_slice] = np.clip(cmd * self.scale, -1.0, 1.0)
        return (out[0], None) if single else (out, None)


@dataclass(frozen=True, eq=False)
class InnoCubeSlew(InnoCubePD):
    """A near-time-optimal slew and a pulsed hold for InnoCube's wheels as flown, per axis in
    wheel acceleration: the rate each axis could still brake from at ``brake_fraction`` of
    its weakest authority, ``ω_ref = −sign(θ)·min(√(2·f·a·|θ|), k_θ·|θ|)`` (θ the error's
    axis-angle vector in body axes, a = J_eff·α_clamp·g_min/I per axis), scaled down as a
    whole to |ω_ref| ≤ ω_max (a margin to the rate limit through a flip at 180°), tracked by
    ``α_cmd = k_ω·(ω_ref − ω)·I/J_eff``, clamped to the flight software's ±100 RPM/s.

    It is what the deadband allows a scripted law: flown with ``action_mode=
    "acceleration_lifted"`` every small correction becomes the finest pulse that moves the
    wheel (:func:`rbenv.satellite.actuators.wheels.lift_over_deadband`); with plain
    ``"acceleration"`` it stalls in the deadband like the flight PD. In that mode the
    observation also carries the last step's command (``wheel_command``), which a one-step
    sensor delay (the scene's ``[sensors] delay_steps = 1``) hides from the measured rates:
    the law then first predicts the state that command is making (a Smith predictor:
    ω += g·α_prev·J_eff/I, the attitude turned by the mean rate over one step, g the realized
    gain's mid-range), which keeps the hold from pulsing twice for one error. The
    magnetorquers get zero. A reference for the learned policy, and its teacher
    (docs/innocube/learned-policy.md).
    """

    brake_fraction: float = 0.6  # of the weakest authority used to brake (margin for the gain)
    position_gain: float = 0.3  # k_θ, 1/s: the reference rate's slope near the target
    rate_gain: float = 0.8  # k_ω, 1/s: fraction of the rate error corrected per second
    max_rate: float = 0.2  # rad/s: bound on |ω_ref| (the rate limit is 0.35)
    authority: np.ndarray = field(init=False, repr=False)  # (3,) rad/s² per axis, weakest
    per_rate: np.ndarray = field(init=False, repr=False)  # (3,) RPM/s per rad/s² of the bus
    command_slice: slice | None = field(init=False, repr=False)  # observed last command
    predict_gain: float = field(init=False, repr=False)  # realized gain, mid-range

    def __post_init__(self):
        super().__post_init__()
        wheels = self.plant.actuator("wheels")
        inertia = np.diag(self.plant.scene.body.inertia)
        eff = np.asarray(wheels.eff_inertia)[np.argmax(np.abs(wheels.wheels.axes_B), axis=0)]
        gain = wheels.wheels.flown_ranges[1][0]  # the realized gain's low end
        object.__setattr__(self, "authority", eff * wheels.wheels.max_acceleration * gain
                           / inertia)
        object.__setattr__(self, "per_rate", inertia / eff / _RPM_S)
        delayed = self.plant.scene.sensors.delay_steps == 1  # else the rates show the command
        object.__setattr__(self, "command_slice", _full_slices(self.plant, self.task).get(
            "wheel_command") if delayed else None)
        object.__setattr__(self, "predict_gain", float(np.mean(wheels.wheels.flown_ranges[1])))

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3-style ``(actions, None)`` for observations (size,) or (N, size)."""
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        decoded = self.task.decode(obs[:, :self.task.observation_size()])
        q, w = decoded["q_err"], decoded["omega_B"]
        if self.command_slice is not None:  # the state the last command is making
            last = obs[:, self.command_slice] / self.scale  # RPM/s about each axis
            dw = self.predict_gain * last / self.per_rate
            q = _turned(q, (w + 0.5 * dw) * self.plant.control_dt)
            w = w + dw
        cmd = self.command_rpm_s(q, w)
        out = np.zeros((len(obs), self.plant.action_shape[0]), np.float32)
        out[:, self.wheel_slice] = np.clip(cmd * self.scale, -1.0, 1.0)
        return (out[0], None) if single else (out, None)

    def command_rpm_s(self, q_err: np.ndarray, omega_B: np.ndarray) -> np.ndarray:
        """(N, 3) commanded wheel accelerations, RPM/s, from δq (N, 4) and ω (N, 3) rad/s."""
        qv = q_err[:, 1:] * np.where(q_err[:, :1] < 0.0, -1.0, 1.0)
        norm = np.linalg.norm(qv, axis=1, keepdims=True)
        angle = 2.0 * np.arctan2(norm, np.abs(q_err[:, :1]))
        theta = qv * (angle / np.maximum(norm, 1e-300))
        mag = np.abs(theta)
        ref = -np.sign(theta) * np.minimum(
            np.sqrt(2.0 * self.brake_fraction * self.authority * mag), self.position_gain * mag)
        ref *= self.max_rate / np.maximum(np.linalg.norm(ref, axis=1, keepdims=True),
                                          self.max_rate)
        cmd = self.rate_gain * (ref - omega_B) * self.per_rate
        return np.clip(cmd, -self.clamp_rpm_s, self.clamp_rpm_s)


def _turned(q: np.ndarray, angle_B: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions ``q ⊗ exp(angle_B/2)``: q turned by the small body-axis
    rotation vector ``angle_B`` (N, 3), rad (first order in the angle, normalised)."""
    v = 0.5 * angle_B
    w0, qv = q[:, :1], q[:, 1:]
    out = np.concatenate([w0 - np.sum(qv * v, axis=1, keepdims=True),
                          w0 * v + qv + np.cross(qv, v)], axis=1)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def resolve_baseline(ref):
    """A baseline class from a registry entry's reference: ``"module:Class"`` or the class."""
    if not isinstance(ref, str):
        return ref
    module, _, attr = ref.partition(":")
    try:
        return getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"scripted baseline {ref!r} cannot be loaded: {exc}") from None


class _Baselines(Mapping):
    """Task name → {baseline name → class}, read from the training settings of the task's id
    (rbenv.agents.settings)."""

    def __getitem__(self, task_name: str) -> dict:
        entry = settings.get(registry.by_name(task_name).env_id)
        return {name: resolve_baseline(ref) for name, ref in entry.baselines.items()}

    def __iter__(self):
        return iter([s.name for s in registry.specs()])

    def __len__(self):
        return len(registry.specs())


BASELINES = _Baselines()


def baseline(env, name: str = "pd"):
    """The scripted baseline ``name`` for ``env``'s task, as its registry entry names them:
    "pd" (the shipped tasks: quaternion PD, rate damping, tracking PD) or "bangbang"
    (reorientation only)."""
    _, task = env_parts(env)
    options = BASELINES[task.name]
    if name not in options:
        raise ValueError(f"task {task.name!r} has scripted baselines {sorted(options)}, got "
                         f"{name!r}")
    return options[name].from_env(env)
