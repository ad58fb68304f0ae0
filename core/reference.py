"""Exact reference solutions of rigid-body rotation, for tests and benchmarks.

The torque-free motions here are exact (closed forms plus one smooth quadrature), so they measure
the *global* error of every integrator in :mod:`rbenv.core.integrators` without a numerical
reference of unknown quality. :func:`solve_ivp_reference` covers torque-driven cases with a tight
DOP853 solution instead.

Conventions (docs/design.md): quaternions are scalar-first ``(w, x, y, z)``, Hamilton, unit, and map
body to world (``v_W = q ⊗ v_B ⊗ q*``). Inertia is given as **principal moments** ``(3,)`` in
kg·m², i.e. the body frame *is* the principal frame: ``I = diag(moments)`` in body axes (any
order). Body rates ``omega_B`` are in rad/s, body frame; times in s.

Sources: reference/rigid-body-physics.md §2.2 (Euler's equations via Jacobi elliptic functions,
after Celledoni, Fassò, Säfström, Zanna, SIAM J. Sci. Comput. 30 (2008) 2084 and Principia's
``euler_solver_body.hpp``), §2.3 option A (attitude by one quadrature of the precession angle)
and §2.5 (symmetric top). The sign conventions of the elliptic solution below are derived here
(each amplitude's sign is chosen and λ's sign follows from Euler's equations), not copied.

This is the only module of ``core`` that imports SciPy.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from itertools import pairwise

import numpy as np
from rbenv.core import quaternion as quat
from rbenv.core.errors import InvalidParameterError, describe
from rbenv.core.inertia import validate as _validate_inertia
from rbenv.core.validation import finite_array
from rbenv.core.vec import cross
from scipy.integrate import solve_ivp
from scipy.special import ellipj, ellipkinc, ellipkm1, elliprf

__all__ = [
    "TorqueFreeSolution",
    "constant_torque_about_axis",
    "solve_ivp_reference",
    "symmetric_top",
    "torque_free",
]

_EPS = np.finfo(float).eps
# Two principal moments closer than this (relative to the largest) count as equal.
_EQUAL_RTOL = 1e-12
# Gauss–Legendre rule used on every panel of the precession-angle quadrature.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_MAX_PANELS = 1 << 16


# --------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------


def _moments(moments, name: str = "moments") -> np.ndarray:
    arr = finite_array(name, moments)
    if arr.shape != (3,):
        raise InvalidParameterError(
            f"{name} must be the three principal moments, shape (3,), got shape {arr.shape}"
        )
    _validate_inertia(np.diag(arr), name=name)
    return arr


def _vector(name: str, value, size: int) -> np.ndarray:
    arr = finite_array(name, value)
    if arr.shape != (size,):
        raise InvalidParameterError(f"{name} must have shape ({size},), got shape {arr.shape}")
    return arr


def _unit_quaternion(name: str, value) -> np.ndarray:
    q = _vector(name, value, 4)
    n = float(np.sqrt(q @ q))
    if abs(n - 1.0) > 1e-6:
        raise InvalidParameterError(
            f"{name} must be a unit quaternion (w, x, y, z), got {describe(q)} with norm {n:.9g}"
        )
    return q / n


def _times(t) -> np.ndarray:
    return finite_array("t", t)


def _axis_quat(axis: int, angle: np.ndarray) -> np.ndarray:
    """Rotation by ``angle`` (...) rad about body axis ``axis`` (0, 1, 2). Returns (..., 4)."""
    half = 0.5 * np.asarray(angle, dtype=float)
    q = np.zeros((*half.shape, 4))
    q[..., 0] = np.cos(half)
    q[..., 1 + axis] = np.sin(half)
    return q


def _relabel(moments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Right-handed relabelling to ascending moments: ``S`` (3, 3), det +1, ``v_sorted = S v``."""
    order = np.argsort(moments, kind="stable")
    S = np.zeros((3, 3))
    S[np.arange(3), order] = 1.0
    if np.linalg.det(S) < 0.0:
        # An odd permutation is a reflection; flipping one axis makes it a rotation. Diagonal
        # inertia does not see the sign, so the sorted moments are unchanged.
        S[0] = -S[0]
    return moments[order], S


# --------------------------------------------------------------------------------------------
# Jacobi elliptic functions with argument reduction
# --------------------------------------------------------------------------------------------


