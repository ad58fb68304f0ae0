"""RigidBody, BodyState, force generators and integrator properties with closed-form answers."""

import numpy as np
import pytest
from rbenv.core import (
    INTEGRATORS,
    BodyState,
    InvalidInertiaError,
    InvalidParameterError,
    NonFiniteError,
    RigidBody,
    ThrusterLayout,
    angular_momentum_W,
    inertia,
    kernels,
    quaternion,
    rotational_energy,
    simulate,
    step,
    wrench_at_points,
)
from rbenv.core import integrators as integ
from scipy.spatial.transform import Rotation

MOMENTS = np.array([5.0, 10.0, 13.0])
Q0 = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))


def asymmetric_body():
    return RigidBody(mass=2.0, inertia=np.diag(MOMENTS))


def spinning_state(omega_B, q=Q0):
    return BodyState(orientation=q, angular_velocity=quaternion.rotate(q, np.asarray(omega_B)))


# --- parameters and validation ---------------------------------------------------------------


def test_body_kind_detects_what_the_step_may_skip():
    assert RigidBody(mass=1.0, inertia=np.eye(3) * 2.0).kind == "isotropic"
    assert RigidBody(mass=1.0, inertia=np.diag([1.0, 2.0, 2.5])).kind == "diagonal"
    R = Rotation.from_rotvec([0.3, 0.2, 0.1]).as_matrix()
    assert RigidBody(mass=1.0, inertia=R @ np.diag([1.0, 2.0, 2.5]) @ R.T).kind == "full"


@pytest.mark.parametrize("mass", [0.0, -1.0, float("nan"), float("inf")])
def test_mass_must_be_positive_and_finite(mass):
    with pytest.raises(InvalidParameterError, match="mass"):
        RigidBody(mass=mass, inertia=np.eye(3))


def test_rod_is_refused_with_reason():
    rod = inertia.rod(1.0, 2.0)
    assert rod[2, 2] == 0.0  # the tensor itself is available for composition
    with pytest.raises(InvalidInertiaError, match="positive definite"):
        RigidBody(mass=1.0, inertia=rod)


def test_triangle_inequality_is_enforced():
    with pytest.raises(InvalidInertiaError, match="triangle"):
        RigidBody(mass=1.0, inertia=np.diag([1.0, 1.0, 3.0]))
    RigidBody(mass=1.0, inertia=np.diag([1.0, 2.0, 3.0]))


def test_state_rejects_nan_and_non_unit_quaternion():
    with pytest.raises(NonFiniteError, match="angular_velocity"):
        BodyState(angular_velocity=[0.0, np.nan, 0.0])
    with pytest.raises(InvalidParameterError, match="unit quaternion"):
        BodyState(orientation=[1.0, 0.1, 0.0, 0.0])
    with pytest.raises(InvalidParameterError, match="shape"):
        BodyState(position=[1.0, 2.0])


def test_state_defaults_and_batch_broadcast():
    s = BodyState(angular_velocity=np.zeros((5, 3)))
    assert s.batch_shape == (5,)
    assert np.array_equal(s.orientation, np.tile([1.0, 0, 0, 0], (5, 1)))
    assert np.array_equal(s.position, np.zeros((5, 3)))


@pytest.mark.parametrize("dt", [0.0, -0.1, float("nan")])
def test_dt_must_be_positive(dt):
    with pytest.raises(InvalidParameterError, match="dt"):
        step(asymmetric_body(), BodyState(), dt)


def test_unknown_integrator_lists_choices():
    with pytest.raises(InvalidParameterError, match="midpoint"):
        step(asymmetric_body(), BodyState(), 0.1, integrator="verlet")


def test_nan_torque_is_rejected():
    with pytest.raises(NonFiniteError, match="torque"):
        step(asymmetric_body(), BodyState(), 0.1, torque=[0.0, np.nan, 0.0])


