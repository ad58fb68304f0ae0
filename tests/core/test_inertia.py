"""Inertia tensors: closed forms, the lecture's particle Challenge, meshes and validity checks.

References are independent of the code under test where possible: hand-derived values, the
lecture's per-particle component formulas in a plain loop, composition of plates with the
parallel-axis theorem, monomial integrals over a simplex, and fine polygonal meshes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rbenv.core import inertia, mesh
from rbenv.core.errors import InvalidInertiaError, InvalidParameterError, NonFiniteError
from rbenv.core.inertia import MeshError

DATA = Path(__file__).parent / "data"


# --------------------------------------------------------------------------- helpers


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """Uniform random proper rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def box_mesh(size):
    """Box centred at the origin: (vertices (8, 3), triangles (12, 3), quads (6, 4)), outward."""
    signs = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    index = {tuple(s): n for n, s in enumerate(signs.tolist())}
    quads = []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        for side in (-1, 1):
            quad = []
            for sj, sk in ((-1, -1), (1, -1), (1, 1), (-1, 1)):  # counter-clockwise about e_i
                s = [0, 0, 0]
                s[i], s[j], s[k] = side, sj, sk
                quad.append(index[tuple(s)])
            quads.append(quad if side > 0 else quad[::-1])
    quads = np.array(quads)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return 0.5 * signs * np.asarray(size, dtype=float), triangles, quads


def icosphere(subdivisions: int):
    """Unit icosphere: vertices on the sphere, outward-wound triangles."""
    t = (1 + 5**0.5) / 2
    # fmt: off
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    # fmt: on
    verts = [np.array(p, dtype=float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        cache, new = {}, []

        def mid(a, b, cache=cache):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = verts[a] + verts[b]
                verts.append(p / np.linalg.norm(p))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = new
    verts, faces = np.array(verts), np.array(f)
    tri = verts[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = np.einsum("fi,fi->f", normals, tri.sum(axis=1)) > 0
    assert outward.all()
    return verts, faces


def polygon_cone_mesh(radius, height, sides, apex_height=None):
    """Pyramid (apex_height given) or prism over a regular polygon inscribed in the circle."""
    phi = 2 * np.pi * np.arange(sides) / sides
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi), np.zeros(sides)], axis=-1)
    k = np.arange(sides)
    nxt = (k + 1) % sides
    centre_lo = sides
    if apex_height is not None:
        verts = np.vstack([ring, [0, 0, 0], [0, 0, apex_height]])
        apex = sides + 1
        mantle = np.stack([k, nxt, np.full(sides, apex)], 1)
        base = np.stack([nxt, k, np.full(sides, centre_lo)], 1)
        faces = np.concatenate([mantle, base])
        return verts, faces
    top = ring + np.array([0.0, 0.0, height])
    verts = np.vstack([ring, top, [0, 0, 0], [0, 0, height]])
    lo, hi = 2 * sides, 2 * sides + 1
    walls = [np.stack([k, nxt, nxt + sides], 1), np.stack([k, nxt + sides, k + sides], 1)]
    bottom = np.stack([nxt, k, np.full(sides, lo)], 1)
    top_cap = np.stack([k + sides, nxt + sides, np.full(sides, hi)], 1)
    faces = np.concatenate([*walls, bottom, top_cap])
    return verts, faces


def rel_err(a, b) -> float:
    return float(np.abs(np.asarray(a) - b).max() / np.abs(b).max())


def write_ascii_stl(path, vertices, faces):
    lines = ["solid test"]
    for tri in vertices[faces]:
        lines += ["facet normal 0 0 0", " outer loop"]
        lines += [f"  vertex {x!r} {y!r} {z!r}" for x, y, z in tri.tolist()]
        lines += [" endloop", "endfacet"]
    path.write_text("\n".join([*lines, "endsolid test", ""]))


def write_binary_stl(path, vertices, faces):
    record = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    data = np.zeros(len(faces), record)
    data["v"] = vertices[faces]
    header = b"solid but actually binary".ljust(80, b" ")  # must not fool the reader
    path.write_bytes(header + np.uint32(len(faces)).tobytes() + data.tobytes())


# --------------------------------------------------------------------------- closed forms


