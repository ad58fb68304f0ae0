"""Model-predictive control of a reorientation: a linearised QP over the rest of the slew (OSQP).

Each control step, for each satellite, :class:`ModelPredictive` solves one quadratic program
and applies its first control (receding horizon). The QP is built from the scene and the task
alone and reads only the observation (the error attitude, the body rate and, with wheels, the
wheel speeds).

**State and model.** ``x = (φ, ω_B[, h_w])``: φ (3,) rad, the error rotation vector of
``q_err = q_target* ⊗ q`` (its axis in body axes), ω_B (3,) rad/s, and with reaction wheels
their momenta h_w (m,) N·m·s. Over a block of ``h`` s with the inputs held,

* ``ω⁺ = ω + h·I⁻¹(B u + τ_d − g(ω̄) − ∂g(ω̄)(ω − ω̄))``, the gyroscopic term
  ``g(ω) = ω × (Iω + G h_w)`` linearised about the predicted rate ω̄;
* ``φ⁺ = φ + h·J⁻¹(φ̄)(ω + ω⁺)/2``, ``J⁻¹`` the inverse right Jacobian of SO(3) at the
  predicted attitude φ̄ (``φ̇ = J⁻¹(φ)ω``; exact along the eigenaxis, where it is the identity
  on ω); the mean of ω is exact for a constant torque;
* ``h_w⁺ = h_w + h·u_max ⊙ u`` for wheels (the motor torque moves momentum into the rotor).

The prediction (φ̄, ω̄) is the previous step's solution (real-time iteration); at an
episode's start, a straight rest-to-rest eigenaxis profile.

**Horizon: the rest of the slew.** At an episode's start the controller fixes an arrival
time: the eigenaxis bang-coast-bang time for the angle, at ``rate_fraction`` of the rate
limit and ``accel_fraction`` of the authority about that axis, times ``time_factor``. The
horizon then shrinks towards it: ``blocks`` blocks, the first one control step (the control
applied), the others sharing the time left to the arrival (at least a control step each), then
``hold_blocks`` blocks of one control step. From the arrival on every state must lie in a box
inside the success thresholds (``box_fraction`` of them per component); the box is soft, its
violation paid per unit at ``box_weight`` (g per rad and per rad/s), so the QP stays
feasible. Inside the box nothing is paid: a settled satellite does not fire.

**Cost and constraints.** Propellant (g; linear in the throttles: ``Σ h·F_i u_i / (Isp g₀)``)
with thrusters, or a small quadratic motor-torque cost with wheels; inputs in their bounds
(throttles in [0, 1], wheel torques within ±u_max); the rate limit at every block boundary
(``|ω_i| ≤ r`` per axis, ``n̂·ω ≤ r`` along the predicted rate and along 26 directions, r =
``rate_margin`` × the limit: a polytope inside the ball); the wheel speed limits
(``|h_w,i| ≤ momentum_margin·J_i Ω_max,i``). With a constant torque over a block the rate is
linear in time, so the limit at the block ends holds inside the block too (up to the
gyroscopic term).

**The time–propellant knob.** ``time_factor`` (default 1): the arrival time relative to the
eigenaxis bang-coast-bang time. Longer arrival times slew slower and spend less; the QP
finds the least-propellant way to arrive at that time (bang-coast-bang with a slower coast).
``rate_fraction`` sets the coast rate of that reference time.

``predict`` follows SB3 (``(actions, state)``; ``state`` (N, 6): the sign memory of q_err,
the arrival time and the episode clock); pass ``episode_start`` at every reset. The solver
objects and the prediction of each batch row are kept in the controller between calls.
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


def _directions() -> np.ndarray:
    """The 26 unit directions of the cube's faces, edges and corners (26, 3)."""
    grid = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                     if (i, j, k) != (0, 0, 0)], float)
    return grid / np.linalg.norm(grid, axis=1, keepdims=True)


_DIRS = _directions()


