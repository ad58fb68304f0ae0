"""``step`` and ``simulate``: advance :class:`BodyState` under world-frame force and torque."""

from __future__ import annotations

import math

import numpy as np
from rbenv.core import integrators, kernels, quaternion
from rbenv.core import validation as check
from rbenv.core.body import BodyState, RigidBody
from rbenv.core.errors import InvalidParameterError, NonFiniteError

_UNIT_TOL2 = check.UNIT_TOL * check.UNIT_TOL
# Largest n_steps that simulate() accepts (10x the longest run in the stability benchmark).
MAX_STEPS = 10_000_000


def _optional_vector(name: str, value):
    return None if value is None else check.vectors(name, value, 3)


def _parts(arr):
    return None if arr is None else kernels.unpack(arr)


def _pack(components, shape) -> np.ndarray:
    out = kernels.pack(components)
    return np.broadcast_to(out, (*shape, out.shape[-1])).copy() if out.shape[:-1] != shape else out


def translate(name: str, body: RigidBody, x, v, h: float, force_W):
    """Advance centre-of-mass position x (m) and velocity v (m/s), (..., 3), under force (N).

    ``euler_seed``/``euler`` use the lecture's explicit Euler (x with the old v), ``semi_implicit``
    updates v first; ``rk4`` and ``midpoint`` use the exact solution for a force held constant
    over the step (``x + v h + ½ a h²``).
    """
    if force_W is None:
        return x + h * v, v
    a = force_W / body.mass
    if name in ("euler_seed", "euler"):
        return x + h * v, v + h * a
    v_new = v + h * a
    if name == "semi_implicit":
        return x + h * v_new, v_new
    return x + h * v + (0.5 * h * h) * a, v_new


def check_finite_state(q, w_B, integrator: str, h: float, *extra) -> None:
    """Raise :class:`NonFiniteError` unless a simulated state (components) is finite and unit.

    q: quaternion components, w_B: body-rate components (floats for one body, (N,) arrays for
    a batch); ``extra``: position, velocity ... that must be finite too, each an (..., 3) array
    or a tuple of components. An orientation
    whose |q| has left 1 (a zero quaternion after ``h·|ω|`` overflowed, say) counts as
    non-finite: it is overflow, not an attitude. One sum per group on floats, a few
    reductions on arrays (``benchmarks/validation_cost.py`` measures the cost).
    """
    q0, q1, q2, q3 = q
    w0, w1, w2 = w_B
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    if type(n2) is float and type(w0) is float:
        ok = abs(n2 - 1.0) <= check.UNIT_TOL and math.isfinite(w0 + w1 + w2)
    else:  # Σ(|q|² − 1)² <= tol² bounds every entry, and is False for NaN or inf
        d = np.ravel(n2) - 1.0
        ok = float(np.dot(d, d)) <= _UNIT_TOL2 and math.isfinite(float(np.sum(w0 + w1 + w2)))
    if ok and extra:
        ok = all(_finite(a) for a in extra)
    if ok:
        return
    raise NonFiniteError(
        f"simulation diverged: the state became non-finite (or overflowed) after a step with "
        f"integrator={integrator!r}, dt={h!r}. Explicit integrators ('euler', 'semi_implicit', "
        "'rk4') are unstable once dt·|ω| is large (≳ 0.5 for the Euler schemes); use "
        "'midpoint' or a smaller dt, and keep dt·|ω| and the torques far from overflow"
    )


def _finite(a) -> bool:
    """An (..., 3) array, or a tuple of components (floats or (N,) arrays), is all finite."""
    if isinstance(a, tuple):
        total = sum(a)
        return math.isfinite(total) if type(total) is float else bool(np.isfinite(total).all())
    return math.isfinite(sum(a.tolist())) if a.ndim == 1 else bool(np.isfinite(a).all())


# What kernel arithmetic raises on overflow (math.ceil(inf), int(nan), 1.0 / 0.0, ...).
_OVERFLOW = (OverflowError, ZeroDivisionError, FloatingPointError, ValueError)


def _diverged_inside(exc: Exception, integrator: str, h: float):
    """Re-raise an arithmetic failure inside an integrator kernel as :class:`NonFiniteError`."""
    if isinstance(exc, InvalidParameterError):
        raise exc
    raise NonFiniteError(
        f"simulation diverged inside integrator={integrator!r} at dt={h!r}: the arithmetic "
        f"overflowed ({type(exc).__name__}: {exc}); reduce dt·|ω| or the torques"
    ) from None


