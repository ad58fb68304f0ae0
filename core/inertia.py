"""Inertia tensors: closed forms for the lecture's shapes, particle sums, meshes and checks.

All tensors are (3, 3) arrays in kg·m², expressed in body axes and taken about the centre of mass
unless an ``about=`` argument says otherwise. Sizes are in metres, masses in kg.

The particle samplers (:func:`box_particles`, :func:`sphere_particles`) answer the lecture's
"Challenge": discretise a shape into particles, sum with :func:`from_particles`, and watch the
result converge to the closed form, which exposes the lecture's hollow-box formula as wrong.
"""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass

import numpy as np
from rbenv.core import validation as check
from rbenv.core.errors import InvalidInertiaError, InvalidParameterError, NonFiniteError, describe
from rbenv.core.mesh import MeshError, check_closed_oriented, check_mesh_arrays, load_mesh

__all__ = [
    "InvalidInertiaError",
    "MassProperties",
    "MeshError",
    "box_particles",
    "from_mesh",
    "from_particles",
    "hollow_box",
    "hollow_cylinder",
    "hollow_sphere",
    "lecture_hollow_box",
    "load_mesh",
    "parallel_axis",
    "principal_axes",
    "rod",
    "solid_box",
    "solid_cone",
    "solid_cylinder",
    "solid_sphere",
    "sphere_particles",
    "validate",
]

# Relative tolerance for symmetry and for the triangle inequality of principal moments.
_RTOL = 1e-9
# A mesh whose |volume| is below this fraction of its bounding-box volume counts as flat.
_FLAT_RTOL = 1e-12
# Largest particle resolution n of the samplers (a solid box is n³ = 8e6 particles at the cap).
MAX_PARTICLE_N = 200


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), centre of mass (m, (3,)) and inertia about the centre of mass (kg·m², (3, 3))."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def _finite_result(func):
    """Raise :class:`NonFiniteError` when finite inputs overflow to a non-finite result."""

    signature = inspect.signature(func)

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with np.errstate(over="ignore", invalid="ignore"):  # named below instead
            out = func(*args, **kwargs)
        parts = (out.mass, out.com, out.inertia) if isinstance(out, MassProperties) else (out,)
        if not all(np.isfinite(p).all() for p in parts):
            bound = signature.bind(*args, **kwargs).arguments
            given = ", ".join(f"{k}={describe(v)}" for k, v in bound.items())
            raise NonFiniteError(
                f"{func.__name__} overflowed: the inputs ({given}) are finite but the result is "
                "not; rescale the units"
            )
        return out

    return wrapper


# --------------------------------------------------------------------------- checks and transforms


def validate(inertia, *, name: str = "inertia") -> np.ndarray:
    """Check that ``inertia`` (3, 3) is a physically valid, invertible rigid-body inertia.

    Rules: shape (3, 3); finite; symmetric; positive definite (every principal moment > 0);
    principal moments obey the triangle inequality ``I1 + I2 >= I3`` (equality, a flat lamina,
    is accepted). Returns the tensor as a float array (symmetrised to round-off). Raises
    :class:`InvalidInertiaError` naming the rule.
    """
    try:
        arr = check.finite_array(name, inertia)
    except InvalidParameterError as exc:
        raise InvalidInertiaError(str(exc)) from None
    if arr.shape != (3, 3):
        raise InvalidInertiaError(f"{name} must have shape (3, 3), got shape {arr.shape}")
    scale = float(np.abs(arr).max())
    if scale == 0.0:
        raise InvalidInertiaError(f"{name} is all zeros; a rigid body needs positive moments")
    asym = float(np.abs(arr - arr.T).max())
    if asym > _RTOL * scale:
        raise InvalidInertiaError(
            f"{name} must be symmetric, got {describe(arr)} (max |I - Iᵀ| = {asym:.3g})"
        )
    arr = _symmetrised(arr)
    # Eigenvalues of the tensor divided by its largest entry: no overflow near 1e308.
    moments = np.linalg.eigvalsh(arr / scale) * scale
    if moments[0] <= _RTOL * scale:
        raise InvalidInertiaError(
            f"{name} is not positive definite: principal moments {describe(moments)}, and every "
            "one must be > 0. A zero or negative moment (a thin rod, a point mass, or a sign "
            "error) has no inverse, so angular acceleration I⁻¹τ is undefined"
        )
    if moments[0] + moments[1] < moments[2] * (1.0 - _RTOL):
        raise InvalidInertiaError(
            f"{name} principal moments {describe(moments)} break the triangle inequality "
            f"I1 + I2 >= I3 ({moments[0] + moments[1]:.6g} < {moments[2]:.6g}); no mass "
            "distribution has this inertia"
        )
    return arr