def test_spheres_and_solid_box_match_textbook_values():
    np.testing.assert_allclose(inertia.solid_sphere(2.0, 3.0), 0.4 * 2 * 9 * np.eye(3))
    np.testing.assert_allclose(inertia.hollow_sphere(2.0, 3.0), 12.0 * np.eye(3))
    np.testing.assert_allclose(inertia.solid_box(6.0, (1, 2, 3)), np.diag([6.5, 5.0, 2.5]))
    np.testing.assert_allclose(inertia.solid_box(3.0, (2, 2, 2)), np.eye(3) * 3 * 4 / 6)


def test_hollow_box_known_values_and_cube():
    np.testing.assert_allclose(
        np.diag(inertia.hollow_box(1.0, (1, 2, 3))), [1.537879, 1.196970, 0.689394], atol=5e-7
    )
    np.testing.assert_allclose(inertia.hollow_box(2.0, (3, 3, 3)), 5 / 18 * 2 * 9 * np.eye(3))


def test_hollow_box_plate_limit_is_two_stacked_plates():
    # d -> 0: top and bottom plates coincide, a solid plate of mass m: I_xx = m h²/12, etc.
    m, w, h = 2.0, 1.5, 0.7
    got = inertia.hollow_box(m, (w, h, 1e-9))
    np.testing.assert_allclose(np.diag(got), [m * h**2 / 12, m * w**2 / 12, m * (w**2 + h**2) / 12])


@pytest.mark.parametrize("size", [(1, 2, 3), (0.3, 0.3, 2.0), (5.0, 0.1, 0.7)])
def test_hollow_box_equals_six_plates_composed_by_parallel_axis(size):
    m, (w, h, d) = 3.0, size
    area = w * h + w * d + h * d
    t = 1e-12  # plate thickness; its contribution is O(t²)
    total = np.zeros((3, 3))
    for axis, dims in enumerate([(t, h, d), (w, t, d), (w, h, t)]):
        plate_area = np.prod([x for x in dims if x != t])
        plate_mass = m * plate_area / (2 * area)
        for side in (-0.5, 0.5):
            offset = np.zeros(3)
            offset[axis] = side * size[axis]
            total += inertia.parallel_axis(inertia.solid_box(plate_mass, dims), plate_mass, offset)
    np.testing.assert_allclose(inertia.hollow_box(m, size), total, rtol=1e-12, atol=1e-15)


def test_lecture_hollow_box_is_its_formula_and_twelve_times_too_big_for_a_cube():
    m, (w, h, d) = 2.0, (1.0, 2.0, 3.0)
    lecture = inertia.lecture_hollow_box(m, (w, h, d))
    np.testing.assert_allclose(
        np.diag(lecture), 5 / 3 * m * np.array([h**2 + d**2, w**2 + d**2, w**2 + h**2])
    )
    cube = [np.diag(f(1.0, (1, 1, 1))) for f in (inertia.lecture_hollow_box, inertia.hollow_box)]
    np.testing.assert_allclose(cube[0] / cube[1], 12.0)


def test_cylinder_and_cone_values():
    m, r, h = 2.0, 0.5, 3.0
    np.testing.assert_allclose(
        inertia.solid_cylinder(m, r, h), np.diag([2 * (0.75 + 9) / 12] * 2 + [0.25])
    )
    apex = inertia.solid_cone(m, r, h, about="apex")
    com = inertia.solid_cone(m, r, h, about="com")
    np.testing.assert_allclose(
        np.diag(apex), [3 / 5 * m * h**2 + 3 / 20 * m * r**2] * 2 + [3 / 10 * m * r**2]
    )
    np.testing.assert_allclose(
        np.diag(com), [3 / 80 * m * h**2 + 3 / 20 * m * r**2] * 2 + [3 / 10 * m * r**2]
    )
    # The centre of mass of a cone lies 3h/4 from its apex: shifting there recovers the apex form.
    np.testing.assert_allclose(inertia.parallel_axis(com, m, [0, 0, 0.75 * h]), apex)
    assert np.array_equal(inertia.solid_cone(m, r, h), apex)


def test_cylinder_and_cone_agree_with_fine_polygonal_meshes():
    m, r, h, sides = 2.0, 0.5, 3.0, 4096  # inscribed polygon: relative error ~ (2π/sides)²
    prism = inertia.from_mesh(*polygon_cone_mesh(r, h, sides), mass=m)
    np.testing.assert_allclose(prism.com, [0, 0, h / 2], atol=1e-12)
    np.testing.assert_allclose(
        prism.inertia, inertia.solid_cylinder(m, r, h), rtol=2e-6, atol=1e-12
    )
    # Apex at z = h, base at z = 0: the centre of mass is at h/4, i.e. 3h/4 below the apex.
    cone = inertia.from_mesh(*polygon_cone_mesh(r, h, sides, apex_height=h), mass=m)
    np.testing.assert_allclose(cone.com, [0, 0, h / 4], atol=1e-12)
    np.testing.assert_allclose(
        cone.inertia, inertia.solid_cone(m, r, h, about="com"), rtol=2e-6, atol=1e-12
    )