def _advance(kernel, integrator, body, q, w_B, h, tau_B, tau_W):
    """``kernel.advance``, with arithmetic overflow inside the kernel reported as divergence.

    On arrays NumPy's overflow is silenced here (it would only warn): the non-finite result
    is what :func:`check_finite_state` then reports, by name."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return kernel.advance(body, q, w_B, h, tau_B, tau_W)
    except _OVERFLOW as exc:
        _diverged_inside(exc, integrator, h)


def _check_types(body, state) -> None:
    """Refuse a body or state of the wrong type, by name (before any of their fields is read)."""
    if not isinstance(body, RigidBody):
        raise InvalidParameterError(f"body must be a core.RigidBody, got {check.show(body)} of "
                                    f"type {type(body).__name__}")
    if not isinstance(state, BodyState):
        raise InvalidParameterError(f"state must be a core.BodyState, got {check.show(state)} "
                                    f"of type {type(state).__name__}")


def _prepare(body, state, dt, force, torque, integrator, torque_B):
    """The step's checked inputs (after :func:`_check_types`)."""
    h = check.positive("dt", dt)
    kernel = integrators.get(integrator)
    loads = {"force": force, "torque": torque, "torque_B": torque_B}
    loads = {k: _optional_vector(k, v) for k, v in loads.items()}
    given = {k: (v, 1) for k, v in loads.items() if v is not None}
    if given:
        batch = check.batch_shape({"state": (state.orientation, 1), **given})
        if batch != state.batch_shape:
            listed = ", ".join(f"{k} {v.shape[:-1]}" for k, (v, _) in given.items())
            raise InvalidParameterError(
                f"batch shapes of {listed} must broadcast to the state's batch shape "
                f"{state.batch_shape}; a load cannot add batch dimensions"
            )
    return h, kernel, loads["force"], loads["torque"], loads["torque_B"]


def step(body: RigidBody, state: BodyState, dt: float, force=None, torque=None,
         integrator: str = "midpoint", *, torque_B=None, translation: bool = True,
         wheel_torque=None) -> BodyState:
    """Advance ``state`` by ``dt`` seconds with force and torque held constant over the step.

    body: the rigid body. state: BodyState with batch shape (...). dt: step in s, > 0.
    force: (..., 3) N, world frame, through the centre of mass. torque: (..., 3) N·m about the
    centre of mass, world frame (use :func:`rbenv.core.forces.wrench_at_points` for forces at
    points). torque_B: (..., 3) N·m fixed in the body frame during the step (thrusters).
    wheel_torque: (n,) or (..., n) N·m, the motor torque on each of ``body.wheels`` (internal:
    it moves momentum between bus and rotors); ``state.wheel_speeds`` (rad/s, relative to the
    body) start at zero when not given.
    integrator: a name in ``INTEGRATORS``. translation: False skips the centre-of-mass update.
    Returns the new BodyState; raises NonFiniteError if the result is not finite.
    """
    _check_types(body, state)
    if body.wheels is not None or wheel_torque is not None or state.wheel_speeds is not None:
        return simulate(body, state, dt, 1, force, torque, integrator, torque_B=torque_B,
                        translation=translation, wheel_torque=wheel_torque)
    h, kernel, force, torque, torque_B = _prepare(body, state, dt, force, torque, integrator,
                                                  torque_B)
    q = kernels.unpack(state.orientation)
    w_B = kernels.rotate_inverse(q, kernels.unpack(state.angular_velocity))
    q_new, w_new = _advance(kernel, integrator, body, q, w_B, h, _parts(torque_B),
                            _parts(torque))
    x, v = state.position, state.velocity
    if translation:
        x, v = translate(integrator, body, x, v, h, force)
        check_finite_state(q_new, w_new, integrator, h, x, v)
    else:
        check_finite_state(q_new, w_new, integrator, h)
    shape = state.batch_shape
    w_W = kernels.rotate(q_new, w_new)
    return BodyState.from_arrays(x, v, _pack(q_new, shape), _pack(w_W, shape))