def _skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def inverse_right_jacobian(phi: np.ndarray) -> np.ndarray:
    """``J_r⁻¹(φ)`` (3, 3): ``φ̇ = J_r⁻¹(φ) ω`` for ``R = exp([φ]×)``, ``Ṙ = R[ω]×``."""
    theta = float(np.linalg.norm(phi))
    S = _skew(phi)
    if theta < 1e-6:
        return np.eye(3) + 0.5 * S + S @ S / 12.0
    half = 0.5 * theta
    coef = 1.0 / theta**2 - (1.0 + math.cos(theta)) / (2.0 * theta * math.sin(theta)) \
        if abs(math.sin(theta)) > 1e-9 else 1.0 / theta**2 - half / (theta**2 * math.tan(half))
    return np.eye(3) + 0.5 * S + coef * S @ S


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
    rows: dict = field(default_factory=dict, init=False, repr=False)
    # s per solve (building and solving the LP of one satellite), appended by predict
    solve_times_s: list = field(default_factory=list, init=False, repr=False)
    # run when named, not in every comparison of the baselines (applicable_baselines)
    on_request: ClassVar[bool] = True

    def __post_init__(self):
        self._highs = require("highspy", "the mpc baseline")
        for name in ("time_factor", "rate_fraction", "accel_fraction", "rate_margin",
                     "momentum_margin", "box_fraction"):
            value = getattr(self, name)
            limit = math.inf if name == "time_factor" else 1.0
            if not (isinstance(value, (int, float)) and 0.0 < value <= limit):
                raise InvalidParameterError(
                    f"ModelPredictive.{name} must be a number in (0, {limit}], got {value!r}")
        for name in ("blocks", "hold_blocks"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise InvalidParameterError(
                    f"ModelPredictive.{name} must be an integer ≥ 1, got {value!r}")
        plant = self.plant
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
        """The fixed sparsity of the QP; variables z = (x_0..x_K, u_0..u_{K-1}, s_1..s_K)."""
        K, nx, nu = self.K, self.nx, self.nu
        ns = 6  # slack per block end: |φ_i|, |ω_i| outside the box
        self.ix = lambda j: j * nx
        self.iu = lambda j: (K + 1) * nx + j * nu
        self.is_ = lambda j: (K + 1) * nx + K * nu + (j - 1) * ns
        self.nz = (K + 1) * nx + K * nu + K * ns
        rows, cols, self.vals_index = [], [], {}
        self._row = 0

        def block(name, r0, c0, shape):
            rr, cc = np.meshgrid(np.arange(shape[0]) + r0, np.arange(shape[1]) + c0,
                                 indexing="ij")
            self.vals_index[name] = (len(rows), shape)
            rows.extend(rr.ravel())
            cols.extend(cc.ravel())

        # dynamics rows: x_{j+1} − A_j x_j − E_j u_j = c_j  (nx rows per block), x_0 = x_now
        r = 0
        block("x0", r, 0, (nx, nx))
        r += nx
        self.r_dyn = r
        for j in range(K):
            block(("Ax", j), r, self.ix(j), (nx, nx))
            block(("I", j), r, self.ix(j + 1), (nx, nx))
            block(("Bu", j), r, self.iu(j), (nx, nu))
            r += nx
        self.r_u = r
        block("u", r, self.iu(0), (K * nu, K * nu))
        r += K * nu
        self.r_s = r
        block("s", r, self.is_(1), (K * ns, K * ns))
        r += K * ns
        # box rows per block end j = 1..K: (φ, ω)_i − s_i ≤ b_i and (φ, ω)_i + s_i ≥ −b_i
        self.r_box = r
        for j in range(1, K + 1):
            block(("boxhi_x", j), r, self.ix(j), (ns, 6))
            block(("boxhi_s", j), r, self.is_(j), (ns, ns))
            r += ns
            block(("boxlo_x", j), r, self.ix(j), (ns, 6))
            block(("boxlo_s", j), r, self.is_(j), (ns, ns))
            r += ns
        # rate rows per block end: 26 directions + the predicted direction
        self.r_rate = r
        self.n_dirs = len(_DIRS) + 1
        for j in range(1, K + 1):
            block(("rate", j), r, self.ix(j) + 3, (self.n_dirs, 3))
            r += self.n_dirs
        self.r_wheel = r
        if self.nw:
            for j in range(1, K + 1):
                block(("wheel", j), r, self.ix(j) + 6, (self.nw, self.nw))
                r += self.nw
        self.m = r
        self.lp_rows = np.concatenate([np.arange(self.r_u), np.arange(self.r_box, r)])
        self.rows_coo = np.array(rows)
        self.cols_coo = np.array(cols)
        probe = sp.coo_matrix((np.arange(1, len(rows) + 1, dtype=float),
                               (self.rows_coo, self.cols_coo)), shape=(self.m, self.nz)).tocsc()
        self.perm = probe.data.astype(int) - 1  # coo entry of each csc entry
        self.csc_indices, self.csc_indptr = probe.indices, probe.indptr
        self.vals = np.zeros(len(rows))
        # constant entries
        self._put("x0", np.eye(nx))
        for j in range(K):
            self._put(("I", j), np.eye(nx))
        self._put("u", np.eye(K * nu))
        self._put("s", np.eye(K * ns))
        for j in range(1, K + 1):
            self._put(("boxhi_x", j), np.eye(6))
            self._put(("boxhi_s", j), -np.eye(ns))
            self._put(("boxlo_x", j), np.eye(6))
            self._put(("boxlo_s", j), np.eye(ns))
            if self.nw:
                self._put(("wheel", j), np.eye(self.nw))

    def _put(self, name, value):
        start, shape = self.vals_index[name]
        self.vals[start:start + shape[0] * shape[1]] = np.asarray(value).ravel()

    def _matrix(self):
        return sp.csc_matrix((self.vals[self.perm], self.csc_indices, self.csc_indptr),
                             shape=(self.m, self.nz))

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
            rate = min(self.rate_fraction * limit, 0.7 * float(h))
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

    def _solve(self, row: _Row, x0: np.ndarray, remaining: float) -> np.ndarray:
        K, nx, nu = self.K, self.nx, self.nu
        h = self._block_times(remaining)
        ends = np.concatenate([[0.0], np.cumsum(h)])
        ref = self._reference(row, x0, ends, remaining)
        I_inv, inertia = self.inv_inertia, self.inertia
        lo = np.full(self.m, -np.inf)
        hi = np.full(self.m, np.inf)
        lo[:nx] = hi[:nx] = x0
        d = np.zeros(3)  # the disturbance is unknown to the controller
        for j in range(K):
            wb = ref[j, 3:6]
            hw = self.G @ ref[j, 6:] if self.nw else np.zeros(3)
            L = inertia @ wb + hw
            g = np.cross(wb, L)
            Dg = _skew(wb) @ inertia - _skew(L)  # ∂(ω × (Iω + h))/∂ω
            Jm = inverse_right_jacobian(0.5 * (ref[j, :3] + ref[j + 1, :3]))
            Aw = np.eye(3) - h[j] * I_inv @ Dg  # ω⁺ = Aw ω + Ew u + cw
            Ew = h[j] * I_inv @ self.B
            cw = h[j] * I_inv @ (d - g + Dg @ wb)
            A = np.zeros((nx, nx))
            E = np.zeros((nx, nu))
            c = np.zeros(nx)
            A[3:6, 3:6] = Aw
            E[3:6] = Ew
            c[3:6] = cw
            half = 0.5 * h[j] * Jm  # φ⁺ = φ + half (ω + ω⁺)
            A[:3, :3] = np.eye(3)
            A[:3, 3:6] = half @ (np.eye(3) + Aw)
            E[:3] = half @ Ew
            c[:3] = half @ cw
            if self.nw:
                A[6:, 6:] = np.eye(self.nw)
                E[6:] = h[j] * np.diag(self.u_max)
            self._put(("Ax", j), -A)
            self._put(("Bu", j), -E)
            r = self.r_dyn + j * nx
            lo[r:r + nx] = hi[r:r + nx] = c
        lo[self.r_u:self.r_s] = self.u_low
        hi[self.r_u:self.r_s] = self.u_high
        lo[self.r_s:self.r_box] = 0.0
        # the box, from the first block end at or after the arrival
        box = np.concatenate([np.full(3, self.box_fraction * self.task.success_angle),
                              np.full(3, self.box_fraction * self.task.success_rate)])
        active = ends[1:] >= remaining - 1e-9
        for j in range(1, K + 1):
            r = self.r_box + (j - 1) * 12
            if active[j - 1]:
                hi[r:r + 6] = box
                lo[r + 6:r + 12] = -box
        rate = self.rate_margin * self.task.rate_limit
        for j in range(1, K + 1):
            w = ref[j, 3:6]
            nrm = np.linalg.norm(w)
            own = w / nrm if nrm > 1e-6 else _DIRS[0]
            self._put(("rate", j), np.vstack([_DIRS, own]))
            r = self.r_rate + (j - 1) * self.n_dirs
            hi[r:r + self.n_dirs] = rate
            lo[r:r + self.n_dirs] = -np.inf
        if self.nw:
            lo[self.r_wheel:self.m] = -np.tile(self.h_max, K)
            hi[self.r_wheel:self.m] = np.tile(self.h_max, K)
        q = np.zeros(self.nz)
        for j in range(K):
            q[self.iu(j):self.iu(j) + nu] = h[j] * self.cost_u
        q[self.is_(1):] = self.box_weight
        return self._solve_lp(row, self._matrix(), q, lo, hi, ends)

    def _solve_lp(self, row, A, q, lo, hi, ends):
        """The same problem as a linear program (no regularisation), by HiGHS's dual simplex,
        warm-started from the last step's basis."""
        highspy = self._highs
        K, nx, nu = self.K, self.nx, self.nu
        keep = self.lp_rows
        A = A[keep]
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = self.nz, len(keep)
        lp.col_cost_ = q
        col_lo = np.full(self.nz, -highspy.kHighsInf)
        col_hi = np.full(self.nz, highspy.kHighsInf)
        col_lo[self.iu(0):] = lo[self.r_u:self.r_box]
        col_hi[self.iu(0):] = hi[self.r_u:self.r_box]
        lp.col_lower_, lp.col_upper_ = col_lo, col_hi
        lp.row_lower_ = np.where(np.isfinite(lo[keep]), lo[keep], -highspy.kHighsInf)
        lp.row_upper_ = np.where(np.isfinite(hi[keep]), hi[keep], highspy.kHighsInf)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = self.nz, len(keep)
        lp.a_matrix_.start_ = A.indptr
        lp.a_matrix_.index_ = A.indices
        lp.a_matrix_.value_ = A.data
        if row.solver is None:
            h = highspy.Highs()
            h.setOptionValue("output_flag", False)
            h.setOptionValue("solver", "simplex")
            h.setOptionValue("simplex_strategy", 1)  # dual
            row.solver = h
        h = row.solver
        h.passModel(lp)
        if row.basis is not None:
            h.setBasis(row.basis)
        h.run()
        sol = h.getSolution()
        if h.getModelStatus() != highspy.HighsModelStatus.kOptimal or not sol.value_valid:
            row.x, row.basis = None, None
            return np.zeros(nu)
        row.basis = h.getBasis()
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