def test_rod_values_singular_and_consistent():
    m, length = 3.0, 2.0
    centre = inertia.rod(m, length)
    end = inertia.rod(m, length, about="end")
    np.testing.assert_allclose(centre, np.diag([1.0, 1.0, 0.0]))
    np.testing.assert_allclose(end, np.diag([4.0, 4.0, 0.0]))
    np.testing.assert_allclose(inertia.parallel_axis(centre, m, [0, 0, length / 2]), end)
    thin_box = inertia.solid_box(m, (1e-9, 1e-9, length))
    np.testing.assert_allclose(centre, thin_box, atol=1e-15)
    with pytest.raises(InvalidInertiaError, match="not positive definite"):
        inertia.validate(centre)


@pytest.mark.parametrize(
    ("call", "field", "value"),
    [
        (lambda: inertia.solid_sphere(0.0, 1.0), "mass", "0.0"),
        (lambda: inertia.solid_sphere(1.0, -2.0), "radius", "-2.0"),
        (lambda: inertia.hollow_sphere(float("nan"), 1.0), "mass", "nan"),
        (lambda: inertia.solid_box(1.0, (1.0, 0.0, 1.0)), "size", "0."),
        (lambda: inertia.solid_box(1.0, (1.0, 2.0)), "size", "2."),
        (lambda: inertia.hollow_box(1.0, (1.0, -2.0, 3.0)), "size", "-2."),
        (lambda: inertia.lecture_hollow_box(-1.0, (1, 1, 1)), "mass", "-1.0"),
        (lambda: inertia.solid_cylinder(1.0, 1.0, 0.0), "height", "0.0"),
        (lambda: inertia.solid_cone(1.0, 1.0, 1.0, about="base"), "about", "'base'"),
        (lambda: inertia.rod(1.0, 1.0, about="tip"), "about", "'tip'"),
        (lambda: inertia.rod(1.0, -1.0), "length", "-1.0"),
        (lambda: inertia.box_particles(1.0, (1, 1, 1), 0), "n", "0"),
        (lambda: inertia.sphere_particles(1.0, 1.0, 2.5), "n", "2.5"),
        (lambda: inertia.from_particles([1.0, -1.0], np.zeros((2, 3))), "masses", "-1.0"),
        (lambda: inertia.from_particles([0.0, 0.0], np.zeros((2, 3))), "masses", "0.0"),
        (lambda: inertia.from_particles([1.0], np.zeros((2, 3))), "masses", "(1,)"),
        (lambda: inertia.from_particles([1.0], np.zeros(3)), "positions", "(3,)"),
    ],
)
def test_bad_parameters_raise_with_field_and_value(call, field, value):
    with pytest.raises(InvalidParameterError) as info:
        call()
    assert field in str(info.value) and value in str(info.value)


def test_non_finite_positions_rejected():
    with pytest.raises(NonFiniteError, match="positions"):
        inertia.from_particles([1.0, 1.0], [[0, 0, 0], [np.nan, 0, 0]])


# ------------------------------------------------------------------ validate, principal axes


def test_validate_accepts_valid_and_boundary_tensors():
    rng = np.random.default_rng(0)
    R = random_rotation(rng)
    rotated = R @ np.diag([1.0, 2.0, 2.5]) @ R.T
    np.testing.assert_allclose(inertia.validate(rotated), rotated, atol=1e-15)
    inertia.validate(np.diag([1.0, 2.0, 3.0]))  # I1 + I2 == I3: a flat lamina, allowed
    inertia.validate(inertia.hollow_box(1.0, (1.0, 2.0, 1e-9)))  # real flat lamina
    inertia.validate(inertia.solid_cone(1.0, 0.2, 1.0))


