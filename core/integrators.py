"""Attitude integrators: one step of (q, ω_B) for a rigid body under torque.

Every integrator here advances the same state by ``h`` seconds: ``q`` body→world unit quaternion
(w, x, y, z) and ``w`` body angular velocity ω_B in rad/s, with a torque held constant over the
step: ``tau_B`` (N·m) fixed in the body frame (thrusters) plus ``tau_W`` (N·m) fixed in the world
frame; either may be ``None``. States are component tuples (see :mod:`rbenv.core.kernels`): floats
for one body, (N,) arrays for a batch. The single env, the vector env, ``rbenv.core.step`` and
``rbenv.core.simulate`` all call these functions: the dynamics exist once.

Equations (correcting the lecture, see docs/design.md, "Where the lecture is wrong"):
    q̇ = ½ q ⊗ (0, ω_B),    I ω̇_B = τ_B − ω_B × (I ω_B + h_B) − ḣ_B   (Euler's equations)

``h_B`` is the internal angular momentum of the actuators (reaction wheels), N·m·s, and ``ḣ_B``
its rate, N·m; every integrator takes them as the keywords ``momentum_B`` and
``momentum_rate_B`` (components; None: zero), with ``h_B`` moving linearly over the step. With
None the step is the rigid body's, unchanged to the bit. The motor torque that spins a wheel
up is internal: it moves momentum between bus and wheels and leaves ``I ω_B + h_B`` alone.

A torque that depends on the state (the orbit's: gravity gradient, ``m × B`` with the field
fixed in inertial axes, drag, radiation pressure) is the keyword ``torque_fn``: a callable
``torque_fn(s, q, w) -> τ_B`` (3 components, N·m) evaluated once per stage for the whole batch,
``s`` the stage's time as a fraction of the step (0, ½ or 1; a Python float), ``q`` the
stage's unit quaternion and ``w`` its rate. rk4 calls it at each of its four stages, the Euler
schemes at the start, and the kick schemes (midpoint, splitting) at the start and end
attitudes with ``w = None``: they refuse a torque_fn whose attribute ``needs_rate`` is true.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from rbenv.core import kernels as k
from rbenv.core import splitting as split
from rbenv.core.body import RigidBody
from rbenv.core.errors import InvalidParameterError

Kernel = Callable[..., tuple[tuple, tuple]]

# Newton for the implicit midpoint stops at this relative residual; continuation in h takes over
# for the rare steps (h·|ω| ≳ 5) where the explicit first guess lies outside Newton's basin.
_NEWTON_RTOL = 4.0 * np.finfo(float).eps
_NEWTON_MAXITER = 8
_MAX_CONTINUATION = 1024
_CONTINUATION_ABOVE = 1.5  # h·|ω| above which the first guess is not trusted
_ZERO = (0.0, 0.0, 0.0)
_E = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def body_torque(q, tau_B, tau_W):
    """Total torque in body axes ``τ_B + Rᵀ τ_W`` (N·m components)."""
    total = _ZERO if tau_B is None else tau_B
    if tau_W is not None:
        total = k.add(total, k.rotate_inverse(q, tau_W))
    return total


def stage_torque(q, w, tau_B, tau_W, torque_fn, s):
    """Body torque of one integrator stage: ``τ_B + Rᵀ τ_W + torque_fn(s, q, ω)`` (N·m
    components); ``s`` the stage's time as a fraction of the step (0, ½ or 1)."""
    total = body_torque(q, tau_B, tau_W)
    if torque_fn is not None:
        total = k.add(total, torque_fn(s, q, w))
    return total


def _refuse_rate_torque(name: str, torque_fn) -> None:
    """The kick schemes evaluate the torque at the end of the step before the new rate is
    known: they take torques of (t, q) only."""
    if torque_fn is not None and getattr(torque_fn, "needs_rate", False):
        raise InvalidParameterError(
            f"integrator {name!r} kicks with the torque at the start and end attitudes and "
            f"cannot evaluate a torque that depends on the body rate (torque_fn.needs_rate "
            f"is true); use 'rk4'")