def _ellipj_mc(w: np.ndarray, m: float, mc: float):
    """sn, cn, dn of w (...) for parameter m with an accurate complement ``mc = 1 − m``.

    SciPy's ``ellipj`` only sees m rounded to double, which near m = 1 (the separatrix) throws
    away the digits of 1 − m that the functions depend on: for 1 − m ≈ 1e-17 and w ≈ K/2,
    ``sn`` is off by ~1e-9. The descending Landen transformation (Abramowitz & Stegun
    16.12.2–4) maps m to μ with ``1 − μ ≈ 4 (1 − m)^(1/2)``, computed from mc without
    cancellation; after a few steps 1 − μ > 1e-2 and ``ellipj`` is accurate to round-off.
    """
    if mc >= 1e-2:
        sn, cn, dn, _ = ellipj(w, m)
        return sn, cn, dn
    kp = np.sqrt(mc)
    r = (1.0 - kp) / (1.0 + kp)  # √μ
    one_minus_r = 2.0 * kp / (1.0 + kp)
    sn, cn, dn = _ellipj_mc(w / (1.0 + r), r * r, one_minus_r * (1.0 + r))
    den = 1.0 + r * sn * sn
    # dn's numerator 1 − √μ sn² written as (1 − √μ) + √μ cn²: no cancellation when dn is small.
    return (1.0 + r) * sn / den, cn * dn / den, (one_minus_r + r * cn * cn) / den


def _jacobi_reduced(u: np.ndarray, m: float, mc: float, K: float):
    """sn, cn, dn of ``v = u − 2Kj`` (|v| ≤ K) and the integer ``j``; ``sn(u) = (−1)^j sn(v)``.

    u: (...) elliptic argument; m = k²; mc = 1 − m, accurate to full relative precision;
    K = K(m) from mc. SciPy's ``ellipj`` loses accuracy for large |u| (error grows with |u|),
    and for ``m > 1 − 1e-9`` it switches to a first-order expansion that is only valid for
    small |u| (errors of 1e5 at u = 40, m = 1 − 1e-11). Reducing to |w| ≤ K/2 with the
    quarter-period identities and evaluating there with :func:`_ellipj_mc` keeps all three
    functions within a few 1e-15 (dn also relatively) for 1 − m from 1 down to 1e-40, at
    |u| ≤ 3K (checked against mpmath).
    """
    kp = np.sqrt(mc)
    j = np.round(u / (2.0 * K))
    v = u - 2.0 * K * j
    far = np.abs(v) > 0.5 * K
    sg = np.where(v < 0.0, -1.0, 1.0)
    w = np.where(far, v - sg * K, v)
    sn, cn, dn = _ellipj_mc(w, m, mc)
    # sn(w ± K) = ±cd(w), cn(w ± K) = ∓k' sd(w), dn(w ± K) = k' nd(w)
    sn_far = sg * cn / dn
    cn_far = -sg * kp * sn / dn
    dn_far = kp / dn
    return (
        np.where(far, sn_far, sn),
        np.where(far, cn_far, cn),
        np.where(far, dn_far, dn),
        j,
    )


def _elliptic_phase(sn0: float, cn0: float, mc: float, K: float) -> float:
    """Argument ``u0`` in (−2K, 2K] with ``sn(u0|m) = sn0``, ``cn(u0|m) = cn0``; mc = 1 − m.

    Carlson's form ``F(φ|m) = sin φ · R_F(cos²φ, 1 − m sin²φ, 1)`` with ``1 − m sin²φ`` written
    as ``cos²φ + mc sin²φ`` stays accurate near the separatrix (m → 1), where ``ellipkinc`` of
    an angle near π/2 with m rounded to double loses digits. sn0² + cn0² = 1.
    """
    c2 = cn0 * cn0
    f = sn0 * float(elliprf(c2, c2 + mc * sn0 * sn0, 1.0))
    if cn0 >= 0.0:
        return f
    return (1.0 if sn0 >= 0.0 else -1.0) * 2.0 * K - f


def _cumsum_compensated(vals: np.ndarray) -> np.ndarray:
    """Prefix sums ``[0, v0, v0 + v1, ...]`` (n + 1,) with Neumaier compensation.

    The precession angle adds the one-period total once per period, so its rounding error
    multiplies with time; compensation keeps it at one rounding per prefix.
    """
    out = np.empty(vals.size + 1)
    out[0] = total = comp = 0.0
    for i, v in enumerate(vals.tolist(), start=1):
        t = total + v
        comp += (total - t) + v if abs(total) >= abs(v) else (v - t) + total
        total = t
        out[i] = total + comp
    return out


# --------------------------------------------------------------------------------------------
# exact torque-free asymmetric body
# --------------------------------------------------------------------------------------------