@pytest.mark.parametrize(
    ("tensor", "rule"),
    [
        (np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
        (np.array([[2.0, 0.1, 0], [0.0, 2, 0], [0, 0, 2]]), "symmetric"),
        (np.diag([1.0, np.nan, 1.0]), "finite"),
        (np.array([[1.0, 2, 0], [2, 1, 0], [0, 0, 1]]), "not positive definite"),  # eig -1, 1, 3
        (np.diag([1.0, 1.0, 0.0]), "not positive definite"),
        (np.zeros((3, 3)), "zeros"),
        (np.eye(2), "shape"),
    ],
)
def test_validate_rejects_invalid_tensors(tensor, rule):
    with pytest.raises(InvalidInertiaError, match=rule):
        inertia.validate(tensor)


def test_validate_triangle_inequality_under_rotation():
    R = random_rotation(np.random.default_rng(1))
    # Diagonal entries of the rotated tensor look harmless; the eigenvalues do not.
    with pytest.raises(InvalidInertiaError, match="triangle"):
        inertia.validate(R @ np.diag([1.0, 1.0, 3.0]) @ R.T)


def test_principal_axes_ascending_proper_and_reconstructing():
    rng = np.random.default_rng(2)
    for _ in range(20):  # enough draws that eigh returns left-handed bases too
        R = random_rotation(rng)
        moments_true = np.sort(rng.uniform(1.0, 2.0, 3))
        tensor = R @ np.diag(moments_true[rng.permutation(3)]) @ R.T
        moments, axes = inertia.principal_axes(tensor)
        np.testing.assert_allclose(moments, moments_true, rtol=1e-12)
        assert np.isclose(np.linalg.det(axes), 1.0)
        np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, tensor, atol=1e-13)


# --------------------------------------------------------------------------- particles


def lecture_loop(masses, positions):
    """The lecture's construction, particle by particle: M, c_m, then the six components."""
    total, moment = 0.0, np.zeros(3)
    for m, x in zip(masses, positions, strict=True):
        total += m
        moment += m * x
    com = moment / total
    ixx = iyy = izz = ixy = iyz = izx = 0.0
    for m, x in zip(masses, positions, strict=True):
        a, b, c = x - com
        ixx += m * (b * b + c * c)
        iyy += m * (c * c + a * a)
        izz += m * (a * a + b * b)
        ixy -= m * a * b
        iyz -= m * b * c
        izx -= m * c * a
    tensor = np.array([[ixx, ixy, izx], [ixy, iyy, iyz], [izx, iyz, izz]])
    return total, com, tensor


def test_from_particles_matches_lecture_component_loop():
    rng = np.random.default_rng(3)
    masses = rng.uniform(0.1, 2.0, 200)
    positions = rng.normal(size=(200, 3)) * [1.0, 2.0, 0.5] + [3.0, -1.0, 2.0]
    props = inertia.from_particles(masses, positions)
    total, com, tensor = lecture_loop(masses, positions)
    assert props.mass == pytest.approx(total, rel=1e-14)
    np.testing.assert_allclose(props.com, com, rtol=1e-13)
    np.testing.assert_allclose(props.inertia, tensor, rtol=1e-12, atol=1e-12)
    inertia.validate(props.inertia)


def test_from_particles_parallel_axis_and_translation():
    rng = np.random.default_rng(4)
    masses, positions = rng.uniform(0.5, 1.0, 50), rng.normal(size=(50, 3))
    props = inertia.from_particles(masses, positions)
    # About the origin, by the definition Σ m (|x|² E − x xᵀ):
    sq = np.einsum("ni,ni->n", positions, positions)
    per_particle = sq[:, None, None] * np.eye(3) - np.einsum("ni,nj->nij", positions, positions)
    about_origin = np.einsum("n,nij->ij", masses, per_particle)
    np.testing.assert_allclose(
        inertia.parallel_axis(props.inertia, props.mass, props.com), about_origin, rtol=1e-12
    )
    shift = np.array([5.0, -7.0, 11.0])
    moved = inertia.from_particles(masses, positions + shift)
    np.testing.assert_allclose(moved.com, props.com + shift, rtol=1e-13)
    np.testing.assert_allclose(moved.inertia, props.inertia, rtol=1e-11, atol=1e-12)


def test_from_particles_stays_accurate_far_from_origin():
    # Σm x xᵀ − M c cᵀ about the origin would cancel ~14 digits here and lose the answer.
    rng = np.random.default_rng(5)
    masses, positions = rng.uniform(0.5, 1.0, 100), rng.normal(size=(100, 3))
    _, _, near = lecture_loop(masses, positions)
    far = inertia.from_particles(masses, positions + 1e7)
    np.testing.assert_allclose(far.inertia, near, rtol=1e-6, atol=1e-6 * np.abs(near).max())