@pytest.mark.parametrize("name", ["euler", "semi_implicit"])
def test_explicit_blow_up_raises_instead_of_returning_nan(name):
    # h·|ω| = 2 near the major axis: the explicit gyroscopic term diverges within tens of steps.
    state = spinning_state([0.2, 0.3, 2.0])
    with pytest.raises(NonFiniteError, match="diverged"):
        simulate(asymmetric_body(), state, 1.0, 2000, integrator=name)


# --- force generators ------------------------------------------------------------------------


def test_wrench_at_points_matches_particle_sum():
    rng = np.random.default_rng(0)
    F, x, c = rng.standard_normal((6, 3)), rng.standard_normal((6, 3)), rng.standard_normal(3)
    force, torque = wrench_at_points(F, x, c)
    assert np.allclose(force, F.sum(0))
    assert np.allclose(torque, sum(np.cross(xi - c, fi) for xi, fi in zip(x, F, strict=True)))


def test_thruster_torque_matrix_is_lever_arm_cross_force():
    rng = np.random.default_rng(1)
    pos, dirs, fmax = rng.standard_normal((12, 3)), rng.standard_normal((12, 3)), rng.uniform(
        0.01, 0.1, 12)
    com = np.array([0.01, -0.02, 0.03])
    layout = ThrusterLayout(pos, dirs, fmax, com)
    for i in range(12):
        f = fmax[i] * dirs[i] / np.linalg.norm(dirs[i])
        assert np.allclose(layout.torque_matrix_B[:, i], np.cross(pos[i] - com, f))
        assert np.allclose(layout.force_matrix_B[:, i], f)
    u = rng.uniform(0, 1, (4, 12))
    _, torque_B = layout.wrench_B(u)
    assert np.allclose(torque_B, u @ layout.torque_matrix_B.T)


def test_thruster_layout_validation_names_the_field():
    with pytest.raises(InvalidParameterError, match=r"max_force\[1\]"):
        ThrusterLayout(np.zeros((2, 3)), np.eye(3)[:2], [0.1, 0.0])
    with pytest.raises(InvalidParameterError, match=r"directions_B\[0\]"):
        ThrusterLayout(np.ones((2, 3)), np.zeros((2, 3)), [0.1, 0.1])


def test_world_inverse_inertia_is_change_of_basis():
    body = asymmetric_body()
    R = Rotation.from_quat(Q0, scalar_first=True).as_matrix()
    assert np.allclose(body.world_inverse_inertia(Q0), R @ np.diag(1 / MOMENTS) @ R.T)
    sphere = RigidBody(mass=1.0, inertia=inertia.solid_sphere(3.0, 0.5))
    # Uniform-scale shortcut: R (s⁻¹E) Rᵀ = s⁻¹E.
    assert np.allclose(sphere.world_inverse_inertia(Q0), np.linalg.inv(sphere.inertia))


# --- the lecture's update, exactly -----------------------------------------------------------


@pytest.mark.parametrize("theta", [0.1, 0.5, 1.0, 2.0, 10.0])
def test_lecture_step_turns_by_cayley_angle(theta):
    dt = 0.05
    omega = (0.0, 0.0, theta / dt)
    q = kernels.cayley((1.0, 0.0, 0.0, 0.0), omega, dt)
    assert quaternion.angle(quaternion.identity(), np.array(q)) == pytest.approx(
        2 * np.arctan(theta / 2), rel=1e-14)


@pytest.mark.parametrize("theta", [0.1, 1.0, 3.0])
def test_unnormalised_lecture_step_grows_the_norm(theta):
    q0 = tuple(Q0.tolist())
    w = (theta, -theta, 0.5 * theta)
    dt = 0.1
    grown = np.linalg.norm(kernels.lecture_increment(q0, w, dt))
    assert grown == pytest.approx(np.sqrt(1 + (np.linalg.norm(w) * dt / 2) ** 2), rel=1e-14)