class TorqueFreeSolution:
    """Exact torque-free motion of an asymmetric rigid body (three distinct principal moments).

    Angular velocity by Jacobi elliptic functions (rigid-body-physics.md §2.2), attitude by the
    z-x-z Euler-angle method of §2.3 option A: ``L_W`` is fixed, the nutation and spin angles
    follow from ``m_B(t)`` in closed form, the precession angle is one quadrature of a smooth
    periodic rate (composite 16-point Gauss–Legendre over one period, then periodicity). The
    moments are sorted internally by a right-handed relabelling (a signed permutation with
    det +1) and results are mapped back, so any axis order works.

    moments: (3,) principal moments, kg·m², body axes = principal axes, any order, distinct.
    omega_B0: (3,) body rates at t = 0, rad/s. q0: (4,) unit body→world quaternion at t = 0.
    Methods take times t (...) in s, any real value (negative = backwards in time).

    Accuracy, measured against a 24-digit mpmath Taylor solution for I = (5, 10, 13) and the
    three ω_B0 of the §2.2 table, q0 = N(0.9, 0.1, −0.3, 0.2): |Δω_B| ≤ 2e-14 rad/s and
    attitude ≤ 4e-14 rad up to t = 100 s; the same near the separatrix (ω_B0 = (1e-4, 2, 1e-4),
    1 − k² = 1.9e-9). Caveats: (1) on and very near the separatrix the motion itself is
    ill-conditioned: 1 − k² ∝ Δ2 may come from a cancellation, and an input that is exactly on
    the separatrix only up to rounding leaves it after ~ln(1/ε)/|λ| s; against the 24-digit
    solution of the rounded input the separatrix formula is within 1e-13 up to t = 10 s.
    (2) For nearly symmetric bodies (relative gap δ between two moments) the spin angle
    changes on an elliptic-argument scale √δ and the attitude error grows to ~1e-16/√δ rad
    (3e-11 at δ = 1e-10); below δ = 1e-12 :func:`torque_free` uses :func:`symmetric_top`.

    Attributes (constants of the motion):
        energy (J), momentum_W ((3,), kg·m²/s, world), G = |L| (kg·m²/s);
        case: "minor" (circulation about the minor axis, Δ2 < 0), "major" (about the major
        axis, Δ2 > 0), "separatrix" (Δ2 = 0 within round-off; includes a steady spin about
        the intermediate axis) or "rest" (ω = 0);
        k2: elliptic parameter m = k² (0 for a spin exactly about the minor/major axis, 1 on
        the separatrix); lam: elliptic rate |λ| (1/s);
        period: period of ω_B(t), 4K/|λ| (s); flip_interval: time between sign changes of the
        intermediate-axis component of ω_B (the Dzhanibekov flip), 2K/|λ| (s). Both are inf on
        the separatrix and at rest; for an exact steady spin about the minor/major axis they
        are the small-amplitude values although nothing oscillates.
    """

    def __init__(self, moments, omega_B0, q0):
        moments = _moments(moments)
        gaps = np.abs(moments[:, None] - moments[None, :])[np.triu_indices(3, 1)]
        if gaps.min() <= _EQUAL_RTOL * moments.max():
            raise InvalidParameterError(
                f"moments must be three distinct values for TorqueFreeSolution, got "
                f"{describe(moments)}; use symmetric_top() or torque_free() for a symmetric or "
                "isotropic body"
            )
        self.moments = moments
        self.omega_B0 = _vector("omega_B0", omega_B0, 3)
        self.q0 = _unit_quaternion("q0", q0)
        L_B0 = moments * self.omega_B0
        self.energy = 0.5 * float(L_B0 @ self.omega_B0)
        self.momentum_W = quat.rotate(self.q0, L_B0)
        self.G = float(np.sqrt(L_B0 @ L_B0))

        I, S = _relabel(moments)
        self._I = I
        self._S = S
        m = S @ L_B0
        self._m0 = m
        I1, I2, I3 = I
        m1, m2, m3 = m
        # Δ_i = G² − 2T I_i written as sums of non-negative terms: no cancellation.
        d1 = m2 * m2 * (I2 - I1) / I2 + m3 * m3 * (I3 - I1) / I3  # Δ1 ≥ 0
        d3n = m1 * m1 * (I3 - I1) / I1 + m2 * m2 * (I3 - I2) / I2  # −Δ3 ≥ 0
        t2a = m1 * m1 * (I2 - I1) / I1
        t2b = m3 * m3 * (I3 - I2) / I3
        d2 = t2b - t2a  # Δ2
        self._steady = np.count_nonzero(m) <= 1
        self.period = np.inf
        self.flip_interval = np.inf

        if self.G == 0.0:
            self.case, self.k2, self.lam, self._kind = "rest", 0.0, 0.0, "steady"
            return

        if abs(d2) <= 8.0 * _EPS * (t2a + t2b):
            # Δ2 is zero to round-off (its sign is noise): the separatrix solution.
            self.case, self.k2 = "separatrix", 1.0
            self._setup_separatrix(d1, d3n)
            return

        # k² and its complement 1 − k², each from its own cancellation-free formula, using
        # (I3 − I2)Δ1 + (I2 − I1)Δ3 = (I3 − I1)Δ2. Near the separatrix K, the argument
        # reduction and u0 need 1 − k² to full relative precision, which 1 − k2 would not give.
        if d2 > 0.0:
            k2 = (I2 - I1) * d3n / ((I3 - I2) * d1)
            mc = (I3 - I1) * d2 / ((I3 - I2) * d1)
        else:
            k2 = (I3 - I2) * d1 / ((I2 - I1) * d3n)
            mc = (I3 - I1) * -d2 / ((I2 - I1) * d3n)
        self.k2 = float(min(k2, 1.0))
        self._mc = float(mc)
        self._K = float(ellipkm1(self._mc))
        if d2 > 0.0:
            # Case (ii): circulation about the major axis e3. m = (B13 cn, B23 sn, s3 B31 dn).
            self.case = "major"
            lam = np.sqrt(d1 * (I3 - I2) / (I1 * I2 * I3))
            s3 = 1.0 if m3 > 0.0 else -1.0
            self._lam_s = s3 * lam  # sign from Euler's equations with the amplitudes' signs
            self._amp = np.array([np.sqrt(I1 * d3n / (I3 - I1)), np.sqrt(I2 * d3n / (I3 - I2)),
                                  s3 * np.sqrt(I3 * d1 / (I3 - I1))])
            # (p1, p2) = (B13 cn, B23 sn): ρ = (B13/B23)², a function of the moments only.
            self._rho = I1 * (I3 - I2) / (I2 * (I3 - I1))
            self._Ja = I1
            a, b = m1, m2
            ratio = np.sqrt(self._rho)
        else:
            # Case (i): circulation about the minor axis e1. m = (s1 B13 dn, B21 sn, B31 cn).
            self.case = "minor"
            lam = np.sqrt(d3n * (I2 - I1) / (I1 * I2 * I3))
            s1 = 1.0 if m1 > 0.0 else -1.0
            self._lam_s = s1 * lam
            self._amp = np.array([s1 * np.sqrt(I1 * d3n / (I3 - I1)),
                                  np.sqrt(I2 * d1 / (I2 - I1)), np.sqrt(I3 * d1 / (I3 - I1))])
            # (p1, p2) = (B21 sn, B31 cn): ρ = (B31/B21)².
            self._rho = I3 * (I2 - I1) / (I2 * (I3 - I1))
            self._Ja = I3
            a, b = m3, m2
            ratio = np.sqrt(self._rho)
        self.lam = float(lam)
        self.period = 4.0 * self._K / self.lam
        self.flip_interval = 2.0 * self._K / self.lam
        self._kind = "elliptic"
        if self._steady:  # spin about a principal axis: ω_B constant, q = q0 ⊗ qexp(t ω_B)
            return
        # cn0 ∝ a/B_cn, sn0 ∝ b/B_sn; the ratio of the two amplitudes is ρ^(1/2) (case ii:
        # B13/B23, case i: B31/B21), so (cn0, sn0) ∝ (a, ρ^(1/2) b) after normalisation.
        cn0, sn0 = a, ratio * b
        r = np.hypot(cn0, sn0)
        self._u0 = _elliptic_phase(sn0 / r, cn0 / r, self._mc, self._K)
        self._setup_quadrature()
        self._setup_orientation()

    # ---- separatrix ---------------------------------------------------------------------

    def _setup_separatrix(self, d1: float, d3n: float) -> None:
        """m = (s1 B13 sech u, G tanh u, s3 B31 sech u), u = λ2 t + u0 (case (iii) of §2.2)."""
        I1, _, I3 = self._I
        m1, m2, m3 = self._m0
        G = self.G
        self._kind = "separatrix"
        self.lam = float(np.sqrt(d1 * d3n / (I1 * I3)) / G)
        if self._steady:  # spin about a principal axis: ω_B constant, q = q0 ⊗ qexp(t ω_B)
            return
        # A zero component (possible only when 1 − k² rounds away) takes the sign it is about
        # to acquire, from Euler's equations at t = 0.
        s1 = np.sign(m1) if m1 != 0.0 else -np.sign(m2 * m3) or 1.0
        s3 = np.sign(m3) if m3 != 0.0 else -np.sign(m1 * m2) or 1.0
        self._amp = np.array([s1 * np.sqrt(I1 * d3n / (I3 - I1)), G,
                              s3 * np.sqrt(I3 * d1 / (I3 - I1))])
        self._lam_s = float(s1 * s3 * self.lam)
        # u0 = atanh(m2/G) with G − |m2| = (m1² + m3²)/(G + |m2|): accurate near the saddle.
        self._u0 = float(np.sign(m2) * np.log((G + abs(m2)) / np.hypot(m1, m3)))
        self._rho = None
        self._setup_orientation()

    # ---- ω(t) ---------------------------------------------------------------------------

    def _momentum_sorted(self, t: np.ndarray):
        """m in the sorted frame (..., 3) plus the helpers the attitude needs."""
        if self._steady:
            return np.broadcast_to(self._m0, (*t.shape, 3)).copy(), None
        u = self._u0 + self._lam_s * t
        if self._kind == "separatrix":
            e = np.exp(-np.abs(u))
            sech = 2.0 * e / (1.0 + e * e)  # 1/cosh(u) without overflow
            m = np.stack((self._amp[0] * sech, self._amp[1] * np.tanh(u), self._amp[2] * sech),
                         axis=-1)
            return m, u
        sn_v, cn_v, dn, j = _jacobi_reduced(u, self.k2, self._mc, self._K)
        sgn = np.where(j % 2 == 0, 1.0, -1.0)
        sn, cn = sgn * sn_v, sgn * cn_v
        if self.case == "major":
            m = np.stack((self._amp[0] * cn, self._amp[1] * sn, self._amp[2] * dn), axis=-1)
        else:
            m = np.stack((self._amp[0] * dn, self._amp[1] * sn, self._amp[2] * cn), axis=-1)
        return m, (u, sn_v, cn_v, dn, j)

    def momentum_B(self, t) -> np.ndarray:
        """Body angular momentum ``I ω_B`` at times t (..., s). Returns (..., 3), kg·m²/s, body."""
        t = _times(t)
        m, _ = self._momentum_sorted(t)
        return m @ self._S  # Sᵀ m, batched

    def omega_B(self, t) -> np.ndarray:
        """Body angular velocity at times t (..., s), Jacobi closed form. Returns (..., 3) rad/s."""
        if self._steady:  # exactly ω_B0, not I⁻¹(I ω_B0) with its rounding
            return np.broadcast_to(self.omega_B0, (*_times(t).shape, 3)).copy()
        return self.momentum_B(t) / self.moments

    # ---- attitude -----------------------------------------------------------------------

    def _g(self, u: np.ndarray) -> np.ndarray:
        """Precession rate minus its constant part, ``φ̇ − G/I2``, at elliptic argument u (...).

        ``φ̇ = G (p1²/J1 + p2²/J2)/(p1² + p2²)``; with ``(p1², p2²) ∝ (ρ cn², sn²)`` (the
        amplitude ratio folded into ρ) this is ``G/I2 + G (1/Ja − 1/I2) ρ cn²/(ρ cn² + sn²)``.
        The constant part is integrated exactly; the rest has one sign and period 2K in u.
        """
        sn_v, cn_v, _, _ = _jacobi_reduced(u, self.k2, self._mc, self._K)
        rc2 = self._rho * cn_v * cn_v
        return self._g_scale * rc2 / (rc2 + sn_v * sn_v)

    def _setup_quadrature(self) -> None:
        """Cumulative integral of φ̇ − G/I2 over one period 2K of u, Gauss–Legendre panels."""
        P = 2.0 * self._K
        self._g_scale = self.G * (1.0 / self._Ja - 1.0 / self._I[1])
        # φ̇(u) has poles at u = ±i·a (mod 2K), a = F(asin √ρ | 1 − k²) (where ρ cn² + sn² = 0).
        # Panels no wider than their distance to a pole converge to round-off with 16 nodes:
        # uniform panels of width min(a, 1), graded geometrically towards u = 0 and u = 2K when
        # a is small (ρ → 0: I2 close to I1 or I3, where φ̇ has a spike of width a).
        a = float(ellipkinc(np.arcsin(np.sqrt(self._rho)), self._mc))
        h = min(1.0, P / 8.0)
        if a >= 0.5 * h:
            edges = np.linspace(0.0, P, int(np.ceil(P / min(a, h))) + 1)
        else:
            graded = a * 2.0 ** np.arange(0, int(np.log2(h / a)) + 1)  # a, 2a, ..., < h·2
            inner = np.linspace(graded[-1], P - graded[-1],
                                max(2, int(np.ceil((P - 2.0 * graded[-1]) / h)) + 1))
            edges = np.concatenate(([0.0], graded[:-1], inner, P - graded[-2::-1], [P]))
        vals = self._panels(edges)
        while edges.size <= _MAX_PANELS:
            finer = np.sort(np.concatenate((edges, 0.5 * (edges[1:] + edges[:-1]))))
            vals2 = self._panels(finer)
            total, total2 = math.fsum(vals), math.fsum(vals2)
            edges, vals = finer, vals2
            if abs(total2 - total) <= 1e-14 * abs(total2):  # geometric: total2 is far better
                break
        self._P, self._edges = P, edges
        self._cum = _cumsum_compensated(vals)

    def _panels(self, edges: np.ndarray) -> np.ndarray:
        """Integrals of φ̇ − G/I2 over the panels between ``edges`` (n + 1,). Returns (n,)."""
        a, width = edges[:-1], np.diff(edges)
        nodes = a[:, None] + 0.5 * width[:, None] * (_GL_X + 1.0)
        return self._g(nodes) @ _GL_W * (0.5 * width)

    def _F(self, u: np.ndarray) -> np.ndarray:
        """Antiderivative ∫₀ᵘ φ̇ ds of the precession rate in the elliptic argument u (...)."""
        I1, I2, _ = self._I
        if self._kind == "separatrix":
            b13, b31 = abs(self._amp[0]), abs(self._amp[2])
            # φ̇ = G/I2 + G(1/I1 − 1/I2) B13² sech² u / (B13² + B31² tanh² u): closed form.
            return self.G * (u / I2 + (1.0 / I1 - 1.0 / I2) * (b13 / b31)
                             * np.arctan((b31 / b13) * np.tanh(u)))
        P, edges = self._P, self._edges
        k = np.floor(u / P)
        r = u - k * P
        j = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, edges.size - 2)
        a = edges[j]
        d = r - a
        nodes = a[..., None] + d[..., None] * (0.5 * (_GL_X + 1.0))
        part = (self._g(nodes) @ _GL_W) * (0.5 * d)
        return self.G * u / I2 + k * self._cum[-1] + self._cum[j] + part

    def _angles(self, m: np.ndarray, aux) -> tuple[np.ndarray, np.ndarray]:
        """Nutation θ and spin ψ (continuous in t) of the z-x-z decomposition, polar axis p3."""
        if self._kind == "separatrix":
            p1, p2, p3 = m[..., 0], m[..., 1], m[..., 2]
            return np.arctan2(np.hypot(p1, p2), p3), np.arctan2(p1, p2)
        _, sn_v, cn_v, _, j = aux
        chi = np.arctan2(sn_v, np.sqrt(self._rho) * cn_v) + np.pi * j
        if self.case == "major":
            p1, p2, p3 = m[..., 0], m[..., 1], m[..., 2]
            psi = 0.5 * np.pi - chi  # atan2(B13 cn, B23 sn), unwrapped
        else:
            p1, p2, p3 = m[..., 1], m[..., 2], m[..., 0]
            psi = chi  # atan2(B21 sn, B31 cn), unwrapped
        return np.arctan2(np.hypot(p1, p2), p3), psi

    def _setup_orientation(self) -> None:
        # Euler frame E: its z axis is the polar axis (e3 in case ii / separatrix, e1 in case
        # i with the cyclic relabelling p = (m2, m3, m1)). q = q_C ⊗ Rz(φ) Rx(θ) Rz(ψ) ⊗ q_tail.
        if self.case == "minor":
            Pc = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
        else:
            Pc = np.eye(3)
        self._q_tail = quat.multiply(quat.from_matrix(Pc), quat.from_matrix(self._S))
        m0, aux0 = self._momentum_sorted(np.zeros(()))
        theta0, psi0 = self._angles(m0, aux0)
        q = quat.multiply(self.q0, quat.conjugate(self._q_tail))
        q = quat.multiply(q, _axis_quat(2, -psi0))
        self._q_C = quat.multiply(q, _axis_quat(0, -theta0))
        self._F0 = self._F(np.asarray(self._u0))

    def orientation(self, t) -> np.ndarray:
        """Exact attitude at times t (..., s): unit body→world quaternion (..., 4), continuous in t.

        ``q(0) = q0``; the sign is not canonicalised (w may be negative) so that q(t) is smooth.
        """
        t = _times(t)
        if self._steady:
            return quat.multiply(self.q0, quat.from_rotation_vector(t[..., None] * self.omega_B0))
        m, aux = self._momentum_sorted(t)
        theta, psi = self._angles(m, aux)
        u = aux if self._kind == "separatrix" else aux[0]
        phi = (self._F(u) - self._F0) / self._lam_s
        q = quat.multiply(self._q_C, _axis_quat(2, phi))
        q = quat.multiply(q, _axis_quat(0, theta))
        q = quat.multiply(q, _axis_quat(2, psi))
        return quat.multiply(q, self._q_tail)

    def state(self, t) -> tuple[np.ndarray, np.ndarray]:
        """``(orientation(t), omega_B(t))``: (..., 4) body→world and (..., 3) rad/s body."""
        return self.orientation(t), self.omega_B(t)

    # ---- flips --------------------------------------------------------------------------

    def flip_times(self, t_end: float) -> np.ndarray:
        """Times in (0, t_end] (s) at which the intermediate-axis component of ω_B changes sign.

        Elliptic cases: zeros of sn(λt + u0), spaced by :attr:`flip_interval`. Separatrix: at most
        one. Returns (n,) sorted; empty for steady spins and rest.
        """
        if self._steady:
            return np.empty(0)
        lam, u0 = self._lam_s, self._u0
        if self._kind == "separatrix":
            t0 = -u0 / lam
            return np.array([t0]) if 0.0 < t0 <= t_end else np.empty(0)
        u_end = u0 + lam * t_end
        lo, hi = sorted((u0, u_end))
        j = np.arange(np.ceil(lo / (2.0 * self._K)), np.floor(hi / (2.0 * self._K)) + 1.0)
        times = np.sort((2.0 * self._K * j - u0) / lam)
        return times[(times > 0.0) & (times <= t_end)]


