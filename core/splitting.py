"""Exact flows of the split free rigid body, for the explicit symplectic ``splitting`` integrator.

With principal moments I₁ ≤ I₂ ≤ I₃ and body momentum m in principal axes, the kinetic energy
splits into three parts, each with an exact flow that is a rotation (McLachlan 1993; Reich 1994;
Touma & Wisdom 1994)::

    T = |m|²/(2 I₂)  +  ½ (1/I₃ − 1/I₂) m₃²  +  ½ (1/I₁ − 1/I₂) m₁²
        sphere S        major-axis part A         minor-axis part C

* A part ``½ a mᵢ²`` turns the body about principal axis i at the rate ``φ̇ = a mᵢ``:
  ``q ← q ⊗ (cos φ/2, sin φ/2 eᵢ)`` and m turns by −φ about eᵢ (so ``L_W = R m`` stays put).
* The sphere S turns the body about m itself, ``q ← q ⊗ exp(h m / I₂)``, and leaves m alone.
  ``|m|²`` is a Casimir, so S commutes with A and C: one S per step, anywhere.

One free step is ``A(h/2) C(h) A(h/2) S(h)``: second order, time-symmetric, symplectic (Lie–
Poisson), |L| and L_W conserved to round-off and the energy error bounded. The ordering is not
arbitrary: the error constant varies by orders of magnitude with the split (Fassò 2003). Taking
the intermediate moment as the sphere's (so both remaining coefficients are as small as they
can be) with the major axis outside was the most accurate of the 12 orderings we measured (all
six plain three-axis splits and six sphere splits), on every scene of ``benchmarks.accuracy``.
A symmetric body (two equal moments) makes C vanish and the step exact.

Bodies with a full inertia tensor step in a working frame of principal axes computed once per
:class:`~rbenv.core.body.RigidBody` (``principal_frame``); for a diagonal tensor the working
frame is a relabelling of the body axes, exact in floating point.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from rbenv.core import kernels as k
from rbenv.core import quaternion
from rbenv.core.backend import namespace

__all__ = ["PrincipalFrame", "free_flow", "principal_frame"]


@dataclass(frozen=True)
class PrincipalFrame:
    """Working frame of one body: axes (major, minor, intermediate) = (outer, inner, sphere).

    ``coefficients`` = (1/I₃ − 1/I₂, 1/I₁ − 1/I₂, 1/I₂) in 1/(kg·m²). For a diagonal tensor,
    ``index`` names the body axis of each working axis and ``sign`` (±1) the sign of the third
    (so the relabelling is a rotation); ``rotation`` is None. For a full tensor, ``rotation`` is
    the working→body quaternion p and ``columns`` the working axes in body coordinates.
    """

    coefficients: tuple
    isotropic: bool
    index: tuple = (0, 1, 2)
    sign: float = 1.0
    rotation: tuple | None = None
    columns: tuple | None = None

    def to_work(self, q, m):
        """Body → working frame: q ⊗ p (or relabelled components) and m in working axes."""
        if self.rotation is None:
            i, j, n = self.index
            s = self.sign
            return (q[0], q[1 + i], q[1 + j], s * q[1 + n]), (m[i], m[j], s * m[n])
        c0, c1, c2 = self.columns
        return k.qmul(q, self.rotation), (k.dot(c0, m), k.dot(c1, m), k.dot(c2, m))

    def to_body(self, q, m):
        """Working → body frame, the inverse of :meth:`to_work`."""
        if self.rotation is None:
            i, j, n = self.index
            s = self.sign
            qv, mv = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            qv[i], qv[j], qv[n] = q[1], q[2], s * q[3]
            mv[i], mv[j], mv[n] = m[0], m[1], s * m[2]
            return (q[0], *qv), tuple(mv)
        p = self.rotation
        c0, c1, c2 = self.columns
        back = k.scale(c0, m[0]), k.scale(c1, m[1]), k.scale(c2, m[2])
        m_B = k.add(k.add(back[0], back[1]), back[2])
        return k.qmul(q, (p[0], -p[1], -p[2], -p[3])), m_B


def _frame_of(body) -> PrincipalFrame:
    inertia = np.asarray(body.inertia, dtype=float)
    moments, vectors = np.linalg.eigh(inertia)
    if body.kind != "full":
        order = np.argsort(np.diag(inertia), kind="stable")
        moments = np.diag(inertia)[order]
    i1, i2, i3 = (float(x) for x in moments)
    coefficients = (1.0 / i3 - 1.0 / i2, 1.0 / i1 - 1.0 / i2, 1.0 / i2)
    isotropic = body.kind == "isotropic"
    if body.kind != "full":
        index = (int(order[2]), int(order[0]), int(order[1]))
        # (major, minor, intermediate) is a rotation of (x, y, z) iff it is a cyclic order.
        sign = 1.0 if index in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
        return PrincipalFrame(coefficients, isotropic, index, sign)
    axes = vectors[:, [2, 0, 1]]
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] *= -1.0
    p = tuple(quaternion.from_matrix(axes).tolist())
    return PrincipalFrame(coefficients, isotropic, rotation=p,
                          columns=tuple(tuple(c) for c in axes.T.tolist()))


_FRAMES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def principal_frame(body) -> PrincipalFrame:
    """The body's working frame, computed on first use and kept while the body lives."""
    frame = _FRAMES.get(body)
    if frame is None:
        frame = _FRAMES[body] = _frame_of(body)
    return frame


def _turn(q, m, phi, xp):
    """Turn by φ about the first axis: ``q ⊗ (cos φ/2, sin φ/2 e₁)``, m by −φ about e₁.

    Components in cyclic order starting at the axis: q = (w, v₁, v₂, v₃), m = (m₁, m₂, m₃).
    """
    c2, s2 = k.cos_sin_half(phi, xp)
    c, s = c2 * c2 - s2 * s2, 2.0 * s2 * c2
    w, a, b, d = q
    m1, m2, m3 = m
    return ((w * c2 - a * s2, w * s2 + a * c2, b * c2 + d * s2, d * c2 - b * s2),
            (m1, c * m2 + s * m3, c * m3 - s * m2))


def free_flow(frame: PrincipalFrame, q, m, h):
    """One torque-free step ``A(h/2) C(h) A(h/2) S(h)`` in the working frame.

    q: working-frame attitude quaternion, m: working-frame momentum (kg·m²/s), h: step (s);
    components are floats or (N,) arrays. Returns (q, m), q normalised.
    """
    a_out, a_in, inv_ref = frame.coefficients
    if not frame.isotropic:
        xp = namespace(m[0])
        q, m = _turn(q, m, (0.5 * h * a_out) * m[0], xp)
        # The inner (second) axis first in cyclic order: (y, z, x).
        qy, my = _turn((q[0], q[2], q[3], q[1]), (m[1], m[2], m[0]), (h * a_in) * m[1], xp)
        q, m = (qy[0], qy[3], qy[1], qy[2]), (my[2], my[0], my[1])
        q, m = _turn(q, m, (0.5 * h * a_out) * m[0], xp)
    return k.qnormalize(k.qmul(q, k.exp(k.scale(m, h * inv_ref)))), m
