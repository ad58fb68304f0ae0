"""Issue 19, item 4: user-facing core functions name the field, the value and the rule."""

from __future__ import annotations

import numpy as np
import pytest
from rbenv.core import inertia, quaternion
from rbenv.core.errors import InvalidInertiaError, InvalidParameterError


def test_to_matrix_on_a_3_vector_names_the_shape():
    with pytest.raises(InvalidParameterError, match=r"q must have shape \(4,\).*shape \(3,\)"):
        quaternion.to_matrix(np.array([1.0, 0.0, 0.0]))


@pytest.mark.parametrize("scale", [2.0, 0.5, 1.0 + 1e-4])
def test_rotate_refuses_a_non_unit_quaternion(scale):
    q = scale * np.array([0.5, 0.5, 0.5, 0.5])
    with pytest.raises(InvalidParameterError, match=r"q must be a unit quaternion.*\|q\| ="):
        quaternion.rotate(q, [1.0, 0.0, 0.0])
    with pytest.raises(InvalidParameterError, match="unit quaternion"):
        quaternion.rotate_inverse(q, [1.0, 0.0, 0.0])


def test_rotate_accepts_round_off_and_gives_the_rotation():
    q = quaternion.from_axis_angle([0.0, 0.0, 1.0], np.pi / 2) * (1.0 + 1e-9)
    assert np.allclose(quaternion.rotate(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-8)


@pytest.mark.parametrize("matrix, rule", [
    (2.0 * np.eye(3), "RᵀR = E"),                        # scaled
    (np.diag([1.0, 1.0, -1.0]), "det R = \\+1"),         # a reflection
    (np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "RᵀR = E"),  # sheared
])
def test_from_matrix_refuses_a_non_rotation(matrix, rule):
    with pytest.raises(InvalidParameterError, match=f"(?s)R must be a rotation matrix.*{rule}"):
        quaternion.from_matrix(matrix)


def test_from_matrix_names_a_wrong_shape():
    rule = r"(?s)R must have shape \(3, 3\).*shape \(2, 2\)"
    with pytest.raises(InvalidParameterError, match=rule):
        quaternion.from_matrix(np.eye(2))


def test_from_matrix_still_inverts_to_matrix():
    q = quaternion.random(np.random.default_rng(0), (5,))
    back = quaternion.from_matrix(quaternion.to_matrix(q))
    assert np.allclose(np.abs(np.sum(back * q, axis=-1)), 1.0, atol=1e-12)


def test_principal_axes_refuses_a_non_symmetric_tensor():
    tensor = np.diag([1.0, 2.0, 2.5])
    tensor[0, 1] = 0.3  # the lower triangle keeps 0
    with pytest.raises(InvalidInertiaError, match=r"(?s)inertia must be symmetric.*= 0\.3\)"):
        inertia.principal_axes(tensor)


def test_principal_axes_refuses_asymmetry_at_huge_scale_without_overflow():
    tensor = np.diag([1e308, 1e308, 1e308])
    tensor[0, 1] = -1e308
    with pytest.raises(InvalidInertiaError, match="must be symmetric"):
        inertia.principal_axes(tensor)


def test_principal_axes_accepts_round_off_asymmetry():
    tensor = np.array([[2.0, 0.1, 0.0], [0.1 + 1e-12, 3.0, 0.0], [0.0, 0.0, 4.0]])
    moments, R = inertia.principal_axes(tensor)
    assert np.allclose(R @ np.diag(moments) @ R.T, tensor, atol=1e-11)


def _body_and_state():
    from rbenv.core import BodyState, RigidBody

    body = RigidBody(mass=2.0, inertia=np.diag([1.0, 2.0, 3.0]))
    return body, BodyState()


@pytest.mark.parametrize("case", ["body None", "state dict", "state None", "body dict"])
@pytest.mark.parametrize("fn", ["step", "simulate"])
def test_step_with_a_wrong_body_or_state_names_it(case, fn):
    from rbenv import core

    body, state = _body_and_state()
    which, value = case.split()
    bad = {"None": None, "dict": {"q": [1.0, 0.0, 0.0, 0.0]}}[value]
    args = (bad, state) if which == "body" else (body, bad)
    want = "core.RigidBody" if which == "body" else "core.BodyState"
    extra = (1,) if fn == "simulate" else ()
    with pytest.raises(InvalidParameterError, match=rf"{which} must be a {want}, got .*"
                                                    rf"type {type(bad).__name__}"):
        getattr(core, fn)(*args, 0.1, *extra)
