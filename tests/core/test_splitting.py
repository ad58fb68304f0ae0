"""The explicit symplectic splitting integrator against invariants and independent references."""

import numpy as np
import pytest
from rbenv.core import INTEGRATORS, BodyState, RigidBody, quaternion, reference, simulate
from rbenv.core.body import invariants
from rbenv.core.splitting import principal_frame

MOMENTS = np.array([5.0, 10.0, 13.0])
Q0 = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
NEAR_INTERMEDIATE = (0.05, 2.0, 0.05)
advance = INTEGRATORS["splitting"].advance


def diagonal_body(moments=MOMENTS):
    return RigidBody(mass=1.0, inertia=np.diag(moments))


def run(body, w0, h, n, q0=Q0, tau_B=None, tau_W=None):
    """Float path: n steps; returns final (q, w) and per-step energy and L_W arrays."""
    q, w = tuple(q0.tolist()), tuple(float(x) for x in w0)
    energy, momentum = [], []
    for _ in range(n):
        q, w = advance(body, q, w, h, tau_B, tau_W)
        e, L = invariants(body, q, w)
        energy.append(e)
        momentum.append(L)
    return np.array(q), np.array(w), np.array(energy), np.array(momentum)


@pytest.mark.parametrize("h_omega", [0.1, 1.0, 10.0])
def test_momentum_conserved_to_round_off_at_any_step(h_omega):
    body = diagonal_body()
    w0 = np.array(NEAR_INTERMEDIATE)
    h = h_omega / np.linalg.norm(w0)
    _, _, energy, L = run(body, w0, h, 5000)
    L0 = np.array(invariants(body, tuple(Q0.tolist()), tuple(w0.tolist()))[1])
    G0 = np.linalg.norm(L0)
    assert np.abs(np.linalg.norm(L, axis=1) - G0).max() < 1e-12 * G0
    assert np.abs(L - L0).max() < 1e-12 * G0
    assert np.isfinite(energy).all()


@pytest.mark.slow
def test_energy_error_bounded_over_a_long_run():
    # Symplectic: the energy error oscillates and does not grow. Over 1e5 steps at
    # h·|ω| = 0.3 (about 4500 turns of the body, through hundreds of flips) the largest error
    # in the last tenth is no larger than in the first tenth, and is O(h²)-small.
    body = diagonal_body()
    w0 = np.array(NEAR_INTERMEDIATE)
    h = 0.3 / np.linalg.norm(w0)
    _, _, energy, _ = run(body, w0, h, 100_000)
    e0 = invariants(body, tuple(Q0.tolist()), tuple(w0.tolist()))[0]
    err = np.abs(energy - e0) / e0
    tenth = len(err) // 10
    assert err[-tenth:].max() <= 1.2 * err[:tenth].max()
    assert err.max() < 1e-2
    # RK4 at the same step drifts: it is dissipative, so its error grows well past the bound.
    q, w = tuple(Q0.tolist()), tuple(w0.tolist())
    for _ in range(100_000):
        q, w = INTEGRATORS["rk4"].advance(body, q, w, h)
    assert abs(invariants(body, q, w)[0] - e0) / e0 > 3 * err.max()


def attitude_error(dt, T=10.0, omega_B=(0.2, 0.3, 2.0)):
    exact = reference.TorqueFreeSolution(MOMENTS, omega_B, Q0).orientation(T)
    q, *_ = run(diagonal_body(), omega_B, dt, round(T / dt))
    return float(quaternion.angle(q, exact))


@pytest.mark.parametrize("omega_B", [(0.2, 0.3, 2.0), NEAR_INTERMEDIATE, (2.0, 0.3, 0.2)])
def test_second_order_against_jacobi_elliptic_solution(omega_B):
    dts = (0.08, 0.04, 0.02, 0.01)
    errors = [attitude_error(dt, omega_B=omega_B) for dt in dts]
    assert np.polyfit(np.log(dts), np.log(errors), 1)[0] == pytest.approx(2.0, abs=0.1)
    # The split's error constant is far below the implicit midpoint's (Cayley attitude update).
    out = simulate(diagonal_body(), BodyState(orientation=Q0, angular_velocity=quaternion.rotate(
        Q0, omega_B)), 0.02, 500, integrator="midpoint")
    exact = reference.TorqueFreeSolution(MOMENTS, omega_B, Q0).orientation(10.0)
    assert errors[2] < 0.2 * float(quaternion.angle(out.orientation, exact))


@pytest.mark.parametrize("moments", [(4.0, 4.0, 7.0), (4.0, 7.0, 7.0)])
def test_exact_for_a_symmetric_top_at_a_large_step(moments):
    # Two equal moments: the minor-axis part vanishes, the other two commute, the step is exact.
    omega_B0 = np.array([0.4, -0.3, 1.5])
    q, w, *_ = run(diagonal_body(moments), omega_B0, 0.5, 40)
    q_exact, w_exact = reference.symmetric_top(np.array(moments), omega_B0, Q0, 20.0)
    assert quaternion.angle(q, q_exact) < 1e-12
    assert np.allclose(w, w_exact, atol=1e-12)


