"""Model-predictive control of a reorientation: a linearised LP over the rest of the slew (HiGHS).

Each control step, for each satellite, :class:`ModelPredictive` solves one linear program and
applies its first control (receding horizon). The LP is built from the scene and the task alone
and reads only the observation (the error attitude, the body rate and, with wheels, the wheel
speeds). It is solved by HiGHS's dual simplex (the ``mpc`` extra: ``highspy``), warm-started
from the previous step's optimal basis, which typically leaves a handful of pivots per step.

**State and model.** ``x = (φ, ω_B[, h_w])``: φ (3,) rad, the error rotation vector of
``q_err = q_target* ⊗ q`` (its axis in body axes), ω_B (3,) rad/s, and with reaction wheels
their momenta h_w (m,) N·m·s. Over a block of ``h`` s with the inputs held,

* ``ω⁺ = ω + h·I⁻¹(B u − g(ω̄) − ∂g(ω̄)(ω − ω̄))``, the gyroscopic term
  ``g(ω) = ω × (Iω + G h_w)`` linearised about the predicted rate ω̄ (the disturbance is
  unknown to the controller; feedback absorbs it);
* ``φ⁺ = φ + h·J⁻¹(φ̄)(ω + ω⁺)/2``, ``J⁻¹`` the inverse right Jacobian of SO(3) at the
  predicted attitude φ̄ (``φ̇ = J⁻¹(φ)ω``; along the eigenaxis it leaves ω unchanged); the
  mean of ω is exact for a constant torque;
* ``h_w⁺ = h_w + h·u_max ⊙ u`` for wheels (the motor torque moves momentum into the rotor).

The prediction (φ̄, ω̄) is the previous step's solution (a real-time iteration); at an
episode's start, a straight eigenaxis profile at constant rate.

**Horizon: the rest of the slew.** At an episode's start the controller fixes an arrival
time: the eigenaxis bang-coast-bang time for the angle, coasting at ``rate_fraction`` of the
rate limit (with wheels, of the smaller of it and ``wheel_rate_fraction`` × the rate their
momentum gives about that axis) and accelerating at ``accel_fraction`` of the authority about
that axis, plus the time to stop the initial rate, times ``time_factor``. The arrival is a
target, not a promise: a later one only pays the box below. The horizon then shrinks towards it:
``blocks`` blocks, the first one control step (the control applied), the others sharing the
time left to the arrival (at least a control step each), then ``hold_blocks`` blocks of one
control step. From the arrival on every state must lie in a box inside the success thresholds
(``box_fraction`` of them per component); the box is soft, its violation paid per unit at
``box_weight`` (g per rad and per rad/s), so the LP stays feasible. Inside the box nothing is
paid: a settled satellite does not fire.

**Cost and constraints.** Propellant (g; linear in the throttles: ``Σ h·F_i u_i / (Isp g₀)``)
with thrusters; with wheels ``wheel_torque_weight`` per second of full motor torque (L1, a
proxy for the electrical energy). Inputs within their bounds (throttles in [0, 1]; wheel
motor torques within ±u_max). The wheel
momenta within ``momentum_margin`` of each wheel's at its speed limit. The rate limit at every
block end, as a polytope (r = ``rate_margin`` × the limit): ``n̂·ω ≤ r`` along the predicted
rate and along six directions tilted 20° around it (|ω| ≤ 1.021 r near the prediction), and
``|n̂·ω| ≤ r`` along the 13 directions of the cube's faces, edges and corners (|ω| ≤ 1.128 r
anywhere). With a constant torque over a block the rate is linear in time, so the limit at the
block ends holds inside the block too (up to the gyroscopic term).

**The time–propellant knob.** ``time_factor`` (default 1): the arrival time relative to the
reference time above. A later arrival slews slower and spends less; the LP finds the
least-propellant way to arrive then (bang-coast-bang with a slower coast).
``rate_fraction`` sets the coast rate of the reference time.

``predict`` follows SB3 (``(actions, state)``; ``state`` (N, 6): the sign memory of q_err,
the arrival time and the episode clock, s); pass ``episode_start`` at every reset. The HiGHS
instance, its last basis and the last prediction of each batch row are kept in the controller
between calls. Reorientation ids only (the observation must carry the error attitude and the
body rate); ``action_mode="throttle"``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from rbenv.agents.baselines.controllers import NotApplicable, env_parts
from rbenv.core.errors import InvalidParameterError

from rbenv.satellite.allocation import max_torque_along
from rbenv.satellite.plant import Plant
from rbenv.satellite.usage import require
from rbenv.tasks import Task

__all__ = ["ModelPredictive"]

_G_PER_KG = 1000.0
_HYSTERESIS = 0.05  # |w| of q_err below which the rotation direction is kept (as the PD)


def _half_directions() -> np.ndarray:
    """13 unit directions (13, 3), one of each ± pair of the cube's faces, edges and corners:
    ``|n̂·ω| ≤ r`` along them bounds ω inside a polytope around the ball of radius r."""
    grid = [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
            if (i, j, k) > (0, 0, 0)]
    d = np.array(grid, float)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


_HALF_DIRS = _half_directions()


_RING = 6  # directions tilted by _RING_TILT around the predicted rate
_RING_TILT = math.radians(20.0)


def _ring(d: np.ndarray) -> np.ndarray:
    """(K, _RING, 3) unit directions at _RING_TILT from each unit vector of d (K, 3), evenly
    around it. With ``n̂·ω ≤ r`` along d and these, |ω| ≤ r·√(1 + (tan(β/2)/cos(π/6))²)
    (1.021 r at β = 20°) for every ω within β of d."""
    a = np.where(np.abs(d[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]),
                 np.array([[0.0, 1.0, 0.0]]))
    e1 = _cross(d, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = _cross(d, e1)
    phase = 2.0 * math.pi * np.arange(_RING) / _RING
    side = np.cos(phase)[None, :, None] * e1[:, None] + np.sin(phase)[None, :, None] * e2[:, None]
    return math.cos(_RING_TILT) * d[:, None] + math.sin(_RING_TILT) * side


def _skew_batch(v: np.ndarray) -> np.ndarray:
    """[v]× (..., 3, 3) of vectors (..., 3)."""
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1),
                     np.stack([-y, x, z], -1)], -2)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for (..., 3) arrays (written out: np.cross is slow on small arrays)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], -1)


def inverse_right_jacobian_batch(phi: np.ndarray) -> np.ndarray:
    """``J_r⁻¹(φ)`` (..., 3, 3) of rotation vectors φ (..., 3), |φ| < 2π: ``φ̇ = J_r⁻¹(φ) ω``
    for ``R = exp([φ]×)``, ``Ṙ = R[ω]×``. ``J_r⁻¹ = 1 + ½[φ]× + k[φ]×²`` with
    ``k = (1 − (θ/2)cot(θ/2))/θ²`` (1/12 + θ²/720 for small θ)."""
    theta = np.linalg.norm(phi, axis=-1)
    small = theta < 1e-3
    safe = np.where(small, 1.0, theta)
    k = np.where(small, 1.0 / 12.0 + theta**2 / 720.0,
                 (1.0 - 0.5 * safe * np.cos(0.5 * safe) / np.sin(0.5 * safe)) / safe**2)
    S = _skew_batch(phi)
    return np.eye(3) + 0.5 * S + k[..., None, None] * (S @ S)


def inverse_right_jacobian(phi: np.ndarray) -> np.ndarray:
    """``J_r⁻¹(φ)`` (3, 3) of one rotation vector (3,) (:func:`inverse_right_jacobian_batch`)."""
    return inverse_right_jacobian_batch(np.asarray(phi, float)[None])[0]


def rotation_vector(q_err: np.ndarray) -> np.ndarray:
    """φ (N, 3) rad of unit quaternions (N, 4) (w, x, y, z); w < 0 gives θ beyond π."""
    v = q_err[:, 1:]
    s = np.linalg.norm(v, axis=1)
    theta = 2.0 * np.arctan2(s, q_err[:, 0])
    return v * (theta / np.maximum(s, 1e-300))[:, None] + \
        np.where(s[:, None] > 1e-300, 0.0, 2.0 * v)


@dataclass
class _Row:
    """One satellite's solver, its previous solution and its clock."""

    solver: object
    x: np.ndarray | None = None  # predicted states (K+1, nx) of the last solution
    basis: object = None  # the LP's last optimal basis (HiGHS)
    times: np.ndarray | None = None  # their times from that step, s