def angular_acceleration(body: RigidBody, w, tau, h_B=None, h_dot_B=None):
    """``ω̇_B = I⁻¹(τ_B − ω_B × (I ω_B + h_B) − ḣ_B)`` (rad/s²); without internal momentum the
    gyroscopic term vanishes when isotropic."""
    if h_B is not None or h_dot_B is not None:
        m = body.inertia_times(w) if h_B is None else k.add(body.inertia_times(w), h_B)
        tau = k.sub(tau, k.cross(w, m))
        return body.inverse_times(tau if h_dot_B is None else k.sub(tau, h_dot_B))
    if body.is_isotropic:
        return body.inverse_times(tau)
    return body.inverse_times(k.sub(tau, k.cross(w, body.inertia_times(w))))


def _momentum_at(h_B, h_dot_B, t):
    """Internal momentum ``h_B + t·ḣ_B`` a time t into the step (None stays None)."""
    if h_B is None or h_dot_B is None:
        return h_B
    return k.add(h_B, h_dot_B, t)


def euler_seed(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None,
               momentum_rate_B=None, torque_fn=None):
    """The lecture, to the letter: ``q ← N(q + ½dt ω q)``, ``ω_W ← ω_W + dt I_W⁻¹ τ_W``.

    No gyroscopic term: inconsistent for asymmetric inertia (a torque-free body keeps ω_W fixed
    and never precesses). Kept for teaching and as the cheapest choice for isotropic bodies.
    ``I_W⁻¹ τ_W = R I⁻¹ Rᵀ τ_W`` is applied as rotate ∘ I⁻¹ ∘ rotate⁻¹; for isotropic inertia
    the lecture's uniform-scale shortcut skips both rotations. Internal momentum enters as the
    lecture would have it: ``−ḣ_B`` adds to the torque, and ``h_B`` (a gyroscopic term) is
    ignored like the body's own.
    """
    w_W = k.rotate(q, w)
    tau = body_torque(q, tau_B, tau_W)  # = Rᵀ τ_W
    if torque_fn is not None:
        tau = k.add(tau, torque_fn(0.0, q, w))
    if momentum_rate_B is not None:
        tau = k.sub(tau, momentum_rate_B)
    if body.is_isotropic:
        alpha_W = body.inverse_times(k.rotate(q, tau))
    else:
        alpha_W = k.rotate(q, body.inverse_times(tau))
    q_new = k.cayley(q, w, h)  # ω_W ⊗ q == q ⊗ ω_B
    return q_new, k.rotate_inverse(q_new, k.add(w_W, alpha_W, h))


def euler(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None, momentum_rate_B=None,
          torque_fn=None):
    """Explicit Euler with the gyroscopic term: the lecture's scheme made consistent (order 1).

    ``ω_W ← ω_W + h I_W⁻¹(τ_W − ω_W × I_W ω_W)`` at the old state, and the lecture's
    quaternion update with the old ω. Unstable for h·|ω| ≳ 0.5 on asymmetric bodies.
    """
    alpha = angular_acceleration(body, w, stage_torque(q, w, tau_B, tau_W, torque_fn, 0.0),
                                 momentum_B, momentum_rate_B)
    q_new = k.cayley(q, w, h)
    return q_new, k.rotate_inverse(q_new, k.rotate(q, k.add(w, alpha, h)))


def semi_implicit(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None,
                  momentum_rate_B=None, torque_fn=None):
    """Semi-implicit (symplectic) Euler, MuJoCo's default: velocity first, then exact exp map.

    ``ω_B ← ω_B + h α_B(q, ω_B)``, ``q ← q ⊗ exp(h ω_B⁺)``. Order 1; the explicit gyroscopic
    term still diverges at high spin (h·|ω| ≳ 0.5).
    """
    tau = stage_torque(q, w, tau_B, tau_W, torque_fn, 0.0)
    w_new = k.add(w, angular_acceleration(body, w, tau, momentum_B, momentum_rate_B), h)
    return k.qnormalize(k.qmul(q, k.exp(k.scale(w_new, h)))), w_new


def _rk4_rate(body, q, w, tau_B, tau_W, h_B=None, h_dot_B=None, torque_fn=None, s=0.0):
    q_dot = k.qmul_vec(q, k.scale(w, 0.5))
    q_unit = q if tau_W is None and torque_fn is None else k.qnormalize(q)
    return q_dot, angular_acceleration(body, w, stage_torque(q_unit, w, tau_B, tau_W, torque_fn,
                                                             s), h_B, h_dot_B)


