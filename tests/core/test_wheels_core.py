"""Reaction wheels through the core API alone: RigidBody(..., wheels=), BodyState(...,
wheel_speeds=), simulate(..., wheel_torque=), against conservation and a closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rbenv.core import (
    BodyState,
    InvalidInertiaError,
    InvalidParameterError,
    RigidBody,
    Wheels,
    quaternion,
    simulate,
    step,
)

PYRAMID = np.array([[math.cos(math.asin(1 / math.sqrt(3))) * math.cos(a),
                     math.cos(math.asin(1 / math.sqrt(3))) * math.sin(a), 1 / math.sqrt(3)]
                    for a in np.radians([45, 135, 225, 315])])


def _total_momentum_W(body, state):
    w_B = state.angular_velocity_B
    h = body.wheels.inertia * (state.wheel_speeds + w_B @ body.wheels.axes.T)
    return quaternion.rotate(state.orientation, w_B @ body.bus.inertia.T + h @ body.wheels.axes)


def test_internal_motor_torques_leave_the_total_momentum_unchanged():
    body = RigidBody(12.0, np.diag([0.185, 0.144, 0.061]), wheels=Wheels(PYRAMID, 3e-5))
    state = BodyState(angular_velocity=[0.05, -0.1, 0.08],
                      wheel_speeds=[100.0, -50.0, 30.0, 0.0])
    L0 = _total_momentum_W(body, state)
    end = simulate(body, state, 0.5, 400, wheel_torque=[0.002, -0.003, 0.001, 0.0025],
                   translation=False)
    assert np.abs(_total_momentum_W(body, end) - L0).max() <= 1e-13 * np.linalg.norm(L0)
    assert np.abs(end.wheel_speeds - state.wheel_speeds).max() > 10.0  # they really spun up


def test_spin_up_follows_the_closed_form():
    """Basilisk's BOE case: hub 2 kg·m² without the rotor, J = 0.15915, u = 0.2 N·m, 5 s."""
    J = 100.0 / (6000 * 2 * math.pi / 60)
    body = RigidBody(10.0, np.diag([2.0, 2.0, 2.0 + J]), wheels=Wheels([[0, 0, 1]], J))
    state = BodyState(angular_velocity=[0.0, 0.0, 0.35])
    end = simulate(body, state, 0.5, 10, wheel_torque=[0.2], integrator="rk4",
                   translation=False)
    assert end.angular_velocity[2] == pytest.approx(0.35 - 0.2 / 2.0 * 5.0, abs=1e-12)
    assert end.wheel_speeds[0] == pytest.approx(0.2 * (2.0 + J) / (2.0 * J) * 5.0, rel=1e-12)
    one = step(body, state, 0.5, integrator="rk4", wheel_torque=[0.2], translation=False)
    np.testing.assert_array_equal(one.wheel_speeds, simulate(
        body, state, 0.5, 1, integrator="rk4", wheel_torque=[0.2],
        translation=False).wheel_speeds)


def test_a_body_without_wheels_refuses_wheel_inputs_and_heavy_rotors_are_named():
    with pytest.raises(InvalidParameterError, match="need a body with wheels"):
        simulate(RigidBody(1.0, np.eye(3)), BodyState(), 0.1, 1, wheel_torque=[0.1])
    with pytest.raises(InvalidInertiaError, match=r"wheels\.inertia"):
        # Rotors on y and z leave a bus with I_x > I_y + I_z: no rigid body's inertia.
        RigidBody(1.0, np.diag([0.3, 0.2, 0.15]), wheels=Wheels([[0, 1, 0], [0, 0, 1]], 0.1))
    with pytest.raises(InvalidParameterError, match=r"wheel_torque must have one entry"):
        simulate(RigidBody(1.0, np.eye(3), wheels=Wheels(np.eye(3), 1e-3)), BodyState(), 0.1,
                 1, wheel_torque=[0.1, 0.2])