def test_euler_seed_is_the_lecture_and_misses_precession():
    # Torque-free asymmetric body: the lecture keeps ω_W fixed forever (no gyroscopic term),
    # so L_W = I_W ω_W drifts as the body turns. The true motion keeps L_W fixed instead.
    body, state = asymmetric_body(), spinning_state([0.05, 2.0, 0.05])
    seed = simulate(body, state, 0.01, 500, integrator="euler_seed")
    assert np.allclose(seed.angular_velocity, state.angular_velocity, atol=1e-12)
    L0 = angular_momentum_W(body, state)
    drift = [np.linalg.norm(angular_momentum_W(body, simulate(
        body, state, dt, int(5 / dt), integrator="euler_seed")) - L0) / np.linalg.norm(L0)
             for dt in (0.02, 0.01, 0.005)]
    assert min(drift) > 1e-3  # refining dt does not help ...
    assert max(drift) / min(drift) < 1.5  # ... the error does not shrink with dt
    exact = simulate(body, state, 0.01, 500, integrator="midpoint")
    assert np.linalg.norm(angular_momentum_W(body, exact) - L0) < 1e-12 * np.linalg.norm(L0)


def test_euler_seed_is_consistent_for_isotropic_bodies():
    # For a sphere ω × Iω = 0: the lecture's scheme loses nothing but the Cayley angle.
    body = RigidBody(mass=1.0, inertia=inertia.solid_sphere(2.0, 0.3))
    state = spinning_state([0.3, -0.2, 0.5])
    a = simulate(body, state, 0.01, 300, integrator="euler_seed")
    b = simulate(body, state, 0.01, 300, integrator="euler")
    assert np.allclose(a.orientation, b.orientation, atol=1e-13)
    assert np.allclose(a.angular_velocity, state.angular_velocity, atol=1e-14)


# --- conservation and closed forms -----------------------------------------------------------


@pytest.mark.parametrize("h_omega", [0.01, 0.1, 1.0, 5.0, 10.0])
@pytest.mark.parametrize("omega_B", [[0.2, 0.3, 2.0], [0.05, 2.0, 0.05], [2.0, 0.3, 0.2]])
def test_midpoint_conserves_invariants_at_any_step(h_omega, omega_B):
    body, state = asymmetric_body(), spinning_state(omega_B)
    h = h_omega / np.linalg.norm(omega_B)
    out = simulate(body, state, h, 200)
    E0, L0 = rotational_energy(body, state), angular_momentum_W(body, state)
    E1, L1 = rotational_energy(body, out), angular_momentum_W(body, out)
    assert abs(E1 - E0) <= 1e-12 * E0
    assert abs(np.linalg.norm(L1) - np.linalg.norm(L0)) <= 1e-12 * np.linalg.norm(L0)
    assert np.linalg.norm(L1 - L0) <= 1e-12 * np.linalg.norm(L0)


def _midpoint_residual(body, m, x, h):
    x, m = np.array(x), np.array(m)
    return np.linalg.norm(x - m - 0.5 * h * np.cross(x, body.apply_inverse(x))) / np.linalg.norm(m)


def test_newton_alone_fails_at_large_step_and_continuation_recovers():
    # A state met near the intermediate axis at h·|ω| = 5: Newton from the explicit guess fails.
    body = asymmetric_body()
    m = (0.3167173685185664, 19.994958045597883, -0.7657302810122353)
    h = 5.0 / np.linalg.norm([0.05, 2.0, 0.05])
    guess = kernels.add(m, kernels.cross(m, body.inverse_times(m)), 0.5 * h)
    _, converged = integ._newton(body, m, guess, h)
    assert not converged
    assert _midpoint_residual(body, m, integ._solve_midpoint(body, m, h), h) < 1e-13


