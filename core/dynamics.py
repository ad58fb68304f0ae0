"""``step`` and ``simulate``: advance :class:`BodyState` under world-frame force and torque."""

from __future__ import annotations

import numpy as np

from core import integrators, kernels, quaternion
from core.body import BodyState, RigidBody
from core.errors import InvalidParameterError, NonFiniteError, require_finite, require_positive


def _optional_vector(name: str, value):
    if value is None:
        return None
    arr = require_finite(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise InvalidParameterError(f"{name} must have shape (..., 3), got shape {arr.shape}")
    return arr


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


def check_finite_state(q, w_B, integrator: str, h: float):
    """Raise :class:`NonFiniteError` if a simulated attitude state (components) is not finite."""
    if all(np.isfinite(c).all() for c in (*q, *w_B)):
        return
    raise NonFiniteError(
        f"simulation diverged: the state became non-finite after a step with integrator="
        f"{integrator!r}, dt={h!r}. Explicit integrators ('euler', 'semi_implicit', 'rk4') are "
        "unstable once dt·|ω| is large (≳ 0.5 for the Euler schemes); use 'midpoint' or a "
        "smaller dt"
    )


def _prepare(body, state, dt, force, torque, integrator, torque_B):
    if not isinstance(body, RigidBody):
        raise InvalidParameterError(f"body must be a core.RigidBody, got {type(body).__name__}")
    if not isinstance(state, BodyState):
        raise InvalidParameterError(f"state must be a core.BodyState, got {type(state).__name__}")
    h = require_positive("dt", dt)
    kernel = integrators.get(integrator)
    return (h, kernel, _optional_vector("force", force), _optional_vector("torque", torque),
            _optional_vector("torque_B", torque_B))


def step(body: RigidBody, state: BodyState, dt: float, force=None, torque=None,
         integrator: str = "midpoint", *, torque_B=None, translation: bool = True) -> BodyState:
    """Advance ``state`` by ``dt`` seconds with force and torque held constant over the step.

    body: the rigid body. state: BodyState with batch shape (...). dt: step in s, > 0.
    force: (..., 3) N, world frame, through the centre of mass. torque: (..., 3) N·m about the
    centre of mass, world frame (use :func:`core.forces.wrench_at_points` for forces at points).
    torque_B: (..., 3) N·m fixed in the body frame during the step (thrusters).
    integrator: a name in ``INTEGRATORS``. translation: False skips the centre-of-mass update.
    Returns the new BodyState; raises NonFiniteError if the result is not finite.
    """
    h, kernel, force, torque, torque_B = _prepare(body, state, dt, force, torque, integrator,
                                                  torque_B)
    q = kernels.unpack(state.orientation)
    w_B = kernels.rotate_inverse(q, kernels.unpack(state.angular_velocity))
    q_new, w_new = kernel.advance(body, q, w_B, h, _parts(torque_B), _parts(torque))
    check_finite_state(q_new, w_new, integrator, h)
    x, v = state.position, state.velocity
    if translation:
        x, v = translate(integrator, body, x, v, h, force)
    shape = state.batch_shape
    w_W = kernels.rotate(q_new, w_new)
    return BodyState.from_arrays(x, v, _pack(q_new, shape), _pack(w_W, shape))


def simulate(body: RigidBody, state: BodyState, dt: float, n_steps: int, force=None, torque=None,
             integrator: str = "midpoint", *, torque_B=None, translation: bool = True,
             trajectory: bool = False):
    """Take ``n_steps`` steps of :func:`step` with constant force/torque (same units and frames).

    Returns the final BodyState, or with ``trajectory=True`` a BodyState whose fields carry a
    leading time axis of length n_steps + 1 (the initial state first).
    """
    h, kernel, force, torque, torque_B = _prepare(body, state, dt, force, torque, integrator,
                                                  torque_B)
    if int(n_steps) != n_steps or n_steps < 0:
        raise InvalidParameterError(f"n_steps must be a non-negative integer, got {n_steps!r}")
    shape = state.batch_shape
    q = kernels.unpack(state.orientation)
    w_B = kernels.rotate_inverse(q, kernels.unpack(state.angular_velocity))
    tau_B, tau_W = _parts(torque_B), _parts(torque)
    x, v = state.position, state.velocity
    history = [(x, v, _pack(q, shape), _pack(w_B, shape))]
    for _ in range(int(n_steps)):
        q, w_B = kernel.advance(body, q, w_B, h, tau_B, tau_W)
        if translation:
            x, v = translate(integrator, body, x, v, h, force)
        if trajectory:
            history.append((x, v, _pack(q, shape), _pack(w_B, shape)))
    check_finite_state(q, w_B, integrator, h)
    if trajectory:
        xs, vs, qs, ws = (np.stack(f) for f in zip(*history, strict=True))
        return BodyState.from_arrays(xs, vs, qs, quaternion.rotate(qs, ws))
    return BodyState.from_arrays(x, v, _pack(q, shape), _pack(kernels.rotate(q, w_B), shape))
