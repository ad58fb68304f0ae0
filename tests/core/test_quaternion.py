"""rbenv.core.quaternion against SciPy's Rotation (scalar-first) on random and edge-case inputs."""

import numpy as np
import pytest
from rbenv.core import quaternion as Q
from rbenv.core.errors import InvalidParameterError
from scipy.spatial.transform import Rotation


def scipy_rot(q):
    return Rotation.from_quat(q, scalar_first=True)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def edge_quaternions():
    """Identity, near-identity, exactly π, near π, and both signs of the double cover."""
    tiny = 1e-9
    qs = [
        [1.0, 0.0, 0.0, 0.0],
        [1.0, tiny, -tiny, tiny],
        [0.0, 1.0, 0.0, 0.0],  # π about x
        [0.0, 0.0, 0.6, 0.8],  # π about (0, .6, .8)
        [1e-8, 1.0, 0.0, 0.0],  # just short of π
        [-1e-8, 0.0, 1.0, 0.0],  # just past π (w < 0)
        [-0.5, 0.5, 0.5, 0.5],  # negative scalar part
    ]
    return Q.normalize(np.array(qs))


def test_multiply_matches_scipy_composition(rng):
    p, q = Q.random(rng, (200,)), Q.random(rng, (200,))
    expected = (scipy_rot(p) * scipy_rot(q)).as_quat(scalar_first=True)
    assert np.allclose(Q.angle(Q.multiply(p, q), expected), 0.0, atol=1e-12)


def test_rotate_and_matrix_match_scipy(rng):
    q = np.concatenate([Q.random(rng, (200,)), edge_quaternions()])
    v = rng.standard_normal((len(q), 3))
    R = scipy_rot(q)
    assert np.allclose(Q.rotate(q, v), R.apply(v), atol=1e-13)
    assert np.allclose(Q.rotate_inverse(q, v), R.inv().apply(v), atol=1e-13)
    assert np.allclose(Q.to_matrix(q), R.as_matrix(), atol=1e-14)


def test_double_cover_gives_same_rotation(rng):
    q = np.concatenate([Q.random(rng, (50,)), edge_quaternions()])
    v = rng.standard_normal((len(q), 3))
    assert np.allclose(Q.rotate(q, v), Q.rotate(-q, v), atol=1e-14)
    assert np.allclose(Q.to_matrix(q), Q.to_matrix(-q), atol=1e-15)
    assert np.allclose(Q.angle(q, -q), 0.0, atol=1e-7)  # sqrt of round-off near identity


def test_from_matrix_round_trip_including_pi(rng):
    q = np.concatenate([Q.random(rng, (300,)), edge_quaternions()])
    back = Q.from_matrix(scipy_rot(q).as_matrix())
    assert np.all(back[..., 0] >= 0.0)
    assert np.allclose(Q.angle(back, q), 0.0, atol=1e-7)
    assert np.allclose(Q.rotate(back, np.eye(3)[0]), Q.rotate(q, np.eye(3)[0]), atol=1e-12)


def test_rotation_vector_maps_match_scipy(rng):
    v = rng.standard_normal((200, 3)) * rng.uniform(0, np.pi, (200, 1))
    v = np.concatenate([v, [[1e-10, 0, 0], [0, 0, 0], [0, 0, np.pi - 1e-9]]])
    q = Q.from_rotation_vector(v)
    expected = Rotation.from_rotvec(v).as_quat(scalar_first=True)
    assert np.allclose(Q.angle(q, expected), 0.0, atol=1e-7)
    assert np.allclose(Q.to_rotation_vector(q), Rotation.from_rotvec(v).as_rotvec(), atol=1e-9)


def test_axis_angle_matches_scipy(rng):
    axis = rng.standard_normal((100, 3))
    ang = rng.uniform(-2 * np.pi, 2 * np.pi, 100)
    unit = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    expected = Rotation.from_rotvec(unit * ang[:, None]).as_quat(scalar_first=True)
    assert np.allclose(Q.angle(Q.from_axis_angle(axis, ang), expected), 0.0, atol=1e-7)


def test_angle_is_geodesic_distance(rng):
    p, q = Q.random(rng, (300,)), Q.random(rng, (300,))
    expected = (scipy_rot(p).inv() * scipy_rot(q)).magnitude()
    assert np.allclose(Q.angle(p, q), expected, atol=1e-12)
    assert np.all((Q.angle(p, q) >= 0) & (Q.angle(p, q) <= np.pi + 1e-15))


def test_near_identity_angle_is_accurate():
    # arccos-based formulas lose half the digits here; atan2 keeps them.
    q = Q.from_axis_angle([0.3, -0.4, 0.5], 1e-10)
    assert Q.angle(Q.identity(), q) == pytest.approx(1e-10, rel=1e-6)


def test_broadcasting_single_against_batch(rng):
    p = Q.random(rng)
    q = Q.random(rng, (7, 3))
    out = Q.multiply(p, q)
    assert out.shape == (7, 3, 4)
    assert np.allclose(out[2, 1], Q.multiply(p, q[2, 1]))


def test_zero_quaternion_and_axis_are_rejected():
    with pytest.raises(InvalidParameterError, match="non-zero"):
        Q.normalize(np.zeros(4))
    with pytest.raises(InvalidParameterError, match="axis"):
        Q.from_axis_angle(np.zeros(3), 1.0)


def test_random_is_uniform_on_so3(rng):
    # For Haar-uniform rotations the angle θ has density (1 − cos θ)/π: E[θ] = π/2 + 2/π.
    theta = Q.angle(Q.identity(), Q.random(rng, (200_000,)))
    assert theta.mean() == pytest.approx(np.pi / 2 + 2 / np.pi, abs=5e-3)
