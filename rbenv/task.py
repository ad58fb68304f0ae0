"""The reorientation task, written once for one satellite (floats) and for N (arrays).

Everything the single env and the vector env compute per step lives here: action → throttle,
throttle → wrench, the physics step (``core.integrators`` kernels), the error quaternion, the
observation, the reward terms, success and loss of control, and the info values. States are
component tuples as in :mod:`core.kernels`: each component is a Python float in
:class:`rbenv.SatelliteReorientEnv` (tens of nanoseconds per operation) and an (N,) array in
:class:`rbenv.SatelliteReorientVectorEnv`. The few operations that differ between the two
(``where``, ``clip``, ``sqrt``, ...) go through :data:`FLOAT_OPS` or :data:`ARRAY_OPS`.

Conventions: quaternions (w, x, y, z), Hamilton, body→world; ``q_err = q_target* ⊗ q`` is the
rotation from the target attitude to the body attitude, its vector part is the same in body
and target axes (it lies on the rotation axis).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields

import numpy as np

from core import INTEGRATORS
from core import kernels as k
from core.dynamics import check_finite_state, translate
from core.errors import InvalidParameterError, NonFiniteError
from rbenv.scene import G0, Scene, load_scene

__all__ = [
    "ACTION_MODES",
    "ARRAY_OPS",
    "FLOAT_OPS",
    "OBS_SIZE",
    "REWARD_TERMS",
    "RewardWeights",
    "State",
    "TaskConfig",
    "make_config",
]

ACTION_MODES = ("throttle", "on_off", "torque")
REWARD_TERMS = ("attitude", "rate", "fuel", "progress", "hold", "failure")
OBS_SIZE = 7
_INV_PI = 1.0 / math.pi
_DEG = 180.0 / math.pi


# --------------------------------------------------------------------------- float / array ops


class _FloatOps:
    """Scalar versions of the few operations that differ between floats and arrays."""

    sqrt = staticmethod(math.sqrt)
    atan2 = staticmethod(math.atan2)

    @staticmethod
    def where(cond, a, b):
        return a if cond else b

    @staticmethod
    def clip1(x):
        return -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)

    @staticmethod
    def min1(x):
        return x if x < 1.0 else 1.0

    @staticmethod
    def sign(x):
        return -1.0 if x < 0.0 else 1.0

    @staticmethod
    def all_finite(components) -> bool:
        return math.isfinite(sum(components))

    @staticmethod
    def any_nan(x) -> bool:
        return x != x


class _ArrayOps:
    """(N,)-array versions of :class:`_FloatOps`."""

    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)
    where = staticmethod(np.where)

    @staticmethod
    def clip1(x):
        return np.clip(x, -1.0, 1.0)

    @staticmethod
    def min1(x):
        return np.minimum(x, 1.0)

    @staticmethod
    def sign(x):
        return np.where(x < 0.0, -1.0, 1.0)

    @staticmethod
    def all_finite(components) -> bool:
        return bool(np.isfinite(sum(components)).all())

    @staticmethod
    def any_nan(x) -> bool:
        return bool(np.isnan(x).any())


FLOAT_OPS = _FloatOps()
ARRAY_OPS = _ArrayOps()


# --------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms (all ≥ 0; the sign is in the term).

    Per control step, with θ the attitude error (rad), ω the body rate, ``L`` the rate limit:
    attitude ``−w·θ/π``; rate ``−w·min(|ω|/L, 1)``; fuel ``−w·Σu_i F_i / ΣF_i``; progress
    ``w·(θ_prev − θ)/π`` (potential-based shaping, sums to ``w·(θ_0 − θ_end)/π``); hold ``+w``
    on every step inside the success thresholds; failure ``−w`` once, on loss of control.
    """

    attitude: float = 0.2
    rate: float = 0.05
    fuel: float = 0.05
    progress: float = 10.0
    hold: float = 1.0
    failure: float = 25.0

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not ok or not math.isfinite(value) or value < 0:
                raise InvalidParameterError(
                    f"reward_weights[{f.name!r}] must be a finite number >= 0, got {value!r}"
                )
            object.__setattr__(self, f.name, float(value))

    @classmethod
    def from_mapping(cls, mapping) -> RewardWeights:
        """Defaults overridden by ``mapping`` (None: all defaults); unknown names are errors."""
        if mapping is None:
            return cls()
        if isinstance(mapping, RewardWeights):
            return mapping
        if not isinstance(mapping, dict):
            raise InvalidParameterError(
                f"reward_weights must be a dict of term -> weight, got {mapping!r}"
            )
        unknown = sorted(set(mapping) - set(REWARD_TERMS))
        if unknown:
            raise InvalidParameterError(
                f"reward_weights has unknown term(s) {unknown}; terms are {list(REWARD_TERMS)}"
            )
        return cls(**mapping)