def simulate(body: RigidBody, state: BodyState, dt: float, n_steps: int, force=None, torque=None,
             integrator: str = "midpoint", *, torque_B=None, translation: bool = True,
             trajectory: bool = False, wheel_torque=None):
    """Take ``n_steps`` steps of :func:`step` with constant force/torque (same units and frames).

    n_steps: integer in [0, MAX_STEPS]. The state is checked after every step, so a divergence
    raises :class:`NonFiniteError` at the step where it happens. Returns the final BodyState,
    or with ``trajectory=True`` a BodyState whose fields carry a leading time axis of length
    n_steps + 1 (the initial state first). wheel_torque: constant motor torques of
    ``body.wheels`` (see :func:`step`).
    """
    _check_types(body, state)
    h, kernel, force, torque, torque_B = _prepare(body, state, dt, force, torque, integrator,
                                                  torque_B)
    n_steps = check.integer("n_steps", n_steps, low=0, high=MAX_STEPS,
                            allow_integral_float=True)
    shape = state.batch_shape
    q = kernels.unpack(state.orientation)
    w_B = kernels.rotate_inverse(q, kernels.unpack(state.angular_velocity))
    tau_B, tau_W = _parts(torque_B), _parts(torque)
    x, v = state.position, state.velocity
    rotors = _Rotors.of(body, state, wheel_torque, shape)
    history = [(x, v, _pack(q, shape), _pack(w_B, shape), rotors.speeds(w_B))]
    advance = kernel.advance
    try:
        for _ in range(n_steps):
            if rotors.wheels is None:
                q, w_B = advance(body, q, w_B, h, tau_B, tau_W)
            else:
                q, w_B = rotors.advance(advance, q, w_B, h, tau_B, tau_W)
            if translation:
                x, v = translate(integrator, body, x, v, h, force)
                check_finite_state(q, w_B, integrator, h, x, v)
            else:
                check_finite_state(q, w_B, integrator, h)
            if trajectory:
                history.append((x, v, _pack(q, shape), _pack(w_B, shape), rotors.speeds(w_B)))
    except _OVERFLOW as exc:
        _diverged_inside(exc, integrator, h)
    if trajectory:
        xs, vs, qs, ws = (np.stack(f) for f in list(zip(*history, strict=True))[:4])
        speeds = None if rotors.wheels is None else np.stack([hh[4] for hh in history])
        return BodyState.from_arrays(xs, vs, qs, quaternion.rotate(qs, ws), speeds)
    return BodyState.from_arrays(x, v, _pack(q, shape), _pack(kernels.rotate(q, w_B), shape),
                                 rotors.speeds(w_B))


class _Rotors:
    """The wheels' absolute spin momenta ``h_i = J_i (Ω_i + ĝ_iᵀω_B)`` over a simulation.

    The integrators step the bus (``body.bus``) with ``G h`` as internal momentum and ``G u``
    as its rate; ``h`` then moves by ``u·dt`` exactly (u is held), and the relative speeds
    are ``Ω = h/J − Gᵀω_B``.
    """

    def __init__(self, wheels, h, u, bus):
        self.wheels, self.h, self.u, self.bus = wheels, h, u, bus

    @classmethod
    def of(cls, body, state, wheel_torque, shape):
        wheels = body.wheels
        if wheels is None:
            if wheel_torque is not None or state.wheel_speeds is not None:
                raise InvalidParameterError(
                    "wheel_torque and wheel_speeds need a body with wheels "
                    "(RigidBody(..., wheels=core.Wheels(axes, inertia)))")
            return cls(None, None, None, None)
        n = wheels.n
        speeds = np.zeros((*shape, n)) if state.wheel_speeds is None else state.wheel_speeds
        u = np.zeros(n) if wheel_torque is None else check.finite_array("wheel_torque",
                                                                          wheel_torque)
        for name, arr in (("wheel_speeds", speeds), ("wheel_torque", u)):
            if arr.shape[-1:] != (n,):
                raise InvalidParameterError(
                    f"{name} must have one entry per wheel, (..., {n}), got shape {arr.shape}")
        w_B = quaternion.rotate_inverse(state.orientation, state.angular_velocity)
        h = wheels.inertia * (np.broadcast_to(speeds, (*shape, n)) + w_B @ wheels.axes.T)
        return cls(wheels, h, np.broadcast_to(u, (*shape, n)), body.bus)

    def advance(self, advance, q, w_B, dt, tau_B, tau_W):
        axes = self.wheels.axes
        out = advance(self.bus, q, w_B, dt, tau_B, tau_W, kernels.unpack(self.h @ axes),
                      kernels.unpack(self.u @ axes))
        self.h = self.h + self.u * dt
        return out

    def speeds(self, w_B):
        """(..., n) relative wheel speeds, rad/s, for body rates w_B (components), or None."""
        if self.wheels is None:
            return None
        w = np.stack(np.broadcast_arrays(*w_B), axis=-1)
        return self.h / self.wheels.inertia - w @ self.wheels.axes.T