def test_isotropic_body_turns_uniformly_about_omega():
    body = RigidBody(mass=1.0, inertia=np.eye(3) * 2.0)
    assert principal_frame(body).isotropic
    w0 = np.array([0.3, -0.4, 1.2])
    q, w, *_ = run(body, w0, 0.7, 10)
    exact = quaternion.multiply(Q0, quaternion.from_rotation_vector(7.0 * w0))
    assert quaternion.angle(q, exact) < 1e-13
    assert np.allclose(w, w0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("moments", [(5.0, 10.0, 13.0), (13.0, 5.0, 10.0), (10.0, 5.0, 13.0)])
def test_full_inertia_matches_the_principal_body(moments):
    # The same physical body described in a rotated body frame: I_B = C diag Cᵀ, q_WB = q_WP ⊗ c*.
    rng = np.random.default_rng(3)
    c = quaternion.random(rng)
    C = quaternion.to_matrix(c)
    full = RigidBody(mass=1.0, inertia=C @ np.diag(moments) @ C.T)
    assert full.kind == "full"
    w_P = np.array([0.3, 1.1, -0.6])
    tau_P = np.array([0.2, -0.1, 0.05])
    q_P, w_Pn, *_ = run(diagonal_body(moments), w_P, 0.05, 400, tau_B=tuple(tau_P.tolist()))
    q_B0 = quaternion.multiply(Q0, quaternion.conjugate(c))
    q_B, w_B, *_ = run(full, C @ w_P, 0.05, 400, q0=q_B0, tau_B=tuple((C @ tau_P).tolist()))
    assert quaternion.angle(quaternion.multiply(q_B, c), q_P) < 1e-11
    assert np.allclose(C.T @ w_B, w_Pn, atol=1e-11)


def test_relabelled_axes_give_the_same_motion():
    # Diagonal bodies whose axes are listed in another order (odd and even permutations).
    w0 = np.array([0.3, 1.1, -0.6])
    base, *_ = run(diagonal_body(), w0, 0.1, 200)
    for perm in ((1, 2, 0), (0, 2, 1), (2, 1, 0)):
        P = np.eye(3)[list(perm)]            # v_new = P v
        if np.linalg.det(P) < 0:
            P[2] *= -1.0
        p = quaternion.from_matrix(P.T)      # old body coords -> new: v_new = P v_old
        body = RigidBody(mass=1.0, inertia=P @ np.diag(MOMENTS) @ P.T)
        assert body.kind == "diagonal"
        q0 = quaternion.multiply(Q0, p)
        q, *_ = run(body, P @ w0, 0.1, 200, q0=q0)
        assert quaternion.angle(quaternion.multiply(q, quaternion.conjugate(p)), base) < 1e-12


@pytest.mark.parametrize("torque", ["torque_B", "torque"])
def test_thruster_slew_matches_tight_reference_and_other_integrators(torque):
    tau = np.array([0.5, 0.0, -0.4])
    omega_B0 = np.array([0.3, 0.1, -0.2])
    T = 4.0
    s0 = BodyState(orientation=Q0, angular_velocity=quaternion.rotate(Q0, omega_B0))
    kw = {torque: tau}
    q_ref, w_ref = reference.solve_ivp_reference(
        MOMENTS, omega_B0, Q0, [T], **{"torque_B" if torque == "torque_B" else "torque_W": tau})
    errors = []
    for dt in (0.04, 0.02, 0.01):
        out = simulate(diagonal_body(), s0, dt, round(T / dt), integrator="splitting", **kw)
        errors.append(float(quaternion.angle(out.orientation, q_ref[-1])))
    assert np.polyfit(np.log([0.04, 0.02, 0.01]), np.log(errors), 1)[0] == pytest.approx(
        2.0, abs=0.15)
    assert errors[-1] < 1e-4
    assert np.allclose(out.angular_velocity_B, w_ref[-1], atol=1e-4)
    for other in ("rk4", "midpoint"):
        ref_out = simulate(diagonal_body(), s0, 0.01, round(T / 0.01), integrator=other, **kw)
        assert quaternion.angle(out.orientation, ref_out.orientation) < 1e-3


def test_batch_matches_float_path_per_body():
    rng = np.random.default_rng(7)
    n = 16
    q = quaternion.random(rng, (n,))
    w = rng.normal(0.0, 1.0, (n, 3))
    tau = rng.normal(0.0, 0.2, (n, 3))
    body = RigidBody(mass=1.0, inertia=np.array([[5.0, 0.3, 0.1], [0.3, 10.0, -0.2],
                                                 [0.1, -0.2, 13.0]]))
    qb, wb = tuple(q.T.copy()), tuple(w.T.copy())
    for _ in range(50):
        qb, wb = advance(body, qb, wb, 0.1, tuple(tau.T.copy()))
    for i in range(n):
        qi, wi = tuple(q[i].tolist()), tuple(w[i].tolist())
        for _ in range(50):
            qi, wi = advance(body, qi, wi, 0.1, tuple(tau[i].tolist()))
        # NumPy's and libm's sin/cos may differ in the last bit: round-off, not bit equality.
        assert np.allclose([c[i] for c in qb], qi, rtol=0, atol=1e-13)
        assert np.allclose([c[i] for c in wb], wi, rtol=0, atol=1e-13)