@dataclass(frozen=True, eq=False)
class TaskConfig:
    """Scene plus env options, with everything the per-step code needs precomputed.

    Build with :func:`make_config`. ``action_matrix`` (n, 4 or 7) maps throttles to
    ``[τ_B (3, N·m), Σ u_i F_i (N), F_B (3, N, only with translation)]``.
    """

    scene: Scene
    action_mode: str
    weights: RewardWeights
    max_initial_angle: float  # rad
    max_initial_rate: float  # rad/s
    allocator_name: str
    n: int = field(init=False)
    action_matrix: np.ndarray = field(init=False, repr=False)
    allocator: object = field(init=False, repr=False)
    torque_authority: np.ndarray = field(init=False, repr=False)
    advance: object = field(init=False, repr=False)
    success_angle: float = field(init=False)  # rad
    obs_rate_scale: float = field(init=False)  # s/rad: ω_B is observed as ω_B / rate_limit
    inv_total_thrust: float = field(init=False)  # 1/N: thrust fraction = Σu_iF_i / ΣF_i
    # Scene scalars read every step, flattened here (one attribute lookup instead of three).
    h: float = field(init=False)  # s, integrator step
    substeps: int = field(init=False)
    control_dt: float = field(init=False)  # s
    fuel_per_impulse: float = field(init=False)  # kg/(N·s) = 1 / (Isp g0)
    rate_limit: float = field(init=False)  # rad/s
    success_rate: float = field(init=False)  # rad/s
    hold_steps: int = field(init=False)
    disturbance_torque: tuple | None = field(init=False)  # N·m, constant model only
    reward_scales: tuple = field(init=False)  # signed weights with 1/π folded in, per term
    action_bounds: tuple = field(init=False, repr=False)  # (low, high) arrays for clipping

    def __post_init__(self):
        sc = self.scene
        thr = sc.thrusters
        object.__setattr__(self, "success_angle", math.radians(sc.episode.success_angle_deg))
        object.__setattr__(self, "obs_rate_scale", 1.0 / sc.episode.rate_limit)
        object.__setattr__(self, "inv_total_thrust", 1.0 / float(thr.max_force.sum()))
        dist = sc.disturbance
        for name, value in (
            ("h", sc.physics.h), ("substeps", sc.physics.substeps),
            ("control_dt", sc.physics.control_dt), ("fuel_per_impulse", 1.0 / (sc.isp * G0)),
            ("rate_limit", sc.episode.rate_limit), ("success_rate", sc.episode.success_rate),
            ("hold_steps", sc.hold_steps),
            ("reward_scales", (-self.weights.attitude * _INV_PI, -self.weights.rate,
                               -self.weights.fuel, self.weights.progress * _INV_PI,
                               self.weights.hold, -self.weights.failure)),
            ("disturbance_torque",
             tuple(dist.torque.tolist()) if dist.model == "constant" else None),
        ):
            object.__setattr__(self, name, value)
        cols = [thr.torque_matrix_B.T, thr.max_force[:, None]]
        if sc.physics.translation:
            cols.append(thr.force_matrix_B.T)
        matrix = np.ascontiguousarray(np.hstack(cols))
        matrix.setflags(write=False)
        object.__setattr__(self, "n", thr.n)
        object.__setattr__(self, "action_matrix", matrix)
        object.__setattr__(self, "advance", INTEGRATORS[sc.physics.integrator].advance)
        allocator, authority = None, None
        if self.action_mode == "torque":
            from rbenv.allocation import axis_authority, make_allocator

            allocator = make_allocator(self.allocator_name, thr.torque_matrix_B)
            authority = axis_authority(thr.torque_matrix_B)
        # Clipping against arrays is cheaper than against Python scalars (no conversion).
        n_act = 3 if self.action_mode == "torque" else thr.n
        low = np.full(n_act, -1.0 if self.action_mode == "torque" else 0.0)
        high = np.ones(n_act)
        for arr in (low, high):
            arr.setflags(write=False)
        object.__setattr__(self, "action_bounds", (low, high))
        object.__setattr__(self, "allocator", allocator)
        object.__setattr__(self, "torque_authority", authority)