def _qadd(q, dq, s):
    return (q[0] + s * dq[0], q[1] + s * dq[1], q[2] + s * dq[2], q[3] + s * dq[3])


def _rk4_sum(y, k1, k2, k3, k4, s, i):
    """Component i of ``y + s (k1 + 2(k2 + k3) + k4)``."""
    return y[i] + s * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])


def _rk4_combine(y, k1, k2, k3, k4, h):
    """The RK4 update of a 3-vector (components written out: the compiled path needs them)."""
    s = h / 6.0
    return (_rk4_sum(y, k1, k2, k3, k4, s, 0), _rk4_sum(y, k1, k2, k3, k4, s, 1),
            _rk4_sum(y, k1, k2, k3, k4, s, 2))


def _rk4_combine_q(y, k1, k2, k3, k4, h):
    """The RK4 update of a quaternion."""
    return (*_rk4_combine(y, k1, k2, k3, k4, h), _rk4_sum(y, k1, k2, k3, k4, h / 6.0, 3))


def rk4(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None, momentum_rate_B=None,
        torque_fn=None):
    """Classical fourth-order Runge–Kutta on (q, ω_B), q normalised at the end of the step.

    Order 4; not conservative: it slowly loses energy once h·|ω| ≳ 1.
    """
    h0, h_dot = momentum_B, momentum_rate_B
    if h_dot is None:  # no internal momentum (or a constant one): no extra calls
        h_mid = h1 = h0
    else:
        h_mid, h1 = _momentum_at(h0, h_dot, 0.5 * h), _momentum_at(h0, h_dot, h)
    f = torque_fn
    k1q, k1w = _rk4_rate(body, q, w, tau_B, tau_W, h0, h_dot, f, 0.0)
    k2q, k2w = _rk4_rate(body, _qadd(q, k1q, 0.5 * h), k.add(w, k1w, 0.5 * h), tau_B, tau_W,
                         h_mid, h_dot, f, 0.5)
    k3q, k3w = _rk4_rate(body, _qadd(q, k2q, 0.5 * h), k.add(w, k2w, 0.5 * h), tau_B, tau_W,
                         h_mid, h_dot, f, 0.5)
    k4q, k4w = _rk4_rate(body, _qadd(q, k3q, h), k.add(w, k3w, h), tau_B, tau_W, h1, h_dot, f,
                         1.0)
    q_new = _rk4_combine_q(q, k1q, k2q, k3q, k4q, h)
    w_new = _rk4_combine(w, k1w, k2w, k3w, k4w, h)
    return k.qnormalize(q_new), w_new


def _residual(body, m, x, h, hw=None):
    """``F(x) = x − m − ½h x × I⁻¹(x − h_w)`` and ``I⁻¹(x − h_w)`` (h_w: internal momentum)."""
    v = body.inverse_times(x if hw is None else k.sub(x, hw))
    c = k.cross(x, v)
    s = 0.5 * h
    return (x[0] - m[0] - s * c[0], x[1] - m[1] - s * c[1], x[2] - m[2] - s * c[2]), v


def _all(cond) -> bool:
    return bool(cond) if np.ndim(cond) == 0 else bool(np.all(cond))


def _newton(body, m, x, h, hw=None):
    """Newton iterations for the midpoint momentum; returns (x, converged) (bool or array)."""
    tol2 = (_NEWTON_RTOL * _NEWTON_RTOL) * (k.dot(m, m) + 1e-300)
    s = 0.5 * h
    inv_cols = body.inverse_columns
    for _ in range(_NEWTON_MAXITER):
        r, v = _residual(body, m, x, h, hw)
        ok = k.dot(r, r) <= tol2
        if _all(ok):
            return x, ok
        # Column j of the Jacobian: e_j − ½h (x × I⁻¹e_j − I⁻¹x × e_j).
        cols = [k.add(_E[j], k.add(k.cross(x, inv_cols[j]), k.cross(v, _E[j]), -1.0), -s)
                for j in range(3)]
        step = k.add(x, k.solve3(*cols, r), -1.0)
        # An entry that has converged stays at the iterate it converged at, as it would alone:
        # a sub-env's root never depends on its neighbours in the batch.
        if np.ndim(ok) != 0:
            step = tuple(np.where(ok, a, b) for a, b in zip(x, step, strict=True))
        x = step
    r, _ = _residual(body, m, x, h, hw)
    return x, k.dot(r, r) <= 256.0 * tol2


