"""Thruster allocation: exactness, bounds, saturation behaviour, fuel optimality, validation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

from rbenv.satellite.allocation import (
    Allocator,
    MinFuelLPAllocator,
    NNLSAllocator,
    PseudoInverseAllocator,
    make_allocator,
    max_torque_along,
    validate_torque_matrix,
)

NAMES = ("pinv", "nnls", "lp")
FORCE = 0.05  # N, cold-gas thruster class (reference/attitude-control.md §4)
HALF = np.array([0.1, 0.1, 0.15])  # m, half extents of a 0.2 × 0.2 × 0.3 m bus


def torque_columns(positions, directions, force, com):
    """(3, n) N·m: r × F for thrusters at positions (n, 3) m pushing along directions (n, 3)."""
    d = np.asarray(directions, float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    return np.cross(np.asarray(positions, float) - com, force * d).T


def cold_gas_layout(com=(0.003, -0.002, 0.008), drop=()):
    """12 thrusters, one at the midpoint of each box edge, firing along the edge's faces.

    Four per body axis form two opposed pure couples (zero net force) about the geometric
    centre: ±x authority 2·F·0.15 m, ±y 2·F·0.15 m, ±z 2·F·0.1 m. The centre-of-mass offset
    adds the small cross-coupling a real bus has. ``drop`` removes thrusters by index.
    """
    a, b, c = HALF
    thrusters = [
        # x couples: edges parallel to x, force along ±y, lever arm c.
        ((0, b, c), (0, -1, 0)),  # +x
        ((0, b, -c), (0, 1, 0)),  # +x
        ((0, -b, c), (0, 1, 0)),  # -x
        ((0, -b, -c), (0, -1, 0)),  # -x
        # y couples: edges parallel to y, force along ±x, lever arm c.
        ((a, 0, c), (1, 0, 0)),  # +y
        ((-a, 0, -c), (-1, 0, 0)),  # +y
        ((-a, 0, c), (-1, 0, 0)),  # -y
        ((a, 0, -c), (1, 0, 0)),  # -y
        # z couples: edges parallel to z, force along ±y, lever arm a.
        ((a, b, 0), (0, 1, 0)),  # +z
        ((-a, -b, 0), (0, -1, 0)),  # +z
        ((-a, b, 0), (0, 1, 0)),  # -z
        ((a, -b, 0), (0, -1, 0)),  # -z
    ]
    keep = [t for i, t in enumerate(thrusters) if i not in drop]
    pos, dirs = zip(*keep, strict=True)
    return torque_columns(pos, dirs, FORCE, np.asarray(com, float))


def random_layout(rng, n):
    """n thrusters at random points of the bus surface, random directions, valid layout."""
    while True:
        pos = rng.uniform(-1.0, 1.0, (n, 3)) * HALF
        face = rng.integers(0, 3, n)
        pos[np.arange(n), face] = np.sign(rng.uniform(-1, 1, n)) * HALF[face]
        B = torque_columns(pos, rng.normal(size=(n, 3)), FORCE, rng.normal(0, 0.005, 3))
        try:
            validate_torque_matrix(B)
        except ValueError:
            continue
        return B


LAYOUTS = {"cold_gas": cold_gas_layout()}
_rng = np.random.default_rng(20240611)
for _n in (6, 8, 12, 16):
    LAYOUTS[f"random{_n}"] = random_layout(_rng, _n)


@pytest.fixture(params=list(LAYOUTS), scope="module")
def layout(request):
    return LAYOUTS[request.param]


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_directions(rng, k):
    return unit(rng.normal(size=(k, 3)))


def pinv_unsaturated_limit(alloc, directions):
    """Per direction (k,), the largest demand magnitude pinv meets without scaling down, N·m."""
    eps = 1e-6
    u = alloc(eps * directions)
    return eps / u.max(axis=1)


def zonotope_authority(B, d):
    """Brute force: the largest s with s·d in {B u : u ∈ [0,1]^n}, from all facet normals.

    Every facet normal of the 3-D zonotope is a cross product of two generators, and the set
    is the intersection of the half-spaces wᵀx ≤ h(w) = Σ max(0, wᵀb_i); the origin is
    interior for a valid layout, so the ray s·d leaves through the facet minimising h(w)/wᵀd.
    """
    best = np.inf
    for i, j in itertools.combinations(range(B.shape[1]), 2):
        w = np.cross(B[:, i], B[:, j])
        if np.linalg.norm(w) < 1e-12 * np.linalg.norm(B[:, i]) * np.linalg.norm(B[:, j]):
            continue
        for w_s in (w, -w):
            wd = w_s @ d
            if wd > 0:
                best = min(best, np.maximum(w_s @ B, 0.0).sum() / wd)
    return best


# --------------------------------------------------------------------------- feasible demands


@pytest.mark.parametrize("name", NAMES)
def test_feasible_demand_is_met_exactly(layout, name):
    rng = np.random.default_rng(1)
    B = layout
    alloc = make_allocator(name, B)
    assert isinstance(alloc, Allocator)
    dirs = random_directions(rng, 64)
    limit = pinv_unsaturated_limit(make_allocator("pinv", B), dirs)
    tau = dirs * (limit * rng.uniform(0.05, 0.95, 64))[:, None]
    u = alloc(tau)
    assert u.shape == (64, B.shape[1])
    assert np.abs(u @ B.T - tau).max() <= 1e-12  # brief asks 1e-9 N·m; torques are ~1e-3
    assert u.min() >= 0.0 and u.max() <= 1.0
    for k in (0, 17, 63):
        single = alloc(tau[k])
        assert single.shape == (B.shape[1],)
        np.testing.assert_allclose(single, u[k], atol=1e-12)
        np.testing.assert_allclose(B @ single, tau[k], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_batch_shape_is_kept(name):
    B = LAYOUTS["cold_gas"]
    alloc = make_allocator(name, B)
    tau = np.random.default_rng(2).normal(0, 1e-3, (2, 5, 3))
    u = alloc(tau)
    assert u.shape == (2, 5, 12)
    np.testing.assert_allclose(u.reshape(10, 12), alloc(tau.reshape(10, 3)), atol=1e-12)
    assert alloc(np.zeros((0, 3))).shape == (0, 12)
    assert alloc([1e-3, 0, 0]).shape == (12,)


@pytest.mark.parametrize("name", NAMES)
def test_zero_demand_fires_nothing(layout, name):
    u = make_allocator(name, layout)(np.zeros((3, 3)))
    assert np.all(u == 0.0)


def test_pure_couple_demand_uses_the_couple():
    B = cold_gas_layout(com=(0, 0, 0))
    tau = np.array([0.0, 0.0, 0.004])  # 40 % of the +z couple (2 · 0.05 N · 0.1 m)
    for name in NAMES:
        u = make_allocator(name, B)(tau)
        np.testing.assert_allclose(B @ u, tau, atol=1e-15)
    # Minimum fuel: 0.8 of one +z thruster's torque, from the +z pair only (how it splits
    # between the pair is a tie; translation is not part of the allocation problem).
    u = make_allocator("lp", B)(tau)
    assert u.sum() == pytest.approx(0.8, rel=1e-12)
    assert np.all(np.delete(u, [8, 9]) == 0.0)


# --------------------------------------------------------------------------- saturation


@pytest.mark.parametrize("name", ["pinv", "lp"])
def test_saturated_demand_keeps_direction(layout, name):
    B = layout
    alloc = make_allocator(name, B)
    rng = np.random.default_rng(3)
    dirs = np.vstack([np.eye(3), -np.eye(3), random_directions(rng, 6)])
    authority = np.array([max_torque_along(B, d) for d in dirs])
    tau = 10.0 * authority[:, None] * dirs
    u = alloc(tau)
    assert u.min() >= 0.0 and u.max() <= 1.0
    achieved = u @ B.T
    mag = np.linalg.norm(achieved, axis=1)
    cosine = np.einsum("ij,ij->i", achieved, dirs) / mag
    np.testing.assert_allclose(cosine, 1.0, rtol=0, atol=1e-12)
    assert np.all(mag <= authority * (1 + 1e-9))
    if name == "lp":
        # The LP reaches the full authority along the demand, not just a fraction of it.
        np.testing.assert_allclose(mag, authority, rtol=1e-9)
    else:
        # Uniform scaling puts the largest throttle exactly at 1.
        np.testing.assert_allclose(u.max(axis=1), 1.0, rtol=1e-12)


def test_saturated_nnls_gives_closest_achievable_torque(layout):
    """Bounded least squares: KKT conditions of min ‖Bu − τ‖² on the box, and no worse than
    the direction-keeping allocators."""
    B = layout
    rng = np.random.default_rng(4)
    dirs = random_directions(rng, 12)
    authority = np.array([max_torque_along(B, d) for d in dirs])
    tau = 10.0 * authority[:, None] * dirs
    u = NNLSAllocator(B)(tau)
    assert u.min() >= 0.0 and u.max() <= 1.0
    scale = np.abs(B).max()
    for k in range(len(tau)):
        g = B.T @ (B @ u[k] - tau[k]) / scale**2  # gradient, dimensionless
        tol = 1e-9 * np.linalg.norm(tau[k]) / scale
        lo, hi = u[k] <= 1e-12, u[k] >= 1.0 - 1e-12  # BVLS may leave 1 - 1 ulp
        inner = ~(lo | hi)
        assert np.all(np.abs(g[inner]) <= tol)
        assert np.all(g[lo] >= -tol) and np.all(g[hi] <= tol)
    err = np.linalg.norm(u @ B.T - tau, axis=1)
    for other in ("pinv", "lp"):
        err_other = np.linalg.norm(make_allocator(other, B)(tau) @ B.T - tau, axis=1)
        assert np.all(err <= err_other * (1 + 1e-9))


def test_nnls_respects_max_throttle():
    B = LAYOUTS["cold_gas"]
    alloc = NNLSAllocator(B, max_throttle=0.25)
    tau = np.random.default_rng(5).normal(0, 0.01, (50, 3))
    u = alloc(tau)
    assert u.min() >= 0.0 and u.max() <= 0.25
    assert np.isclose(u.max(), 0.25)
    small = np.array([0.0, 0.0, 0.001])  # 0.25 of the +z couple would give 0.0025 N·m
    np.testing.assert_allclose(B @ alloc(small), small, atol=1e-15)


# --------------------------------------------------------------------------- random sweep


def sweep_demands(rng, B, k):
    """k demands from 1e-6 to 30× the authority, plus columns and zonotope vertices."""
    dirs = random_directions(rng, k)
    mags = 10.0 ** rng.uniform(-6, np.log10(30), k) * np.abs(B).sum(axis=1).max()
    tau = dirs * mags[:, None]
    sign = rng.integers(0, 2, (8, B.shape[1])).astype(float)
    return np.vstack([tau, B.T, sign @ B.T, 1e6 * B.T, [[0.0, 0.0, 1e-300]]])


@pytest.mark.parametrize(("name", "k"), [("pinv", 20000), ("nnls", 400), ("lp", 150)])
def test_throttles_never_leave_unit_box(layout, name, k):
    B = layout
    rng = np.random.default_rng(6)
    tau = sweep_demands(rng, B, k)
    u = make_allocator(name, B)(tau)
    assert np.isfinite(u).all()
    assert u.min() >= 0.0 and u.max() <= 1.0
    achieved = u @ B.T
    if name != "nnls":
        mag = np.linalg.norm(achieved, axis=1)
        norm = np.linalg.norm(tau, axis=1)
        nz = mag > 0
        cosine = np.einsum("ij,ij->i", achieved[nz], tau[nz]) / (mag[nz] * norm[nz])
        assert np.all(cosine >= 1 - 1e-9)
        assert np.all(mag <= norm * (1 + 1e-9))
        # Only a demand too small to register may come back empty.
        assert np.all(norm[~nz] < 1e-200)


# --------------------------------------------------------------------------- fuel


def test_lp_uses_least_fuel(layout):
    B = layout
    rng = np.random.default_rng(7)
    dirs = random_directions(rng, 40)
    limit = pinv_unsaturated_limit(make_allocator("pinv", B), dirs)
    tau = dirs * (limit * rng.uniform(0.05, 0.99, 40))[:, None]
    fuel = {name: make_allocator(name, B)(tau).sum(axis=1) for name in NAMES}
    assert np.all(fuel["lp"] <= fuel["pinv"] + 1e-9)
    assert np.all(fuel["lp"] <= fuel["nnls"] + 1e-9)


def test_lp_matches_highs_directly(layout):
    """The vectorised fast path and the HiGHS fallback both reach linprog's optimum."""
    B = layout
    rng = np.random.default_rng(8)
    dirs = random_directions(rng, 30)
    authority = np.array([max_torque_along(B, d) for d in dirs])
    # Up to 0.999 of the authority: many demands need throttles at 1 and bypass the fast path.
    tau = dirs * (authority * rng.uniform(0.01, 0.999, 30))[:, None]
    u = MinFuelLPAllocator(B)(tau)
    np.testing.assert_allclose(u @ B.T, tau, rtol=0, atol=1e-12)
    for k in range(len(tau)):
        ref = linprog(np.ones(B.shape[1]), A_eq=B, b_eq=tau[k], bounds=(0, 1), method="highs")
        assert ref.status == 0
        assert u[k].sum() <= ref.fun + 1e-9


