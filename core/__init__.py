"""rbenv's rigid-body core: quaternions, inertia tensors, rigid-body state and integrators.

Imports only NumPy (SciPy only inside :mod:`core.reference`). See DESIGN.md for conventions:
quaternions are scalar-first, Hamilton, body→world; names carry frames (``_W`` world, ``_B`` body).
"""

from core import inertia, quaternion

__all__ = ["inertia", "quaternion"]
