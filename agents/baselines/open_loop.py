"""Optimised open-loop commands for reaction-wheel reorientation and for detumbling (SciPy).

The sibling of :mod:`rbenv.agents.baselines.optimal` (thruster reorientation) for the cases the
energy-rate bounds cover (:func:`rbenv.agents.baselines.bounds.energy_settle_bound`,
:func:`rbenv.agents.baselines.bounds.detumble_fuel_bound`): one seeded episode, commands
through *one*
actuator group (``"wheels"``: motor torques as fractions of u_max in [-1, 1]; ``"thrusters"``:
throttles in [0, 1]), every other actuator idle. Direct single shooting, as there:

* the dynamics are integrated here with RK4 on ``(q, ω_B)`` and the rotors' absolute momenta
  ``h`` (``I ω̇ = τ − ω × (I ω + G h) − G u``, ``ḣ = u``, I the bus inertia), written
  independently of :mod:`core`, with the env's speed-limit rule on the motor torque; orbit
  torques (gravity gradient, rods' field) are not modelled: the margins below absorb them;
* SciPy's SLSQP keeps the rate below the rate limit (97 %) and each wheel below 95 % of its
  speed limit at every control step, and requires the success thresholds with margins (angle
  0.7°, where the task has one; rate 0.7 × the success rate) at the settle step and through
  the hold; the objective is the propellant (thrusters) or the mean squared command (wheels);
* gradients are forward differences, all perturbed sequences integrated in one NumPy batch.

:func:`time_optimal` bisects on the settle step; :func:`fuel_optimal` fixes it. A solution is
*achievable*, never a bound: :func:`replay` runs it in the env itself on the same seeded
episode and reads the env's success, settle time and propellant, which are what count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines.controllers import baseline
from rbenv.core.errors import InvalidParameterError
from scipy.optimize import minimize

from rbenv.satellite.scene import Scene

__all__ = ["Episode", "Solution", "fuel_optimal", "replay", "solve", "time_optimal"]

_RATE_MARGIN = 0.97  # fraction of the rate limit allowed at the control steps
_SPEED_MARGIN = 0.95  # fraction of each wheel's speed limit allowed at the control steps
_ANGLE_MARGIN = 0.7  # fraction of the success angle required during settle and hold
_SETTLE_RATE_MARGIN = 0.7  # fraction of the success rate required during settle and hold
_FD_STEP = 1e-6  # forward-difference step on a command
_FEAS_TOL = 1e-6  # constraint slack accepted, as a fraction of the squared threshold


def _make(env_id: str, scene):
    return gym.make(env_id, **({} if scene is None else {"scene": scene}))


@dataclass(frozen=True, eq=False)
class Episode:
    """One seeded episode of ``env_id`` commanded through ``actuator`` ("wheels" or
    "thrusters"): the task's scene (its physics and episode tables), the start as the env
    draws it (q0 (4,), omega0_B (3,) rad/s, bias_B (3,) N·m, wheel_speed0 (n,) rad/s or
    None), the target q_target (4,) (None: detumbling) and the action layout."""

    env_id: str
    scene_arg: object
    seed: int
    actuator: str
    scene: Scene
    q0: np.ndarray
    omega0_B: np.ndarray
    bias_B: np.ndarray
    q_target: np.ndarray | None
    wheel_speed0: np.ndarray | None
    action_size: int
    action_slice: slice
    orbit_torques: bool = False

    @classmethod
    def from_seed(cls, seed: int, env_id: str, scene=None, actuator: str = "wheels",
                  orbit_torques: bool | None = None) -> Episode:
        """The episode ``env_id`` starts at ``reset(seed=seed)`` (read from the env itself).

        orbit_torques: model the orbit's gravity gradient and field torques (default: only
        for the rods, whose torque is ``m × B``; the wheels and thrusters leave them to the
        margins)."""
        env = _make(env_id, scene)
        try:
            base = env.unwrapped
            plant = base.plant
            tables = [a.scene_table for a in plant.actuators]
            if actuator not in tables:
                raise InvalidParameterError(
                    f"actuator={actuator!r}: the scene's actuators are {tables}")
            act = plant.actuator(actuator)
            if getattr(act, "action_mode", "throttle") != "throttle":
                raise InvalidParameterError(
                    f"actuator {actuator!r} is in action_mode {act.action_mode!r}; the "
                    "optimiser commands throttle mode")
            if actuator == "wheels":
                ws = act.wheels
                if ws.as_flown or ws.viscous or ws.coulomb or ws.friction_drawn:
                    raise InvalidParameterError(
                        f"scene {plant.scene.name!r}: the optimiser models ideal wheels (no "
                        "friction, deadband, gain or start-up delay)")
            orbit = plant.scene.orbit
            if orbit_torques is None:
                orbit_torques = actuator == "magnetorquers"
            if actuator == "magnetorquers" and not (orbit.enabled and orbit.magnetic_field
                                                    and orbit_torques):
                raise InvalidParameterError(
                    f"actuator 'magnetorquers' on scene {plant.scene.name!r}: the rods need "
                    "the orbit's magnetic field, and orbit_torques=True")
            orbit_torques = bool(orbit_torques and orbit.enabled)
            start = 0
            for a in plant.actuators:
                size = int(np.prod(a.action_shape))
                if a.scene_table == actuator:
                    sl = slice(start, start + size)
                start += size
            base.reset(seed=seed)
            st = base._st
            bias = np.zeros(3) if st.bias is None else np.array(st.bias, float).ravel()
            target = getattr(st, "q_target_conj", None)
            speed0 = getattr(st, "wheel_speed", None)
            return cls(env_id=env_id, scene_arg=scene, seed=seed, actuator=actuator,
                       scene=plant.scene, q0=np.array(st.q, float).ravel(),
                       omega0_B=np.array(st.omega_B, float).ravel(), bias_B=bias,
                       q_target=None if target is None
                       else np.array(target, float).ravel() * np.array([1.0, -1, -1, -1]),
                       wheel_speed0=None if speed0 is None
                       else np.array(speed0, float).ravel(),
                       action_size=start, action_slice=sl, orbit_torques=orbit_torques)
        finally:
            env.close()

    @property
    def dt(self) -> float:
        return self.scene.physics.control_dt

    @property
    def n(self) -> int:
        """Commands per step."""
        return self.action_slice.stop - self.action_slice.start

    @property
    def low(self) -> float:
        return 0.0 if self.actuator == "thrusters" else -1.0

    def _bus_inertia(self) -> np.ndarray:
        inertia = np.asarray(self.scene.body.inertia, float)
        wheels = self.scene.actuators.get("wheels")
        return inertia if wheels is None else inertia - np.asarray(wheels.spin_inertia_B, float)

    def rollout(self, U: np.ndarray) -> dict:
        """Commands U (M, N, n) held per step → ``q`` (M, N+1, 4), ``omega_B`` (M, N+1, 3) and,
        for wheels, ``wheel_speed`` (M, N+1, n_wheels) rad/s, at the control steps."""
        sc = self.scene
        inertia = self._bus_inertia()
        inv = np.linalg.inv(inertia)
        M, N, _ = U.shape
        subs = sc.physics.substeps
        dt = self.dt
        h = dt / subs
        q = np.broadcast_to(self.q0, (M, 4)).astype(float)
        w = np.broadcast_to(self.omega0_B, (M, 3)).astype(float)
        ws = sc.actuators.get("wheels")
        if ws is not None:
            G = np.asarray(ws.axes_B, float)  # (n, 3)
            J = np.asarray(ws.inertia, float)
            top = np.asarray(ws.max_speed, float)
            j_eff = 1.0 / (1.0 / J + np.einsum("ni,ij,nj->n", G, inv, G))
            speed = np.broadcast_to(self.wheel_speed0, (M, len(J))).astype(float)
            hw = J * (speed + w @ G.T)  # absolute spin momenta
        qs, wsq, sp = [q], [w], [] if ws is None else [speed]
        B = None if self.actuator != "thrusters" else np.asarray(
            sc.thrusters.torque_matrix_B, float)
        orbit = self._orbit_vectors(N) if self.orbit_torques else None
        for k in range(N):
            tau = np.broadcast_to(self.bias_B, (M, 3)).astype(float)
            u = np.zeros((M, 3 if ws is None else len(J)))
            dipole = None
            if B is not None:
                tau = tau + np.clip(U[:, k], 0.0, 1.0) @ B.T
            elif self.actuator == "wheels":
                u = np.clip(U[:, k], -1.0, 1.0) * np.asarray(ws.max_torque, float)
                head = np.maximum((top - np.abs(speed)) * j_eff / dt, 0.0)
                u = np.where(speed * u >= 0.0, np.clip(u, -head, head), u)
            elif self.actuator == "magnetorquers":
                rods = sc.actuators["magnetorquers"]
                dipole = np.clip(U[:, k], -1.0, 1.0) @ (
                    np.asarray(rods.axes_B, float) * np.asarray(rods.max_dipole, float)[:, None])
            hb = None if ws is None else hw @ G
            hb_dot = None if ws is None else u @ G
            for j in range(subs):
                fn = None if orbit is None else _orbit_torque(orbit, 2 * (k * subs + j), dipole)
                q, w = _rk4(q, w, tau, inertia, inv, h, hb, hb_dot, fn)
                if hb is not None:
                    hb = hb + hb_dot * h
            if ws is not None:
                hw = hw + u * dt
                speed = hw / J - w @ G.T
                sp.append(speed)
            qs.append(q)
            wsq.append(w)
        out = {"q": np.stack(qs, axis=1), "omega_B": np.stack(wsq, axis=1)}
        if ws is not None:
            out["wheel_speed"] = np.stack(sp, axis=1)
        return out

    def _orbit_vectors(self, steps: int) -> dict:
        """The orbit's inertial vectors at every half integrator step of ``steps`` control steps
        (entry i at time i·h/2, as the env's table), the gravity-gradient factor 3n², the
        whole spacecraft's inertia it acts on, and a residual dipole (A·m², body) or None."""
        sc = self.scene
        orbit = sc.orbit
        h = self.dt / sc.physics.substeps
        t = np.arange(2 * steps * sc.physics.substeps + 3) * (0.5 * h)
        residual = None
        if orbit.residual_dipole is not None:
            from rbenv.satellite.disturbances import ResidualDipole

            residual = np.asarray(ResidualDipole.parse(orbit.residual_dipole).moment_B_Am2,
                                  float)
        return {"r_N": np.stack(orbit.direction_N(t, np), axis=-1) if orbit.gravity_gradient
                else None,
                "B_N": np.stack(orbit.field_N(t, np), axis=-1) if orbit.magnetic_field
                else None,
                "gg": 3.0 * orbit.mean_motion ** 2,
                "inertia": np.asarray(sc.body.inertia, float), "residual": residual}

    def error_sin2(self, q: np.ndarray) -> np.ndarray:
        """sin²(θ/2) of the error rotation q_target* ⊗ q, (...,)."""
        c = self.q_target * np.array([1.0, -1.0, -1.0, -1.0])
        e = _qmul(np.broadcast_to(c, q.shape), q)
        return (e[..., 1:] ** 2).sum(axis=-1)


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def _to_body(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)ᵀ v for unit q (scalar first, body → world): v in body axes, (..., 3)."""
    wq, u = q[..., :1], q[..., 1:]
    c = np.cross(u, v)
    return v - 2.0 * wq * c + 2.0 * np.cross(u, c)


def _orbit_torque(orbit: dict, base: int, dipole):
    """The orbit torques of one substep starting at half-step ``base``: a function of the
    stage (0, ½, 1) and the stage's attitude, N·m body axes (gravity gradient
    ``3n² r̂_B × I r̂_B``, the rods' and the residual dipole's ``m × B_B``)."""
    if orbit["residual"] is not None:
        dipole = orbit["residual"] if dipole is None else dipole + orbit["residual"]

    def torque(stage: float, q: np.ndarray) -> np.ndarray:
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
        i = base + int(2 * stage)
        out = np.zeros((*q.shape[:-1], 3))
        if orbit["r_N"] is not None:
            r = _to_body(q, np.broadcast_to(orbit["r_N"][i], out.shape))
            out = out + orbit["gg"] * np.cross(r, r @ orbit["inertia"].T)
        if dipole is not None and orbit["B_N"] is not None:
            out = out + np.cross(dipole, _to_body(q, np.broadcast_to(orbit["B_N"][i],
                                                                     out.shape)))
        return out
    return torque


def _derivative(q, w, tau, inertia, inv, hb, hb_dot, fn=None, stage=0.0):
    """q̇ = ½ q ⊗ (0, ω_B); I ω̇_B = τ − ω × (I ω + h_B) − ḣ_B (h_B: the rotors' momentum),
    τ plus ``fn(stage, q)`` (the orbit torques) where given."""
    zero = np.zeros((*q.shape[:-1], 1))
    q_dot = 0.5 * _qmul(q, np.concatenate([zero, w], axis=-1))
    m = w @ inertia.T if hb is None else w @ inertia.T + hb
    if fn is not None:
        tau = tau + fn(stage, q)
    t = tau - np.cross(w, m) - (0.0 if hb_dot is None else hb_dot)
    return q_dot, t @ inv.T


def _rk4(q, w, tau, inertia, inv, h, hb=None, hb_dot=None, fn=None):
    mid = None if hb is None else hb + 0.5 * h * hb_dot
    end = None if hb is None else hb + h * hb_dot
    k1 = _derivative(q, w, tau, inertia, inv, hb, hb_dot, fn, 0.0)
    k2 = _derivative(q + 0.5 * h * k1[0], w + 0.5 * h * k1[1], tau, inertia, inv, mid, hb_dot,
                     fn, 0.5)
    k3 = _derivative(q + 0.5 * h * k2[0], w + 0.5 * h * k2[1], tau, inertia, inv, mid, hb_dot,
                     fn, 0.5)
    k4 = _derivative(q + h * k3[0], w + h * k3[1], tau, inertia, inv, end, hb_dot, fn, 1.0)
    q = q + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
    w = w + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
    return q / np.linalg.norm(q, axis=-1, keepdims=True), w


@dataclass
class Solution:
    """Optimised commands (N, n) per control step, settle step, SLSQP outcome."""

    commands: np.ndarray
    settle_step: int
    converged: bool
    feasible: bool  # every constraint met (to _FEAS_TOL of its threshold) by the commands
    message: str
    iterations: int


def _expand(x: np.ndarray, n: int, steps: int, block: int) -> np.ndarray:
    """Block commands (..., nb·n) → per-step commands (..., steps, n)."""
    nb = -(-steps // block)
    u = x.reshape((*x.shape[:-1], nb, n))
    return np.repeat(u, block, axis=-2)[..., :steps, :]


def _resample(U: np.ndarray, nb: int, low: float) -> np.ndarray:
    """Per-step commands (N', n) → block commands (nb·n,) by averaging over time-scaled bins."""
    N = U.shape[0]
    edges = np.linspace(0, N, nb + 1)
    out = np.empty((nb, U.shape[1]))
    for i in range(nb):
        lo, hi = int(edges[i]), max(math.ceil(edges[i + 1]), int(edges[i]) + 1)
        out[i] = U[lo:min(hi, N)].mean(axis=0)
    return np.clip(out, low, 1.0).ravel()


def solve(ep: Episode, settle_step: int, *, block: int = 1, guess=None, maxiter: int = 150,
          objective: str | None = None) -> Solution:
    """Commands that settle at control step ``settle_step`` and hold, least ``objective``
    ("fuel": propellant, thrusters only; "effort": mean squared command; default: fuel for
    thrusters, effort for wheels). Horizon ``settle_step + hold_steps − 1`` steps, commands
    held over ``block`` steps; guess: per-step commands (N', n) resampled to the horizon."""
    sc = ep.scene
    n, low = ep.n, ep.low
    ep_t = sc.episode
    hold = sc.hold_steps
    steps = settle_step + hold - 1
    nb = -(-steps // block)
    x0 = (np.full(nb * n, 0.05 if low == 0.0 else 0.0) if guess is None
          else _resample(np.asarray(guess, float), nb, low))
    objective = objective or ("fuel" if ep.actuator == "thrusters" else "effort")
    if objective == "fuel":
        if ep.actuator != "thrusters":
            raise InvalidParameterError(f"objective='fuel' needs thrusters, not {ep.actuator!r}")
        force = np.asarray(sc.thrusters.max_force, float)
        w = np.tile(force, nb) / force.sum()

        def cost(x):
            return float(w @ x), w
    else:
        def cost(x):
            return float(x @ x) / x.size, 2.0 * x / x.size
    rate2 = (_RATE_MARGIN * ep_t.rate_limit) ** 2
    settle2 = (_SETTLE_RATE_MARGIN * ep_t.success_rate) ** 2
    has_angle = ep.q_target is not None
    ang2 = math.sin(0.5 * _ANGLE_MARGIN * math.radians(ep_t.success_angle_deg)) ** 2
    wheels = sc.actuators.get("wheels") if ep.actuator == "wheels" else None
    top2 = None if wheels is None else (_SPEED_MARGIN * np.asarray(wheels.max_speed)) ** 2

    def constraints_of(X: np.ndarray) -> np.ndarray:
        r = ep.rollout(_expand(X, n, steps, block))
        r2 = (r["omega_B"][:, 1:] ** 2).sum(axis=-1)
        parts = [(rate2 - r2) / rate2, (settle2 - r2[:, settle_step - 1:steps]) / settle2]
        if has_angle:
            parts.append((ang2 - ep.error_sin2(r["q"][:, settle_step:steps + 1])) / ang2)
        if top2 is not None:
            parts.append(((top2 - r["wheel_speed"][:, 1:] ** 2) / top2).reshape(len(X), -1))
        return np.concatenate(parts, axis=1)

    cache = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            step = np.where(x + _FD_STEP <= 1.0, _FD_STEP, -_FD_STEP)
            X = np.vstack([x, x + np.diag(step)])
            G = constraints_of(X)
            cache[key] = (G[0], ((G[1:] - G[0]) / step[:, None]).T)
        return cache[key]

    res = minimize(lambda x: cost(x)[0], x0, jac=lambda x: cost(x)[1], method="SLSQP",
                   bounds=[(low, 1.0)] * x0.size,
                   constraints=[{"type": "ineq", "fun": lambda x: evaluate(x)[0],
                                 "jac": lambda x: evaluate(x)[1]}],
                   options={"maxiter": maxiter, "ftol": 1e-7})
    x = np.clip(res.x, low, 1.0)
    g = constraints_of(x[None])[0]
    return Solution(commands=_expand(x, n, steps, block), settle_step=settle_step,
                    converged=bool(res.success), feasible=bool(g.min() >= -_FEAS_TOL),
                    message=str(res.message), iterations=int(res.nit))


def time_optimal(ep: Episode, feasible_step: int, guess, infeasible_step: int = 0, *,
                 block: int = 1, maxiter: int = 150) -> Solution:
    """The earliest settle step SLSQP reaches, by bisection between ``infeasible_step``
    (known infeasible, e.g. from the bound) and ``feasible_step`` (guess: its commands, e.g. a
    controller's that settles then). Where SLSQP finds no solution at ``feasible_step`` (the
    guess used another actuator, or the margins are too tight) from the guess or from rest,
    the step grows by half, up to
    the latest settle step of a successful episode, before giving up (an infeasible Solution).
    """
    latest = ep.scene.episode_steps - ep.scene.hold_steps + 1
    hi = min(max(feasible_step, infeasible_step + 1), latest)
    while True:
        best = solve(ep, hi, guess=guess, maxiter=maxiter, block=block)
        if not best.feasible and guess is not None:  # a saturated guess can trap SLSQP
            best = solve(ep, hi, guess=None, maxiter=maxiter, block=block)
        if best.feasible or hi == latest:
            break
        infeasible_step, hi = hi, min(latest, max(hi + 1, math.ceil(1.5 * hi)))
    if not best.feasible:
        return best
    lo = infeasible_step
    while hi - lo > 1:
        mid = (lo + hi) // 2
        sol = solve(ep, mid, guess=best.commands, maxiter=maxiter, block=block)
        if sol.feasible:
            best, hi = sol, mid
        else:
            lo = mid
    return best


def fuel_optimal(ep: Episode, settle_step: int, guess, *, block: int = 2,
                 maxiter: int = 150) -> Solution:
    """Least propellant (thrusters) settling at ``settle_step``, throttles held ``block``."""
    return solve(ep, settle_step, block=block, guess=guess, maxiter=maxiter, objective="fuel")


def replay(commands, ep: Episode) -> dict:
    """Run ``commands`` in the env on ``ep``'s seeded episode: an (N, n) array of the episode's
    actuator (open loop; then zero, every other actuator idle throughout) or a scripted
    baseline's name ("pd", "bdot", ...) acting closed loop.

    Returns the env's ``success``, ``settle_time_s`` (NaN unless successful), ``fuel_kg`` (0
    without thrusters) and ``commands`` (steps, n): the episode actuator's part of each action.
    """
    env = _make(ep.env_id, ep.scene_arg)
    try:
        base = env.unwrapped
        policy = baseline(env, commands) if isinstance(commands, str) else None
        obs, state = env.reset(seed=ep.seed)[0], None
        k, info, applied = 0, {}, []
        while True:
            if policy is not None:
                a, state = policy.predict(obs, state=state, deterministic=True)
                a = np.asarray(a, np.float32)
            else:
                a = np.zeros(ep.action_size, np.float32)
                if k < len(commands):
                    a[ep.action_slice] = commands[k]
            applied.append(np.clip(np.asarray(a, float)[ep.action_slice], ep.low, 1.0))
            obs, _, term, trunc, info = env.step(a)
            k += 1
            if term or trunc:
                break
        ok = bool(info["is_success"])
        plant = base.plant
        settle = (info["time_s"] - plant.scene.episode.hold_time + plant.control_dt
                  if ok else math.nan)
        return {"success": ok, "settle_time_s": float(settle),
                "fuel_kg": float(info.get("fuel_kg", 0.0)), "commands": np.array(applied)}
    finally:
        env.close()
