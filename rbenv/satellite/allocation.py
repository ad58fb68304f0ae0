"""Thruster allocation: turn a body torque demand into thruster throttles in [0, 1].

A layout of n thrusters is described by its torque matrix ``B`` (3, n), N·m: column ``i`` is the
body torque ``r_i × F_i`` of thruster ``i`` about the centre of mass at full throttle
(:attr:`rbenv.core.ThrusterLayout.torque_matrix_B`). Translation is ignored here. For a demand
``tau_B`` (..., 3) N·m an allocator returns throttles ``u`` (..., n) in [0, 1] with
``B @ u == tau_B`` whenever that is achievable. The three allocators differ in which solution
they pick and in what they do when the demand exceeds the layout's authority (saturation):

======================  ==============================  =======================================
allocator               feasible demand                 saturated demand
======================  ==============================  =======================================
PseudoInverseAllocator  ``B⁺τ`` + null-space shift      uniform scale-down: torque ∥ demand,
                        (not fuel-optimal)              often below the true authority
NNLSAllocator           Lawson–Hanson NNLS, bounded     closest achievable torque
                        LS if NNLS exceeds the bound    ``argmin ‖Bu − τ‖``: direction may change
MinFuelLPAllocator      minimum ``Σu`` (HiGHS LP, with  largest ``s·τ`` (s ≤ 1) the layout can
                        a vectorised exact fast path)   give, then minimum fuel at that ``s``
======================  ==============================  =======================================

Per-call cost on one core (12-thruster test layout, scipy 1.17, ``timeit``; the machines are
shared, so read ratios, not absolute numbers):

=======  ===================  =====================  ========================================
name     1 demand             1024 feasible          1024 saturated
=======  ===================  =====================  ========================================
pinv     ≈ 15 µs              ≈ 0.15 ms              ≈ 0.2 ms
nnls     ≈ 20 µs              ≈ 15 ms (loop)         ≈ 0.1 s (bounded LS per demand)
lp       ≈ 25 µs; ≈ 1.6 ms    ≈ 1 ms (fast path)     ≈ 1.7 s (one HiGHS LP per demand)
         saturated
=======  ===================  =====================  ========================================

So a controller that saturates every step on thousands of satellites (bang-bang) wants pinv;
on that layout it reaches ≈ 91–94 % of the authority along the demand and uses ≈ 1.8× the
LP's fuel for feasible demands, where NNLS is within ≈ 1 % of the LP's fuel.

Every layout is validated once, at construction: finite, shape (3, n), and able to produce
torque along each of ±x, ±y, ±z with non-negative throttles (which is equivalent to the columns
positively spanning R³, i.e. rank 3 and a strictly positive null-space vector).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from scipy.optimize import linprog, lsq_linear, nnls

from rbenv.core import validation as check
from rbenv.core.backend import matmul
from rbenv.core.errors import InvalidParameterError, describe

__all__ = [
    "ALLOCATORS",
    "Allocator",
    "MinFuelLPAllocator",
    "NNLSAllocator",
    "PseudoInverseAllocator",
    "axis_authority",
    "make_allocator",
    "max_torque_along",
    "validate_torque_matrix",
]

_AXES = (
    ("+x", 0, 1.0),
    ("-x", 0, -1.0),
    ("+y", 1, 1.0),
    ("-y", 1, -1.0),
    ("+z", 2, 1.0),
    ("-z", 2, -1.0),
)
# Relative NNLS residual above which a unit direction counts as outside the thrust cone.
_CONE_TOL = 1e-9
# Throttle slack (dimensionless) accepted as rounding before clipping to the bounds.
_THROTTLE_TOL = 1e-12
# Largest layout for which the LP fast path enumerates all C(n, 3) thruster triples.
_FAST_PATH_MAX_THRUSTERS = 64
# Fast-path working set, in float64 entries per chunk of the batch.
_FAST_PATH_CHUNK = 1 << 21


@runtime_checkable
class Allocator(Protocol):
    """Maps a body torque demand to thruster throttles.

    torque_matrix: (3, n) N·m per unit throttle. ``__call__(tau_B)``: tau_B (..., 3) N·m →
    throttles (..., n) in [0, 1].
    """

    torque_matrix: np.ndarray

    def __call__(self, tau_B) -> np.ndarray: ...


def _as_torque_matrix(torque_matrix, name: str = "torque_matrix") -> np.ndarray:
    """Finite float copy of a (3, n) torque matrix with n ≥ 1, else ``InvalidParameterError``."""
    B = check.finite_array(name, torque_matrix)
    if B.ndim != 2 or B.shape[0] != 3 or B.shape[1] == 0:
        raise InvalidParameterError(
            f"{name} must have shape (3, n) with n >= 1 thrusters, got {B.shape}"
        )
    return np.array(B, dtype=float)


def _scale(B: np.ndarray, name: str = "torque_matrix") -> float:
    """Largest column norm of ``B`` in N·m, used to make the LPs and NNLS dimensionless."""
    s = float(np.linalg.norm(B, axis=0).max())
    if s == 0.0:
        raise InvalidParameterError(
            f"{name} must have a non-zero column, got all zeros: the layout produces no torque "
            "at all (every lever arm is parallel to its thrust)"
        )
    if not np.isfinite(s):
        raise InvalidParameterError(f"{name} column norms overflow: rescale the units")
    return s


def validate_torque_matrix(torque_matrix, name: str = "torque_matrix") -> np.ndarray:
    """Check a layout can produce torque in every direction; return it as a read-only array.

    torque_matrix: (3, n) N·m per unit throttle; ``name`` labels it in messages. For each of
    ±x, ±y, ±z, NNLS solves ``min ‖B u − e‖, u ≥ 0`` on B scaled by its largest column; a
    residual above 1e-9 means that direction is unreachable. Raises ``InvalidParameterError``
    (a ``ValueError``) naming each unreachable direction and its best residual. The only
    torque-reach check in rbenv: scenes and allocators both call it.
    """
    B = _as_torque_matrix(torque_matrix, name)
    Bn = B / _scale(B, name)
    missing, residuals = [], []
    for axis_name, axis, sign in _AXES:
        e = np.zeros(3)
        e[axis] = sign
        _, residual = nnls(Bn, e, maxiter=50 * B.shape[1])
        if residual > _CONE_TOL:
            missing.append(axis_name)
            residuals.append(f"{axis_name} {residual:.3g}")
    if missing:
        rank = int(np.linalg.matrix_rank(Bn))
        raise InvalidParameterError(
            f"thruster layout cannot produce torque along {', '.join(missing)}: no non-negative "
            f"throttles on {name} of shape {B.shape} (rank {rank}) give that torque (best "
            f"relative NNLS residual: {'; '.join(residuals)}); every body axis needs thrusters "
            "whose torque r × F points along it, both ways"
        )
    B.setflags(write=False)
    return B


def _as_demand(tau_B) -> tuple[np.ndarray, tuple[int, ...]]:
    """Validate a demand; return it as (N, 3) float plus the batch shape to restore."""
    tau = check.finite_array("tau_B", tau_B)
    if tau.ndim == 0 or tau.shape[-1] != 3:
        raise InvalidParameterError(
            f"tau_B must have shape (3,) or (..., 3) in N·m, got shape {tau.shape}"
        )
    return tau.reshape(-1, 3), tau.shape[:-1]


def _polish(Bn: np.ndarray, u: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Re-solve an LP vertex exactly: fix throttles at their bounds, least-squares the rest.

    HiGHS meets the equality only to its feasibility tolerance (1e-7); this brings
    ``Bn @ u == target`` to rounding without changing the fuel. Bn: (3, n); u: (n,); target:
    (3,), both in units of the largest column norm.
    """
    u = np.clip(u, 0.0, 1.0)
    residual = np.linalg.norm(Bn @ u - target)
    at_zero = u <= 1e-9
    at_one = u >= 1.0 - 1e-9
    free = ~(at_zero | at_one)
    polished = np.where(at_one, 1.0, 0.0)
    if free.any():
        rhs = target - Bn[:, at_one].sum(axis=1)
        polished[free] = np.linalg.lstsq(Bn[:, free], rhs, rcond=None)[0]
    if polished.min() < -1e-9 or polished.max() > 1.0 + 1e-9:
        return u
    polished = np.clip(polished, 0.0, 1.0)
    if np.linalg.norm(Bn @ polished - target) <= residual:
        return polished
    return u