def _first_pieces(hw: float) -> int:
    """Continuation's first step count K: the smallest power of two ≥ 2 with h·|ω|/K ≤ 1."""
    return 2 ** max(1, int(np.ceil(np.log2(max(float(hw), 1.0)))))


def _continue(body, m, h, pieces: int, h_int):
    """Newton at h/K, 2h/K, …, h (K = ``pieces``), each from the previous root; (x, ok)."""
    x, ok = m, True
    for j in range(1, pieces + 1):
        x, okj = _newton(body, m, x, h * j / pieces, h_int)
        ok = ok & okj
    return x, ok


def _continuation(body, m, h, hw, h_int=None):
    """Solve one body by continuation in h: K = :func:`_first_pieces`, doubled until Newton
    converges at every one of the K steps; None past ``_MAX_CONTINUATION``."""
    pieces = _first_pieces(hw)
    while pieces <= _MAX_CONTINUATION:
        x, ok = _continue(body, m, h, pieces, h_int)
        if ok:
            return x
        pieces *= 2
    return None


def _continuation_batch(body, m, h, hw, h_int=None):
    """:func:`_continuation` for each entry of (n,) components, as that entry would run alone.

    Entries with the same K run together; an entry keeps the first root it converges to, and
    only those that fail go on to 2K. NaN components where even the largest K fails.
    """
    n = hw.shape[0]
    out = tuple(np.full(n, np.nan) for _ in range(3))
    pieces = np.array([_first_pieces(v) for v in hw.tolist()])  # the few hard entries only
    todo = np.ones(n, bool)
    while todo.any():
        for count in np.unique(pieces[todo]).tolist():
            sel = np.flatnonzero(todo & (pieces == count))
            if count > _MAX_CONTINUATION:
                todo[sel] = False
                continue
            h_sel = None if h_int is None else tuple(c[sel] for c in h_int)
            x, ok = _continue(body, tuple(c[sel] for c in m), h, count, h_sel)
            ok = np.broadcast_to(ok, sel.shape)
            for c, xc in zip(out, x, strict=True):
                c[sel[ok]] = np.broadcast_to(xc, sel.shape)[ok]
            todo[sel[ok]] = False
            pieces[sel[~ok]] *= 2
    return out


def _solve_midpoint(body, m, h, h_int=None):
    """Midpoint momentum ``m̄`` solving ``m̄ = m + ½h m̄ × I⁻¹(m̄ − h_int)``.

    The wanted root is the branch that tends to m as h → 0. For h·|ω| ≤ 1.5 Newton from the
    explicit guess finds it. Beyond that Newton may fail (from h·|ω| ≈ 5) or, worse, converge to
    another root (seen from h·|ω| ≈ 4: invariants still exact, motion wrong), so those entries
    are solved by continuation in h. Returns NaN components if even that fails.
    """
    w = body.inverse_times(m if h_int is None else k.sub(m, h_int))
    hw = h * k.sqrt(k.dot(w, w))
    large = hw > _CONTINUATION_ABOVE
    if np.ndim(hw) == 0:
        if not large:
            x, ok = _newton(body, m, k.add(m, k.cross(m, w), 0.5 * h), h, h_int)
            if ok:
                return x
        x = _continuation(body, m, h, hw, h_int)
        return (math.nan,) * 3 if x is None else x
    x, ok = _newton(body, m, k.add(m, k.cross(m, w), 0.5 * h), h, h_int)
    redo = large | ~ok
    if not redo.any():
        return x
    sub = tuple(np.broadcast_to(c, redo.shape)[redo] for c in m)
    h_sub = None if h_int is None else tuple(np.broadcast_to(c, redo.shape)[redo]
                                             for c in h_int)
    xs = _continuation_batch(body, sub, h, hw[redo], h_sub)
    out = tuple(np.array(np.broadcast_to(c, redo.shape), dtype=float) for c in x)
    for c, cs in zip(out, xs, strict=True):
        c[redo] = cs
    return out