def test_from_particles_scalar_mass_broadcasts():
    props = inertia.from_particles(0.5, [[1, 0, 0], [-1, 0, 0]])
    assert props.mass == 1.0
    np.testing.assert_allclose(props.inertia, np.diag([0.0, 1.0, 1.0]))


# --------------------------------------------------------------------------- the Challenge


RESOLUTIONS = (2, 4, 8, 16)


def challenge_errors(sampler, exact, *args, surface):
    errors = []
    for n in RESOLUTIONS:
        masses, positions = sampler(*args, n, surface=surface)
        props = inertia.from_particles(masses, positions)
        assert props.mass == pytest.approx(args[0], rel=1e-13)
        np.testing.assert_allclose(props.com, 0.0, atol=1e-13)
        errors.append(rel_err(props.inertia, exact))
    return np.array(errors)


@pytest.mark.parametrize(
    ("sampler", "args", "surface", "exact", "tol"),
    [
        (inertia.box_particles, (2.0, (1.0, 2.0, 3.0)), False, inertia.solid_box, 5e-3),
        (inertia.box_particles, (2.0, (1.0, 2.0, 3.0)), True, inertia.hollow_box, 3e-3),
        (inertia.box_particles, (2.0, (1.0, 1.0, 1.0)), True, inertia.hollow_box, 3e-3),
        (inertia.sphere_particles, (2.0, 0.7), False, inertia.solid_sphere, 3.5e-3),
        (inertia.sphere_particles, (2.0, 0.7), True, inertia.hollow_sphere, 2.5e-3),
    ],
)
def test_challenge_particles_converge_to_closed_form(sampler, args, surface, exact, tol):
    errors = challenge_errors(sampler, exact(*args), *args, surface=surface)
    assert (np.diff(errors) < 0).all(), errors
    assert errors[-1] < tol, errors
    orders = np.log2(errors[:-1] / errors[1:])  # midpoint rule: second order
    np.testing.assert_allclose(orders, 2.0, atol=0.15)


def test_challenge_exposes_the_lecture_hollow_box():
    # The lecture's own construction (particles on the box surface) converges to hollow_box and
    # lands a factor ~12 below the lecture's (5/3) m (h² + d²) for a cube.
    for size, factor in (((1.0, 1.0, 1.0), 12.0), ((1.0, 2.0, 3.0), None)):
        masses, positions = inertia.box_particles(1.0, size, 64, surface=True)
        particles = inertia.from_particles(masses, positions).inertia
        np.testing.assert_allclose(particles, inertia.hollow_box(1.0, size), rtol=1e-3, atol=1e-12)
        ratio = np.diag(inertia.lecture_hollow_box(1.0, size)) / np.diag(particles)
        assert (ratio > 5).all(), ratio
        if factor:
            np.testing.assert_allclose(ratio, factor, rtol=1e-3)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_sphere_surface_particles_error_is_the_midpoint_rule_in_z(n):
    # Equal-area bands: <z²> is the midpoint rule for ∫z² dz/2 = (1 − 1/n²)/3, and equally spaced
    # azimuths (>= 3 per band) average cos²φ to 1/2 exactly, so the tensor is known in closed form.
    masses, positions = inertia.sphere_particles(1.0, 1.0, n, surface=True)
    got = inertia.from_particles(masses, positions).inertia
    expected = np.diag([2 / 3 - 1 / (6 * n**2)] * 2 + [2 / 3 + 1 / (3 * n**2)])
    np.testing.assert_allclose(got, expected, atol=1e-14)


def test_sphere_surface_particles_are_on_the_sphere_and_evenly_weighted_per_area():
    masses, positions = inertia.sphere_particles(3.0, 2.0, 12, surface=True)
    np.testing.assert_allclose(np.linalg.norm(positions, axis=1), 2.0)
    # Equal-area bands carry equal mass (Archimedes), whatever their point count.
    z = np.round(positions[:, 2], 12)
    band_mass = [masses[z == b].sum() for b in np.unique(z)]
    np.testing.assert_allclose(band_mass, 3.0 / 12)


# --------------------------------------------------------------------------- meshes