def make_config(scene=None, *, integrator=None, control_dt=None, substeps=None,
                action_mode="throttle", reward_weights=None, max_initial_angle_deg=None,
                max_initial_rate=None, allocator="pinv") -> TaskConfig:
    """Resolve env options against a scene (name, path or Scene) into a :class:`TaskConfig`.

    integrator, control_dt (s), substeps: override the scene's physics. action_mode:
    "throttle" | "on_off" | "torque". reward_weights: dict overriding :class:`RewardWeights`.
    max_initial_angle_deg (0–180) and max_initial_rate (rad/s): initial-condition ranges
    (curriculum), default from the scene. allocator: "pinv" | "nnls" | "lp" (torque mode only).
    """
    sc = load_scene("cubesat-12u" if scene is None else scene)
    sc = sc.with_physics(integrator=integrator, control_dt=control_dt, substeps=substeps)
    if action_mode not in ACTION_MODES:
        raise InvalidParameterError(
            f"action_mode must be one of {list(ACTION_MODES)}, got {action_mode!r}"
        )
    if allocator not in ("pinv", "nnls", "lp"):
        raise InvalidParameterError(
            f"allocator must be one of ['pinv', 'nnls', 'lp'], got {allocator!r}"
        )
    angle, rate = initial_ranges(sc, max_initial_angle_deg, max_initial_rate)
    return TaskConfig(scene=sc, action_mode=action_mode,
                      weights=RewardWeights.from_mapping(reward_weights),
                      max_initial_angle=angle, max_initial_rate=rate, allocator_name=allocator)


def with_initial_ranges(cfg: TaskConfig, max_initial_angle_deg=None,
                        max_initial_rate=None) -> TaskConfig:
    """``cfg`` with new initial-condition ranges (curriculum); None keeps the current value."""
    deg = max_initial_angle_deg
    angle, rate = initial_ranges(
        cfg.scene, float(np.degrees(cfg.max_initial_angle)) if deg is None else deg,
        cfg.max_initial_rate if max_initial_rate is None else max_initial_rate)
    return dataclasses.replace(cfg, max_initial_angle=angle, max_initial_rate=rate)


def initial_ranges(scene: Scene, max_angle_deg=None, max_rate=None) -> tuple[float, float]:
    """Validated (max initial angle in rad, max initial rate in rad/s); None: scene default."""
    ep = scene.episode
    deg = ep.max_initial_angle_deg if max_angle_deg is None else max_angle_deg
    rate = ep.max_initial_rate if max_rate is None else max_rate
    ok_deg = isinstance(deg, (int, float)) and not isinstance(deg, bool) and 0 <= deg <= 180
    if not ok_deg:
        raise InvalidParameterError(f"max_initial_angle_deg must be in [0, 180], got {deg!r}")
    ok_rate = isinstance(rate, (int, float)) and not isinstance(rate, bool) and 0 <= rate
    if not ok_rate or rate >= ep.rate_limit:
        raise InvalidParameterError(
            f"max_initial_rate must be in [0, rate_limit = {ep.rate_limit!r}) rad/s, got {rate!r}"
        )
    return math.radians(float(deg)), float(rate)


# --------------------------------------------------------------------------- state


