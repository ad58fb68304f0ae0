"""The optional compiled path (core.compiled) against the float and NumPy paths it compiles."""

import numpy as np
import pytest
from rbenv.core import INTEGRATORS, RigidBody, compiled, quaternion
from rbenv.core.errors import InvalidParameterError

N = 32


def bodies():
    rng = np.random.default_rng(1)
    c = quaternion.to_matrix(quaternion.random(rng))
    return {
        "diagonal": RigidBody(mass=1.0, inertia=np.diag([5.0, 10.0, 13.0])),
        "full": RigidBody(mass=1.0, inertia=c @ np.diag([2.0, 3.0, 4.5]) @ c.T),
        "isotropic": RigidBody(mass=1.0, inertia=np.eye(3) * 2.5),
    }


def batch(seed=0):
    rng = np.random.default_rng(seed)
    parts = (quaternion.random(rng, (N,)), rng.normal(0.0, 1.0, (N, 3)),
             rng.normal(0.0, 0.5, (N, 3)), rng.normal(0.0, 0.5, (N, 3)))
    return tuple(tuple(np.ascontiguousarray(a[:, i]) for i in range(a.shape[1])) for a in parts)


def entry(components, i):
    return None if components is None else tuple(float(c[i]) for c in components)


CASES = [("rk4", kind, torques) for kind in ("diagonal", "full", "isotropic")
         for torques in ("none", "body", "both")]
CASES += [(name, "full", "both") for name in ("euler_seed", "euler", "semi_implicit")]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "kind", "torques"), CASES)
def test_compiled_step_equals_the_float_path_bit_for_bit(name, kind, torques):
    pytest.importorskip("numba")
    body = bodies()[kind]
    q, w, tau_B, tau_W = batch()
    tau_B = None if torques == "none" else tau_B
    tau_W = tau_W if torques == "both" else None
    q_c, w_c = compiled.get(name).advance(body, q, w, 0.05, tau_B, tau_W)
    advance = INTEGRATORS[name].advance
    for i in range(N):
        q_f, w_f = advance(body, entry(q, i), entry(w, i), 0.05, entry(tau_B, i), entry(tau_W, i))
        # The same operations in the same order on IEEE doubles, and libm's math functions
        # on both sides: the compiled loop reproduces the float path exactly.
        assert tuple(float(c[i]) for c in q_c) == q_f
        assert tuple(float(c[i]) for c in w_c) == w_f
    # Against the NumPy batch path: round-off at most (NumPy's own tan in the exp map).
    q_n, w_n = advance(body, q, w, 0.05, tau_B, tau_W)
    for a, b in zip(q_c + w_c, q_n + w_n, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


def test_compiled_run_stays_on_the_numpy_trajectory():
    pytest.importorskip("numba")
    body = bodies()["full"]
    q, w, tau_B, _ = batch(3)
    q_n, w_n = q, w
    step = compiled.get("rk4")
    for _ in range(200):
        q, w = step.advance(body, q, w, 0.05, tau_B)
        q_n, w_n = INTEGRATORS["rk4"].advance(body, q_n, w_n, 0.05, tau_B)
    assert max(np.abs(a - b).max() for a, b in zip(q + w, q_n + w_n, strict=True)) < 1e-13


def test_floats_broadcast_against_arrays():
    pytest.importorskip("numba")
    body = bodies()["diagonal"]
    q, w, _, _ = batch()
    tau = (0.1, -0.2, 0.3)
    q_c, w_c = compiled.get("rk4").advance(body, q, w, 0.05, tau)
    q_n, w_n = INTEGRATORS["rk4"].advance(body, q, w, 0.05, tau)
    for a, b in zip(q_c + w_c, q_n + w_n, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("name", "kind", "torques"), CASES)
def test_one_body_on_floats_runs_the_compiled_kernel_bit_for_bit(name, kind, torques):
    """Floats in, floats out (the single env's path), equal to the float kernel exactly."""
    pytest.importorskip("numba")
    body = bodies()[kind]
    q, w, tau_B, tau_W = batch(5)
    tau_B = None if torques == "none" else tau_B
    tau_W = tau_W if torques == "both" else None
    step, advance = compiled.get(name), INTEGRATORS[name].advance
    for i in range(4):
        args = (entry(q, i), entry(w, i), 0.05, entry(tau_B, i), entry(tau_W, i))
        q_c, w_c = step.advance(body, *args)
        assert all(type(c) is float for c in q_c + w_c)
        assert (q_c, w_c) == advance(body, *args)


def test_one_body_with_an_array_among_the_floats_broadcasts():
    pytest.importorskip("numba")
    body = bodies()["full"]
    w = (np.array([0.1, 0.2, -0.3]), 0.5, -0.25)
    q_c, w_c = compiled.get("rk4").advance(body, (1.0, 0.0, 0.0, 0.0), w, 0.05)
    q_n, w_n = INTEGRATORS["rk4"].advance(body, (1.0, 0.0, 0.0, 0.0), w, 0.05)
    for a, b in zip(q_c + w_c, q_n + w_n, strict=True):
        assert np.shape(a) == (3,)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", ["midpoint", "splitting", "nope"])
def test_integrators_that_are_not_compiled_are_refused_by_name(name):
    pytest.importorskip("numba")
    with pytest.raises(InvalidParameterError, match=f"compiled integrator must be one of .*{name}"):
        compiled.get(name)


def test_without_numba_get_names_the_extra(monkeypatch):
    monkeypatch.setattr(compiled, "numba", None)
    compiled.get.cache_clear()
    assert not compiled.available()
    with pytest.raises(InvalidParameterError, match=r"rbenv\[fast\]"):
        compiled.get("rk4")
    compiled.get.cache_clear()