def _max_scale_lp(Bn: np.ndarray, target: np.ndarray, s_max: float | None):
    """Solve max s s.t. Bn u = s·target, u ∈ [0, 1]^n, 0 ≤ s ≤ s_max; return (s, u).

    Bn: (3, n); target: (3,), both in units of the largest column norm.
    """
    n = Bn.shape[1]
    c = np.zeros(n + 1)
    c[-1] = -1.0
    A_eq = np.hstack([Bn, -target[:, None]])
    res = linprog(
        c, A_eq=A_eq, b_eq=np.zeros(3), bounds=[(0.0, 1.0)] * n + [(0.0, s_max)], method="highs"
    )
    if res.status != 0:
        raise RuntimeError(f"HiGHS failed on the authority LP (always feasible): {res.message}")
    s = float(res.x[-1])
    return s, _polish(Bn, res.x[:n], s * target)


def max_torque_along(torque_matrix, direction) -> float:
    """Largest torque magnitude the layout can produce along a direction (LP, HiGHS).

    torque_matrix: (3, n) N·m per unit throttle; direction: (3,), any non-zero length (it is
    normalised). Returns ``max s`` in N·m such that ``B u = s·d̂`` for some ``u ∈ [0, 1]^n``
    (0.0 if the layout cannot torque that way at all). Bang-bang controllers use it as the
    per-axis authority; it is also the magnitude :class:`MinFuelLPAllocator` reaches when it
    saturates. One LP, ≈ 1.5 ms: call it at set-up, not per step.
    """
    B = _as_torque_matrix(torque_matrix)
    d = check.finite_array("direction", direction)
    if d.shape != (3,):
        raise InvalidParameterError(f"direction must have shape (3,), got {d.shape}")
    norm = float(np.linalg.norm(d))
    if norm == 0.0:
        raise InvalidParameterError(f"direction must be non-zero, got {describe(d)}")
    scale = _scale(B)
    s, _ = _max_scale_lp(B / scale, d / norm, None)
    return s * scale


