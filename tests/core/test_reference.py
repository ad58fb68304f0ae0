"""Checks of the exact reference solutions in core.reference against independent computations.

The numerical reference here is a tight DOP853 solution of Euler's equations and
q̇ = ½ q ⊗ (0, ω_B) written out in this file (its own quaternion product), so it shares no code
with the module under test. Reference numbers come from rigid-body-physics.md §2.2.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from rbenv.core import quaternion as quat
from rbenv.core.errors import InvalidInertiaError, InvalidParameterError
from rbenv.core.reference import (
    TorqueFreeSolution,
    constant_torque_about_axis,
    solve_ivp_reference,
    symmetric_top,
    torque_free,
)
from scipy.integrate import solve_ivp

I_REF = (5.0, 10.0, 13.0)
Q0 = tuple(np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2]))
NEAR_MINOR = (2.0, 0.3, 0.2)
NEAR_MAJOR = (0.2, 0.3, 2.0)
NEAR_INTERMEDIATE = (0.05, 2.0, 0.05)  # Dzhanibekov

# (moments, ω_B0): the three cases of §2.2 plus relabelled bodies (an even and an odd
# permutation of the axes, and sign changes), which exercise the internal right-handed sort.
CASES = {
    "minor": (I_REF, NEAR_MINOR),
    "major": (I_REF, NEAR_MAJOR),
    "intermediate": (I_REF, NEAR_INTERMEDIATE),
    "shuffled-even": ((13.0, 5.0, 10.0), (0.2, 2.0, 0.3)),
    "shuffled-odd": ((10.0, 5.0, 13.0), (2.0, 0.05, -0.05)),
    "negative-rates": (I_REF, (-0.2, -0.3, -2.0)),
}


def _qmul(p, q):
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return np.array([
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ])


@functools.cache
def _integrate(moments, omega0, q0, times, events_axis=None):
    """Independent DOP853 solution (rtol = atol = 1e-13) of the torque-free (q, ω_B) system."""
    inertia = np.array(moments)

    def rhs(_t, y):
        w = y[4:]
        w_dot = -np.cross(w, inertia * w) / inertia
        return np.concatenate((0.5 * _qmul(y[:4], (0.0, *w)), w_dot))

    event = None
    if events_axis is not None:
        def event(_t, y):
            return y[4 + events_axis]

    sol = solve_ivp(rhs, (0.0, max(times)), np.concatenate((q0, omega0)), method="DOP853",
                    t_eval=np.array(times), rtol=1e-13, atol=1e-13, events=event)
    assert sol.success
    q = sol.y[:4].T / np.linalg.norm(sol.y[:4].T, axis=1, keepdims=True)
    crossings = None if event is None else sol.t_events[0]
    return q, sol.y[4:].T, crossings


# --------------------------------------------------------------------------------------------
# asymmetric body: ω_B(t) and q(t) against the integrated equations
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(CASES))
def test_omega_matches_integrated_euler_equations(name):
    moments, omega0 = CASES[name]
    sol = TorqueFreeSolution(moments, omega0, Q0)
    _, w_num, _ = _integrate(moments, omega0, Q0, (10.0, 20.0))
    err = np.abs(sol.omega_B([10.0, 20.0]) - w_num).max()
    assert err <= 1e-10  # measured ≤ 7e-13
    assert np.allclose(sol.omega_B(0.0), omega0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", list(CASES))
def test_orientation_matches_integrated_attitude(name):
    moments, omega0 = CASES[name]
    sol = TorqueFreeSolution(moments, omega0, Q0)
    q_num, _, _ = _integrate(moments, omega0, Q0, (10.0, 20.0))
    err = quat.angle(sol.orientation([10.0, 20.0]), q_num)
    assert err.max() <= 1e-9  # measured ≤ 1.3e-12 rad
    assert quat.angle(sol.orientation(0.0), np.array(Q0)) <= 1e-15


def test_long_horizon_attitude_and_kinematics():
    """At t = 100 s (≈ 9 flips) the attitude still matches, and q̇ = ½ q ⊗ ω_B holds locally."""
    moments, omega0 = I_REF, NEAR_INTERMEDIATE
    sol = TorqueFreeSolution(moments, omega0, Q0)
    q_num, w_num, _ = _integrate(moments, omega0, Q0, (100.0,))
    # measured 1e-11, which is the ODE's own error (vs a 24-digit mpmath Taylor solution the
    # exact solution is within 1e-14 here)
    assert quat.angle(sol.orientation(100.0), q_num[0]) <= 1e-9
    assert np.abs(sol.omega_B(100.0) - w_num[0]).max() <= 1e-10
    # Fourth-order central difference of the exact q(t) against the kinematic equation: checks
    # the precession-angle quadrature at a late time without any integrator.
    h, t = 1e-3, 97.3
    q = sol.orientation(t + h * np.array([-2.0, -1.0, 1.0, 2.0]))
    q_dot = (q[0] - 8.0 * q[1] + 8.0 * q[2] - q[3]) / (12.0 * h)
    expected = 0.5 * _qmul(sol.orientation(t), (0.0, *sol.omega_B(t)))
    assert np.abs(q_dot - expected).max() <= 1e-9  # measured 2e-12


@pytest.mark.parametrize("name", ["minor", "major", "intermediate", "shuffled-odd"])
def test_invariants_along_exact_solution(name):
    moments, omega0 = CASES[name]
    sol = TorqueFreeSolution(moments, omega0, Q0)
    t = np.linspace(0.0, 100.0, 2001)
    q, w = sol.state(t)
    L_B = np.asarray(moments) * w
    energy = 0.5 * np.sum(L_B * w, axis=-1)
    L_W = quat.rotate(q, L_B)
    assert np.abs(energy / sol.energy - 1.0).max() <= 1e-12
    assert np.abs(L_W - sol.momentum_W).max() <= 1e-12 * np.linalg.norm(sol.momentum_W)
    assert np.allclose(sol.momentum_B(t), L_B, rtol=0, atol=1e-15 * sol.G)


# --------------------------------------------------------------------------------------------
# reference numbers (§2.2 table) and the Dzhanibekov flip
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("omega0", "case", "k2", "lam", "period", "flip"),
    [
        (NEAR_MINOR, "minor", 0.031936, 1.118722, 5.662062, 2.831031),
        (NEAR_MAJOR, "major", 0.017043, 1.393115, 4.529573, 2.264787),
        (NEAR_INTERMEDIATE, "major", 0.999534, 0.961393, 21.728398, 10.864199),
    ],
)
def test_reference_numbers_from_the_note(omega0, case, k2, lam, period, flip):
    sol = TorqueFreeSolution(I_REF, omega0, Q0)
    assert sol.case == case
    assert sol.k2 == pytest.approx(k2, abs=1e-6)
    assert sol.lam == pytest.approx(lam, abs=1e-6)
    assert sol.period == pytest.approx(period, abs=1e-6)
    assert sol.flip_interval == pytest.approx(flip, abs=1e-6)


def test_dzhanibekov_flip_times_match_integrated_zero_crossings():
    sol = TorqueFreeSolution(I_REF, NEAR_INTERMEDIATE, Q0)
    predicted = sol.flip_times(60.0)
    _, _, crossings = _integrate(I_REF, NEAR_INTERMEDIATE, Q0, (60.0,), events_axis=1)
    assert predicted.size == crossings.size == 5
    assert np.abs(predicted - crossings).max() <= 1e-9  # measured 3e-12 s
    assert np.allclose(np.diff(predicted), 10.864199, atol=1e-6)
    # ω_y really changes sign there (and only there).
    w_before = sol.omega_B(predicted - 1e-3)[:, 1]
    w_after = sol.omega_B(predicted + 1e-3)[:, 1]
    assert np.all(np.sign(w_before) == -np.sign(w_after))
    t = np.linspace(0.0, 60.0, 6001)
    assert np.count_nonzero(np.diff(np.sign(sol.omega_B(t)[:, 1]))) == 5


# --------------------------------------------------------------------------------------------
# degenerate motions
# --------------------------------------------------------------------------------------------


def _separatrix_rates():
    # Δ2 = 0: m1²(I2 − I1)/I1 = m3²(I3 − I2)/I3 with m1 = 1.
    m3 = np.sqrt((I_REF[1] - I_REF[0]) / I_REF[0] * I_REF[2] / (I_REF[2] - I_REF[1]))
    return (1.0 / I_REF[0], 2.0, m3 / I_REF[2])


@pytest.mark.parametrize(
    "omega0",
    [_separatrix_rates(), (1e-4, 2.0, 1e-4), (1e-8, -2.0, 0.0)],
    ids=["on-separatrix", "near-separatrix", "near-intermediate-axis"],
)
def test_separatrix_and_near_separatrix(omega0):
    sol = TorqueFreeSolution(I_REF, omega0, Q0)
    times = (5.0, 10.0)
    q_num, w_num, _ = _integrate(I_REF, tuple(omega0), Q0, times)
    q, w = sol.state(np.array(times))
    assert np.abs(w - w_num).max() <= 1e-10  # measured ≤ 5e-13
    assert quat.angle(q, q_num).max() <= 1e-9


def test_on_separatrix_motion_is_heteroclinic():
    sol = TorqueFreeSolution(I_REF, _separatrix_rates(), Q0)
    assert sol.case == "separatrix" and sol.k2 == 1.0 and np.isinf(sol.flip_interval)
    m_y = sol.momentum_B(np.linspace(0.0, 40.0, 401))[:, 1]
    assert np.all(np.diff(m_y) >= 0.0) and m_y[0] > 0.0  # creeps towards +G, never flips back
    assert abs(abs(m_y[-1]) - sol.G) <= 1e-9 * sol.G  # approaches the intermediate axis


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("moments", [I_REF, (10.0, 13.0, 5.0)])
def test_spin_exactly_about_a_principal_axis_is_steady(axis, moments):
    omega0 = np.zeros(3)
    omega0[axis] = -1.7
    sol = TorqueFreeSolution(moments, omega0, Q0)
    t = np.array([0.0, 3.0, 50.0])
    q, w = sol.state(t)
    assert np.array_equal(w, np.broadcast_to(omega0, (3, 3)))
    expected = quat.multiply(np.array(Q0), quat.from_rotation_vector(t[:, None] * omega0))
    assert quat.angle(q, expected).max() <= 1e-13


def test_rest():
    sol = TorqueFreeSolution(I_REF, np.zeros(3), Q0)
    q, w = sol.state(np.array([0.0, 7.0]))
    assert sol.case == "rest" and not w.any()
    assert quat.angle(q, np.array(Q0)).max() <= 1e-15


# --------------------------------------------------------------------------------------------
# symmetric and isotropic bodies, dispatcher
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("moments", "omega0"),
    [
        ((4.0, 4.0, 7.0), (0.3, -0.2, 1.5)),  # oblate, axis z
        ((7.0, 4.0, 4.0), (1.5, 0.3, -0.2)),  # oblate, axis x
        ((6.0, 2.5, 6.0), (0.4, 1.1, -0.7)),  # prolate, axis y
    ],
)
def test_symmetric_top_matches_integration(moments, omega0):
    times = (10.0, 20.0)
    q, w = symmetric_top(moments, omega0, Q0, np.array(times))
    q_num, w_num, _ = _integrate(moments, omega0, Q0, times)
    assert np.abs(w - w_num).max() <= 1e-10  # measured ≤ 2e-13
    assert quat.angle(q, q_num).max() <= 1e-10  # measured ≤ 1.1e-12
    q_d, w_d = torque_free(moments, omega0, Q0, np.array(times))
    assert np.array_equal(q_d, q) and np.array_equal(w_d, w)


def test_symmetric_top_two_moment_form_means_axis_z():
    t = np.array([0.0, 4.0, 9.0])
    q2, w2 = symmetric_top((4.0, 7.0), (0.3, -0.2, 1.5), Q0, t)
    q3, w3 = symmetric_top((4.0, 4.0, 7.0), (0.3, -0.2, 1.5), Q0, t)
    assert np.array_equal(q2, q3) and np.array_equal(w2, w3)


def test_isotropic_body_spins_about_a_fixed_world_axis():
    omega0 = np.array([0.3, 1.5, -0.2])
    t = np.array([0.0, 2.0, 30.0])
    q, w = torque_free((3.0, 3.0, 3.0), omega0, Q0, t)
    omega_W = quat.rotate(np.array(Q0), omega0)
    expected = quat.multiply(quat.from_rotation_vector(t[:, None] * omega_W), np.array(Q0))
    assert quat.angle(q, expected).max() <= 1e-14
    assert np.array_equal(w, np.broadcast_to(omega0, (3, 3)))
    q_num, _, _ = _integrate((3.0, 3.0, 3.0), tuple(omega0), Q0, (30.0,))
    assert quat.angle(q[-1], q_num[0]) <= 1e-10


def test_torque_free_dispatches_asymmetric_bodies_to_the_elliptic_solution():
    t = np.array([1.0, 12.0])
    q, w = torque_free(I_REF, NEAR_INTERMEDIATE, Q0, t)
    sol = TorqueFreeSolution(I_REF, NEAR_INTERMEDIATE, Q0)
    assert np.array_equal(q, sol.orientation(t)) and np.array_equal(w, sol.omega_B(t))


def test_batched_times_keep_their_shape():
    sol = TorqueFreeSolution(I_REF, NEAR_MINOR, Q0)
    t = np.linspace(0.0, 5.0, 6).reshape(2, 3)
    assert sol.orientation(t).shape == (2, 3, 4)
    assert sol.omega_B(t).shape == (2, 3, 3)
    assert sol.orientation(2.5).shape == (4,)
    assert np.allclose(sol.orientation(t)[1, 2], sol.orientation(5.0), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------------------------
# torque-driven references
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_constant_torque_about_principal_axis(axis):
    t = np.linspace(0.0, 5.0, 6)
    q, w = constant_torque_about_axis(I_REF, axis, 0.7, t, Q0)
    tau_B = np.zeros(3)
    tau_B[axis] = 0.7
    q_b, w_b = solve_ivp_reference(I_REF, np.zeros(3), Q0, t, torque_B=tau_B)
    q_w, w_w = solve_ivp_reference(I_REF, np.zeros(3), Q0, t,
                                   torque_W=quat.rotate(np.array(Q0), tau_B))
    for q_num, w_num in ((q_b, w_b), (q_w, w_w)):
        assert np.abs(w - w_num).max() <= 1e-12
        assert quat.angle(q, q_num).max() <= 1e-11
    assert quat.angle(q[-1], np.array(Q0)) == pytest.approx(0.5 * 0.7 / I_REF[axis] * 25.0)


def test_piecewise_constant_torque_with_breakpoints():
    alpha = 0.7 / I_REF[2]
    t = np.array([0.5, 1.0, 1.5, 3.0])

    def torque_B(s):
        return np.array([0.0, 0.0, 0.7]) if s < 1.0 else np.zeros(3)

    q, w = solve_ivp_reference(I_REF, np.zeros(3), Q0, t, torque_B=torque_B, breakpoints=[1.0])
    t_on = np.minimum(t, 1.0)
    angle = 0.5 * alpha * t_on**2 + alpha * np.maximum(t - 1.0, 0.0)
    expected = quat.multiply(np.array(Q0), quat.from_axis_angle([0.0, 0.0, 1.0], angle))
    assert np.abs(w[:, 2] - alpha * t_on).max() <= 1e-12
    assert quat.angle(q, expected).max() <= 1e-12


def test_solve_ivp_reference_agrees_with_exact_flow_and_full_tensor():
    t = np.array([0.0, 10.0, 3.0])  # any order
    q_ref, w_ref = solve_ivp_reference(I_REF, NEAR_INTERMEDIATE, Q0, t)
    sol = TorqueFreeSolution(I_REF, NEAR_INTERMEDIATE, Q0)
    assert np.abs(w_ref - sol.omega_B(t)).max() <= 1e-10
    assert quat.angle(q_ref, sol.orientation(t)).max() <= 1e-9
    # The same body described in axes rotated by R: I' = R I Rᵀ, ω' = R ω, q' = q ⊗ R*.
    r = quat.normalize(np.array([0.3, -0.5, 0.2, 0.7]))
    R = quat.to_matrix(r)
    q_rot, w_rot = solve_ivp_reference(R @ np.diag(I_REF) @ R.T, R @ np.array(NEAR_INTERMEDIATE),
                                       quat.multiply(np.array(Q0), quat.conjugate(r)), t)
    assert np.abs(w_rot - w_ref @ R.T).max() <= 1e-10
    assert quat.angle(q_rot, quat.multiply(q_ref, quat.conjugate(r))).max() <= 1e-9


# --------------------------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------------------------


def test_invalid_inputs_are_refused_with_clear_errors():
    with pytest.raises(InvalidParameterError, match="distinct"):
        TorqueFreeSolution((4.0, 4.0, 7.0), NEAR_MINOR, Q0)
    with pytest.raises(InvalidInertiaError, match="triangle"):
        TorqueFreeSolution((1.0, 2.0, 5.0), NEAR_MINOR, Q0)
    with pytest.raises(InvalidParameterError, match="unit quaternion"):
        TorqueFreeSolution(I_REF, NEAR_MINOR, (1.0, 1.0, 0.0, 0.0))
    with pytest.raises(InvalidParameterError, match="two equal"):
        symmetric_top(I_REF, NEAR_MINOR, Q0, 1.0)
    with pytest.raises(InvalidParameterError, match=">= 0"):
        solve_ivp_reference(I_REF, NEAR_MINOR, Q0, [-1.0, 1.0])
