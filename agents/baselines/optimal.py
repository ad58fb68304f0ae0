"""Optimised open-loop throttle sequences for one reorientation episode (a reference, SciPy).

Direct single shooting: the unknowns are the throttles of each control step (optionally held
over blocks of steps), the dynamics are integrated with open_loop's RK4 on ``(q, ω_B)`` (written
independently of :mod:`core`), and SciPy's SLSQP minimises the propellant subject to

* the rate limit at every control step (with a margin),
* the success thresholds (with margins) at the settle step and at every step of the hold.

Gradients are forward differences, all perturbed sequences integrated in one NumPy batch. A
solution is *achievable*, never a bound: :func:`replay` runs it in the env itself on the same
seeded episode and reads the env's success, settle time and propellant. Used by
``benchmarks/bounds.py`` to check that the lower bounds of
:mod:`rbenv.agents.baselines.bounds` lie below a
trajectory optimised for that episode, and to show how much room the bounds leave.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from rbenv.agents.baselines.bounds import episode_starts
from rbenv.agents.baselines.controllers import baseline
from rbenv.agents.baselines.open_loop import _expand, _qmul, _resample, _rk4
from scipy.optimize import minimize

import rbenv
from rbenv.satellite.scene import Scene, load_scene

__all__ = ["Problem", "Solution", "fuel_optimal", "replay", "solve", "time_optimal"]

_RATE_MARGIN = 0.97  # fraction of the rate limit allowed at the control steps
_ANGLE_MARGIN = 0.7  # fraction of the success angle required during settle and hold
_SETTLE_RATE_MARGIN = 0.7  # fraction of the success rate required during settle and hold
_FD_STEP = 1e-6  # forward-difference step on a throttle
_FEAS_TOL = 1e-6  # constraint slack accepted, as a fraction of the squared threshold


@dataclass(frozen=True, eq=False)
class Problem:
    """One episode: scene, start (q0 (4,), omega0_B (3,), bias_B (3,) N·m), target (4,)."""

    scene: Scene
    q0: np.ndarray
    omega0_B: np.ndarray
    q_target: np.ndarray
    bias_B: np.ndarray

    @classmethod
    def from_seed(cls, seed: int, scene=None) -> Problem:
        """The reorientation episode the env starts at ``reset(seed=seed)``."""
        sc = scene if isinstance(scene, Scene) else load_scene(
            *(() if scene is None else (scene,)))
        st = episode_starts(1, seed, sc)
        return cls(scene=sc, q0=st["q"][0], omega0_B=st["omega_B"][0],
                   q_target=st["q_target"][0], bias_B=st["bias_B"][0])

    @property
    def dt(self) -> float:
        return self.scene.physics.control_dt

    def rollout(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Throttles U (M, N, n) held per step → q (M, N+1, 4), ω_B (M, N+1, 3) at the steps."""
        sc = self.scene
        inertia = np.asarray(sc.body.inertia, float)
        inv = np.linalg.inv(inertia)
        B = np.asarray(sc.thrusters.torque_matrix_B, float)
        M, N, _ = U.shape
        subs = sc.physics.substeps
        h = self.dt / subs
        q = np.broadcast_to(self.q0, (M, 4)).astype(float)
        w = np.broadcast_to(self.omega0_B, (M, 3)).astype(float)
        qs, ws = [q], [w]
        for k in range(N):
            tau = U[:, k] @ B.T + self.bias_B
            for _ in range(subs):
                q, w = _rk4(q, w, tau, inertia, inv, h)
            qs.append(q)
            ws.append(w)
        return np.stack(qs, axis=1), np.stack(ws, axis=1)

    def error_sin2(self, q: np.ndarray) -> np.ndarray:
        """sin²(θ/2) of the error rotation q_target* ⊗ q, (...,)."""
        c = self.q_target * np.array([1.0, -1.0, -1.0, -1.0])
        e = _qmul(np.broadcast_to(c, q.shape), q)
        return (e[..., 1:] ** 2).sum(axis=-1)


@dataclass
class Solution:
    """An optimised sequence: throttles (N, n) per control step, settle step, SLSQP outcome."""

    throttles: np.ndarray
    settle_step: int
    converged: bool
    feasible: bool  # every constraint met (to _FEAS_TOL of its threshold) by the throttles
    message: str
    iterations: int


