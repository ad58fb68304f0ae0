"""Rigid-body parameters (frozen) and state (arrays with leading batch dimensions)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from rbenv.core import kernels, quaternion
from rbenv.core import validation as check
from rbenv.core.errors import InvalidInertiaError
from rbenv.core.inertia import validate
from rbenv.core.vec import unit_rows

# A tensor whose principal moments agree to this relative tolerance is treated as isotropic.
_ISOTROPIC_RTOL = 1e-12
# Smallest accepted mass (kg): the smallest normal float, so that 1/mass is finite.
MIN_MASS = float(np.finfo(float).tiny)


@dataclass(frozen=True, eq=False)
class Wheels:
    """Reaction wheels of a rigid body: n rotors spinning about body-fixed axes.

    axes: (n, 3) spin axes in body axes (normalised here). inertia: (n,) kg·m², each rotor's
    spin-axis inertia (> 0). The rotors' spin inertia is part of the body's inertia; the
    integrators step the bus ``I − Σ J ĝĝᵀ`` (:func:`bus_inertia`) with the rotors' absolute
    spin momentum as internal angular momentum (:mod:`rbenv.core.integrators`). The env's
    reaction wheels (:mod:`rbenv.satellite.actuators.wheels`) are these rotors with motors.
    """

    axes: np.ndarray
    inertia: np.ndarray

    def __post_init__(self):
        axes = check.finite_array("wheels.axes", self.axes)
        if axes.ndim != 2 or axes.shape[1] != 3 or not 1 <= len(axes) <= 64:
            raise check.InvalidParameterError(
                f"wheels.axes must be 1 to 64 spin axes [x, y, z], got shape {axes.shape}")
        axes = unit_rows("wheels.axes", axes)
        inertia = np.broadcast_to(check.finite_array("wheels.inertia", self.inertia),
                                  (len(axes),)).astype(float)
        if np.any(inertia <= 0.0):
            raise check.InvalidParameterError(
                f"wheels.inertia must be > 0 kg·m² per rotor, got {inertia.tolist()}")
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "inertia", inertia)

    @property
    def n(self) -> int:
        return len(self.inertia)

    @property
    def spin_inertia(self) -> np.ndarray:
        """(3, 3) ``Σ J_i ĝ_i ĝ_iᵀ``, kg·m²."""
        return (self.axes.T * self.inertia) @ self.axes


def bus_inertia(inertia, spin_inertia) -> np.ndarray:
    """(3, 3) kg·m²: the bus's inertia ``I − Σ J ĝĝᵀ``, a body's whole inertia (rotors
    included) less its rotors' spin inertia (:attr:`Wheels.spin_inertia`, or several summed)."""
    return np.asarray(inertia, dtype=float) - spin_inertia