def midpoint(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None,
             momentum_rate_B=None, torque_fn=None):
    """Implicit midpoint on body momentum + Cayley attitude update (the default integrator).

    Torque enters by Strang splitting (half kick, free step, half kick). The free step solves
    ``m̄ = m + ½h m̄ × I⁻¹m̄``, sets ``m⁺ = 2m̄ − m`` and ``q⁺ = N(q ⊗ (1, ½h I⁻¹m̄))``; with no
    torque it conserves energy, |L| and the vector L_W to round-off at any h·|ω| (order 2).
    With internal momentum m is the total ``I ω + h_B``, the body rate ``I⁻¹(m − h_B)`` with
    h_B at the midpoint of the step, and ``|m|`` and L_W stay exact whatever ``ḣ_B``.
    """
    _refuse_rate_torque("midpoint", torque_fn)
    if momentum_B is not None or momentum_rate_B is not None:
        return _midpoint_internal(body, q, w, h, tau_B, tau_W, momentum_B, momentum_rate_B,
                                  torque_fn)
    forced = tau_B is not None or tau_W is not None or torque_fn is not None
    m = body.inertia_times(w)
    if forced:
        m = k.add(m, stage_torque(q, None, tau_B, tau_W, torque_fn, 0.0), 0.5 * h)
    # Isotropic: m × I⁻¹m = 0, so the free step keeps m and turns about it.
    m_mid = m if body.is_isotropic else _solve_midpoint(body, m, h)
    q_new = k.cayley(q, body.inverse_times(m_mid), h)
    m_new = k.add(k.scale(m_mid, 2.0), m, -1.0)
    if forced:
        m_new = k.add(m_new, stage_torque(q_new, None, tau_B, tau_W, torque_fn, 1.0), 0.5 * h)
    return q_new, body.inverse_times(m_new)


def _midpoint_internal(body, q, w, h, tau_B, tau_W, h_B, h_dot_B, torque_fn=None):
    """:func:`midpoint` with internal momentum (the motor torque is internal: no kick)."""
    zero = k.scale(w, 0.0)
    h0 = zero if h_B is None else h_B
    h_mid = h0 if h_dot_B is None else k.add(h0, h_dot_B, 0.5 * h)
    h1 = h0 if h_dot_B is None else k.add(h0, h_dot_B, h)
    forced = tau_B is not None or tau_W is not None or torque_fn is not None
    m = k.add(body.inertia_times(w), h0)
    if forced:
        m = k.add(m, stage_torque(q, None, tau_B, tau_W, torque_fn, 0.0), 0.5 * h)
    m_mid = _solve_midpoint(body, m, h, h_mid)
    q_new = k.cayley(q, body.inverse_times(k.sub(m_mid, h_mid)), h)
    m_new = k.add(k.scale(m_mid, 2.0), m, -1.0)
    if forced:
        m_new = k.add(m_new, stage_torque(q_new, None, tau_B, tau_W, torque_fn, 1.0), 0.5 * h)
    return q_new, body.inverse_times(k.sub(m_new, h1))


def splitting(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None,
              momentum_rate_B=None, torque_fn=None):
    """Explicit symplectic splitting of the free body (:mod:`rbenv.core.splitting`), torque as
    kicks.

    Strang: half kick ``m += ½h τ``, the free step ``A(h/2) C(h) A(h/2) S(h)`` (each part an
    exact rotation about a principal axis or about m), half kick at the new attitude. Order 2,
    explicit (no iteration); with no torque |L| and L_W are conserved to round-off and the
    energy error stays bounded at any h·|ω|.
    """
    if momentum_B is not None or momentum_rate_B is not None:
        raise InvalidParameterError(
            "integrator 'splitting' splits the free body into exact rotations about its "
            "principal axes, which do not exist with internal angular momentum (momentum_B); "
            "use 'midpoint' (exact invariants) or 'rk4'")
    _refuse_rate_torque("splitting", torque_fn)
    forced = tau_B is not None or tau_W is not None or torque_fn is not None
    m = body.inertia_times(w)
    if forced:
        m = k.add(m, stage_torque(q, None, tau_B, tau_W, torque_fn, 0.0), 0.5 * h)
    frame = split.principal_frame(body)
    q_new, m_new = frame.to_body(*split.free_flow(frame, *frame.to_work(q, m), h))
    if forced:
        m_new = k.add(m_new, stage_torque(q_new, None, tau_B, tau_W, torque_fn, 1.0), 0.5 * h)
    return q_new, body.inverse_times(m_new)