def axis_authority(torque_matrix) -> np.ndarray:
    """Symmetric torque authority about each body axis, (3,) N·m.

    For each axis the weaker of the two directions ``±e_k`` (:func:`max_torque_along`), so a
    demand of that size is achievable both ways. Three pairs of LPs: call at set-up.
    """
    return np.array([min(max_torque_along(torque_matrix, e), max_torque_along(torque_matrix, -e))
                     for e in np.eye(3)])


@dataclass(frozen=True, eq=False)
class _AllocatorBase:
    """Shared validation and batch handling. torque_matrix: (3, n) N·m per unit throttle."""

    torque_matrix: np.ndarray
    _scale: float = field(init=False, repr=False)
    _Bn: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        B = validate_torque_matrix(self.torque_matrix)
        scale = _scale(B)
        Bn = B / scale
        Bn.setflags(write=False)
        object.__setattr__(self, "torque_matrix", B)
        object.__setattr__(self, "_scale", scale)
        object.__setattr__(self, "_Bn", Bn)

    @property
    def n_thrusters(self) -> int:
        """Number of thrusters (columns of the torque matrix)."""
        return self.torque_matrix.shape[1]

    def __call__(self, tau_B) -> np.ndarray:
        """Throttles for a torque demand. tau_B: (..., 3) N·m → (..., n) in [0, 1]."""
        tau, batch = _as_demand(tau_B)
        return self._allocate(tau).reshape(*batch, self.n_thrusters)

    def _allocate(self, tau: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class PseudoInverseAllocator(_AllocatorBase):
    """Minimum-norm pseudo-inverse plus a positive null-space shift; fully vectorised.

    torque_matrix: (3, n) N·m per unit throttle. ``u = B⁺τ + t·v`` where ``v > 0`` spans part of
    the null space (``B v = 0``), chosen once by an LP that maximises its smallest component
    (so lifting the most negative throttle costs the others as little as possible; for a
    layout of opposed couples ``v`` is all-ones, Basilisk's ``F − min(F)``), and ``t ≥ 0`` is
    the smallest shift with ``u ≥ 0``. If then ``max(u) > 1`` the whole vector is divided by
    ``max(u)``: the achieved torque stays **parallel** to the demand with a reduced magnitude,
    which can be below the layout's true authority along that direction (see
    :func:`max_torque_along`). Not fuel-optimal. ≈ 15 µs for one demand, ≈ 0.2 ms for 1024.
    """

    _pinv_T: np.ndarray = field(init=False, repr=False)
    _shift: np.ndarray = field(init=False, repr=False)
    _neg_inv_shift: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        super().__post_init__()
        B, Bn = self.torque_matrix, self._Bn
        n = self.n_thrusters
        # max m s.t. Bn v = 0, m ≤ v_i ≤ 1: the most uniform strictly positive null vector.
        c = np.zeros(n + 1)
        c[-1] = -1.0
        A_ub = np.hstack([-np.eye(n), np.ones((n, 1))])
        A_eq = np.hstack([Bn, np.zeros((3, 1))])
        res = linprog(
            c,
            A_ub=A_ub,
            b_ub=np.zeros(n),
            A_eq=A_eq,
            b_eq=np.zeros(3),
            bounds=[(0.0, 1.0)] * n + [(None, None)],
            method="highs",
        )
        pinv = np.linalg.pinv(B)
        v = None
        if res.status == 0 and res.x[-1] > 1e-6:
            # Project out the LP's equality error so that t·v adds no torque beyond rounding.
            v = res.x[:n] - pinv @ (B @ res.x[:n])
            v = v / v.max()
        if v is None or v.min() <= 1e-9:
            # Unreachable for a validated layout (positive spanning ⇔ a positive null vector
            # exists); kept so a numerically borderline layout fails here, not per call.
            raise InvalidParameterError(
                "torque_matrix has no strictly positive null-space vector, so the pseudo-inverse "
                "cannot be shifted to non-negative throttles; use the 'nnls' or 'lp' allocator"
            )
        for name, arr in (("_pinv_T", pinv.T), ("_shift", v), ("_neg_inv_shift", -1.0 / v)):
            arr = np.ascontiguousarray(arr)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def _allocate(self, tau: np.ndarray) -> np.ndarray:
        u = matmul(tau, self._pinv_T)
        if u.shape[0] == 0:
            return u
        t = (u * self._neg_inv_shift).max(axis=1)
        np.maximum(t, 0.0, out=t)
        u += t[:, None] * self._shift
        peak = u.max(axis=1)
        over = peak > 1.0
        if over.any():
            u[over] /= peak[over, None]
        # Only rounding is clipped here: the shift and scale already put u in [0, 1].
        return np.clip(u, 0.0, 1.0, out=u)


@dataclass(frozen=True, eq=False)
class NNLSAllocator(_AllocatorBase):
    """Non-negative least squares per demand, bounded least squares when NNLS overshoots.

    torque_matrix: (3, n) N·m per unit throttle; max_throttle: upper bound in (0, 1]. Each
    demand first goes to ``scipy.optimize.nnls`` (Lawson–Hanson, min ‖Bu − τ‖ with u ≥ 0: exact
    for every demand of a validated layout). If that needs a throttle above ``max_throttle``,
    ``scipy.optimize.lsq_linear(method="bvls")`` solves min ‖Bu − τ‖ with ``0 ≤ u ≤
    max_throttle``: still exact when some bounded solution exists, and otherwise the **closest
    achievable torque**, whose direction can differ from the demand (use the pinv or lp
    allocator when the torque direction matters, e.g. eigenaxis slews). Neither solution is
    fuel-optimal. Python loop over the batch: ≈ 15 µs per demand, ≈ 0.1 ms more for each that
    needs the bounded solve.
    """

    max_throttle: float = 1.0

    def __post_init__(self):
        super().__post_init__()
        try:
            m = float(self.max_throttle)
        except (TypeError, ValueError) as exc:
            raise InvalidParameterError(
                f"max_throttle must be a number in (0, 1], got {self.max_throttle!r}"
            ) from exc
        if not (0.0 < m <= 1.0):
            raise InvalidParameterError(f"max_throttle must be in (0, 1], got {m!r}")
        object.__setattr__(self, "max_throttle", m)

    def _allocate(self, tau: np.ndarray) -> np.ndarray:
        Bn, m = self._Bn, self.max_throttle
        tn = tau / self._scale
        out = np.empty((tau.shape[0], self.n_thrusters))
        maxiter = 50 * self.n_thrusters
        for k, t in enumerate(tn):
            u, _ = nnls(Bn, t, maxiter=maxiter)
            if u.max(initial=0.0) > m + _THROTTLE_TOL:
                u = lsq_linear(Bn, t, bounds=(0.0, m), method="bvls").x
            out[k] = np.clip(u, 0.0, m)
        return out


@dataclass(frozen=True, eq=False)
class MinFuelLPAllocator(_AllocatorBase):
    """Minimum total throttle ``Σu`` with ``B u = τ``, ``0 ≤ u ≤ 1``; direction-keeping saturation.

    torque_matrix: (3, n) N·m per unit throttle. A saturated demand is solved
    lexicographically: first the largest ``s ∈ [0, 1]`` with ``B u = s·τ`` achievable, then the
    minimum fuel at that ``s`` (two stages rather than one LP with a weight on ``s``, because a
    weight large enough to rank ``s`` first depends on the layout). The achieved torque is
    parallel to the demand with the largest magnitude the layout allows
    (:func:`max_torque_along`).

    Fast paths, exact and vectorised, for layouts of up to 64 thrusters:

    * Feasible demands: a minimum-fuel vertex uses three thrusters ``T`` with ``u_T = B_T⁻¹ τ ≥
      0`` and is optimal whenever its dual ``λ = B_T⁻ᵀ 1`` satisfies ``Bᵀλ ≤ 1``. Construction
      keeps every such triple; a call picks, per demand, the kept triple with ``u_T ≥ 0`` of
      lowest peak throttle and accepts it if that peak is ≤ 1.
    * The saturation scale: the reachable torques form a zonotope whose facet normals are
      cross products of column pairs, so ``s = min h(w) / wᵀτ`` over those normals ``w`` (with
      ``wᵀτ > 0``, ``h(w) = Σ max(0, wᵀb_i)``). This replaces the first LP stage.

    The remaining demands go to HiGHS one by one, ≈ 1.5–2 ms each: a feasible demand whose
    unbounded minimum-fuel solution exceeds a throttle of 1 (one LP), and every saturated
    demand (one LP at the known scale; up to three if HiGHS rejects that boundary LP).
    """

    _triples: np.ndarray = field(init=False, repr=False)
    _triple_inv: np.ndarray = field(init=False, repr=False)
    _facet_normals_T: np.ndarray = field(init=False, repr=False)
    _facet_support: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        super().__post_init__()
        Bn, n = self._Bn, self.n_thrusters
        triples = np.zeros((0, 3), dtype=np.intp)
        inv = np.zeros((3, 0))
        normals = np.zeros((0, 3))
        if n <= _FAST_PATH_MAX_THRUSTERS:
            idx = np.array(list(itertools.combinations(range(n), 3)), dtype=np.intp)
            idx = idx.reshape(-1, 3)
            T = Bn[:, idx].transpose(1, 0, 2)
            norms = np.linalg.norm(Bn, axis=0)
            # Near-singular triples would amplify rounding; the LP handles their demands.
            ok = np.abs(np.linalg.det(T)) > 1e-6 * norms[idx].prod(axis=1)
            idx, T = idx[ok], T[ok]
            M = np.linalg.inv(T)
            lam = M.sum(axis=1)
            dual_ok = (lam @ Bn <= 1.0 + 1e-9).all(axis=1)
            triples = idx[dual_ok]
            # u_T for all kept triples at once: (N, 3) @ (3, 3K) → (N, K, 3).
            inv = M[dual_ok].reshape(-1, 3).T

            pairs = np.array(list(itertools.combinations(range(n), 2)), dtype=np.intp)
            pairs = pairs.reshape(-1, 2)
            w = np.cross(Bn[:, pairs[:, 0]].T, Bn[:, pairs[:, 1]].T)
            w_norm = np.linalg.norm(w, axis=1)
            keep = w_norm > 1e-9 * norms[pairs].prod(axis=1)
            w = w[keep] / w_norm[keep, None]
            normals = np.vstack([w, -w])
        support = np.maximum(normals @ Bn, 0.0).sum(axis=1)
        for name, arr in (
            ("_triples", triples),
            ("_triple_inv", np.ascontiguousarray(inv)),
            ("_facet_normals_T", np.ascontiguousarray(normals.T)),
            ("_facet_support", support),
        ):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def _fast_path(self, tn: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Fill ``out`` rows solved by a kept triple; return a mask of the rows still to solve."""
        N, K = tn.shape[0], self._triples.shape[0]
        todo = np.ones(N, dtype=bool)
        if K == 0:
            return todo
        chunk = max(1, _FAST_PATH_CHUNK // (3 * K))
        for start in range(0, N, chunk):
            stop = min(N, start + chunk)
            uT = (tn[start:stop] @ self._triple_inv).reshape(stop - start, K, 3)
            # Every kept triple with u_T >= 0 is optimal; take the one with the lowest peak.
            peak = np.where(uT.min(axis=2) >= -_THROTTLE_TOL, uT.max(axis=2), np.inf)
            best = peak.argmin(axis=1)
            rows = np.arange(stop - start)
            u_best = uT[rows, best]
            good = peak[rows, best] <= 1.0 + _THROTTLE_TOL
            r = rows[good]
            block = out[start:stop]
            block[r] = 0.0
            block[r[:, None], self._triples[best[r]]] = np.clip(u_best[r], 0.0, 1.0)
            todo[start:stop] = ~good
        return todo

    def _saturation_scale(self, tn: np.ndarray) -> np.ndarray:
        """Largest achievable fraction of each demand, capped at 1; NaN if not precomputed.

        tn: (N, 3) demands in units of the largest column norm. Returns (N,).
        """
        if self._facet_support.size == 0:
            return np.full(tn.shape[0], np.nan)
        wt = tn @ self._facet_normals_T
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(wt > 0.0, self._facet_support / wt, np.inf)
        return np.minimum(ratio.min(axis=1), 1.0)

    def _solve_one(self, t: np.ndarray, s: float) -> np.ndarray:
        """HiGHS for one demand t (3,) (units of the largest column norm); s: known scale or NaN."""
        Bn, n = self._Bn, self.n_thrusters
        if not s < 1.0 - 1e-9:
            res = linprog(np.ones(n), A_eq=Bn, b_eq=t, bounds=(0.0, 1.0), method="highs")
            if res.status == 0:
                return _polish(Bn, res.x, t)
        if s < 1.0 - 1e-9:
            res = linprog(np.ones(n), A_eq=Bn, b_eq=s * t, bounds=(0.0, 1.0), method="highs")
            if res.status == 0:
                return _polish(Bn, res.x, s * t)
        # No scale known, or HiGHS rejects the fuel LP sitting exactly on the boundary: find
        # the scale by LP, then minimise fuel there; failing that, the scale LP's throttles
        # still give s·τ, only without the fuel minimisation.
        s, u_dir = _max_scale_lp(Bn, t, 1.0)
        res = linprog(np.ones(n), A_eq=Bn, b_eq=s * t, bounds=(0.0, 1.0), method="highs")
        if res.status == 0:
            u = _polish(Bn, res.x, s * t)
            if u.sum() <= u_dir.sum():
                return u
        return u_dir

    def _allocate(self, tau: np.ndarray) -> np.ndarray:
        tn = tau / self._scale
        out = np.empty((tau.shape[0], self.n_thrusters))
        todo = np.flatnonzero(self._fast_path(tn, out))
        if todo.size:
            scale = self._saturation_scale(tn[todo])
            for k, s in zip(todo, scale, strict=True):
                out[k] = self._solve_one(tn[k], float(s))
        return out


ALLOCATORS: dict[str, type[_AllocatorBase]] = {
    "pinv": PseudoInverseAllocator,
    "nnls": NNLSAllocator,
    "lp": MinFuelLPAllocator,
}


def make_allocator(name: str, torque_matrix, **options) -> Allocator:
    """Build an allocator by name: ``"pinv"``, ``"nnls"`` or ``"lp"``.

    torque_matrix: (3, n) N·m per unit throttle. ``options`` go to the class (e.g.
    ``max_throttle`` for ``"nnls"``).
    """
    try:
        cls = ALLOCATORS[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"allocator name must be one of {sorted(ALLOCATORS)}, got {name!r}"
        ) from None
    return cls(torque_matrix, **options)
