"""Force generators: forces at points become wrenches; thrusters are body-fixed generators."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import InvalidParameterError, describe, require_finite
from core.vec import cross


def wrench_at_points(force_W, point_W, com_W) -> tuple[np.ndarray, np.ndarray]:
    """Net force and torque about the centre of mass from forces applied at points.

    force_W, point_W: (..., k, 3) in N and m, world frame; com_W: (..., 3) m. Returns
    ``(F, τ)`` each (..., 3): ``F = Σ F_i`` (the full force accelerates the centre of mass,
    whatever the lever arm) and ``τ = Σ (x_i − c) × F_i`` in N·m.
    """
    force_W = require_finite("force_W", force_W)
    point_W = require_finite("point_W", point_W)
    com_W = require_finite("com_W", com_W)
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
        pos = require_finite("positions_B", self.positions_B)
        dirs = require_finite("directions_B", self.directions_B)
        fmax = require_finite("max_force", self.max_force)
        com = require_finite("com_B", self.com_B)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] == 0:
            raise InvalidParameterError(f"positions_B must have shape (n, 3), got {pos.shape}")
        n = pos.shape[0]
        if dirs.shape != (n, 3):
            raise InvalidParameterError(f"directions_B must have shape ({n}, 3), got {dirs.shape}")
        fmax = np.broadcast_to(fmax, (n,)).astype(float) if fmax.ndim == 0 else fmax
        if fmax.shape != (n,):
            raise InvalidParameterError(f"max_force must have shape ({n},), got {fmax.shape}")
        if (fmax <= 0).any():
            i = int(np.argmax(fmax <= 0))
            raise InvalidParameterError(f"max_force[{i}] must be > 0 N, got {fmax[i]!r}")
        lengths = np.linalg.norm(dirs, axis=1)
        if (lengths < 1e-12).any():
            i = int(np.argmax(lengths < 1e-12))
            raise InvalidParameterError(
                f"directions_B[{i}] must be a non-zero vector, got {describe(dirs[i])}"
            )
        if com.shape != (3,):
            raise InvalidParameterError(f"com_B must have shape (3,), got {com.shape}")
        dirs = dirs / lengths[:, None]
        forces = dirs * fmax[:, None]
        torque_matrix = cross(pos - com, forces).T
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