# Bodies per NumPy pass in a large batch: a step creates a few hundred temporaries, and at 4096
# doubles (32 KB) each they stay in L2; unchunked, N = 262 144 runs 2-3x slower per body.
BATCH_CHUNK = 4096


def _slice(components, part: slice, n: int):
    if components is None:
        return None
    return tuple(c[part] if isinstance(c, np.ndarray) and c.shape == (n,) else c
                 for c in components)


def chunked(kernel: Kernel) -> Kernel:
    """``kernel`` applied to batches above 2·BATCH_CHUNK bodies one chunk at a time.

    The kernels are element-wise across bodies, so the result is bit-identical to one call;
    one body (floats) and batches up to 2·BATCH_CHUNK go straight to the kernel.
    """
    def advance(body, q, w, h, tau_B=None, tau_W=None, momentum_B=None,
                momentum_rate_B=None, torque_fn=None):
        c = q[0]
        if momentum_B is not None or momentum_rate_B is not None or torque_fn is not None:
            # torque_fn evaluates the whole batch at once (its lookups index all N bodies)
            return kernel(body, q, w, h, tau_B, tau_W, momentum_B=momentum_B,
                          momentum_rate_B=momentum_rate_B, torque_fn=torque_fn)
        if type(c) is float or np.size(c) <= 2 * BATCH_CHUNK:
            return kernel(body, q, w, h, tau_B, tau_W)
        n = np.size(c)
        q_out = tuple(np.empty(n) for _ in range(4))
        w_out = tuple(np.empty(n) for _ in range(3))
        for start in range(0, n, BATCH_CHUNK):
            part = slice(start, start + BATCH_CHUNK)
            q_c, w_c = kernel(body, _slice(q, part, n), _slice(w, part, n), h,
                              _slice(tau_B, part, n), _slice(tau_W, part, n))
            for out, val in zip(q_out + w_out, q_c + w_c, strict=True):
                out[part] = val
        return q_out, w_out

    advance.__doc__ = kernel.__doc__
    advance.__wrapped__ = kernel
    return advance


@dataclass(frozen=True)
class Integrator:
    """A named integrator: its kernel, its order and what it conserves without torque.

    ``advance`` is the step as written, for one body (floats) or a batch, and what
    :mod:`rbenv.core.compiled` compiles. ``advance_batch`` is the same step for large batches, fed
    chunk by chunk (:func:`chunked`) when ``element_wise``; use it where N may exceed
    2·BATCH_CHUNK (it costs one Python call more on a single body). The midpoint's Newton
    decides convergence over the whole batch, so it is not split: its round-off would depend on
    the chunking.
    """

    name: str
    advance: Kernel
    order: int
    conserves: str
    summary: str
    element_wise: bool = True
    advance_batch: Kernel = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "advance_batch",
                           chunked(self.advance) if self.element_wise else self.advance)


INTEGRATORS: dict[str, Integrator] = {
    i.name: i
    for i in (
        Integrator("euler_seed", euler_seed, 0, "nothing physical",
                   "lecture scheme, no gyroscopic term; inconsistent for asymmetric inertia"),
        Integrator("euler", euler, 1, "nothing", "explicit Euler with gyroscopic term"),
        Integrator("semi_implicit", semi_implicit, 1, "nothing",
                   "velocity first, exp-map attitude (MuJoCo's Euler)"),
        Integrator("rk4", rk4, 4, "nothing (slowly dissipative)", "classical RK4"),
        Integrator("midpoint", midpoint, 2, "energy, |L|, L_W",
                   "implicit midpoint + Cayley: exact invariants at any h·|ω|",
                   element_wise=False),
        Integrator("splitting", splitting, 2, "|L|, L_W; energy error bounded",
                   "explicit symplectic split into rotations about principal axes"),
    )
}


def get(name: str) -> Integrator:
    """Look up an integrator by name; the error lists the valid names."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"integrator must be one of {sorted(INTEGRATORS)}, got {name!r}"
        ) from None