@dataclass(eq=False)
class ModelPredictive:
    """Linearised model-predictive control over the rest of the slew (module docstring).

    Thrusters (throttles in [0, 1], propellant cost) or reaction wheels (motor torques within
    their limit, wheel speeds within theirs); other actuators get zero.
    """

    plant: Plant
    task: Task
    time_factor: float = 1.0  # arrival time / the eigenaxis bang-coast-bang time
    rate_fraction: float = 0.92  # coast rate of that reference time, of the rate limit
    accel_fraction: float = 0.9  # of the authority about the eigenaxis, for that time
    rate_margin: float = 0.95  # the QP keeps |ω| below this fraction of the rate limit
    momentum_margin: float = 0.95  # wheels: of each wheel's momentum at its speed limit
    blocks: int = 12  # blocks to the arrival
    hold_blocks: int = 3  # blocks of one control step after it
    box_fraction: float = 0.4  # of the success angle and rate, per component
    box_weight: float = 2000.0  # g per rad (and per rad/s) outside the box
    wheel_torque_weight: float = 0.01  # wheels: per second of full motor torque, each wheel
    wheel_rate_fraction: float = 1.3  # wheels: of the rate their momentum gives, for that time
    rows: dict = field(default_factory=dict, init=False, repr=False)
    # s per solve (building and solving the LP of one satellite), appended by predict
    solve_times_s: list = field(default_factory=list, init=False, repr=False)
    # run when named, not in every comparison of the baselines (applicable_baselines)
    on_request: ClassVar[bool] = True

    def __post_init__(self):
        self._highs = require("highspy", "the mpc baseline")
        unbounded = ("time_factor", "wheel_rate_fraction", "box_weight")
        for name in ("time_factor", "rate_fraction", "accel_fraction", "rate_margin",
                     "momentum_margin", "box_fraction", *unbounded[1:]):
            value = getattr(self, name)
            limit = math.inf if name in unbounded else 1.0
            if not (isinstance(value, (int, float)) and 0.0 < value <= limit):
                raise InvalidParameterError(
                    f"ModelPredictive.{name} must be a number in (0, {limit}], got {value!r}")
        if not (isinstance(self.wheel_torque_weight, (int, float))
                and 0.0 <= self.wheel_torque_weight < math.inf):
            raise InvalidParameterError(f"ModelPredictive.wheel_torque_weight must be a "
                                        f"number ≥ 0, got {self.wheel_torque_weight!r}")
        for name in ("blocks", "hold_blocks"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise InvalidParameterError(
                    f"ModelPredictive.{name} must be an integer ≥ 1, got {value!r}")
        plant = self.plant
        names = set(self.task.observation_slices())
        if "omega_B" not in names or not names & {"q_err", "rot6_err"}:
            raise NotApplicable(f"mpc reads the error attitude and the body rate; task "
                                f"{self.task.name!r} observes {sorted(names)}")
        if plant.action_mode != "throttle":
            raise NotApplicable(f"mpc drives action_mode 'throttle', got {plant.action_mode!r}")
        self.wheels = plant.actuator("wheels")
        self.thrusters = plant.actuator("thrusters")
        self.inertia = np.asarray(plant.scene.body.inertia, float)
        self.inv_inertia = np.linalg.inv(self.inertia)
        self.dt = float(plant.control_dt)
        if self.wheels is not None:
            ws = self.wheels.wheels
            self.driver = self.wheels
            self.G = np.asarray(ws.axes_B, float).T  # (3, m): wheel axes as columns
            self.u_max = np.asarray(ws.max_torque, float)
            self.B = -self.G * self.u_max  # body torque per unit action
            self.u_low, self.u_high = -1.0, 1.0
            self.cost_u = np.zeros(self.B.shape[1])
            self.h_max = self.momentum_margin * np.asarray(ws.inertia * ws.max_speed, float)
            self.slices = _wheel_slices(plant, self.task)
        elif self.thrusters is not None:
            layout = plant.scene.thrusters
            self.driver = self.thrusters
            self.B = np.asarray(layout.torque_matrix_B, float)
            self.u_low, self.u_high = 0.0, 1.0
            # g of propellant per throttle-second of each thruster
            self.cost_u = _G_PER_KG * np.asarray(layout.max_force, float) \
                * self.thrusters.fuel_per_impulse
            self.G = None
        else:
            raise NotApplicable(f"mpc needs thrusters or reaction wheels; scene "
                                f"{plant.scene.name!r} has neither")
        self.action_slice = plant.action_slices[plant.actuators.index(self.driver)]
        self.nu = self.B.shape[1]
        self.nw = 0 if self.wheels is None else self.nu
        self.nx = 6 + self.nw
        self.K = self.blocks + self.hold_blocks
        self._pattern()

    @classmethod
    def from_env(cls, env, **kwargs):
        """The controller for ``env`` (single, vector or wrapped), from its scene and task."""
        plant, task = env_parts(env)
        return cls(plant, task, **kwargs)

    # ------------------------------------------------------------------ QP structure
    def _pattern(self):
        """The LP's fixed sparsity. Columns z = (x_0..x_K, u_0..u_{K-1}, s_1..s_K); rows:
        dynamics ``x_{j+1} − A_j x_j − E_j u_j = c_j`` (K·nx), the soft box ``(φ, ω)_j ∓ s_j``
        (K·12), the rate polytope (K·14: 13 two-sided cube directions and the predicted one).
        x_0, the inputs, the slacks and the wheel momenta are column bounds."""
        K, nx, nu = self.K, self.nx, self.nu
        self.ix = lambda j: j * nx
        self.iu = lambda j: (K + 1) * nx + j * nu
        self.is_ = lambda j: (K + 1) * nx + K * nu + (j - 1) * 6
        nt = self.nw  # wheels: |u| bounds t, paid at wheel_torque_weight
        self.it = (K + 1) * nx + K * nu + K * 6
        self.nz = self.it + K * nt
        j = np.arange(K)[:, None, None]
        r, c = np.arange(nx)[None, :, None], np.arange(nx)[None, None, :]
        dyn = j * nx + r
        parts = [  # (rows, cols) of each value group, in the order _values fills them
            (dyn, self.ix(0) + j * nx + c),  # −A_j
            ((j * nx + np.arange(nx)[None, :]).ravel(),
             (self.ix(1) + j * nx + np.arange(nx)[None, :]).ravel()),  # +I on x_{j+1}
            (dyn, self.iu(0) + j * nu + np.arange(nu)[None, None, :]),  # −E_j
        ]
        self.r_box = K * nx
        i6 = np.arange(6)[None, :]
        jj = np.arange(K)[:, None]
        hi_rows, lo_rows = self.r_box + jj * 12 + i6, self.r_box + jj * 12 + 6 + i6
        x_cols, s_cols = self.ix(1) + jj * nx + i6, self.is_(1) + jj * 6 + i6
        parts += [(hi_rows, x_cols), (hi_rows, s_cols), (lo_rows, x_cols), (lo_rows, s_cols)]
        self.r_rate = self.r_box + K * 12
        self.n_dirs = len(_HALF_DIRS) + 1 + _RING
        d = np.arange(self.n_dirs)[None, :, None]
        parts.append((self.r_rate + j * self.n_dirs + d,
                      self.ix(1) + j * nx + 3 + np.arange(3)[None, None, :]))
        self.r_abs = self.r_rate + K * self.n_dirs
        if nt:  # u − t ≤ 0 and u + t ≥ 0, per wheel and block
            a = np.arange(K * nt)
            parts += [(self.r_abs + 2 * a, self.iu(0) + a), (self.r_abs + 2 * a, self.it + a),
                      (self.r_abs + 2 * a + 1, self.iu(0) + a),
                      (self.r_abs + 2 * a + 1, self.it + a)]
        self.m = self.r_abs + 2 * K * nt
        parts = [np.broadcast_arrays(*p) for p in parts]
        rows = np.concatenate([p[0].ravel() for p in parts])
        cols = np.concatenate([p[1].ravel() for p in parts])
        probe = sp.coo_matrix((np.arange(1, len(rows) + 1, dtype=float), (rows, cols)),
                              shape=(self.m, self.nz)).tocsc()
        self.perm = probe.data.astype(int) - 1  # coo entry of each csc entry
        self.csc_indices, self.csc_indptr = probe.indices, probe.indptr
        ones = np.ones(K * 6)
        self.box_values = np.concatenate([ones, -ones, ones, ones])
        ones = np.ones(K * nt)
        self.abs_values = np.concatenate([ones, -ones, ones, ones])
        self.identity_values = np.ones(K * nx)

    def _values(self, A, E, D) -> np.ndarray:
        """The LP matrix's values in CSC order from A (K, nx, nx), E (K, nx, nu) and the
        rate directions D (K, n_dirs, 3)."""
        vals = np.concatenate([-A.ravel(), self.identity_values, -E.ravel(), self.box_values,
                               D.ravel(), self.abs_values])
        return vals[self.perm]

    # ------------------------------------------------------------------ one satellite
    def arrival_time(self, phi: np.ndarray, omega_B: np.ndarray) -> float:
        """The arrival time (s) fixed at an episode's start (module docstring)."""
        theta = float(np.linalg.norm(phi))
        limit = self.task.rate_limit
        if theta < 1e-9:
            return self.dt * (self.blocks + 1)
        n = phi / theta
        In = self.inertia @ n
        if self.wheels is None:
            accel = max_torque_along(self.B, In / np.linalg.norm(In)) / np.linalg.norm(In)
            rate = self.rate_fraction * limit
        else:
            torque = np.min(self.u_max / np.maximum(np.abs(self.G.T @ In), 1e-12))
            accel = float(torque)
            h = np.min(self.h_max / np.maximum(np.abs(self.G.T @ In), 1e-12))
            rate = self.rate_fraction * min(limit, self.wheel_rate_fraction * float(h))
        accel *= self.accel_fraction
        stop = float(np.linalg.norm(omega_B)) / accel  # removing the initial rate, roughly
        if theta >= rate * rate / accel:
            t = theta / rate + rate / accel
        else:
            t = 2.0 * math.sqrt(theta / accel)
        latest = self.plant.scene.episode.duration - self.plant.scene.episode.hold_time \
            - (self.hold_blocks + 2) * self.dt
        return min(self.time_factor * (t + stop), latest)

    def _block_times(self, remaining: float) -> np.ndarray:
        """Durations (K,) s: a control step, the rest of the slew in blocks - 1, then holds."""
        dt, nb = self.dt, self.blocks
        rest = max(remaining - dt, 0.0)
        h = np.full(self.K, dt)
        h[1:nb] = max(dt, rest / (nb - 1)) if nb > 1 else dt
        return h

    def _reference(self, row: _Row, x0: np.ndarray, ends: np.ndarray, remaining: float):
        """Predicted states (K+1, nx) at the block ends ``ends`` (K+1,) s."""
        if row.x is not None:
            ref = np.empty((len(ends), self.nx))
            t_prev = row.times - self.dt
            for i in range(self.nx):
                ref[:, i] = np.interp(ends, t_prev, row.x[:, i])
            ref[0] = x0
            return ref
        # straight eigenaxis profile, constant rate, arriving at ``remaining``
        T = max(remaining, self.dt)
        s = np.clip(ends / T, 0.0, 1.0)[:, None]
        ref = np.repeat(x0[None], len(ends), axis=0)
        ref[:, :3] = x0[:3] * (1.0 - s)
        ref[1:, 3:6] = np.where(ends[1:, None] < T, -x0[:3] / T, 0.0)
        return ref

    def _linearise(self, ref: np.ndarray, h: np.ndarray):
        """Block matrices about the prediction ``ref`` (K+1, nx) with durations h (K,):
        ``x_{j+1} = A_j x_j + E_j u_j + c_j``; A (K, nx, nx), E (K, nx, nu), c (K, nx)."""
        K, nx, nu = self.K, self.nx, self.nu
        I, I_inv = self.inertia, self.inv_inertia
        wb = ref[:K, 3:6]
        L = wb @ I.T + (ref[:K, 6:] @ self.G.T if self.nw else 0.0)
        g = _cross(wb, L)
        Dg = _skew_batch(wb) @ I - _skew_batch(L)  # ∂(ω × (Iω + h))/∂ω
        hh = h[:, None, None]
        Aw = np.eye(3) - hh * (I_inv @ Dg)
        Ew = hh * (I_inv @ self.B)
        cw = h[:, None] * ((np.einsum("kab,kb->ka", Dg, wb) - g) @ I_inv.T)
        half = 0.5 * hh * inverse_right_jacobian_batch(0.5 * (ref[:K, :3] + ref[1:, :3]))
        A = np.zeros((K, nx, nx))
        E = np.zeros((K, nx, nu))
        c = np.zeros((K, nx))
        A[:, :3, :3] = np.eye(3)
        A[:, :3, 3:6] = half @ (np.eye(3) + Aw)
        A[:, 3:6, 3:6] = Aw
        E[:, :3] = half @ Ew
        E[:, 3:6] = Ew
        c[:, :3] = np.einsum("kab,kb->ka", half, cw)
        c[:, 3:6] = cw
        if self.nw:
            A[:, 6:, 6:] = np.eye(self.nw)
            E[:, 6:] = hh * np.diag(self.u_max)
        return A, E, c

    def _solve(self, row: _Row, x0: np.ndarray, remaining: float) -> np.ndarray:
        """The first block's inputs (nu,) of the LP from state x0 (nx,), ``remaining`` s to
        the arrival."""
        highspy = self._highs
        K, nx, nu = self.K, self.nx, self.nu
        inf = highspy.kHighsInf
        h = self._block_times(remaining)
        ends = np.concatenate([[0.0], np.cumsum(h)])
        ref = self._reference(row, x0, ends, remaining)
        A, E, c = self._linearise(ref, h)
        w = ref[1:, 3:6]
        nrm = np.linalg.norm(w, axis=1, keepdims=True)
        own = np.where(nrm > 1e-6, w / np.maximum(nrm, 1e-300), _HALF_DIRS[0])
        D = np.concatenate([np.broadcast_to(_HALF_DIRS, (K, *_HALF_DIRS.shape)),
                            own[:, None], _ring(own)], axis=1)
        # column bounds: x_0 fixed, wheel momenta within their limit, inputs, slacks ≥ 0
        col_lo = np.full(self.nz, -inf)
        col_hi = np.full(self.nz, inf)
        col_lo[:nx] = col_hi[:nx] = x0
        if self.nw:
            states_lo = col_lo[nx:(K + 1) * nx].reshape(K, nx)
            states_hi = col_hi[nx:(K + 1) * nx].reshape(K, nx)
            states_lo[:, 6:], states_hi[:, 6:] = -self.h_max, self.h_max
        col_lo[self.iu(0):self.is_(1)] = self.u_low
        col_hi[self.iu(0):self.is_(1)] = self.u_high
        col_lo[self.is_(1):] = 0.0  # slacks, and t ≥ |u| (wheels)
        # row bounds: dynamics, the box from the first block end at or after the arrival
        row_lo = np.full(self.m, -inf)
        row_hi = np.full(self.m, inf)
        row_lo[:self.r_box] = row_hi[:self.r_box] = c.ravel()
        box = np.concatenate([np.full(3, self.box_fraction * self.task.success_angle),
                              np.full(3, self.box_fraction * self.task.success_rate)])
        active = ends[1:] >= remaining - 1e-9
        box_hi = row_hi[self.r_box:self.r_rate].reshape(K, 2, 6)
        box_lo = row_lo[self.r_box:self.r_rate].reshape(K, 2, 6)
        box_hi[active, 0] = box
        box_lo[active, 1] = -box
        rate = self.rate_margin * self.task.rate_limit
        rate_lo = row_lo[self.r_rate:self.r_abs].reshape(K, self.n_dirs)
        rate_lo[:, :len(_HALF_DIRS)] = -rate
        row_hi[self.r_rate:self.r_abs] = rate
        row_hi[self.r_abs::2] = 0.0  # u − t ≤ 0
        row_lo[self.r_abs + 1::2] = 0.0  # u + t ≥ 0
        q = np.zeros(self.nz)
        q[self.iu(0):self.is_(1)] = (h[:, None] * self.cost_u).ravel()
        q[self.is_(1):self.it] = self.box_weight
        q[self.it:] = (h[:, None] * np.full(self.nw, self.wheel_torque_weight)).ravel()
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = self.nz, self.m
        lp.col_cost_, lp.col_lower_, lp.col_upper_ = q, col_lo, col_hi
        lp.row_lower_, lp.row_upper_ = row_lo, row_hi
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = self.nz, self.m
        lp.a_matrix_.start_ = self.csc_indptr
        lp.a_matrix_.index_ = self.csc_indices
        lp.a_matrix_.value_ = self._values(A, E, D)
        if row.solver is None:
            row.solver = highspy.Highs()
            row.solver.setOptionValue("output_flag", False)
            row.solver.setOptionValue("solver", "simplex")
            row.solver.setOptionValue("simplex_strategy", 1)  # dual simplex
        solver = row.solver
        solver.passModel(lp)
        if row.basis is not None:
            solver.setBasis(row.basis)  # warm start from the last step's optimal basis
        solver.run()
        sol = solver.getSolution()
        if solver.getModelStatus() != highspy.HighsModelStatus.kOptimal or not sol.value_valid:
            row.x, row.basis = None, None
            return np.zeros(nu)
        row.basis = solver.getBasis()
        z = np.asarray(sol.col_value)
        row.x, row.times = z[:(K + 1) * nx].reshape(K + 1, nx), ends
        return np.clip(z[self.iu(0):self.iu(0) + nu], self.u_low, self.u_high)

    def wheel_speeds(self, obs: np.ndarray) -> np.ndarray:
        """(N, m) wheel speeds relative to the body, rad/s, from observations (N, size)."""
        return obs[:, self.slices] * self.wheels.wheels.max_speed

    # ------------------------------------------------------------------ SB3 interface
    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3-style ``(actions, state)`` for observations (size,) or (N, size)."""
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        obs = obs.reshape(-1, obs.shape[-1])
        n = len(obs)
        decoded = self.task.decode(obs[:, :self.task.observation_size()])
        q_err = decoded["q_err"]
        omega = decoded["omega_B"]
        starts = np.ones(n, bool) if state is None else (
            np.zeros(n, bool) if episode_start is None
            else np.asarray(episode_start, bool).reshape(n))
        prev = np.zeros((n, 6)) if state is None else np.asarray(state, float).reshape(n, 6)
        # keep q_err's sign continuous with the last step unless clearly shorter the other way
        flip = (~starts) & (np.sum(q_err * prev[:, :4], axis=1) < 0) & \
            (np.abs(q_err[:, 0]) < _HYSTERESIS)
        q_err = np.where(flip[:, None], -q_err, q_err)
        phi = rotation_vector(q_err)
        new_state = np.empty((n, 6))
        new_state[:, :4] = q_err
        out = np.zeros((n, self.plant.action_shape[0]), np.float32)
        hw = self.wheel_speeds(obs) * self.wheels.wheels.inertia if self.nw else None
        for i in range(n):
            if starts[i] or i not in self.rows:
                arrival = self.arrival_time(phi[i], omega[i])
                clock = 0.0
                row = self.rows.get(i)
                self.rows[i] = row = _Row(solver=None if row is None else row.solver)
            else:
                arrival, clock = prev[i, 4], prev[i, 5]
                row = self.rows[i]
            x0 = np.concatenate([phi[i], omega[i], [] if hw is None else hw[i]])
            t0 = time.perf_counter()
            u = self._solve(row, x0, arrival - clock)
            self.solve_times_s.append(time.perf_counter() - t0)
            out[i, self.action_slice] = u
            new_state[i, 4:] = arrival, clock + self.dt
        state_out = new_state.astype(np.float64)
        return (out[0], state_out[0]) if single else (out, state_out)


def _wheel_slices(plant: Plant, task: Task) -> slice:
    start = task.observation_size()
    for act in plant.actuators:
        for name, width in act.observation_structure.items():
            if name == "wheel_speed":
                return slice(start, start + width)
            start += width
    raise NotApplicable("mpc with wheels needs their speeds in the observation")
