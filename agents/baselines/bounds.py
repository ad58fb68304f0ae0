"""Lower bounds on settle time and propellant for the reorientation task, from a scene alone.

No policy, however clever, settles sooner or spends less than these bounds on an episode, so
``achieved / bound`` measures how far a controller is from the limit (docs/bounds.md derives
each bound and says why it is valid). Everything here holds for the continuous rigid-body
dynamics ``I ω̇ + ω × Iω = τ``, throttles in [0, 1] held over each control step of ``dt`` s (as
the env applies them), the rate limit checked at the control steps (as the env checks it) and
the scene's disturbance torque if it is a constant or a per-episode bias.

Three facts carry both bounds:

* the attitude error angle θ changes no faster than the body rate: ``|θ̇| ≤ |ω|`` (θ is the
  distance to the target in the bi-invariant metric of SO(3), whose speed is ``|ω|``);
* settling needs θ < ``success_angle`` and ``|ω| <`` ``success_rate`` at a control step;
* the gyroscopic term ``ω × Iω`` does no work and keeps ``|Iω|``: any weighted rate
  ``s = |P^½ ω|`` with ``P = I + κ I²`` (positive definite) changes only through the torque,
  ``|ṡ| ≤ |P^½ I⁻¹ τ|``.

Settle time: ``v = |ω|`` obeys ``|v̇| ≤ A``, with ``A`` the largest ``|I⁻¹(Bu + τ_d)|`` over
throttles (a vertex of the box, enumerated) plus a gyroscopic allowance, and ``v ≤ V̂`` between
steps (:func:`rate_cap`). The fastest ``v`` profile covering the angle is bang-coast-bang
(:func:`bang_coast_bang_time`). Propellant: :func:`fuel_bound`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from rbenv.core.errors import InvalidParameterError
from scipy.optimize import linprog

from rbenv.satellite.actuators.thrusters import G0
from rbenv.satellite.scene import Scene, load_scene

__all__ = [
    "SceneLimits",
    "TorqueLimits",
    "WheelLimits",
    "bang_coast_bang_time",
    "detumble_fuel_bound",
    "energy_settle_bound",
    "episode_starts",
    "fuel_bound",
    "gyro_coefficient",
    "max_weighted_torque",
    "min_impulse_lp",
    "rate_cap",
    "rate_caps_with_wheels",
    "scene_limits",
    "settle_time_bound",
    "weighted_rate_forms",
]

_MAX_ENUMERATED_THRUSTERS = 20  # 2^20 throttle vertices; beyond, the triangle inequality
# The weighted-rate family P = I + κ I², κ = t / λ_max with t on this grid (t > -1: P > 0).
_KAPPA_GRID = np.concatenate([np.linspace(-0.98, 0.0, 50), np.linspace(0.02, 4.0, 50)])


@dataclass(frozen=True)
class SceneLimits:
    """What the bounds need from a scene (SI units; rad, s).

    inertia_B: (3, 3) kg·m² about the centre of mass; inertia_min/max: its principal moments.
    torque_max: N·m, largest ``|B u|`` over throttles u in [0, 1]^n (B: torque matrix).
    accel_axis: rad/s², ``torque_max / inertia_min`` (largest torque along any axis over the
    smallest principal inertia). accel_max: rad/s², largest ``|I⁻¹ B u|`` (≤ accel_axis).
    gyro_coeff: 1/rad, ``c`` with ``|I⁻¹(ω × Iω)| ≤ c |ω|²``. rate_limit: rad/s, checked at
    control steps; rate_cap: rad/s, bound on ``|ω|`` at every instant (:func:`rate_cap`).
    settle_time_max: s, latest settle time of a successful episode (the hold must end within
    the episode). fuel_per_impulse: kg/(N·s) = 1 / (Isp g0).
    """

    inertia_B: np.ndarray
    inertia_min: float
    inertia_max: float
    torque_matrix_B: np.ndarray
    max_force: np.ndarray
    torque_max: float
    accel_axis: float
    accel_max: float
    gyro_coeff: float
    rate_limit: float
    rate_cap: float
    control_dt: float
    success_angle: float
    success_rate: float
    settle_time_max: float
    fuel_per_impulse: float
    constant_torque_B: np.ndarray  # N·m, the scene's constant disturbance (zeros if none)

    def summary(self) -> dict:
        """The scalar limits as a JSON-ready dict."""
        keys = ("inertia_min", "inertia_max", "torque_max", "accel_axis", "accel_max",
                "gyro_coeff", "rate_limit", "rate_cap", "control_dt", "success_angle",
                "success_rate", "settle_time_max", "fuel_per_impulse")
        return {k: float(getattr(self, k)) for k in keys}


def max_weighted_torque(torque_matrix_B, weight=None) -> float:
    """Largest ``|M B u|`` over throttles u in [0, 1]^n (M: (3, 3), default identity).

    ``|M B u|`` is convex in u, so its maximum over the box is at a vertex (u_i ∈ {0, 1}); up
    to 20 thrusters every vertex is checked (exact), beyond that the triangle inequality
    ``Σ |M b_i|`` is returned (still an upper bound, looser).
    """
    B = np.asarray(torque_matrix_B, float)
    MB = B if weight is None else np.asarray(weight, float) @ B
    n = MB.shape[1]
    if n > _MAX_ENUMERATED_THRUSTERS:
        return float(np.linalg.norm(MB, axis=0).sum())
    best = 0.0
    low_bits = min(n, 12)
    low = ((np.arange(2 ** low_bits)[:, None] >> np.arange(low_bits)) & 1).astype(float)
    base = low @ MB[:, :low_bits].T  # (2^low_bits, 3)
    for high in range(2 ** (n - low_bits)):
        bits = (high >> np.arange(n - low_bits)) & 1
        shift = MB[:, low_bits:] @ bits
        best = max(best, float(np.sqrt(((base + shift) ** 2).sum(axis=1)).max()))
    return best


def gyro_coefficient(inertia_B, grid: int = 401) -> float:
    """An upper bound on ``c = max |I⁻¹(ω × Iω)|`` over unit ω (1/rad; |gyro accel| ≤ c|ω|²).

    The function is evaluated on a grid of ``grid²`` points on each face of the cube [-1, 1]³,
    projected to the sphere; every unit vector lies within δ = (2/(grid − 1))/√2 of a grid
    point (radial projection onto the ball does not increase distances). With D = I − λ̄ (λ̄
    the mid-range of the principal moments), ``ω × Iω = ω × Dω``, so the function is Lipschitz
    with constant ``(λmax − λmin)/λmin`` on the sphere; the grid maximum plus that constant
    times δ is therefore an upper bound (within ≈ 1 % of the true maximum at the default grid).
    """
    inertia = np.asarray(inertia_B, float)
    lam = np.linalg.eigvalsh(inertia)
    g = np.linspace(-1.0, 1.0, grid)
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    faces = []
    for axis in range(3):
        others = [i for i in range(3) if i != axis]
        for sign in (-1.0, 1.0):
            p = np.empty((a.size, 3))
            p[:, axis], p[:, others[0]], p[:, others[1]] = sign, a, b
            faces.append(p)
    w = np.vstack(faces)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    gyro = np.linalg.solve(inertia, np.cross(w, w @ inertia.T).T).T
    delta = (2.0 / (grid - 1)) / math.sqrt(2.0)
    lipschitz = (lam[-1] - lam[0]) / lam[0]
    return float(np.linalg.norm(gyro, axis=1).max() + lipschitz * delta)


def rate_cap(rate_limit: float, gyro_coeff: float, control_dt: float) -> float:
    """Bound on ``|ω(t)|`` at every instant when ``|ω| ≤ rate_limit`` at the control steps.

    Within a step the torque ``Bu + τ_d`` is constant, so ``ω(t) = ω_k + t·a + r(t)`` with a
    constant ``a`` and a gyroscopic remainder ``|r(t)| ≤ c V² t`` while ``|ω| ≤ V``. ``|ω_k +
    t a|`` is convex in t, hence ≤ max(|ω_k|, |ω_k+1 − r(dt)|) ≤ L + c V² dt, and ``|ω(t)| ≤
    L + 2 c V² dt``. The smallest root V of ``2 c dt V² − V + L = 0`` is the cap (|ω| starts
    below it and, being continuous, cannot jump past the gap between the two roots). rad/s.
    """
    a = 2.0 * gyro_coeff * control_dt
    if a == 0.0:
        return float(rate_limit)
    disc = 1.0 - 4.0 * a * rate_limit
    if disc < 0.0:
        raise InvalidParameterError(
            f"rate_limit={rate_limit!r} rad/s with control_dt={control_dt!r} s: the "
            "gyroscopic term can outgrow the rate limit within a step, so no finite rate cap "
            "follows (need 8·c·dt·L ≤ 1)")
    return float((1.0 - math.sqrt(disc)) / (2.0 * a))


def _check_scene(scene: Scene) -> None:
    """The bounds assume a bounded disturbance and the nominal model."""
    if scene.disturbance.model == "random" and scene.disturbance.noise_sigma > 0.0:
        raise InvalidParameterError(
            f"scene {scene.name!r}: disturbance.noise_sigma={scene.disturbance.noise_sigma!r} "
            "makes the disturbance torque unbounded, so no lower bound holds (need 0)")
    if scene.randomization.enabled:
        raise InvalidParameterError(
            f"scene {scene.name!r}: randomization is enabled; the bounds need the nominal "
            "inertia and thrusters (use the scene without randomization)")


def scene_limits(scene=None) -> SceneLimits:
    """The limits of ``scene`` (a Scene, a shipped name or a path; default cubesat-12u)."""
    sc = scene if isinstance(scene, Scene) else load_scene(*(() if scene is None else (scene,)))
    _check_scene(sc)
    inertia = np.array(sc.body.inertia, float)
    lam = np.linalg.eigvalsh(inertia)
    B = np.array(sc.thrusters.torque_matrix_B, float)
    torque_max = max_weighted_torque(B)
    gyro = gyro_coefficient(inertia)
    ep, dt = sc.episode, sc.physics.control_dt
    constant = (np.array(sc.disturbance.torque, float) if sc.disturbance.model == "constant"
                else np.zeros(3))
    return SceneLimits(
        inertia_B=inertia, inertia_min=float(lam[0]), inertia_max=float(lam[-1]),
        torque_matrix_B=B, max_force=np.array(sc.thrusters.max_force, float),
        torque_max=torque_max, accel_axis=torque_max / float(lam[0]),
        accel_max=max_weighted_torque(B, np.linalg.inv(inertia)), gyro_coeff=float(gyro),
        rate_limit=float(ep.rate_limit), rate_cap=rate_cap(ep.rate_limit, gyro, dt),
        control_dt=float(dt), success_angle=math.radians(ep.success_angle_deg),
        success_rate=float(ep.success_rate),
        settle_time_max=float(ep.duration - ep.hold_time + dt),
        fuel_per_impulse=1.0 / (sc.actuators["thrusters"].isp * G0), constant_torque_B=constant)


# --------------------------------------------------------------------------- settle time

def bang_coast_bang_time(distance, v0, v_end, accel, v_cap):
    """Least time T for a speed v(t) with ``|v̇| ≤ accel``, ``0 ≤ v ≤ v_cap``, v(0) = v0 and
    v(T) ≤ v_end to cover ``∫ v dt ≥ distance``. Arrays broadcast; s.

    The largest speed profile for a given T is ``min(v0 + a t, v_cap, v_end + a (T − t))``
    (accelerate, coast, brake), and its integral grows with T, so T is the first time it
    reaches ``distance``: one of four closed forms (no motion needed; accelerating only; a
    triangle; a trapezoid with a coast at ``v_cap``). Requires v0 ≤ v_cap and v_end ≤ v_cap.
    """
    d = np.maximum(np.asarray(distance, float), 0.0)
    v0, v_end, a, cap = (np.asarray(x, float) for x in (v0, v_end, accel, v_cap))
    # Braking from v0 down to v_end takes at least this long, covering this much.
    t_brake = np.maximum(v0 - v_end, 0.0) / a
    d_brake = np.where(v0 > v_end, (v0 ** 2 - v_end ** 2) / (2.0 * a), 0.0)
    # Below v_end, accelerating only: v0 T + a T²/2 = d, valid while v0 + a T ≤ v_end.
    t_accel = (np.sqrt(v0 ** 2 + 2.0 * a * d) - v0) / a
    accel_only = (v0 < v_end) & (v0 + a * t_accel <= v_end)
    # Triangle: peak vp with (vp² − v0²)/2a + (vp² − v_end²)/2a = d.
    vp = np.sqrt(a * d + 0.5 * (v0 ** 2 + v_end ** 2))
    vp = np.maximum(vp, np.maximum(v0, v_end))
    t_tri = (2.0 * vp - v0 - v_end) / a
    # Trapezoid: accelerate to the cap, coast, brake.
    d_ramps = (2.0 * cap ** 2 - v0 ** 2 - v_end ** 2) / (2.0 * a)
    t_trap = (2.0 * cap - v0 - v_end) / a + (d - d_ramps) / cap
    t = np.where(vp <= cap, t_tri, t_trap)
    t = np.where(accel_only, t_accel, t)
    return np.where(d <= d_brake, t_brake, t)


def settle_time_bound(limits: SceneLimits, angle0, omega0_B, bias_B=None) -> dict:
    """Per-episode lower bound on the settle time (first control step inside the thresholds).

    angle0: (N,) initial error angle, rad. omega0_B: (N, 3) initial body rate, rad/s.
    bias_B: (N, 3) the episode's constant disturbance bias, N·m (None: zero); the scene's
    constant disturbance is added. Returns ``continuous`` (N,) s, the bang-coast-bang time
    with v0 = |ω0| (the initial rate counted as if it all pointed along the manoeuvre),
    v_end = success_rate, accel = accel_max + |I⁻¹τ_d| + c·rate_cap² and the rate cap; and
    ``sampled`` (N,) s, the same rounded up to a whole number of control steps (settle times
    are control-step times), plus ``accel`` (N,) rad/s².
    """
    lim = limits
    angle0 = np.asarray(angle0, float)
    v0 = np.linalg.norm(np.asarray(omega0_B, float), axis=-1)
    dist = _disturbance(lim, bias_B, angle0.shape)
    dist_accel = np.linalg.norm(np.linalg.solve(lim.inertia_B, dist.T).T, axis=-1)
    accel = lim.accel_max + dist_accel + lim.gyro_coeff * lim.rate_cap ** 2
    t = bang_coast_bang_time(angle0 - lim.success_angle, v0, lim.success_rate, accel,
                             lim.rate_cap)
    dt = lim.control_dt
    sampled = np.ceil(t / dt - 1e-9) * dt
    return {"continuous": t, "sampled": sampled, "accel": accel}


def _disturbance(lim: SceneLimits, bias_B, shape) -> np.ndarray:
    """(N, 3) disturbance torque per episode: the bias (if any) plus the constant one, N·m."""
    out = np.broadcast_to(lim.constant_torque_B, (*shape, 3)).astype(float)
    if bias_B is not None:
        out = out + np.asarray(bias_B, float)
    return out


# --------------------------------------------------------------------------- propellant

def weighted_rate_forms(inertia_B, kappa) -> dict:
    """For ``P = I + κ I²`` (needs 1 + κ λ > 0 for every principal moment λ):

    ``P_half`` (3, 3) = P^½, ``W`` (3, 3) = P^½ I⁻¹ (s = |P^½ ω| has ``|ṡ| ≤ |W τ|``),
    ``mu_min``, ``mu_max``: the extreme eigenvalues of P (``|ω| ≤ s / √mu_min``).
    """
    lam, V = np.linalg.eigh(np.asarray(inertia_B, float))
    g = lam * (1.0 + kappa * lam)
    if (g <= 0.0).any():
        raise InvalidParameterError(
            f"kappa={kappa!r} makes P = I + κI² not positive definite (need 1 + κλ > 0 for "
            f"every principal moment λ in {lam.tolist()})")
    return {"P_half": (V * np.sqrt(g)) @ V.T, "W": (V * (np.sqrt(g) / lam)) @ V.T,
            "mu_min": float(g.min()), "mu_max": float(g.max())}


def min_impulse_lp(torque_matrix_B, max_force, direction, weight=None) -> float:
    """Least thruster impulse Σ F_i x_i (N·s) whose weighted torque impulse ``M B x`` is the unit
    vector ``direction`` (x_i ≥ 0: seconds at full throttle); M: (3, 3), default identity.

    A linear program (HiGHS). Its minimum over all directions is ``1 / max_i |M b_i| / F_i``,
    attained along the best single thruster (because ``|M B x| ≤ Σ x_i |M b_i|``): that is the
    constant :func:`fuel_bound` uses. Raises InvalidParameterError if unreachable.
    """
    B = np.asarray(torque_matrix_B, float)
    MB = B if weight is None else np.asarray(weight, float) @ B
    e = np.asarray(direction, float)
    e = e / np.linalg.norm(e)
    res = linprog(np.asarray(max_force, float), A_eq=MB, b_eq=e, bounds=(0.0, None),
                  method="highs")
    if res.status != 0:
        raise InvalidParameterError(
            f"direction={e.tolist()} cannot be produced by the layout (LP status {res.status})")
    return float(res.fun)


def fuel_bound(limits: SceneLimits, angle0, omega0_B, bias_B=None, time_s=None,
               kappas=_KAPPA_GRID) -> dict:
    """Per-episode lower bound on the propellant (kg) spent by the settle time.

    angle0 (N,) rad, omega0_B (N, 3) rad/s, bias_B (N, 3) N·m or None. time_s: the settle time
    (scalar or (N,), s); default the latest a successful episode can settle
    (``limits.settle_time_max``), which gives the bound for any successful policy.

    For each weight P = I + κ I² (κ over a grid; every one gives a valid bound, so the largest
    is kept): ``s = |P^½ ω|`` starts at s0 = |P^½ ω0|, must end below s_f = √μmax·success_rate,
    and changes at rate ≤ |W τ_B| + |W τ_d|. With S = ∫|W τ_B| dt over [0, T], s(t) ≤ (s0 + s_f
    + S + |Wτ_d| T)/2 throughout, and the angle needs ∫|ω| ≥ θ0 − θ_s with |ω| ≤ s/√μmin, so
    ``S ≥ 2√μmin (θ0 − θ_s)/T − s0 − s_f − |Wτ_d| T``. Thrust Σ u_i F_i ≥ |W τ_B| / k with
    k = max_i |W b_i|/F_i (:func:`min_impulse_lp`), so the impulse is ≥ S/k and the propellant
    ≥ S/(k Isp g0). Returns ``kg`` (N,), ``impulse_Ns`` (N,) and ``kappa`` (N,) (the best κ).
    """
    lim = limits
    angle0 = np.asarray(angle0, float)
    w0 = np.asarray(omega0_B, float)
    T = np.broadcast_to(lim.settle_time_max if time_s is None else np.asarray(time_s, float),
                        angle0.shape)
    dist = _disturbance(lim, bias_B, angle0.shape)
    need = np.maximum(angle0 - lim.success_angle, 0.0)
    lam_max = lim.inertia_max
    best = np.zeros(angle0.shape)
    best_kappa = np.full(angle0.shape, np.nan)
    for t in kappas:
        f = weighted_rate_forms(lim.inertia_B, t / lam_max)
        k = float((np.linalg.norm(f["W"] @ lim.torque_matrix_B, axis=0) / lim.max_force).max())
        s0 = np.linalg.norm(w0 @ f["P_half"].T, axis=-1)
        s_f = math.sqrt(f["mu_max"]) * lim.success_rate
        d_w = np.linalg.norm(dist @ f["W"].T, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            S = 2.0 * math.sqrt(f["mu_min"]) * need / T - s0 - s_f - d_w * T
        impulse = np.where(T > 0, np.maximum(S, 0.0) / k, 0.0)
        better = impulse > best
        best = np.where(better, impulse, best)
        best_kappa = np.where(better, t / lam_max, best_kappa)
    return {"kg": best * lim.fuel_per_impulse, "impulse_Ns": best, "kappa": best_kappa}


# --------------------------------------------------------------------------- episodes

def episode_starts(episodes: int, seed: int, scene=None, env_id: str | None = None,
                   **env_kwargs) -> dict:
    """The starts of episodes ``seed + i`` of a vector env, as evaluated (``env_id``: default
    the reorientation id of :mod:`rbenv.tasks.reorient`).

    Returns ``q`` (N, 4) (scalar first, body → world), ``omega_B`` (N, 3) rad/s, ``bias_B``
    (N, 3) N·m (zeros when the scene has no random bias) and, where the task has a target,
    ``angle`` (N,) rad and ``q_target`` (N, 4): the values the env draws at
    ``reset(seed=seed)``.
    """
    import gymnasium as gym

    from rbenv.envs import transition
    from rbenv.satellite.draws import EpisodeDraws
    from rbenv.tasks import reorient

    kwargs = dict(env_kwargs)
    if scene is not None:
        kwargs["scene"] = scene
    envs = gym.make_vec(env_id or reorient.SPEC.env_id, num_envs=episodes,
                        vectorization_mode="vector_entry_point", **kwargs)
    try:
        env = envs.unwrapped
        seeds = np.arange(seed, seed + episodes, dtype=np.uint64)
        start = transition.start(env.plant, env.task,
                                 EpisodeDraws(seeds, np.zeros(episodes, dtype=np.uint64)))
    finally:
        envs.close()
    bias = start["bias"]
    bias = np.zeros((episodes, 3)) if bias is None else np.stack(bias, axis=-1)
    out = {"q": np.stack(start["q"], axis=-1).astype(float),
           "omega_B": np.stack(start["omega_B"], axis=-1).astype(float),
           "bias_B": np.broadcast_to(bias, (episodes, 3)).astype(float)}
    if "angle" in start:  # a task with a target
        target_conj = np.stack(start["q_target_conj"], axis=-1).astype(float)
        out["angle"] = np.asarray(start["angle"], float)
        out["q_target"] = target_conj * np.array([1.0, -1.0, -1.0, -1.0])
    return out


# ------------------------------------------------------- any actuator mix: the energy rate

@dataclass(frozen=True)
class TorqueLimits:
    """What the energy-rate bounds need from a scene with any actuators (SI units; rad, s).

    inertia_B: (3, 3) kg·m², the matrix that multiplies ω̇ in the equations of motion (the
    bus ``I − Σ J ĝĝᵀ`` with wheels, else the body); inertia_min/max: its principal moments.
    rate_gain_control: kg^½·m/s², the largest ``|I^-½ τ|`` over control torques (thrusters,
    wheel motors with their friction, rods in the strongest field; the groups' maxima added);
    torque_ext: N·m, a bound on the orbit's and the scene's constant disturbance torques (a
    per-episode bias is added per episode). The rest as :class:`SceneLimits`.
    """

    inertia_B: np.ndarray
    inertia_min: float
    inertia_max: float
    rate_gain_control: float
    torque_ext: float
    rate_limit: float
    control_dt: float
    success_angle: float
    success_rate: float
    settle_time_max: float
    wheels: WheelLimits | None = None  # the momentum cap's data; None: no wheels, no cap


@dataclass(frozen=True, eq=False)
class WheelLimits:
    """What the wheels' momentum cap needs (SI units): the bus rate is ``I⁻¹(H − G h)``, so a
    bounded total momentum H and bounded rotor momenta h bound it (docs/bounds.md).

    inertia_whole_B: (3, 3) kg·m², the spacecraft's with the rotors (``Iω + Gh = I_whole ω +
    G J Ω``). axes_B: (n, 3) spin axes. inertia: (n,) kg·m², J_s. speed_bound: (n,) rad/s, a
    bound on |Ω_i| after any control step: max(Ω_max, u_net·dt/J) (the motor may not speed a
    wheel past Ω_max at the step's end, but a wheel slowing down may cross zero); speed0: (n,)
    rad/s, the largest |Ω_i| at the start. torque_other: N·m, the largest torque the other
    actuators (thrusters, rods) put on the whole spacecraft; with the external torques it is
    all that changes |H|. gyro_coeff: 1/rad, c with ``|I⁻¹(ω × Iω)| ≤ c|ω|²`` for the bus
    inertia I (:func:`gyro_coefficient`).
    """

    inertia_whole_B: np.ndarray
    axes_B: np.ndarray
    inertia: np.ndarray
    speed_bound: np.ndarray
    speed0: np.ndarray
    torque_other: float
    gyro_coeff: float


def why_no_torque_limits(scene: Scene) -> str | None:
    """None when :func:`torque_limits` can bound every torque of ``scene``, else why not."""
    if scene.randomization.enabled:
        return f"scene {scene.name!r} randomizes the model; the bounds need the nominal one"
    if scene.disturbance.model == "random" and scene.disturbance.noise_sigma > 0.0:
        return f"scene {scene.name!r} has per-step disturbance noise, which no bound covers"
    orbit = scene.orbit
    if orbit.enabled and (orbit.drag or orbit.srp):
        return (f"scene {scene.name!r} has drag or solar radiation pressure, which the bounds "
                "do not bound yet")
    return None


def field_max(orbit) -> float:
    """T, the largest magnitude of the orbit's tilted-dipole field: ``|B| = (R/r)³ |3(m·r̂)r̂ −
    m| ≤ 2 (R/r)³ |m|`` (the maximum over directions, at the dipole's poles)."""
    from rbenv.satellite.orbit import IGRF14_2025_NT, R_REF

    moment = 1e-9 * math.sqrt(sum(v * v for v in IGRF14_2025_NT))
    return 2.0 * (R_REF / orbit.radius) ** 3 * moment


def torque_limits(scene=None, used=None) -> TorqueLimits:
    """The limits of any scene the energy-rate bounds cover (:func:`why_no_torque_limits`).

    used: the actuator tables (``"thrusters"``, ``"wheels"``, ``"magnetorquers"``) whose
    commands may act; default all of the scene's. The others are taken as idle (their
    torque is zero; idle wheels still carry their momentum). A bound for a restricted set
    holds only for policies that leave the others idle (e.g. a wheels-only manoeuvre).
    """
    sc = scene if isinstance(scene, Scene) else load_scene(*(() if scene is None else (scene,)))
    reason = why_no_torque_limits(sc)
    if reason is not None:
        raise InvalidParameterError(reason)
    present = sorted(sc.actuators)
    used = set(present if used is None else used)
    if not used or not used <= set(present):
        raise InvalidParameterError(
            f"used={sorted(used)!r}: must be a non-empty subset of the scene's actuators "
            f"{present}")
    whole = np.array(sc.body.inertia, float)
    wheels, rods = sc.actuators.get("wheels"), sc.actuators.get("magnetorquers")
    inertia = whole if wheels is None else whole - np.asarray(wheels.spin_inertia_B, float)
    lam, vec = np.linalg.eigh(inertia)
    inv_half = vec @ np.diag(lam ** -0.5) @ vec.T  # I^-½
    gain, other = 0.0, 0.0  # other: |torque| of thrusters and rods on the whole spacecraft
    if sc.thrusters is not None and "thrusters" in used:
        B = np.array(sc.thrusters.torque_matrix_B, float)
        gain += max_weighted_torque(B, inv_half)
        other += max_weighted_torque(B)
    if wheels is not None and "wheels" in used:  # ḣ = u per rotor, on the bus as −G u
        gain += max_over_symmetric_box(_wheel_torque_columns(wheels), inv_half)
    field = field_max(sc.orbit) if sc.orbit.enabled and sc.orbit.magnetic_field else 0.0
    if rods is not None and "magnetorquers" in used:  # |m × B| ≤ Σ m_i |B|
        gain += float(np.sum(rods.max_dipole)) * field / math.sqrt(lam[0])
        other += float(np.sum(rods.max_dipole)) * field
    ext = float(np.linalg.norm(sc.disturbance.torque)) if sc.disturbance.model == "constant" \
        else 0.0
    if sc.orbit.enabled and sc.orbit.gravity_gradient:  # |3n² r̂ × I r̂| ≤ 3n²(λmax − λmin)/2
        lw = np.linalg.eigvalsh(whole)
        ext += 1.5 * sc.orbit.mean_motion ** 2 * float(lw[-1] - lw[0])
    if sc.orbit.enabled and sc.orbit.residual_dipole is not None:
        from rbenv.satellite.disturbances import ResidualDipole

        dipole = ResidualDipole.parse(sc.orbit.residual_dipole).moment_B_Am2
        ext += float(np.linalg.norm(dipole)) * field
    ep, dt = sc.episode, sc.physics.control_dt
    return TorqueLimits(
        inertia_B=inertia, inertia_min=float(lam[0]), inertia_max=float(lam[-1]),
        rate_gain_control=float(gain), torque_ext=ext, rate_limit=float(ep.rate_limit),
        control_dt=float(dt), success_angle=math.radians(ep.success_angle_deg),
        success_rate=float(ep.success_rate),
        settle_time_max=float(ep.duration - ep.hold_time + dt),
        wheels=None if wheels is None else _wheel_limits(wheels, whole, inertia, other,
                                                         float(dt), "wheels" in used))


def _wheel_limits(wheels, inertia_whole, inertia_bus, torque_other: float, dt: float,
                  commanded: bool = True) -> WheelLimits:
    """The wheels' part of :class:`TorqueLimits` (see :class:`WheelLimits`)."""
    J = np.asarray(wheels.inertia, float)
    top = np.asarray(wheels.max_speed, float)
    net = np.linalg.norm(_wheel_torque_columns(wheels), axis=0)  # (n,) largest net |u_i|
    if not commanded:  # idle wheels: only the bearing friction turns them
        net = net - np.asarray(wheels.max_torque, float) * max(
            1.0, float(np.max(np.asarray(wheels.realized_gain, float))))
    start = np.minimum(np.abs(np.asarray(wheels.initial_speed, float)) + wheels.random_speed,
                       top)
    return WheelLimits(inertia_whole_B=np.asarray(inertia_whole, float),
                       axes_B=np.asarray(wheels.axes_B, float), inertia=J,
                       speed_bound=np.maximum(top, net * dt / J), speed0=start,
                       torque_other=float(torque_other),
                       gyro_coeff=gyro_coefficient(inertia_bus))


def _wheel_torque_columns(wheels) -> np.ndarray:
    """(3, n) N·m: each wheel's axis times its largest net torque on the rotor: the motor
    limit, times the realized gain where one above 1 can be drawn, plus the largest bearing
    friction (viscous at top speed, coulomb)."""
    def top(x):
        return float(np.max(np.asarray(x, float))) if x is not None else 0.0
    gain = max(1.0, top(wheels.realized_gain))
    torque = (np.asarray(wheels.max_torque, float) * gain
              + top(wheels.viscous) * np.asarray(wheels.max_speed, float) + top(wheels.coulomb))
    return np.asarray(wheels.axes_B, float).T * torque


def max_over_symmetric_box(columns, weight) -> float:
    """Largest ``|M C σ|`` over σ in [−1, 1]ⁿ (C: (3, n) columns, M: (3, 3)): convex, so at a
    vertex; every sign vector is checked (n ≤ 16)."""
    MC = np.asarray(weight, float) @ np.asarray(columns, float)
    n = MC.shape[1]
    if n > 16:
        return float(np.linalg.norm(MC, axis=0).sum())
    signs = 1.0 - 2.0 * ((np.arange(2 ** n)[:, None] >> np.arange(n)) & 1)
    return float(np.linalg.norm(signs @ MC.T, axis=1).max())


def energy_settle_bound(limits: TorqueLimits, omega0_B, angle0=None, bias_B=None) -> dict:
    """Per-episode lower bound on the settle time from the energy rate ``s = √(ωᵀIω)``.

    With any internal momentum (wheels) the gyroscopic terms are ``ω × (Iω + Gh)``, normal
    to ω, so ``d(½ωᵀIω)/dt = ω·τ`` and ``|ṡ| ≤ |I^-½ τ| ≤ A`` (control and external
    torques). ``|ω| ≤ s/√λmin``; at a settle step ``|ω| < ω_s``, so ``s < √λmax ω_s``; at a
    control step ``|ω| ≤ L``, so ``s ≤ √λmax L``, and within a step ``s ≤ √λmax L + A dt``.

    Reorientation (``angle0`` (N,) rad): ``∫ s dt ≥ √λmin (θ0 − θ_s)``, the fastest s profile
    is bang-coast-bang in s (:func:`bang_coast_bang_time`); with wheels its cap is also
    ``√λmin`` times the rate and momentum caps of :func:`rate_caps_with_wheels` (returned as
    ``rate_cap``). Detumbling (``angle0`` None): s
    must fall from s0 to √λmax ω_s, so ``T ≥ (s0 − √λmax ω_s)/A``. omega0_B (N, 3) rad/s,
    bias_B (N, 3) N·m or None. Returns ``continuous`` and ``sampled`` (N,) s (rounded up to a
    control step) and ``accel`` (N,) (A, in the units of s per second).
    """
    lim = limits
    w0 = np.atleast_2d(np.asarray(omega0_B, float))
    s0 = np.sqrt(np.einsum("ni,ij,nj->n", w0, lim.inertia_B, w0))
    bias = np.zeros_like(w0) if bias_B is None else np.atleast_2d(np.asarray(bias_B, float))
    accel = lim.rate_gain_control + (lim.torque_ext + np.linalg.norm(bias, axis=-1)) \
        / math.sqrt(lim.inertia_min)
    s_end = math.sqrt(lim.inertia_max) * lim.success_rate
    out = {}
    if angle0 is None:
        t = np.maximum(s0 - s_end, 0.0) / accel
    else:
        cap = math.sqrt(lim.inertia_max) * lim.rate_limit + accel * lim.control_dt
        dist = math.sqrt(lim.inertia_min) * (np.asarray(angle0, float) - lim.success_angle)
        if lim.wheels is not None:  # in |ω| units (÷√λmin), capped by rate and momentum
            caps = rate_caps_with_wheels(lim, w0, bias, accel)
            out["rate_cap"] = caps
            cap = np.minimum(cap, math.sqrt(lim.inertia_min) * caps["cap"])
        t = bang_coast_bang_time(dist, np.minimum(s0, cap), np.minimum(s_end, cap), accel, cap)
    dt = lim.control_dt
    return {"continuous": t, "sampled": np.ceil(t / dt - 1e-9) * dt, "accel": accel, **out}


def rate_caps_with_wheels(limits: TorqueLimits, omega0_B, bias_B, accel) -> dict:
    """Bounds on ``|ω(t)|`` over a successful reorientation with wheels, rad/s, (N,) each.

    ``energy``: √(λmax/λmin) L + A dt/√λmin (the energy cap of :func:`energy_settle_bound`).
    ``rate``: L + ½ dt·a_max: |ω| ≤ L at the control steps on either side of t and
    ``|ω̇| ≤ a_max = A/√λmin + g``, g bounding the gyroscopic ``|I⁻¹ ω × (Iω + Gh)|`` at
    ``|ω| ≤ V`` (the energy cap): the smaller of ``V|H|max/λmin`` (``Iω + Gh`` is H_B, |H_B| =
    |H|) and ``cV² + V max|G h|/λmin``.
    ``momentum``: ``ω = I⁻¹(H − G h)`` with ``|H| ≤ |H|max`` and ``|h_i| ≤ J_i(Ω̄_i + L)``:
    ``|H|max/λmin + max over signs |I⁻¹ G diag(h_max) σ|``. ``momentum_max``: |H|max, N·m·s,
    ``|I_whole ω0| + max |G J Ω0|`` plus the largest external and thruster/rod torque times
    the latest settle time. ``cap``: the smallest of the three. docs/bounds.md proves each.
    """
    lim, wh = limits, limits.wheels
    w0 = np.atleast_2d(np.asarray(omega0_B, float))
    lam_min, dt, L = lim.inertia_min, lim.control_dt, lim.rate_limit
    sign_box = 1.0 - 2.0 * ((np.arange(2 ** len(wh.inertia))[:, None]
                             >> np.arange(len(wh.inertia))) & 1)  # (2^n, n)
    GJ0 = wh.axes_B.T * (wh.inertia * wh.speed0)  # (3, n): G J Ω0,max
    h0 = np.linalg.norm(w0 @ wh.inertia_whole_B.T, axis=-1) \
        + float(np.linalg.norm(sign_box @ GJ0.T, axis=1).max())
    torque_h = (lim.torque_ext + wh.torque_other
                + np.linalg.norm(np.atleast_2d(bias_B), axis=-1))  # |dH/dt| ≤ this
    h_max = h0 + torque_h * lim.settle_time_max
    energy = math.sqrt(lim.inertia_max / lam_min) * L + accel * dt / math.sqrt(lam_min)
    Gh = wh.axes_B.T * (wh.inertia * (wh.speed_bound + L))  # (3, n): G diag(h_max)
    gyro = np.minimum(energy * h_max / lam_min,
                      wh.gyro_coeff * energy ** 2
                      + energy * float(np.linalg.norm(sign_box @ Gh.T, axis=1).max()) / lam_min)
    rate = L + 0.5 * dt * (accel / math.sqrt(lam_min) + gyro)
    inv = np.linalg.inv(lim.inertia_B)
    stored = float(np.linalg.norm(sign_box @ (inv @ Gh).T, axis=1).max())
    momentum = h_max / lam_min + stored
    return {"energy": energy, "rate": rate, "momentum": momentum, "momentum_max": h_max,
            "cap": np.minimum(np.minimum(energy, rate), momentum)}


def detumble_fuel_bound(limits: SceneLimits, omega0_B, bias_B=None, time_s=None,
                        kappas=_KAPPA_GRID) -> dict:
    """Per-episode lower bound on the propellant (kg) a thruster detumble spends by its settle
    time: each weighted rate ``s = |P^½ ω|`` (:func:`fuel_bound`) must fall from s0 to below
    s_f = √μmax·ω_s while ``|ṡ| ≤ |W τ_B| + |W τ_d|``, so ``S = ∫|W τ_B| ≥ s0 − s_f − |Wτ_d| T``
    and the impulse is at least S/k. time_s: the settle time (default the latest a successful
    episode can settle). Returns ``kg`` (N,), ``impulse_Ns`` (N,) and ``kappa`` (N,)."""
    lim = limits
    w0 = np.atleast_2d(np.asarray(omega0_B, float))
    n = len(w0)
    T = np.broadcast_to(lim.settle_time_max if time_s is None else np.asarray(time_s, float),
                        (n,))
    dist = _disturbance(lim, bias_B, (n,))
    best, best_kappa = np.zeros(n), np.full(n, np.nan)
    for t in kappas:
        f = weighted_rate_forms(lim.inertia_B, t / lim.inertia_max)
        k = float((np.linalg.norm(f["W"] @ lim.torque_matrix_B, axis=0) / lim.max_force).max())
        s0 = np.linalg.norm(w0 @ f["P_half"].T, axis=-1)
        s_f = math.sqrt(f["mu_max"]) * lim.success_rate
        d_w = np.linalg.norm(dist @ f["W"].T, axis=-1)
        impulse = np.maximum(s0 - s_f - d_w * T, 0.0) / k
        better = impulse > best
        best = np.where(better, impulse, best)
        best_kappa = np.where(better, t / lim.inertia_max, best_kappa)
    return {"kg": best * lim.fuel_per_impulse, "impulse_Ns": best, "kappa": best_kappa}