def test_from_mesh_offset_rotated_box_is_exact():
    rng = np.random.default_rng(6)
    R, offset = random_rotation(rng), np.array([10.0, -20.0, 5.0])
    verts, faces, _ = box_mesh((1.0, 2.0, 3.0))
    moved = verts @ R.T + offset
    props = inertia.from_mesh(moved, faces, mass=6.0)
    assert props.mass == 6.0
    np.testing.assert_allclose(props.com, offset, rtol=0, atol=1e-12)
    expected = R @ inertia.solid_box(6.0, (1, 2, 3)) @ R.T
    np.testing.assert_allclose(props.inertia, expected, rtol=0, atol=1e-12)
    dense = inertia.from_mesh(moved, faces, density=2.0)
    assert dense.mass == pytest.approx(12.0, rel=1e-13)
    np.testing.assert_allclose(dense.inertia, 2 * expected, rtol=0, atol=1e-11)
    shell = inertia.from_mesh(moved, faces, mass=6.0, shell=True)
    np.testing.assert_allclose(shell.com, offset, rtol=0, atol=1e-12)
    shell_expected = R @ inertia.hollow_box(6.0, (1, 2, 3)) @ R.T
    np.testing.assert_allclose(shell.inertia, shell_expected, rtol=0, atol=1e-12)


def test_from_mesh_stays_accurate_far_from_origin():
    # Integrating about the origin would cancel ~12 digits of Σ∫x xᵀ against m c cᵀ here.
    R, offset = random_rotation(np.random.default_rng(7)), np.array([3e6, -1e6, 2e6])
    verts, faces, _ = box_mesh((1.0, 2.0, 3.0))
    props = inertia.from_mesh(verts @ R.T + offset, faces, mass=6.0)
    expected = R @ inertia.solid_box(6.0, (1, 2, 3)) @ R.T
    np.testing.assert_allclose(props.inertia, expected, rtol=0, atol=1e-8)


def test_from_mesh_matches_simplex_monomial_integrals():
    # Unit right tetrahedron: ∫x² dV = 2!/5! = 1/60, ∫xy dV = 1/120, V = 1/6, c = (1/4, 1/4, 1/4).
    verts, faces = inertia.load_mesh(DATA / "unit_tetra.stl")
    props = inertia.from_mesh(verts, faces, density=1.0)
    assert props.mass == pytest.approx(1 / 6, rel=1e-14)
    np.testing.assert_allclose(props.com, 0.25, rtol=1e-14)
    second = np.full((3, 3), 1 / 120) + np.eye(3) * (1 / 60 - 1 / 120)
    second -= (1 / 6) * np.outer(props.com, props.com)
    np.testing.assert_allclose(props.inertia, np.trace(second) * np.eye(3) - second, rtol=1e-13)


def test_shell_accepts_an_open_surface():
    # A single 1.5 × 0.4 rectangle (two triangles) is a plate: solid_box with zero thickness.
    verts = np.array([[-0.75, -0.2, 0], [0.75, -0.2, 0], [0.75, 0.2, 0], [-0.75, 0.2, 0]])
    props = inertia.from_mesh(verts, [[0, 1, 2], [0, 2, 3]], mass=2.0, shell=True)
    np.testing.assert_allclose(props.inertia, inertia.solid_box(2.0, (1.5, 0.4, 1e-12)), atol=1e-14)
    with pytest.raises(MeshError, match="not closed"):
        inertia.from_mesh(verts, [[0, 1, 2], [0, 2, 3]], mass=2.0)


def test_icosphere_converges_to_sphere():
    solid_err, shell_err = [], []
    for level in range(4):
        verts, faces = icosphere(level)
        solid_err.append(
            rel_err(
                inertia.from_mesh(verts, faces, mass=1.0).inertia, inertia.solid_sphere(1.0, 1.0)
            )
        )
        shell_err.append(
            rel_err(
                inertia.from_mesh(verts, faces, mass=1.0, shell=True).inertia,
                inertia.hollow_sphere(1.0, 1.0),
            )
        )
    for errors in (solid_err, shell_err):
        assert (np.diff(errors) < 0).all(), errors
        assert errors[-1] < 1e-2, errors


@pytest.mark.parametrize("fmt", ["ascii_stl", "binary_stl", "obj"])
def test_load_mesh_round_trip(tmp_path, fmt):
    verts, faces, quads = box_mesh((1.0, 2.0, 3.0))
    verts = verts + np.array([0.5, -1.0, 2.0])  # exactly representable in float32 (binary STL)
    if fmt == "obj":
        path = tmp_path / "box.obj"
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in verts.tolist()]
        lines += ["f " + " ".join(str(i + 1) for i in quad) for quad in quads]
        path.write_text("\n".join(lines) + "\n")
    else:
        path = tmp_path / "box.stl"
        (write_ascii_stl if fmt == "ascii_stl" else write_binary_stl)(path, verts, faces)
    loaded_verts, loaded_faces = inertia.load_mesh(path)
    assert loaded_verts.shape == (8, 3) and loaded_faces.shape == (12, 3)
    direct = inertia.from_mesh(verts, faces, mass=6.0)
    loaded = inertia.from_mesh(loaded_verts, loaded_faces, mass=6.0)
    np.testing.assert_allclose(loaded.com, direct.com, atol=1e-14)
    np.testing.assert_allclose(loaded.inertia, direct.inertia, atol=1e-13)


