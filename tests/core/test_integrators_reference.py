"""Integrators against the exact torque-free solutions in core.reference."""

import numpy as np
import pytest
from rbenv.core import BodyState, RigidBody, angular_momentum_W, quaternion, reference, simulate

MOMENTS = np.array([5.0, 10.0, 13.0])
Q0 = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
NEAR_MAJOR = np.array([0.2, 0.3, 2.0])
NEAR_INTERMEDIATE = np.array([0.05, 2.0, 0.05])


def body():
    return RigidBody(mass=1.0, inertia=np.diag(MOMENTS))


def start(omega_B):
    return BodyState(orientation=Q0, angular_velocity=quaternion.rotate(Q0, omega_B))


def attitude_error(integrator, dt, T=10.0, omega_B=NEAR_MAJOR):
    exact = reference.TorqueFreeSolution(MOMENTS, omega_B, Q0).orientation(T)
    out = simulate(body(), start(omega_B), dt, round(T / dt), integrator=integrator)
    return float(quaternion.angle(out.orientation, exact))


@pytest.mark.parametrize(("integrator", "order", "dts"), [
    ("euler", 1.0, (0.01, 0.005, 0.0025)),
    ("semi_implicit", 1.0, (0.01, 0.005, 0.0025)),
    ("midpoint", 2.0, (0.04, 0.02, 0.01)),
    ("rk4", 4.0, (0.08, 0.04, 0.02)),
    ("splitting", 2.0, (0.08, 0.04, 0.02)),
])
def test_fitted_convergence_order(integrator, order, dts):
    errors = [attitude_error(integrator, dt) for dt in dts]
    fitted = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert fitted == pytest.approx(order, abs=0.25)
    assert errors[-1] < errors[0]


def test_euler_seed_fails_the_precession_test():
    # Without −ω × Iω the lecture's body spins about a fixed world axis: it never precesses,
    # so its attitude error stays O(1) however small dt is (docs/design.md: the missing
    # gyroscopic term).
    errors = [attitude_error("euler_seed", dt) for dt in (0.02, 0.01, 0.005)]
    assert min(errors) > 0.1
    assert errors[-1] > 0.5 * errors[0]
    assert attitude_error("midpoint", 0.005) < 1e-3


@pytest.mark.parametrize("integrator", ["rk4", "midpoint", "splitting"])
def test_dzhanibekov_flip_period_matches_exact_solution(integrator):
    sol = reference.TorqueFreeSolution(MOMENTS, NEAR_INTERMEDIATE, Q0)
    assert sol.flip_interval == pytest.approx(10.864199, abs=1e-5)  # reference notes §2.2
    dt, T = 0.005, 25.0
    traj = simulate(body(), start(NEAR_INTERMEDIATE), dt, round(T / dt), integrator=integrator,
                    trajectory=True)
    w_y = traj.angular_velocity_B[:, 1]
    t = np.arange(len(w_y)) * dt
    crossings = t[1:][np.sign(w_y[1:]) != np.sign(w_y[:-1])]
    expected = sol.flip_times(T)
    assert len(crossings) == len(expected) >= 2
    tol = 0.05 if integrator == "midpoint" else 0.01
    assert np.allclose(crossings, expected, atol=tol)
    # The body really turns over: its intermediate axis reverses in the world frame.
    e2_start = quaternion.rotate(traj.orientation[0], [0.0, 1.0, 0.0])
    i_half = round(expected[0] * 1.5 / dt) if len(expected) == 1 else round(
        0.5 * (expected[0] + expected[1]) / dt)
    e2_later = quaternion.rotate(traj.orientation[i_half], [0.0, 1.0, 0.0])
    assert np.dot(e2_start, e2_later) < -0.9


@pytest.mark.parametrize("integrator", ["rk4", "midpoint", "splitting"])
def test_symmetric_top_closed_form(integrator):
    I_perp, I_par = 4.0, 7.0
    moments = np.array([I_perp, I_perp, I_par])
    omega_B0 = np.array([0.4, -0.3, 1.5])
    T, dt = 8.0, 0.005
    top = RigidBody(mass=1.0, inertia=np.diag(moments))
    s0 = BodyState(orientation=Q0, angular_velocity=quaternion.rotate(Q0, omega_B0))
    out = simulate(top, s0, dt, round(T / dt), integrator=integrator)
    q_exact, w_exact = reference.symmetric_top(moments, omega_B0, Q0, T)
    # The splitting is exact for a symmetric top: only round-off remains.
    tol = {"rk4": 1e-9, "midpoint": 1e-4, "splitting": 1e-11}[integrator]
    assert quaternion.angle(out.orientation, q_exact) < tol
    assert np.allclose(out.angular_velocity_B, w_exact, atol=tol)


def test_rk4_world_torque_matches_tight_reference():
    # A torque fixed in the world frame must be re-expressed in body axes at every stage.
    tau_W = np.array([0.3, -0.2, 0.5])
    omega_B0 = np.array([0.3, 0.1, -0.2])
    T, dt = 4.0, 0.01
    out = simulate(body(), start(omega_B0), dt, round(T / dt), torque=tau_W, integrator="rk4")
    q_ref, w_ref = reference.solve_ivp_reference(MOMENTS, omega_B0, Q0, [T], torque_W=tau_W)
    assert quaternion.angle(out.orientation, q_ref[-1]) < 1e-8
    assert np.allclose(out.angular_velocity_B, w_ref[-1], atol=1e-8)


@pytest.mark.parametrize("integrator", ["rk4", "midpoint", "splitting"])
def test_body_torque_matches_tight_reference(integrator):
    tau_B = np.array([0.5, 0.0, -0.4])
    omega_B0 = np.array([0.3, 0.1, -0.2])
    T, dt = 4.0, 0.01
    out = simulate(body(), start(omega_B0), dt, round(T / dt), torque_B=tau_B,
                   integrator=integrator)
    q_ref, w_ref = reference.solve_ivp_reference(MOMENTS, omega_B0, Q0, [T], torque_B=tau_B)
    tol = 1e-8 if integrator == "rk4" else 1e-3
    assert quaternion.angle(out.orientation, q_ref[-1]) < tol
    assert np.allclose(out.angular_velocity_B, w_ref[-1], atol=tol)


def test_midpoint_keeps_world_momentum_along_exact_solution():
    sol = reference.TorqueFreeSolution(MOMENTS, NEAR_INTERMEDIATE, Q0)
    out = simulate(body(), start(NEAR_INTERMEDIATE), 0.05, 400)
    assert np.allclose(angular_momentum_W(body(), out), sol.momentum_W, rtol=1e-12, atol=1e-12)