class State:
    """Mutable episode state; each field a float (one satellite) or an (N,) array (batch).

    q: body→world quaternion (4 components); w: ω_B rad/s (3); q_target_conj: conjugate of the
    target quaternion (4); q_err, angle: canonical error quaternion (4) and its angle (rad) at
    the last step or reset; hold: consecutive
    steps inside the success thresholds; steps: control steps taken; fuel_kg, impulse_Ns:
    cumulative; bias: disturbance torque bias N·m (3) or None; health: (n,) or (N, n) float
    array of 1 (working) / 0 (failed), or None; x, v: centre-of-mass position (m) and velocity
    (m/s) (3) or None; throttle: last applied throttles (n,) or (N, n).
    """

    __slots__ = ("angle", "bias", "fuel_kg", "health", "hold", "impulse_Ns", "q", "q_err",
                 "q_target_conj", "steps", "throttle", "v", "w", "x")

    def __init__(self, **values):
        for name in self.__slots__:
            setattr(self, name, values.get(name))

    def __getstate__(self):
        return {name: getattr(self, name) for name in self.__slots__}

    def __setstate__(self, values):
        for name in self.__slots__:
            setattr(self, name, values[name])


# --------------------------------------------------------------------------- episode start


def restricted_haar_angle(u: float, max_angle: float) -> float:
    """Rotation angle of a Haar-uniform rotation conditioned on angle ≤ max_angle (rad).

    The Haar measure gives the angle the CDF ``(θ − sin θ)/π`` on [0, π]; this inverts it at
    ``u·(θm − sin θm)`` by bisection (u in [0, 1)). With max_angle = π it is the full SO(3).
    """
    target = u * (max_angle - math.sin(max_angle))
    lo, hi = 0.0, max_angle
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid - math.sin(mid) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _unit(v: list) -> list:
    inv = 1.0 / math.sqrt(sum(x * x for x in v))
    return [x * inv for x in v]


def sample_episode(cfg: TaskConfig, rng: np.random.Generator) -> dict:
    """Draw one episode's start from ``rng``: lists of floats, one satellite.

    q_target is uniform on SO(3) (a normalised 4-D Gaussian, as ``core.quaternion.random``).
    The error rotation ``q_target* ⊗ q`` is Haar-uniform on the ball of angle ≤
    max_initial_angle (at 180°: q is an independent uniform rotation); the initial body rate
    has a uniform direction and a magnitude uniform in [0, max_initial_rate]. Then the
    disturbance bias (``random`` model) and the reset faults (``random`` model). Draw layout,
    fixed: 11 normals (target, attitude, rate direction), 2 uniforms, then 3 normals (bias)
    and n uniforms (faults) when modelled. The vector env calls this per sub-env with that
    sub-env's generator, so a sub-env and a single env seeded alike start identically.
    """
    g = rng.standard_normal(11).tolist()
    frac_angle, frac_rate = rng.random(2).tolist()
    q_target = _unit(g[0:4])
    if cfg.max_initial_angle >= math.pi:
        q = _unit(g[4:8])
    else:
        theta = restricted_haar_angle(frac_angle, cfg.max_initial_angle)
        q = list(k.qmul(q_target, k.exp(k.scale(_unit(g[4:7]), theta))))
    w = k.scale(_unit(g[8:11]), cfg.max_initial_rate * frac_rate)
    start = {"q": q, "omega_B": list(w), "q_target": q_target, "bias": None, "health": None}
    sc = cfg.scene
    if sc.disturbance.model == "random":
        start["bias"] = (sc.disturbance.bias_sigma * rng.standard_normal(3)).tolist()
    if sc.faults.model == "random":
        start["health"] = (rng.random(cfg.n) >= sc.faults.p_reset).astype(float)
    return start


# --------------------------------------------------------------------------- per step


def nan_action_error(action) -> ValueError:
    """The ValueError for an action containing NaN, naming the first bad index."""
    bad = np.argwhere(np.isnan(np.asarray(action, dtype=float)))
    where = tuple(int(i) for i in bad[0]) if len(bad) else ()
    return ValueError(
        f"action must not contain NaN (got NaN at index {where}); actions outside [-1, 1] are "
        "clipped to the action space, but NaN has no meaning"
    )


def throttle(cfg: TaskConfig, a: np.ndarray) -> np.ndarray:
    """Throttles (duty cycles) in [0, 1] from an action, (n,) or (N, n) (torque mode: (…, 3)).

    throttle: ``clip(a, 0, 1)`` (a ≤ 0 is off; values outside [-1, 1] are clipped). on_off:
    ``a > 0`` fires at full throttle. torque: ``clip(a, -1, 1) · authority`` (N·m per axis)
    allocated by the configured allocator. NaN is rejected (ValueError), in throttle mode by
    the caller from the propagated NaN thrust (no extra check on the hot path).
    """
    mode = cfg.action_mode
    low, high = cfg.action_bounds
    if mode == "throttle":
        return np.minimum(np.maximum(a, low), high)
    if np.isnan(a).any():
        raise nan_action_error(a)
    if mode == "on_off":
        return (a > 0.0).astype(float)
    return cfg.allocator(np.minimum(np.maximum(a, low), high) * cfg.torque_authority)