@dataclass(frozen=True, eq=False)
class RigidBody:
    """Mass (kg) and inertia (kg·m², (3, 3), about the centre of mass, body axes) of one body.

    Validated at construction: mass finite and > 0; inertia symmetric, finite, positive definite
    and obeying the triangle inequality (a rod, with ``I_zz = 0``, is refused: it has no inverse).
    ``kind`` records what the step may skip: ``"isotropic"`` (sphere, cube: no change of basis,
    no gyroscopic term), ``"diagonal"`` (body axes are principal axes) or ``"full"``.
    ``specialize=False`` forces ``"full"`` (the general path), for benchmarks and cross-checks.
    """

    mass: float
    inertia: np.ndarray
    specialize: bool = True
    wheels: Wheels | None = None  # reaction wheels (their rotors are inside ``inertia``)
    inertia_inv: np.ndarray = field(init=False, repr=False)
    kind: str = field(init=False)
    # True when I = s·E: the change of basis and the gyroscopic term vanish. A field, not a
    # property: the integrators read it several times per step.
    is_isotropic: bool = field(init=False, repr=False)
    _diag: tuple = field(init=False, repr=False)
    _diag_inv: tuple = field(init=False, repr=False)
    _rows: tuple = field(init=False, repr=False)
    _inv_rows: tuple = field(init=False, repr=False)
    inverse_columns: tuple = field(init=False, repr=False)
    bus: RigidBody | None = field(init=False, repr=False)  # without the rotors' spin (wheels)

    def __post_init__(self):
        mass = check.number("mass", self.mass, low=MIN_MASS)
        check.flag("specialize", self.specialize)
        bus = None
        if self.wheels is not None:
            if not isinstance(self.wheels, Wheels):
                raise check.InvalidParameterError(
                    f"wheels must be a core.Wheels, got {type(self.wheels).__name__}")
            try:
                bus = RigidBody(mass, bus_inertia(self.inertia, self.wheels.spin_inertia),
                                self.specialize)
            except InvalidInertiaError as exc:
                raise InvalidInertiaError(
                    f"wheels.inertia: the body's inertia less its rotors' spin inertia must "
                    f"still be a rigid body's, but {exc}") from None
        object.__setattr__(self, "bus", bus)
        inertia = validate(self.inertia)
        inertia.setflags(write=False)
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            inv = np.linalg.inv(inertia)
            inv = 0.5 * (inv + inv.T)
            d_inv = 1.0 / np.diag(inertia)
        if not (np.isfinite(inv).all() and np.isfinite(d_inv).all()):
            raise InvalidInertiaError(
                f"inertia {check.show(inertia)} is too small: its inverse overflows; scale the "
                "units (every principal moment must be a normal float, >= ~1e-300 kg·m²)"
            )
        inv.setflags(write=False)
        d = np.diag(inertia).copy()
        off = np.abs(inertia - np.diag(d)).max()
        if not self.specialize:
            kind = "full"
        elif off == 0.0 and np.ptp(d) <= _ISOTROPIC_RTOL * d.max():
            kind = "isotropic"
        elif off == 0.0:
            kind = "diagonal"
        else:
            kind = "full"
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "inertia_inv", inv)
        object.__setattr__(self, "kind", kind)
        object.__setattr__(self, "is_isotropic", kind == "isotropic")
        # Plain-float copies: the component kernels run at Python-float speed for one body.
        object.__setattr__(self, "_diag", tuple(d.tolist()))
        object.__setattr__(self, "_diag_inv", tuple((1.0 / d).tolist()))
        object.__setattr__(self, "_rows", tuple(tuple(r) for r in inertia.tolist()))
        object.__setattr__(self, "_inv_rows", tuple(tuple(r) for r in inv.tolist()))
        # Columns of I⁻¹ as float triples: the implicit midpoint's Jacobian uses them.
        object.__setattr__(self, "inverse_columns", tuple(tuple(c) for c in inv.T.tolist()))

    def inertia_times(self, v: tuple) -> tuple:
        """``I v`` on components (floats or (N,) arrays), body axes."""
        if self.kind == "isotropic":
            s = self._diag[0]
            return (s * v[0], s * v[1], s * v[2])
        if self.kind == "diagonal":
            d0, d1, d2 = self._diag
            return (d0 * v[0], d1 * v[1], d2 * v[2])
        (a, b, c), (d, e, f), (g, h, i) = self._rows
        x, y, z = v
        return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)

    def inverse_times(self, v: tuple) -> tuple:
        """``I⁻¹ v`` on components (floats or (N,) arrays), body axes."""
        if self.kind == "isotropic":
            s = self._diag_inv[0]
            return (s * v[0], s * v[1], s * v[2])
        if self.kind == "diagonal":
            d0, d1, d2 = self._diag_inv
            return (d0 * v[0], d1 * v[1], d2 * v[2])
        (a, b, c), (d, e, f), (g, h, i) = self._inv_rows
        x, y, z = v
        return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)

    def apply_inertia(self, v_B: np.ndarray) -> np.ndarray:
        """``I v`` in body axes. v_B: (..., 3) rad/s. Returns (..., 3) (kg·m²/s for ω)."""
        return kernels.pack(self.inertia_times(kernels.unpack(np.asarray(v_B, dtype=float))))

    def apply_inverse(self, v_B: np.ndarray) -> np.ndarray:
        """``I⁻¹ v`` in body axes. v_B: (..., 3) (torque N·m → rad/s², momentum → rad/s)."""
        return kernels.pack(self.inverse_times(kernels.unpack(np.asarray(v_B, dtype=float))))

    def world_inverse_inertia(self, q: np.ndarray) -> np.ndarray:
        """World-space inverse inertia ``R I⁻¹ Rᵀ`` (the lecture's change of basis).

        q: (..., 4) body→world, scalar first. Returns (..., 3, 3) in 1/(kg·m²). For isotropic
        inertia the lecture's uniform-scale shortcut applies: ``R (s⁻¹E) Rᵀ = s⁻¹E``.
        """
        q = np.asarray(q, dtype=float)
        if self.is_isotropic:
            return np.broadcast_to(self.inertia_inv, (*q.shape[:-1], 3, 3))
        R = quaternion.to_matrix(q)
        return R @ self.inertia_inv @ np.swapaxes(R, -1, -2)

    def world_inertia(self, q: np.ndarray) -> np.ndarray:
        """World-space inertia ``R I Rᵀ``. q: (..., 4) body→world. Returns (..., 3, 3) kg·m²."""
        q = np.asarray(q, dtype=float)
        R = quaternion.to_matrix(q)
        return R @ self.inertia @ np.swapaxes(R, -1, -2)


