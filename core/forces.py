"""Force generators: forces at points become wrenches; thrusters are body-fixed generators."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError, describe
from rbenv.core.vec import cross

# Most thrusters a layout may have (allocation and per-step cost grow with the count).
MAX_THRUSTERS = 256


def wrench_at_points(force_W, point_W, com_W) -> tuple[np.ndarray, np.ndarray]:
    """Net force and torque about the centre of mass from forces applied at points.

    force_W, point_W: (..., k, 3) in N and m, world frame; com_W: (..., 3) m. Returns
    ``(F, τ)`` each (..., 3): ``F = Σ F_i`` (the full force accelerates the centre of mass,
    whatever the lever arm) and ``τ = Σ (x_i − c) × F_i`` in N·m.
    """
    force_W = check.vectors("force_W", force_W, 3)
    point_W = check.vectors("point_W", point_W, 3)
    com_W = check.vectors("com_W", com_W, 3)
    for name, arr in (("force_W", force_W), ("point_W", point_W)):
        if arr.ndim < 2:
            raise InvalidParameterError(
                f"{name} must have shape (..., k, 3) (k forces), got shape {arr.shape}"
            )
    check.batch_shape({"force_W": (force_W, 2), "point_W": (point_W, 2), "com_W": (com_W, 1)})
    check.batch_shape({"force_W": (force_W, 1), "point_W": (point_W, 1)})
    r = point_W - com_W[..., None, :]
    return force_W.sum(axis=-2), cross(r, force_W).sum(axis=-2)


@dataclass(frozen=True, eq=False)
class ThrusterLayout:
    """Thrusters fixed in the body frame: where they sit, which way they push, how hard.

    positions_B: (n, 3) m, mount points in body axes. directions_B: (n, 3), direction of the
    force on the body (opposite to the exhaust), normalised at construction. max_force: (n,) N
    at full throttle. com_B: (3,) m, centre of mass in the same body axes (default origin).
    """

    positions_B: np.ndarray
    directions_B: np.ndarray
    max_force: np.ndarray
    com_B: np.ndarray = field(default_factory=lambda: np.zeros(3))
    force_matrix_B: np.ndarray = field(init=False, repr=False)
    torque_matrix_B: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        pos = check.array("positions_B", self.positions_B, (None, 3))
        n = pos.shape[0]
        if not 1 <= n <= MAX_THRUSTERS:
            raise InvalidParameterError(
                f"positions_B must list between 1 and {MAX_THRUSTERS} thrusters, got {n}"
            )
        dirs = check.array("directions_B", self.directions_B, (n, 3))
        fmax = check.finite_array("max_force", self.max_force)
        fmax = np.broadcast_to(fmax, (n,)).astype(float) if fmax.ndim == 0 else fmax
        fmax = check.array("max_force", fmax, (n,))
        com = check.array("com_B", self.com_B, (3,))
        if (fmax <= 0).any():
            i = int(np.argmax(fmax <= 0))
            raise InvalidParameterError(f"max_force[{i}] must be > 0 N, got {fmax[i]!r}")
        lengths = np.linalg.norm(dirs, axis=1)
        if not np.isfinite(lengths).all():  # |d|² overflowed: only the direction matters
            dirs = dirs / np.abs(dirs).max(axis=1, keepdims=True)
            lengths = np.linalg.norm(dirs, axis=1)
        if (lengths < 1e-12).any() or not np.isfinite(lengths).all():
            i = int(np.argmax((lengths < 1e-12) | ~np.isfinite(lengths)))
            raise InvalidParameterError(
                f"directions_B[{i}] must be a non-zero vector of finite length, got "
                f"{describe(dirs[i])}"
            )
        dirs = dirs / lengths[:, None]
        forces = dirs * fmax[:, None]
        torque_matrix = cross(pos - com, forces).T
        if not np.isfinite(torque_matrix).all():
            raise InvalidParameterError(
                "thruster layout overflows: r × F is not finite for these positions_B and "
                "max_force; rescale the units"
            )
        for name, arr in (("positions_B", pos), ("directions_B", dirs), ("max_force", fmax),
                          ("com_B", com), ("force_matrix_B", forces.T.copy()),
                          ("torque_matrix_B", np.ascontiguousarray(torque_matrix))):
            arr = np.array(arr, dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n(self) -> int:
        """Number of thrusters."""
        return self.positions_B.shape[0]

    def wrench_B(self, throttle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame force (N) and torque about the centre of mass (N·m) for throttles.

        throttle: (..., n) in [0, 1] (fraction of max force, or duty cycle over the step).
        Returns (force_B, torque_B), each (..., 3).
        """
        return throttle @ self.force_matrix_B.T, throttle @ self.torque_matrix_B.T