def wrench(cfg: TaskConfig, u: np.ndarray):
    """Components ``(τx, τy, τz, Σu_iF_i[, Fx, Fy, Fz])``, body frame, of throttles (n,)/(N, n)."""
    if u.ndim == 1:
        return (u @ cfg.action_matrix).tolist()  # a list of floats: kernels index it alike
    return tuple(cfg.action_matrix.T @ u.T)


def physics_step(cfg: TaskConfig, ops, st: State, parts: tuple, dist_noise) -> None:
    """Advance ``st`` over one control step under thruster wrench ``parts`` (see :func:`wrench`).

    The thruster torque (duty cycle × full torque, held over the step) plus the disturbance
    (constant torque, or bias + ``dist_noise``) drives ``substeps`` integrator steps; with
    translation the centre of mass moves under the body force rotated to the world frame at
    each substep. Raises NonFiniteError if the attitude state is not finite afterwards.
    """
    tau = parts[:3]
    if st.bias is not None:
        tau = k.add(tau, st.bias)
        if dist_noise is not None:
            tau = k.add(tau, dist_noise, cfg.scene.disturbance.noise_sigma)
    elif cfg.disturbance_torque is not None:
        tau = k.add(tau, cfg.disturbance_torque)
    body, h, advance = cfg.scene.body, cfg.h, cfg.advance
    q, w = st.q, st.w
    for _ in range(cfg.substeps):
        if st.x is not None:
            _translate(cfg, st, k.rotate(q, parts[4:7]))
        q, w = advance(body, q, w, h, tau, None)
    if not ops.all_finite((*q, *w)):
        name = cfg.scene.physics.integrator
        check_finite_state(q, w, name, h)
        raise NonFiniteError(f"simulation diverged (state overflow) with integrator={name!r}, "
                             f"dt={h!r}")
    st.q, st.w = q, w
    impulse = parts[3] * cfg.control_dt
    st.impulse_Ns = st.impulse_Ns + impulse
    st.fuel_kg = st.fuel_kg + impulse * cfg.fuel_per_impulse


def _translate(cfg: TaskConfig, st: State, force_W: tuple) -> None:
    """Move the centre of mass one integrator step under force_W (N, world frame), per axis."""
    name, body, h = cfg.scene.physics.integrator, cfg.scene.body, cfg.h
    moved = [translate(name, body, st.x[i], st.v[i], h, force_W[i]) for i in range(3)]
    st.x = tuple(m[0] for m in moved)
    st.v = tuple(m[1] for m in moved)


def error(ops, q_target_conj: tuple, q: tuple) -> tuple[tuple, object]:
    """Canonical error quaternion ``q_err = q_target* ⊗ q`` (w ≥ 0) and its angle in [0, π]."""
    e = k.qmul(q_target_conj, q)
    s = ops.sign(e[0])
    e = (s * e[0], s * e[1], s * e[2], s * e[3])
    return e, 2.0 * ops.atan2(ops.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), e[0])


def observe(cfg: TaskConfig, ops, st: State, noise) -> tuple:
    """The 7 observation components: canonical q_err (4) then ω_B / rate_limit (3), in [-1, 1].

    noise: None, or 6 standard-normal components; then the attitude is measured as
    ``q ⊗ exp(σ_att·n[:3])`` and the rate as ``ω_B + σ_rate·n[3:]``; without noise it reuses
    ``st.q_err``, the true error of the last :func:`evaluate` (or reset).
    """
    w = st.w
    if noise is None:
        e = st.q_err
    else:
        sn = cfg.scene.sensor_noise
        q = k.qnormalize(k.qmul(st.q, k.exp(k.scale(noise[:3], sn.attitude))))
        w = k.add(w, noise[3:], sn.rate)
        e, _ = error(ops, st.q_target_conj, q)
    s = cfg.obs_rate_scale
    clip1 = ops.clip1
    return (*e, clip1(w[0] * s), clip1(w[1] * s), clip1(w[2] * s))