def test_lp_without_fast_paths_agrees(monkeypatch):
    """Layouts beyond the fast-path size run every demand through HiGHS, same answers."""
    import rbenv.satellite.allocation as allocation

    B = LAYOUTS["random12"]
    fast = MinFuelLPAllocator(B)
    monkeypatch.setattr(allocation, "_FAST_PATH_MAX_THRUSTERS", 0)
    slow = MinFuelLPAllocator(B)
    rng = np.random.default_rng(10)
    dirs = random_directions(rng, 12)
    authority = np.array([max_torque_along(B, d) for d in dirs])
    tau = dirs * (authority * np.r_[rng.uniform(0.05, 0.99, 6), [10.0] * 6])[:, None]
    u_fast, u_slow = fast(tau), slow(tau)
    assert u_slow.min() >= 0.0 and u_slow.max() <= 1.0
    np.testing.assert_allclose(u_slow[:6] @ B.T, tau[:6], rtol=0, atol=1e-12)
    np.testing.assert_allclose(u_slow[6:] @ B.T, authority[6:, None] * dirs[6:], rtol=1e-9)
    np.testing.assert_allclose(u_slow.sum(axis=1), u_fast.sum(axis=1), rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- authority


def test_max_torque_along_matches_brute_force(layout):
    B = layout
    rng = np.random.default_rng(9)
    for d in np.vstack([np.eye(3), -np.eye(3), random_directions(rng, 4)]):
        s = max_torque_along(B, d)
        np.testing.assert_allclose(s, zonotope_authority(B, d), rtol=1e-9)
        # Consistency: an LP solution achieves it, and nothing beyond it is reachable.
        u = MinFuelLPAllocator(B)(3.0 * s * d)
        np.testing.assert_allclose(B @ u, s * d, rtol=0, atol=1e-12 * s / 1e-3 + 1e-15)
        assert max_torque_along(B, 7.0 * d) == pytest.approx(s, rel=1e-12)


def test_cold_gas_axis_authority_is_the_couple():
    # Centred: every column is a pure-axis torque, so the authority is one couple. (With the
    # centre-of-mass offset, cross-coupled thrusters add a few per cent more.)
    B = cold_gas_layout(com=(0, 0, 0))
    for axis, lever in ((0, 0.15), (1, 0.15), (2, 0.1)):
        for sign in (1.0, -1.0):
            d = np.zeros(3)
            d[axis] = sign
            assert max_torque_along(B, d) == pytest.approx(2 * FORCE * lever, rel=1e-9)


# --------------------------------------------------------------------------- validation


def test_layout_pushing_one_way_is_refused():
    a, b, c = HALF
    pos = [(x, y, z) for x in (-a, a) for y in (-b, b) for z in (-c, 0, c)]
    B = torque_columns(pos, [(0, 0, 1)] * len(pos), FORCE, np.zeros(3))
    for name in NAMES:
        with pytest.raises(ValueError, match=r"cannot produce torque along \+z, -z"):
            make_allocator(name, B)


def test_layout_without_minus_z_is_refused():
    B = cold_gas_layout(com=(0, 0, 0), drop=(10, 11))
    with pytest.raises(ValueError, match=r"cannot produce torque along -z:"):
        PseudoInverseAllocator(B)
    with pytest.raises(ValueError, match=r"along -z:"):
        validate_torque_matrix(B)


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (np.zeros((12, 3)), r"shape \(3, n\)"),
        (np.zeros((3, 0)), r"shape \(3, n\)"),
        (np.zeros((3, 4)), "all zeros"),
        (np.full((3, 6), np.nan), "torque_matrix must be finite"),
        (np.eye(3), r"along -x, -y, -z"),
    ],
)
def test_bad_torque_matrix_is_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        MinFuelLPAllocator(bad)


