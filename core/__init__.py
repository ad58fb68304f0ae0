"""rbenv's rigid-body core: quaternions, inertia tensors, rigid-body state and integrators.

Imports only NumPy (SciPy only inside :mod:`rbenv.core.reference`). Conventions (docs/design.md):
quaternions are scalar-first (w, x, y, z), Hamilton, body→world; names carry frames
(``_W`` world, ``_B`` body); SI units.
"""

from rbenv.core import inertia, kernels, quaternion
from rbenv.core.body import BodyState, RigidBody, Wheels, angular_momentum_W, rotational_energy
from rbenv.core.dynamics import simulate, step
from rbenv.core.errors import (
    InvalidInertiaError,
    InvalidParameterError,
    NonFiniteError,
    RbenvValueError,
)
from rbenv.core.forces import ThrusterLayout, wrench_at_points
from rbenv.core.integrators import INTEGRATORS

__all__ = [
    "INTEGRATORS",
    "BodyState",
    "InvalidInertiaError",
    "InvalidParameterError",
    "NonFiniteError",
    "RbenvValueError",
    "RigidBody",
    "ThrusterLayout",
    "Wheels",
    "angular_momentum_W",
    "inertia",
    "kernels",
    "quaternion",
    "rotational_energy",
    "simulate",
    "step",
    "wrench_at_points",
]