def _symmetrised(arr: np.ndarray) -> np.ndarray:
    """``(A + Aᵀ)/2``, halving first only when the sum would overflow."""
    sym = 0.5 * (arr + arr.T)
    return sym if np.isfinite(sym).all() else 0.5 * arr + 0.5 * arr.T


def _require_symmetric(name: str, arr: np.ndarray, scale: float) -> None:
    """Raise :class:`InvalidInertiaError` unless ``arr`` is symmetric within _RTOL·scale."""
    unit = arr / scale if scale > 0.0 else arr  # divided first: no overflow near 1e308
    asym = float(np.abs(unit - unit.T).max())
    if asym > _RTOL:
        raise InvalidInertiaError(
            f"{name} must be symmetric (max |A − Aᵀ| <= {_RTOL} of the largest entry), got "
            f"{describe(arr)} (max |A − Aᵀ| = {asym * (scale or 1.0):.3g})")


def principal_axes(inertia) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and axes of a symmetric (3, 3) tensor.

    Returns ``(moments, R)``: moments (3,) ascending; R (3, 3) a proper rotation (det +1) whose
    columns are the principal axes in body coordinates, so ``inertia == R @ diag(moments) @ R.T``.
    A tensor that is not symmetric (max |A − Aᵀ| above 1e-9 of its largest entry, the tolerance
    of :func:`validate`) raises :class:`InvalidInertiaError`: eigh would silently read only
    one triangle of it.
    """
    arr = check.array("inertia", inertia, (3, 3))
    scale = float(np.abs(arr).max())
    _require_symmetric("inertia", arr, scale)
    if 1e-150 < scale < 1e150:
        moments, R = np.linalg.eigh(0.5 * (arr + arr.T))
    else:  # near over- or underflow: decompose the tensor divided by its largest entry
        scale = scale or 1.0
        moments, R = np.linalg.eigh(_symmetrised(arr / scale))
        moments = moments * scale
    if np.linalg.det(R) < 0:
        R[:, 2] = -R[:, 2]
    return moments, R


@_finite_result
def parallel_axis(inertia_com, mass: float, offset) -> np.ndarray:
    """Inertia about a point displaced by ``offset`` (m, (3,)) from the centre of mass.

    ``I_P = I_C + m (|d|² E − d dᵀ)``. inertia_com: (3, 3) about the centre of mass; mass in kg.
    To move between two points neither of which is the centre of mass, go through it.
    """
    d = check.array("offset", offset, (3,))
    J = check.array("inertia_com", inertia_com, (3, 3))
    m = check.number("mass", mass, low=0.0)
    return J + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))


# --------------------------------------------------------------------------- closed forms


@_finite_result
def solid_sphere(mass: float, radius: float) -> np.ndarray:
    """Uniform solid sphere: ``(2/5) m r² E``. mass in kg, radius in m."""
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    return 0.4 * m * r * r * np.eye(3)


@_finite_result
def hollow_sphere(mass: float, radius: float) -> np.ndarray:
    """Thin spherical shell: ``(2/3) m r² E``. mass in kg, radius in m."""
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    return (2.0 / 3.0) * m * r * r * np.eye(3)


@_finite_result
def solid_box(mass: float, size) -> np.ndarray:
    """Uniform solid box: ``I_xx = m (h² + d²) / 12``, cyclic. size = (w, h, d) FULL extents, m."""
    m = check.positive("mass", mass)
    w2, h2, d2 = _size3(size) ** 2
    return (m / 12.0) * np.diag([h2 + d2, w2 + d2, w2 + h2])


@_finite_result
def hollow_box(mass: float, size) -> np.ndarray:
    """Closed thin-walled box (six plates, uniform areal density): the correct tensor.

    size = (w, h, d), FULL extents along body x, y, z (m). With ``S = wh + wd + hd``,
    ``I_xx = m [hd(h²+d²) + wd(3h²+d²) + wh(h²+3d²)] / (12 S)``, cyclic; a cube gives
    ``(5/18) m a²``. Each plate adds its own in-plane moment and the parallel-axis term of its
    offset ``±extent/2``; plates share the mass in proportion to their area.
    """
    m = check.positive("mass", mass)
    w, h, d = _size3(size)
    area = w * h + w * d + h * d
    moments = [_hollow_box_sum(w, h, d), _hollow_box_sum(h, d, w), _hollow_box_sum(d, w, h)]
    return m * np.diag(moments) / (12.0 * area)


def _hollow_box_sum(along: float, b: float, c: float) -> float:
    """``12 S I / m`` of a closed thin box about the axis of extent ``along``; b, c: the others."""
    end_plates = b * c * (b * b + c * c)  # the two plates normal to the axis
    side_plates = along * c * (3 * b * b + c * c) + along * b * (b * b + 3 * c * c)
    return end_plates + side_plates


@_finite_result
def lecture_hollow_box(mass: float, size) -> np.ndarray:
    """The lecture's hollow box ``(5/3) m (h² + d²)``, cyclic. WRONG: do not use for physics.

    size = (w, h, d) FULL extents (m). Kept only so tests and benchmarks can show the error: for
    a cube it gives ``(10/3) m a²``, 12× the correct ``(5/18) m a²`` of :func:`hollow_box`, and
    the lecture's own particle Challenge (:func:`box_particles` with ``surface=True``) converges
    to :func:`hollow_box`, not to this.
    """
    m = check.positive("mass", mass)
    w2, h2, d2 = _size3(size) ** 2
    return (5.0 / 3.0) * m * np.diag([h2 + d2, w2 + d2, w2 + h2])


@_finite_result
def solid_cylinder(mass: float, radius: float, height: float) -> np.ndarray:
    """Uniform solid cylinder, symmetry axis body z: ``m(3r² + h²)/12``, ``m r²/2``. Units kg, m."""
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    h = check.positive("height", height)
    transverse = m * (3.0 * r * r + h * h) / 12.0
    return np.diag([transverse, transverse, 0.5 * m * r * r])


@_finite_result
def hollow_cylinder(mass: float, radius: float, height: float) -> np.ndarray:
    """Closed thin-walled cylinder (tube + two end discs, uniform areal density), axis body z.

    mass kg, radius and height m. Returns (3, 3) kg·m² about the centre. The tube (area 2πrh)
    contributes ``m_t r²`` axially and ``m_t (r²/2 + h²/12)`` transversally; each disc (area
    πr²) ``m_d r²/2`` and ``m_d (r²/4 + h²/4)``; mass is shared in proportion to area.
    """
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    h = check.positive("height", height)
    tube_area, disc_area = 2.0 * np.pi * r * h, np.pi * r * r
    m_t = m * tube_area / (tube_area + 2.0 * disc_area)
    m_d = 0.5 * (m - m_t)
    axial = m_t * r**2 + 2.0 * m_d * 0.5 * r**2
    transverse = m_t * (0.5 * r**2 + h**2 / 12.0) + 2.0 * m_d * (0.25 * r**2 + 0.25 * h**2)
    return np.diag([transverse, transverse, axial])


@_finite_result
def solid_cone(mass: float, radius: float, height: float, about: str = "apex") -> np.ndarray:
    """Uniform solid cone, axis body z, base radius ``radius`` (m), height ``height`` (m).

    ``about="apex"``: ``I_xx = (3/5) m h² + (3/20) m r²`` (the lecture's form);
    ``about="com"``: ``I_xx = (3/80) m h² + (3/20) m r²``; the centre of mass lies on the axis
    ``3h/4`` from the apex. ``I_zz = (3/10) m r²`` for both.
    """
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    h = check.positive("height", height)
    about = check.choice("about", about, ("apex", "com"))
    axial_factor = {"apex": 3.0 / 5.0, "com": 3.0 / 80.0}[about]
    transverse = axial_factor * m * h * h + 0.15 * m * r * r
    return np.diag([transverse, transverse, 0.3 * m * r * r])


@_finite_result
def rod(mass: float, length: float, about: str = "center") -> np.ndarray:
    """Thin rod along body z: ``m L²/12`` (``about="center"``) or ``m L²/3`` (``"end"``); I_zz = 0.

    mass in kg, length in m. The tensor is singular (positive semi-definite, not definite): it is
    returned for composition with other parts, but :func:`validate` rejects it because a body
    with a zero moment has no ``I⁻¹``.
    """
    m, length = check.positive("mass", mass), check.positive("length", length)
    about = check.choice("about", about, ("center", "end"))
    factor = {"center": 1.0 / 12.0, "end": 1.0 / 3.0}[about]
    moment = factor * m * length * length
    return np.diag([moment, moment, 0.0])


def _size3(size) -> np.ndarray:
    """Full extents (w, h, d) as a (3,) array of finite, strictly positive floats."""
    a = check.array("size", size, (3,))
    if (a <= 0).any():
        raise InvalidParameterError(
            f"size must be 3 finite full extents (w, h, d) > 0 in m, got {describe(a)}"
        )
    return a


# --------------------------------------------------------------------------- particles


@_finite_result
def from_particles(masses, positions) -> MassProperties:
    """Mass, centre of mass and inertia about it of a rigid set of point masses.

    masses: (n,) kg, >= 0 with a positive sum (a scalar is broadcast); positions: (n, 3) m.
    One vectorised pass accumulates Σm, Σm x and Σm x xᵀ (the lecture's "minimise loops"), then
    shifts the second moment to the centre of mass and forms ``I = tr(C) E − C``.
    """
    x = check.finite_array("positions", positions)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) == 0:
        raise InvalidParameterError(f"positions must have shape (n >= 1, 3), got shape {x.shape}")
    m = check.finite_array("masses", masses)
    if m.ndim > 1 or (m.ndim == 1 and len(m) != len(x)):
        raise InvalidParameterError(
            f"masses must be a scalar or have shape ({len(x)},) to match positions, got {m.shape}"
        )
    m = np.broadcast_to(m, (len(x),))
    if (m < 0).any():
        i = int(np.argmax(m < 0))
        raise InvalidParameterError(f"masses must be >= 0, got masses[{i}] = {m[i]!r}")
    total = float(m.sum())
    if total <= 0.0:
        raise InvalidParameterError(f"masses must have a positive sum, got {total!r}")
    # Sums are taken about one of the particles, not the origin: algebraically the same, but it
    # avoids cancellation in Σm x xᵀ − M c cᵀ when the body sits far from the origin.
    ref = x[0]
    r = x - ref
    first = m @ r
    second = np.einsum("n,ni,nj->ij", m, r, r)
    d = first / total
    return _mass_properties(total, ref + d, second - total * np.outer(d, d))


def _mass_properties(mass: float, com: np.ndarray, second_moment: np.ndarray) -> MassProperties:
    """Pack mass properties from the second moment ``C = Σ m r rᵀ`` about the centre of mass."""
    c = 0.5 * (second_moment + second_moment.T)
    return MassProperties(float(mass), com, np.trace(c) * np.eye(3) - c)


def box_particles(
    mass: float, size, n: int, surface: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Particles sampling a uniform box centred at the origin: the lecture's Challenge.

    size = (w, h, d) FULL extents (m); n cells along every edge. ``surface=False``: n³
    cell-centred points filling the box, equal masses. ``surface=True``: n² cell-centred points
    on each of the six faces, each weighted by its cell area (faces differ in area), so the sum
    tends to :func:`hollow_box`. Returns ``(masses (N,) kg, positions (N, 3) m)``; the masses sum
    to ``mass``. The midpoint rule makes the error in every moment exactly ∝ 1/n².
    """
    m, a = check.positive("mass", mass), _size3(size)
    n = _count("n", n)
    ticks = [(np.arange(n) + 0.5) / n * ai - 0.5 * ai for ai in a]
    if not surface:
        grid = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1).reshape(-1, 3)
        return np.full(len(grid), m / len(grid)), grid
    positions, areas = [], []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        uj, uk = np.meshgrid(ticks[j], ticks[k], indexing="ij")
        for side in (-0.5, 0.5):
            p = np.empty((n * n, 3))
            p[:, i], p[:, j], p[:, k] = side * a[i], uj.ravel(), uk.ravel()
            positions.append(p)
            areas.append(np.full(n * n, a[j] * a[k] / (n * n)))
    w = np.concatenate(areas)
    return m * w / w.sum(), np.concatenate(positions)


def sphere_particles(
    mass: float, radius: float, n: int, surface: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Particles sampling a uniform sphere centred at the origin: the lecture's Challenge.

    radius in m; n sets the resolution. ``surface=True``: n equal-area bands in z (Archimedes: a
    band's area depends only on its height), each carrying equally spaced points at its mid-height,
    about as many as keep the spacing uniform; every point is weighted by its share of the band's
    area. ``surface=False``: n spherical shells of equal thickness, shell i carrying that lattice
    (with ~π(i + ½) bands, so spacing stays ≈ r/n) at its mid-radius, weighted by the shell's exact
    mass. Returns ``(masses (N,) kg, positions (N, 3) m)``; masses sum to ``mass``; errors ∝ 1/n².
    """
    m, r = check.positive("mass", mass), check.positive("radius", radius)
    n = _count("n", n)
    if surface:
        w, u = _sphere_lattice(n)
        return m * w, r * u
    edges = np.arange(n + 1) / n
    shell_mass = np.diff(edges**3)  # exact fraction of the ball between consecutive radii
    parts = [_sphere_lattice(max(1, round(np.pi * (i + 0.5)))) for i in range(n)]
    masses = np.concatenate([shell_mass[i] * w for i, (w, _) in enumerate(parts)])
    mid = 0.5 * (edges[:-1] + edges[1:])
    positions = np.concatenate([mid[i] * u for i, (_, u) in enumerate(parts)])
    return m * masses, r * positions


def _sphere_lattice(n_bands: int) -> tuple[np.ndarray, np.ndarray]:
    """Weights (N,) summing to 1 and unit vectors (N, 3) on n_bands equal-area z-bands.

    Each band gets ``M >= 3`` equally spaced azimuths: then Σcos²φ = M/2 and Σ sinφcosφ = 0
    exactly, so the only error is the midpoint rule in z.
    """
    z_edges = np.linspace(-1.0, 1.0, n_bands + 1)
    z = 0.5 * (z_edges[:-1] + z_edges[1:])
    band_arc = np.abs(np.diff(np.arccos(z_edges)))
    rho = np.sqrt(1.0 - z * z)
    counts = np.maximum(3, np.round(2.0 * np.pi * rho / band_arc).astype(int))
    band = np.repeat(np.arange(n_bands), counts)
    slot = np.arange(len(band)) - np.repeat(np.cumsum(counts) - counts, counts)
    phi = 2.0 * np.pi * (slot + 0.5 * (band % 2)) / counts[band]
    u = np.stack([rho[band] * np.cos(phi), rho[band] * np.sin(phi), z[band]], axis=-1)
    return 1.0 / (n_bands * counts[band]), u


def _count(name: str, value) -> int:
    return check.count(name, value, low=1, high=MAX_PARTICLE_N)


# --------------------------------------------------------------------------- meshes


@_finite_result
def from_mesh(vertices, faces, *, mass=None, density=None, shell: bool = False) -> MassProperties:
    """Exact mass properties of a uniform solid (or thin shell) bounded by a triangle mesh.

    vertices: (V, 3) m; faces: (F, 3) vertex indices, counter-clockwise seen from outside. Give
    exactly one of ``mass`` (kg) or ``density`` (kg/m³ for a solid, kg/m² for a shell).
    Solid: signed tetrahedra from a reference point (divergence theorem, as in Eberly's and
    MuJoCo's "exact" mode); the mesh must be closed and consistently oriented with positive
    volume, else :class:`MeshError` says which rule broke. ``shell=True``: exact second moments of
    each triangle of uniform areal density; open and unoriented surfaces are fine.
    """
    v, f = check_mesh_arrays(vertices, faces)
    if (mass is None) == (density is None):
        raise InvalidParameterError(
            f"give exactly one of mass= or density=, got mass={mass!r}, density={density!r}"
        )
    # Integrate about the vertex centroid rather than the origin: exact either way for a closed
    # surface, and far better conditioned for a mesh placed far from the origin.
    used = np.unique(f)
    if len(used) < len(v):  # vertices no face uses carry no mass: leave them out entirely
        v, f = v[used], np.searchsorted(used, f)
    ref = v.mean(axis=0)
    a, b, c = (v[f[:, k]] - ref for k in range(3))
    if shell:
        measure, first, second = _shell_integrals(a, b, c)
    else:
        check_closed_oriented(f, len(v))
        measure, first, second = _solid_integrals(a, b, c)
        _check_volume(measure, v)
    if measure <= 0.0:
        raise MeshError(f"mesh surface area must be > 0, got {measure!r} m²")
    if density is None:
        total = check.positive("mass", mass)
    else:
        total = check.positive("density", density) * measure
    d = first / measure
    second_com = (total / measure) * second - total * np.outer(d, d)
    return _mass_properties(total, ref + d, second_com)


def _solid_integrals(a, b, c) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, ∫x dV and ∫x xᵀ dV from tetrahedra (0, a, b, c); a, b, c: (F, 3)."""
    det = np.einsum("fi,fi->f", a, np.cross(b, c))
    s = a + b + c
    second = sum(np.einsum("f,fi,fj->ij", det, p, p) for p in (a, b, c, s))
    return det.sum() / 6.0, det @ s / 24.0, second / 120.0


def _shell_integrals(a, b, c) -> tuple[float, np.ndarray, np.ndarray]:
    """Area, ∫x dA and ∫x xᵀ dA over triangles (a, b, c); a, b, c: (F, 3)."""
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    s = a + b + c
    second = sum(np.einsum("f,fi,fj->ij", area, p, p) for p in (a, b, c, s))
    return area.sum(), area @ s / 3.0, second / 12.0


def _check_volume(volume: float, vertices: np.ndarray) -> None:
    box = float(np.prod(np.ptp(vertices, axis=0)))
    if volume < -_FLAT_RTOL * box:
        raise MeshError(
            f"mesh is inside-out: signed volume {volume:.6g} m³ < 0, so its faces are wound "
            "clockwise seen from outside (normals point inward); reverse every face, "
            "e.g. faces[:, ::-1]"
        )
    if volume <= _FLAT_RTOL * box:
        raise MeshError(
            f"mesh encloses zero volume ({volume:.3g} m³): it is flat or degenerate; a solid "
            "needs volume > 0 (use shell=True for a surface)"
        )