def test_weld_merges_nearly_coincident_corners_and_drops_collapsed_triangles():
    verts, faces, _ = box_mesh((1.0, 2.0, 3.0))
    soup = verts[faces] * (1 + 1e-13 * np.random.default_rng(8).standard_normal((12, 3, 3)))
    sliver = np.array([[[0.5, 1.0, 1.5], [0.5, 1.0, 1.5 + 1e-14], [-0.5, 1.0, 1.5]]])
    welded_verts, welded_faces = mesh.weld(np.concatenate([soup, sliver]))
    assert welded_verts.shape == (8, 3) and welded_faces.shape == (12, 3)
    props = inertia.from_mesh(welded_verts, welded_faces, mass=6.0)
    np.testing.assert_allclose(props.inertia, np.diag([6.5, 5.0, 2.5]), atol=1e-9)


def test_committed_obj_with_mixed_index_styles():
    verts, faces = inertia.load_mesh(DATA / "box_1x2x3_quads.obj")
    assert faces.shape == (12, 3)
    props = inertia.from_mesh(verts, faces, mass=6.0)
    np.testing.assert_allclose(props.com, [0.5, -1.0, 2.0], atol=1e-14)
    np.testing.assert_allclose(props.inertia, np.diag([6.5, 5.0, 2.5]), atol=1e-13)


def closed_box():
    verts, faces, _ = box_mesh((1.0, 2.0, 3.0))
    return verts, faces


@pytest.mark.parametrize(
    ("corrupt", "error", "message"),
    [
        (lambda v, f: (v, f[1:]), MeshError, "not closed"),
        (lambda v, f: (v, np.vstack([f[:1, ::-1], f[1:]])), MeshError, "inconsistently oriented"),
        (lambda v, f: (v, f[:, ::-1]), MeshError, "inside-out"),
        (lambda v, f: (v, np.vstack([f, [[0, 1, 8]]])), MeshError, "outside the 8 vertices"),
        (lambda v, f: (v, np.vstack([f, [[0, 1, 1]]])), MeshError, "repeats a vertex"),
        (lambda v, f: (v, f.astype(float)), MeshError, "integer"),
        (lambda v, f: (np.where(v == v[3], np.nan, v), f), NonFiniteError, "vertices"),
        (lambda v, f: (v, np.array([[0, 1, 2], [0, 2, 1]])), MeshError, "zero volume"),
    ],
)
def test_from_mesh_rejects_bad_meshes(corrupt, error, message):
    verts, faces = corrupt(*closed_box())
    with pytest.raises(error, match=message):
        inertia.from_mesh(verts, faces, mass=1.0)


def test_from_mesh_needs_exactly_one_of_mass_and_density():
    verts, faces = closed_box()
    for kwargs in ({}, {"mass": 1.0, "density": 1.0}):
        with pytest.raises(InvalidParameterError, match="exactly one of mass= or density="):
            inertia.from_mesh(verts, faces, **kwargs)
    with pytest.raises(InvalidParameterError, match="density"):
        inertia.from_mesh(verts, faces, density=-1.0)


def test_load_mesh_rejects_bad_files(tmp_path):
    bad_suffix = tmp_path / "box.ply"
    bad_suffix.write_text("ply\n")
    with pytest.raises(MeshError, match=r"\.stl or \.obj"):
        inertia.load_mesh(bad_suffix)
    bad_obj = tmp_path / "bad.obj"
    bad_obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    with pytest.raises(MeshError, match="line 4"):
        inertia.load_mesh(bad_obj)
    not_stl = tmp_path / "junk.stl"
    not_stl.write_bytes(b"\x00\x01 definitely not a mesh")
    with pytest.raises(MeshError, match="not an STL"):
        inertia.load_mesh(not_stl)


# ------------------------------------------------------------------ hollow cylinder