def test_large_steps_follow_the_branch_that_tends_to_m():
    # Newton can converge to a spurious root for h·|ω| ≳ 4; the solver must pick the root that
    # continuation from h = 0 reaches, in scalar and batched form alike.
    body = asymmetric_body()
    rng = np.random.default_rng(0)
    w = rng.standard_normal((300, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    h = 8.0
    m = tuple(body.apply_inertia(w).T)
    batched = np.array(integ._solve_midpoint(body, m, h)).T
    for i in range(0, 300, 15):
        mi = tuple(float(c[i]) for c in m)
        x = mi
        for j in range(1, 257):  # fine continuation: unambiguous branch
            x, _ = integ._newton(body, mi, x, h * j / 256)
        assert np.allclose(batched[i], x, atol=1e-11)
        assert np.allclose(integ._solve_midpoint(body, mi, h), x, atol=1e-11)


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("name", ["rk4", "midpoint", "semi_implicit", "euler"])
def test_constant_principal_torque_from_rest_gives_half_alpha_t_squared(axis, name):
    body = asymmetric_body()
    tau = np.zeros(3)
    tau[axis] = 0.7
    alpha = tau[axis] / MOMENTS[axis]
    T, h = 2.0, 0.01
    out = simulate(body, BodyState(), h, int(T / h), torque=tau, integrator=name)
    expected = 0.5 * alpha * T**2
    got = quaternion.angle(quaternion.identity(), out.orientation)
    tol = {"rk4": 1e-12, "midpoint": 1e-5, "semi_implicit": 2e-2, "euler": 2e-2}[name]
    assert got == pytest.approx(expected, rel=tol)
    assert np.allclose(out.angular_velocity[axis], alpha * T, rtol=1e-12)


def test_translation_under_constant_force_is_exact_for_second_order_schemes():
    body = RigidBody(mass=4.0, inertia=np.eye(3))
    state = BodyState(velocity=[1.0, 0.0, -2.0])
    F = np.array([0.4, -0.8, 1.2])
    for name in ("rk4", "midpoint"):
        out = simulate(body, state, 0.1, 30, force=F, integrator=name)
        T = 3.0
        assert np.allclose(out.position, state.velocity * T + 0.5 * F / 4.0 * T**2, atol=1e-12)
    frozen = simulate(body, state, 0.1, 30, force=F, translation=False)
    assert np.array_equal(frozen.position, state.position)


@pytest.mark.parametrize("name", sorted(INTEGRATORS))
def test_batched_step_equals_individual_steps(name):
    rng = np.random.default_rng(7)
    q = quaternion.random(rng, (6,))
    w = rng.normal(0, 0.5, (6, 3))
    tau = rng.normal(0, 0.2, (6, 3))
    body = asymmetric_body()
    batch = step(body, BodyState(orientation=q, angular_velocity=w), 0.05, torque=tau,
                 integrator=name)
    for i in range(6):
        one = step(body, BodyState(orientation=q[i], angular_velocity=w[i]), 0.05,
                   torque=tau[i], integrator=name)
        assert np.allclose(one.orientation, batch.orientation[i], atol=1e-15, rtol=0)
        assert np.allclose(one.angular_velocity, batch.angular_velocity[i], atol=1e-15, rtol=0)


@pytest.mark.parametrize("name", sorted(INTEGRATORS))
def test_full_inertia_matches_diagonal_in_principal_frame(name):
    # The same physical body described in rotated body axes must move identically.
    rng = np.random.default_rng(3)
    P = Rotation.from_rotvec([0.4, -0.3, 0.8])
    p = P.as_quat(scalar_first=True)
    diag_body = asymmetric_body()
    full_body = RigidBody(mass=2.0, inertia=P.as_matrix() @ np.diag(MOMENTS) @ P.as_matrix().T)
    q = quaternion.random(rng)
    w_B = np.array([0.3, -1.1, 0.4])
    s_diag = spinning_state(w_B, q)
    # Body axes of full_body = P applied to principal axes: q_full = q ⊗ p*.
    q_full = quaternion.multiply(q, quaternion.conjugate(p))
    s_full = BodyState(orientation=q_full, angular_velocity=s_diag.angular_velocity)
    a = simulate(diag_body, s_diag, 0.01, 100, integrator=name)
    b = simulate(full_body, s_full, 0.01, 100, integrator=name)
    assert np.allclose(a.angular_velocity, b.angular_velocity, atol=1e-12)
    assert quaternion.angle(quaternion.multiply(a.orientation, quaternion.conjugate(p)),
                            b.orientation) < 1e-11


def test_trajectory_has_time_axis():
    traj = simulate(asymmetric_body(), spinning_state([0.1, 0.2, 0.3]), 0.1, 10, trajectory=True)
    assert traj.orientation.shape == (11, 4)
    assert np.array_equal(traj.orientation[0], Q0)


# ------------------------------------------------------------------ overflow and batch checks


@pytest.mark.parametrize("integrator", sorted(INTEGRATORS))
@pytest.mark.parametrize("inertia_diag", [(1.0, 1.0, 1.0), (1.0, 2.0, 2.5)])
def test_overflowing_step_raises_instead_of_returning_a_zero_quaternion(integrator, inertia_diag):
    body = RigidBody(mass=1.0, inertia=np.diag(inertia_diag))
    state = BodyState(angular_velocity=[0.1, 0.2, 0.3])
    with pytest.raises(NonFiniteError, match="diverged"):
        step(body, state, 1e160, integrator=integrator)


# The state overflows on purpose (NumPy reports it on the way to the named error).
@pytest.mark.filterwarnings("ignore:(overflow|invalid value) encountered:RuntimeWarning")
def test_simulate_checks_every_step_and_translation():
    body = RigidBody(mass=1.0, inertia=np.eye(3))
    with pytest.raises(NonFiniteError, match="diverged"):
        simulate(body, BodyState(velocity=[1e300, 0.0, 0.0]), 1e10, 3)
    with pytest.raises(NonFiniteError, match="diverged"):
        step(body, BodyState(), 10.0, force=[1e308, 1e308, 0.0])


def test_mismatched_batches_name_the_fields():
    body = RigidBody(mass=1.0, inertia=np.eye(3))
    state = BodyState(angular_velocity=np.zeros((3, 3)))
    with pytest.raises(InvalidParameterError, match=r"state \(3,\), torque \(2,\)"):
        step(body, state, 0.1, torque=np.zeros((2, 3)))
    with pytest.raises(InvalidParameterError, match=r"torque \(4, 3\).*state's batch shape"):
        step(body, state, 0.1, torque=np.zeros((4, 3, 3)))
    with pytest.raises(InvalidParameterError, match=r"position \(2,\), angular_velocity \(3,\)"):
        BodyState(position=np.zeros((2, 3)), angular_velocity=np.zeros((3, 3)))


def test_empty_batches_step_to_empty_batches():
    body = RigidBody(mass=1.0, inertia=np.diag([1.0, 2.0, 2.5]))
    out = simulate(body, BodyState(angular_velocity=np.zeros((0, 3))), 0.1, 3,
                   torque=np.zeros((0, 3)))
    assert out.orientation.shape == (0, 4) and out.angular_velocity.shape == (0, 3)


@pytest.mark.parametrize("bad", [True, "0.1", 1 + 1j, {"dt": 0.1}, 10**400])
def test_dt_type_holes_are_closed(bad):
    body = RigidBody(mass=1.0, inertia=np.eye(3))
    with pytest.raises(InvalidParameterError, match="dt"):
        step(body, BodyState(), bad)


def test_n_steps_cap_and_numpy_integers():
    body = RigidBody(mass=1.0, inertia=np.eye(3))
    with pytest.raises(InvalidParameterError, match="n_steps must be >= 0 and <= 10000000"):
        simulate(body, BodyState(), 0.1, 10**12)
    simulate(body, BodyState(), 0.1, np.int64(2))