# --------------------------------------------------------------------------------------------
# symmetric and isotropic bodies, dispatcher
# --------------------------------------------------------------------------------------------


def _symmetry_axis(moments: np.ndarray) -> int | None:
    """Index of the odd principal axis of a symmetric body, -1 if isotropic, None if asymmetric."""
    tol = _EQUAL_RTOL * moments.max()
    eq = [abs(moments[(i + 1) % 3] - moments[(i + 2) % 3]) <= tol for i in range(3)]
    if sum(eq) >= 2:
        return -1
    if sum(eq) == 1:
        return eq.index(True)
    return None


def symmetric_top(moments, omega_B0, q0, t) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form torque-free motion of an axially symmetric (or isotropic) body (§2.5).

    moments: ``(I_perp, I_par)`` with the symmetry axis along body z, or (3,) principal moments
    of which two are equal (rel. tol 1e-12; their mean is used), kg·m². omega_B0: (3,) rad/s,
    body. q0: (4,) unit body→world. t: (...) s.
    Returns ``q`` (..., 4) body→world and ``omega_B`` (..., 3) rad/s, body:
    ``q(t) = qexp(t L_W/I⊥) ⊗ q0 ⊗ qexp(s t e_a)``, ``s = (I⊥ − I∥)/I⊥ · ω_a0``, and ω_B rotates
    about the symmetry axis e_a by −s t.
    """
    arr = finite_array("moments", moments)
    if arr.shape == (2,):
        arr = np.array([arr[0], arr[0], arr[1]])
    moments = _moments(arr)
    axis = _symmetry_axis(moments)
    if axis is None:
        raise InvalidParameterError(
            f"moments must have two equal values for symmetric_top (rel. tol {_EQUAL_RTOL:g}), "
            f"got {describe(moments)}; use TorqueFreeSolution for an asymmetric body"
        )
    omega_B0 = _vector("omega_B0", omega_B0, 3)
    q0 = _unit_quaternion("q0", q0)
    t = _times(t)
    if axis == -1:
        axis, i_perp, i_par = 2, moments.mean(), moments.mean()
    else:
        i_par = moments[axis]
        i_perp = 0.5 * (moments[(axis + 1) % 3] + moments[(axis + 2) % 3])
    L_B = omega_B0 * i_perp
    L_B[axis] = i_par * omega_B0[axis]
    L_W = quat.rotate(q0, L_B)
    s = (i_perp - i_par) / i_perp * omega_B0[axis]
    e = np.zeros(3)
    e[axis] = 1.0
    spin = quat.from_rotation_vector((s * t)[..., None] * e)
    q = quat.multiply(quat.from_rotation_vector(t[..., None] * (L_W / i_perp)), q0)
    q = quat.multiply(q, spin)
    # ω_B(t) = Rz(−s t) ω_B0 about e_a, i.e. the inverse of the spin rotation.
    omega = quat.rotate_inverse(spin, np.broadcast_to(omega_B0, (*t.shape, 3)))
    return q, omega


def torque_free(moments, omega_B0, q0, t) -> tuple[np.ndarray, np.ndarray]:
    """Exact torque-free motion of any valid body: dispatch to the right closed form.

    moments: (3,) principal moments, kg·m², body axes. omega_B0: (3,) rad/s, body. q0: (4,) unit
    body→world. t: (...) s. Returns ``q`` (..., 4) body→world and ``omega_B`` (..., 3) rad/s, body.
    Isotropic: ``ω`` constant, ``q = qexp(t ω_W) ⊗ q0``; two equal moments (rel. tol 1e-12):
    :func:`symmetric_top`; otherwise :class:`TorqueFreeSolution`.
    """
    moments = _moments(moments)
    if _symmetry_axis(moments) is not None:
        return symmetric_top(moments, omega_B0, q0, t)
    return TorqueFreeSolution(moments, omega_B0, q0).state(t)


def constant_torque_about_axis(
    moments, axis: int, torque: float, t, q0=None
) -> tuple[np.ndarray, np.ndarray]:
    """Motion from rest under a constant torque about principal body axis ``axis`` (0, 1, 2).

    moments: (3,) kg·m². torque: N·m about body axis ``axis`` (also fixed in the world, since the
    body turns about it). t: (...) s. q0: (4,) unit body→world, default identity.
    Returns ``q`` (..., 4) body→world (angle ½ α t², α = torque/I_axis) and ``omega_B`` (..., 3)
    rad/s (α t along the axis). Gyroscopic terms vanish because ω stays along a principal axis.
    """
    moments = _moments(moments)
    if axis not in (0, 1, 2):
        raise InvalidParameterError(f"axis must be 0, 1 or 2, got {axis!r}")
    q0 = quat.identity() if q0 is None else _unit_quaternion("q0", q0)
    t = _times(t)
    alpha = float(torque) / moments[axis]
    omega = np.zeros((*t.shape, 3))
    omega[..., axis] = alpha * t
    return quat.multiply(q0, _axis_quat(axis, 0.5 * alpha * t * t)), omega


# --------------------------------------------------------------------------------------------
# tight numerical reference for torque-driven motion
# --------------------------------------------------------------------------------------------


def _torque_fn(name: str, spec) -> Callable[[float], np.ndarray] | None:
    if spec is None:
        return None
    if callable(spec):
        def fn(t: float) -> np.ndarray:
            return _vector(f"{name}({t})", spec(t), 3)
        return fn
    const = _vector(name, spec, 3)
    return lambda t: const


def solve_ivp_reference(
    moments,
    omega_B0,
    q0,
    t_eval,
    torque_B=None,
    torque_W=None,
    rtol: float = 1e-13,
    atol: float = 1e-13,
    breakpoints: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Tight DOP853 solution of Euler's equations and ``q̇ = ½ q ⊗ (0, ω_B)`` from t = 0.

    moments: (3,) principal moments or a (3, 3) inertia tensor, kg·m², body axes.
    omega_B0: (3,) rad/s, body. q0: (4,) unit body→world. t_eval: (...) times ≥ 0, s, any order.
    torque_B / torque_W: N·m in the body / world frame; None, a constant (3,) or a callable
    ``t -> (3,)`` (both may be given; they add). For torque with jumps (piecewise constant)
    pass the jump times as ``breakpoints`` (s): the integration restarts there so the
    tolerance is met across the discontinuity.
    Returns ``q`` (..., 4) body→world, renormalised, and ``omega_B`` (..., 3) rad/s, body.
    """
    arr = finite_array("moments", moments)
    if arr.shape == (3,):
        inertia = np.diag(_moments(arr))
    else:
        inertia = _validate_inertia(arr, name="moments")
    inv_inertia = np.linalg.inv(inertia)
    omega_B0 = _vector("omega_B0", omega_B0, 3)
    q0 = _unit_quaternion("q0", q0)
    t_eval = _times(t_eval)
    if np.any(t_eval < 0.0):
        raise InvalidParameterError(f"t_eval must be >= 0 (integration starts at t = 0), got "
                                    f"{describe(t_eval)}")
    tau_B = _torque_fn("torque_B", torque_B)
    tau_W = _torque_fn("torque_W", torque_W)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, w = y[:4], y[4:]
        tau = np.zeros(3)
        if tau_B is not None:
            tau = tau + tau_B(t)
        if tau_W is not None:
            qn = q / np.sqrt(q @ q)
            tau = tau + quat.rotate_inverse(qn, tau_W(t))
        w_dot = inv_inertia @ (tau - cross(w, inertia @ w))
        q_dot = 0.5 * quat.multiply(q, np.array([0.0, w[0], w[1], w[2]]))
        return np.concatenate((q_dot, w_dot))

    ts, inverse = np.unique(t_eval.ravel(), return_inverse=True)
    out = np.empty((ts.size, 7))
    y = np.concatenate((q0, omega_B0))
    t_end = float(ts[-1]) if ts.size else 0.0
    cuts = sorted({float(b) for b in (breakpoints or ()) if 0.0 < float(b) < t_end})
    edges = [0.0, *cuts, t_end]
    done = np.zeros(ts.size, dtype=bool)
    for a, b in pairwise(edges):
        sel = ~done & (ts <= b)
        if b == a:
            out[sel] = y
            done |= sel
            continue
        t_out = ts[sel]
        extra = t_out.size == 0 or t_out[-1] != b  # also evaluate at b to carry the state on
        if extra:
            t_out = np.append(t_out, b)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", t_eval=t_out, rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(f"solve_ivp_reference failed on [{a}, {b}] s: {sol.message}")
        out[sel] = sol.y[:, : sol.y.shape[1] - extra].T
        y = sol.y[:, -1]
        done |= sel
    if ts.size and not done.all():
        out[~done] = y
    out = out[inverse].reshape(*t_eval.shape, 7)
    return quat.normalize(out[..., :4]), out[..., 4:]