@pytest.mark.parametrize("name", NAMES)
def test_bad_demand_is_refused(name):
    alloc = make_allocator(name, LAYOUTS["cold_gas"])
    with pytest.raises(ValueError, match=r"tau_B must be finite.*nan"):
        alloc([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"tau_B must be finite"):
        alloc(np.array([[0.0, 0.0, 0.0], [np.inf, 0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"tau_B must have shape"):
        alloc(np.zeros(4))
    with pytest.raises(ValueError, match=r"tau_B must have shape"):
        alloc(0.0)


def test_bad_names_and_options_are_refused():
    B = LAYOUTS["cold_gas"]
    with pytest.raises(ValueError, match="allocator name must be one of"):
        make_allocator("qp", B)
    with pytest.raises(ValueError, match="max_throttle"):
        NNLSAllocator(B, max_throttle=1.5)
    with pytest.raises(ValueError, match="direction must be non-zero"):
        max_torque_along(B, np.zeros(3))
    with pytest.raises(ValueError, match="direction must be finite"):
        max_torque_along(B, [np.nan, 0, 1])


def test_allocators_are_frozen():
    alloc = make_allocator("pinv", LAYOUTS["cold_gas"])
    with pytest.raises(AttributeError):
        alloc.torque_matrix = np.eye(3)
    with pytest.raises(ValueError):
        alloc.torque_matrix[0, 0] = 1.0