@dataclass(frozen=True, eq=False)
class BodyState:
    """State of one or many rigid bodies, world frame, SI units; leading batch dims broadcast.

    position (..., 3) m: centre of mass. velocity (..., 3) m/s. orientation (..., 4): unit
    quaternion (w, x, y, z), body→world. angular_velocity (..., 3) rad/s: ω_W, world frame, as in
    the lecture. Fields not given default to zero (identity orientation). Construction checks
    shapes, finiteness and that orientations are unit to 1e-6 (normalise with
    ``rbenv.core.quaternion.normalize`` first if needed).
    """

    position: np.ndarray = None
    velocity: np.ndarray = None
    orientation: np.ndarray = None
    angular_velocity: np.ndarray = None
    wheel_speeds: np.ndarray = None  # (..., n) rad/s relative to the body, or None (no wheels)

    def __post_init__(self):
        if self.wheel_speeds is not None:
            speeds = check.finite_array("wheel_speeds", self.wheel_speeds)
            if speeds.ndim < 1:
                raise check.InvalidParameterError(
                    f"wheel_speeds must be (..., n) rad/s, one per wheel, got a scalar {speeds}")
            object.__setattr__(self, "wheel_speeds", np.array(speeds, dtype=float))
        given = {
            "position": (self.position, 3),
            "velocity": (self.velocity, 3),
            "orientation": (self.orientation, 4),
            "angular_velocity": (self.angular_velocity, 3),
        }
        arrays = {k: check.vectors(k, v, w) for k, (v, w) in given.items() if v is not None}
        batch = check.batch_shape({k: (a, 1) for k, a in arrays.items()})
        if "orientation" in arrays:
            check.unit_quaternion("orientation", arrays["orientation"])
        for name, (_, width) in given.items():
            if name in arrays:
                full = np.array(np.broadcast_to(arrays[name], (*batch, width)))
            elif name == "orientation":
                full = quaternion.identity(batch)
            else:
                full = np.zeros((*batch, width))
            object.__setattr__(self, name, full)

    @classmethod
    def from_arrays(cls, position, velocity, orientation, angular_velocity,
                    wheel_speeds=None) -> BodyState:
        """Build a state from already-checked float arrays without validation (hot paths)."""
        state = object.__new__(cls)
        object.__setattr__(state, "position", position)
        object.__setattr__(state, "velocity", velocity)
        object.__setattr__(state, "orientation", orientation)
        object.__setattr__(state, "angular_velocity", angular_velocity)
        object.__setattr__(state, "wheel_speeds", wheel_speeds)
        return state

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch dimensions shared by all fields."""
        return self.orientation.shape[:-1]

    @property
    def angular_velocity_B(self) -> np.ndarray:
        """Body-frame angular velocity ω_B = Rᵀ ω_W, (..., 3) rad/s."""
        return quaternion.rotate_inverse(self.orientation, self.angular_velocity)


def invariants(body: RigidBody, q: tuple, w_B: tuple) -> tuple:
    """Energy ``½ ω_B·Iω_B`` (J) and world momentum ``L_W = R I ω_B`` (N·m·s) on components.

    q: body→world quaternion, w_B: body rates (rad/s), as :mod:`rbenv.core.kernels` components
    (floats for one body, (N,) arrays for a batch). Returns (energy, L_W components).
    """
    m = body.inertia_times(w_B)
    return 0.5 * kernels.dot(w_B, m), kernels.rotate(q, m)


def _state_invariants(body: RigidBody, state: BodyState):
    q = kernels.unpack(state.orientation)
    return invariants(body, q, kernels.rotate_inverse(q, kernels.unpack(state.angular_velocity)))


def rotational_energy(body: RigidBody, state: BodyState) -> np.ndarray:
    """Rotational kinetic energy ``½ ω_B·Iω_B`` in J, shape = state.batch_shape."""
    return np.asarray(_state_invariants(body, state)[0], dtype=float)


def angular_momentum_W(body: RigidBody, state: BodyState) -> np.ndarray:
    """Angular momentum about the centre of mass, world frame ``L_W = R I ω_B``, (..., 3)."""
    return kernels.pack(_state_invariants(body, state)[1])