def test_hollow_cylinder_matches_sampled_surface():
    """Closed thin-walled cylinder vs. an area-weighted point sampling of tube and end discs."""
    m, r, h, n = 2.0, 0.3, 1.0, 400
    phi = (np.arange(n) + 0.5) / n * 2 * np.pi
    z = (np.arange(n) + 0.5) / n * h - h / 2
    P, Z = np.meshgrid(phi, z, indexing="ij")
    tube = np.stack([r * np.cos(P).ravel(), r * np.sin(P).ravel(), Z.ravel()], 1)
    rho = np.sqrt((np.arange(n) + 0.5) / n) * r  # equal-area rings
    R, P2 = np.meshgrid(rho, phi, indexing="ij")
    disc = np.stack([(R * np.cos(P2)).ravel(), (R * np.sin(P2)).ravel()], 1)
    caps = [np.column_stack([disc, np.full(len(disc), s * h / 2)]) for s in (-1, 1)]
    pts = np.concatenate([tube, *caps])
    area = np.concatenate([np.full(len(tube), 2 * np.pi * r * h / len(tube)),
                           np.full(2 * len(disc), np.pi * r * r / len(disc))])
    ref = inertia.from_particles(m * area / area.sum(), pts).inertia
    np.testing.assert_allclose(inertia.hollow_cylinder(m, r, h), ref, rtol=2e-3, atol=1e-9)


def test_hollow_cylinder_limits_are_the_thin_tube_and_the_thin_disc():
    """Independent limits: a long tube (h ≫ r) and a flat pillbox (h ≪ r), closed forms."""
    m, r = 2.0, 0.3
    # h → ∞: the discs' share of the mass vanishes; the tube has I_zz = m r², I_xx = m h²/12.
    h = 1e6
    J = inertia.hollow_cylinder(m, r, h)
    np.testing.assert_allclose(J[2, 2], m * r * r, rtol=1e-6)
    np.testing.assert_allclose(J[0, 0], m * h * h / 12.0, rtol=1e-6)
    # h → 0: two coincident discs of mass m/2 each: I_zz = m r²/2, I_xx = m r²/4.
    J = inertia.hollow_cylinder(m, r, 1e-9)
    np.testing.assert_allclose(np.diag(J), [m * r * r / 4, m * r * r / 4, m * r * r / 2],
                               rtol=1e-7)


# ------------------------------------------------------------------ hostile mesh input


def _tetrahedron():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return v, f


def test_unused_far_vertex_is_ignored():
    v, f = _tetrahedron()
    with_far = inertia.from_mesh(np.vstack([v, [1e6, -1e6, 1e6]]), f, mass=1.0)
    plain = inertia.from_mesh(v, f, mass=1.0)
    np.testing.assert_allclose(with_far.inertia, plain.inertia, rtol=1e-12)
    np.testing.assert_allclose(with_far.com, [0.25, 0.25, 0.25], rtol=1e-12)


def test_only_regular_mesh_files_are_read(tmp_path):
    import os

    fifo = tmp_path / "pipe.stl"
    os.mkfifo(fifo)
    with pytest.raises(MeshError, match="must be a regular file, got a FIFO"):
        inertia.load_mesh(fifo)
    zero = tmp_path / "zero.obj"
    zero.symlink_to("/dev/zero")
    with pytest.raises(MeshError, match="character device"):
        inertia.load_mesh(zero)
    folder = tmp_path / "dir.stl"
    folder.mkdir()
    with pytest.raises(MeshError, match="directory"):
        inertia.load_mesh(folder)


def test_stl_face_count_cap(tmp_path):
    n = mesh.MAX_MESH_FACES + 1
    path = tmp_path / "big.stl"
    path.write_bytes(b"\0" * 80 + np.uint32(n).tobytes() + b"\0" * (50 * n))
    with pytest.raises(MeshError, match=f"{n} triangles; the limit is {mesh.MAX_MESH_FACES}"):
        inertia.load_mesh(path)


def test_overflowing_closed_forms_name_their_arguments():
    with pytest.raises(NonFiniteError, match=r"solid_sphere overflowed.*radius=1e\+200"):
        inertia.solid_sphere(1e200, 1e200)
    with pytest.raises(InvalidParameterError, match="n must be >= 1 and <= 200"):
        inertia.box_particles(1.0, (1, 1, 1), 10**6)


def test_validate_and_principal_axes_near_overflow():
    big = np.diag([1.0, 2.0, 2.5]) * 1e307
    np.testing.assert_allclose(inertia.validate(big), big)
    moments, R = inertia.principal_axes(big)
    np.testing.assert_allclose(moments, [1e307, 2e307, 2.5e307])
    np.testing.assert_allclose(np.abs(R), np.eye(3))