def evaluate(cfg: TaskConfig, ops, st: State, thrust_fraction):
    """Reward terms, reward, success and loss of control after a physics step; updates st.

    Returns ``(terms, reward, success, failure)``; terms follow :data:`REWARD_TERMS` and
    ``reward`` is their left-to-right sum. Success and failure use the true state (not the
    noisy measurement): success when the error < success angle and |ω| < success rate held
    for ``hold_steps`` steps; failure (loss of control) when |ω| > rate limit.
    """
    s_att, s_rate, s_fuel, s_prog, s_hold, s_fail = cfg.reward_scales
    st.q_err, angle = error(ops, st.q_target_conj, st.q)
    w = st.w
    rate = ops.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    inside = (angle < cfg.success_angle) & (rate < cfg.success_rate)
    st.hold = ops.where(inside, st.hold + 1, 0)
    st.steps = st.steps + 1
    success = st.hold >= cfg.hold_steps
    failure = rate > cfg.rate_limit
    terms = (
        s_att * angle,
        s_rate * ops.min1(rate * cfg.obs_rate_scale),
        s_fuel * thrust_fraction,
        s_prog * (st.angle - angle),
        s_hold * inside,
        s_fail * failure,
    )
    st.angle = angle
    reward = terms[0] + terms[1] + terms[2] + terms[3] + terms[4] + terms[5]
    return terms, reward, success, failure


def info(cfg: TaskConfig, ops, st: State, terms, success) -> dict:
    """Info values: error (deg), rate (deg/s), fuel (kg), impulse (N·s), time, success, terms."""
    w = st.w
    out = {
        "attitude_error_deg": st.angle * _DEG,
        "rate_dps": ops.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * _DEG,
        "fuel_kg": st.fuel_kg,
        "impulse_Ns": st.impulse_Ns,
        "time_s": st.steps * cfg.control_dt,
        "is_success": success,
        "reward_attitude": terms[0],
        "reward_rate": terms[1],
        "reward_fuel": terms[2],
        "reward_progress": terms[3],
        "reward_hold": terms[4],
        "reward_failure": terms[5],
    }
    if st.x is not None:
        v = st.v
        out["speed_mps"] = ops.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if st.health is not None:
        out["failed_thrusters"] = cfg.n - st.health.sum(axis=-1)
    return out


# --------------------------------------------------------------------------- reset helpers

STATE_OPTIONS = {"q": 4, "omega_B": 3, "q_target": 4}


def override_start(start: dict, options: dict | None, index: int | None = None) -> dict:
    """Replace sampled start values by ``options["q" | "omega_B" | "q_target"]`` when given.

    One env: values of shape (4,), (3,), (4,). Vector env: (N, 4), (N, 3), (N, 4), of which
    row ``index`` is used. Quaternions must be unit to 1e-6 (they are renormalised); ω_B in
    rad/s, body frame. Unknown option names are errors.
    """
    if not options:
        return start
    allowed = set(STATE_OPTIONS)
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise InvalidParameterError(f"reset options has unknown key(s) {unknown}; allowed: "
                                    f"{sorted(allowed)}")
    for key, width in STATE_OPTIONS.items():
        if key not in options:
            continue
        arr = np.asarray(options[key], dtype=float)
        if index is not None:
            arr = arr[index]
        if arr.shape != (width,) or not np.isfinite(arr).all():
            shape = (width,) if index is None else ("num_envs", width)
            raise InvalidParameterError(
                f"options[{key!r}] must be finite with shape {shape}, got "
                f"{np.asarray(options[key])!r}"
            )
        if width == 4:
            norm = float(np.linalg.norm(arr))
            if abs(norm - 1.0) > 1e-6:
                raise InvalidParameterError(
                    f"options[{key!r}] must be a unit quaternion (w, x, y, z), got norm {norm!r}"
                )
            arr = arr / norm
        start[key] = arr.tolist()
    return start


def conj(q) -> tuple:
    """Conjugate of a quaternion given as 4 components."""
    return (q[0], -q[1], -q[2], -q[3])