def solve(problem: Problem, settle_step: int, *, block: int = 1, guess=None,
          stretch: bool = False, maxiter: int = 150) -> Solution:
    """Least-propellant throttles that settle at control step ``settle_step`` and hold.

    The horizon is ``settle_step + hold_steps − 1`` steps; throttles are held over ``block``
    steps. guess: per-step throttles (N', n) resampled to the horizon, or None (all 0.1).
    stretch: also scale the guess by (N'/N)², which maps a rest-to-rest manoeuvre onto the
    same path flown N/N' times slower (torques scale as 1/time², gyroscopic terms alike).
    """
    sc = problem.scene
    n = sc.thrusters.n
    ep = sc.episode
    hold = sc.hold_steps
    steps = settle_step + hold - 1
    nb = -(-steps // block)
    if guess is None:
        x0 = np.full(nb * n, 0.1)
    else:
        guess = np.asarray(guess, float)
        factor = (len(guess) / steps) ** 2 if stretch else 1.0
        x0 = np.clip(factor * _resample(guess, nb, 0.0), 0.0, 1.0)
    force = np.asarray(sc.thrusters.max_force, float)
    cost = np.tile(force, nb) * block * problem.dt / (force.sum() * problem.dt)
    rate2 = (_RATE_MARGIN * ep.rate_limit) ** 2
    ang2 = math.sin(0.5 * _ANGLE_MARGIN * math.radians(ep.success_angle_deg)) ** 2
    settle2 = (_SETTLE_RATE_MARGIN * ep.success_rate) ** 2
    scale = np.concatenate([np.full(steps, 1.0 / rate2), np.full(hold, 1.0 / ang2),
                            np.full(hold, 1.0 / settle2)])
    cache = {}

    def constraints_of(X: np.ndarray) -> np.ndarray:
        q, w = problem.rollout(_expand(X, n, steps, block))
        r2 = (w[:, 1:] ** 2).sum(axis=-1)
        tail = slice(settle_step, steps + 1)
        g = np.concatenate([rate2 - r2, ang2 - problem.error_sin2(q[:, tail]),
                            settle2 - r2[:, settle_step - 1:steps]], axis=1)
        return g * scale

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            step = np.where(x + _FD_STEP <= 1.0, _FD_STEP, -_FD_STEP)
            X = np.vstack([x, x + np.diag(step)])
            G = constraints_of(X)
            cache[key] = (G[0], ((G[1:] - G[0]) / step[:, None]).T)
        return cache[key]

    res = minimize(lambda x: float(cost @ x), x0, jac=lambda x: cost, method="SLSQP",
                   bounds=[(0.0, 1.0)] * x0.size,
                   constraints=[{"type": "ineq", "fun": lambda x: evaluate(x)[0],
                                 "jac": lambda x: evaluate(x)[1]}],
                   options={"maxiter": maxiter, "ftol": 1e-7})
    x = np.clip(res.x, 0.0, 1.0)
    g = constraints_of(x[None])[0]
    return Solution(throttles=_expand(x, n, steps, block), settle_step=settle_step,
                    converged=bool(res.success), feasible=bool(g.min() >= -_FEAS_TOL),
                    message=str(res.message), iterations=int(res.nit))


def time_optimal(problem: Problem, feasible_step: int, guess, infeasible_step: int = 0, *,
                 maxiter: int = 150) -> Solution:
    """The earliest settle step SLSQP reaches, by bisection between ``infeasible_step``
    (known infeasible, e.g. from the bound) and ``feasible_step`` (guess: its throttles)."""
    best = solve(problem, feasible_step, guess=guess, maxiter=maxiter)
    if not best.feasible:
        return best
    lo, hi = infeasible_step, feasible_step
    while hi - lo > 1:
        mid = (lo + hi) // 2
        sol = solve(problem, mid, guess=best.throttles, maxiter=maxiter)
        if sol.feasible:
            best, hi = sol, mid
        else:
            lo = mid
    return best


def fuel_optimal(problem: Problem, guess, *, block: int = 4, maxiter: int = 200) -> Solution:
    """Least propellant settling at the latest step a successful episode may (held ``block``).

    guess: a controller's per-step throttles, stretched over the horizon (see :func:`solve`).
    """
    steps = problem.scene.episode_steps
    return solve(problem, steps - problem.scene.hold_steps + 1, block=block, guess=guess,
                 stretch=True, maxiter=maxiter)


def replay(throttles, seed: int, scene=None) -> dict:
    """Run ``throttles`` in the env on episode ``seed``: an (N, n) array open loop (then zero
    throttle), a policy with ``predict`` or a scripted baseline's name ("pd", "bangbang").

    Returns the env's ``success``, ``settle_time_s`` (NaN unless successful), ``fuel_kg`` and
    the ``throttles`` (steps, n) applied.
    """
    env = gym.make(rbenv.ENV_ID, **({} if scene is None else {"scene": scene}))
    try:
        plant = env.unwrapped.plant
        zero = np.zeros(plant.actuator("thrusters").n, dtype=np.float32)
        policy = None if isinstance(throttles, np.ndarray) else throttles
        if isinstance(policy, str):
            policy = baseline(env, policy)
        obs, state = env.reset(seed=seed)[0], None
        k, info, applied = 0, {}, []
        while True:
            if policy is not None:
                a, state = policy.predict(obs, state=state, deterministic=True)
            else:
                a = np.asarray(throttles[k], np.float32) if k < len(throttles) else zero
            applied.append(plant.actuator("thrusters").command(np.asarray(a, float)))
            obs, _, term, trunc, info = env.step(a)
            k += 1
            if term or trunc:
                break
        ok = bool(info["is_success"])
        settle = (info["time_s"] - plant.scene.episode.hold_time + plant.control_dt
                  if ok else math.nan)
        return {"success": ok, "settle_time_s": float(settle), "fuel_kg": float(info["fuel_kg"]),
                "throttles": np.array(applied)}
    finally:
        env.close()
