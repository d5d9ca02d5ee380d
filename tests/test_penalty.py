"""The obstacle penalty: compiled value, gradient and Hessian (penalty.py) and obstacles as data.

``P(x, y) = sum_j W exp(-(s_j)^n)``, ``s_j = |(x, y) - c_j|^2 / r_j^2`` (spec section 1).
``ObstaclePenalty.__call__`` (NumPy) is the independent evaluation of the value; derivatives
are checked against 5-point central differences.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import CASES, EXTREMAL_COSTATE, fd_jacobian
from leapfrog_planner import Flow, OptimalControlProblem, obstacle_penalty
from leapfrog_planner.bvp.shooting import ShootingSettings, solve_shooting
from leapfrog_planner.model.penalty import as_obstacle_array, clearance, penalty_terms
from leapfrog_planner.roots import RootSettings

OBSTACLES = CASES[4].obstacles
EXPONENTS = [1, 2, 3]

# Points over case 4's obstacle field (mostly within a few radii of some obstacle).
points = st.tuples(st.floats(-0.1, 2.1), st.floats(-0.65, 0.6))


def terms(pen, x, y, hessian=True):
    return np.array(penalty_terms(x, y, pen.obstacles, pen.weight, pen.exponent, hessian))


def dense(pen, xy):
    """The penalty's formula summed over every obstacle (NumPy, no cutoff): ``W sum exp(-s^n)``."""
    xy = np.asarray(xy, dtype=float)
    d2 = ((xy[..., None, :] - pen.obstacles[:, :2]) ** 2).sum(-1) / pen.obstacles[:, 2] ** 2
    return (pen.weight * np.exp(-(d2**pen.exponent))).sum(-1)


def grad_fd(pen, xy):
    return fd_jacobian(lambda q: dense(pen, q), xy, 1e-5)[0]


@pytest.mark.parametrize("exponent", EXPONENTS)
@settings(max_examples=60)
@given(xy=points, weight=st.sampled_from([100.0, 1.0, 37.5]))
def test_value_gradient_hessian_against_numpy_and_finite_differences(exponent, xy, weight):
    pen = obstacle_penalty(OBSTACLES, weight, exponent)
    xy = np.array(xy)
    P, Px, Py, Pxx, Pxy, Pyy = terms(pen, *xy)
    assert np.all(np.isfinite([P, Px, Py, Pxx, Pxy, Pyy]))
    # Value: the formula in NumPy, term for term; the penalty's own call gives the same.
    # (exp(-a) carries a relative rounding error ~ a eps, hence rel 1e-11 where a ~ 300.)
    assert P == pytest.approx(float(dense(pen, xy)), rel=1e-11, abs=1e-14 * weight)
    assert float(pen(xy)) == P
    # Gradient: 5-point differences of the NumPy value. Scales: W / r and W / r^2 (r = 0.1).
    g_scale, h_scale = weight / 0.1, weight / 0.01
    np.testing.assert_allclose([Px, Py], grad_fd(pen, xy), rtol=0, atol=1e-8 * g_scale)
    # Hessian: 5-point differences of the compiled gradient; symmetric by construction.
    H_fd = fd_jacobian(lambda q: terms(pen, *q)[1:3], xy, 1e-5)
    np.testing.assert_allclose([[Pxx, Pxy], [Pxy, Pyy]], H_fd, rtol=0, atol=1e-7 * h_scale)
    # Without the Hessian: same value and gradient, zeros in its place.
    no_h = terms(pen, *xy, hessian=False)
    np.testing.assert_array_equal(no_h[:3], [P, Px, Py])
    np.testing.assert_array_equal(no_h[3:], 0.0)


@pytest.mark.parametrize("exponent", EXPONENTS)
def test_at_an_obstacle_centre_everything_is_finite_and_exact(exponent):
    """At s = 0: P = W, grad P = 0; Hessian -2W/r^2 I for n = 1 (exp(-s)), 0 for n >= 2."""
    W, r = 100.0, 0.1
    pen = obstacle_penalty([[0.4, 0.05, r]], W, exponent)
    P, Px, Py, Pxx, Pxy, Pyy = terms(pen, 0.4, 0.05)
    assert np.all(np.isfinite([P, Px, Py, Pxx, Pxy, Pyy]))
    assert P == W and Px == 0.0 and Py == 0.0 and Pxy == 0.0
    expected = -2.0 * W / r**2 if exponent == 1 else 0.0
    assert Pxx == pytest.approx(expected, abs=1e-9) and Pyy == pytest.approx(expected, abs=1e-9)
    H_fd = fd_jacobian(lambda q: terms(pen, *q)[1:3], np.array([0.4, 0.05]), 1e-5)
    np.testing.assert_allclose(H_fd, [[expected, 0.0], [0.0, expected]], atol=1e-5)
    # And in the field of all of case 4's obstacles, at each centre.
    full = obstacle_penalty(OBSTACLES, W, exponent)
    for cx, cy, _ in OBSTACLES:
        t = terms(full, cx, cy)
        assert np.all(np.isfinite(t))
        assert t[0] == pytest.approx(float(full([cx, cy])), rel=1e-13)
        assert t[0] >= W


def test_far_away_and_without_obstacles_the_penalty_is_exactly_zero():
    pen = obstacle_penalty(OBSTACLES)
    np.testing.assert_array_equal(terms(pen, 50.0, -40.0), 0.0)
    assert float(pen([50.0, -40.0])) == 0.0
    empty = obstacle_penalty([])
    assert empty.obstacles.shape == (0, 3)
    np.testing.assert_array_equal(terms(empty, 0.4, 0.05), 0.0)
    np.testing.assert_array_equal(empty(np.zeros((5, 2))), np.zeros(5))
    # Huge coordinates (a blown-up shooting iterate) give zeros, not NaN.
    np.testing.assert_array_equal(terms(pen, 1e200, -1e200), 0.0)


@pytest.mark.parametrize("exponent", EXPONENTS)
@pytest.mark.parametrize("weight", [1.0, 100.0, 1e6])
@pytest.mark.parametrize("r", [0.01, 0.1, 1.0])
def test_an_obstacle_beyond_the_cutoff_is_skipped_and_its_terms_are_negligible(exponent, weight, r):
    """Obstacles with s^n > 60 + ln W are skipped. Just inside, the exact terms are kept; just
    outside, the exact terms (NumPy, no cutoff) are below 1e-17 for the value and gradient and
    1e-14 for the Hessian, whatever the disc size: far below the rounding of O(1) terms."""
    far = 60.0 + max(np.log(weight), 0.0)
    for sn, skipped in ((far * 0.999, False), (far * 1.001, True)):
        d = r * sn ** (1.0 / (2 * exponent))  # distance from the centre where s^n = sn
        got = terms(obstacle_penalty([[0.0, 0.0, r]], weight, exponent), d, 0.0)
        s = (d / r) ** 2
        e = weight * np.exp(-(s**exponent))
        dP_ds = -exponent * s ** (exponent - 1) * e
        n = exponent
        d2P_ds2 = e * (n**2 * s ** (2 * n - 2) - n * (n - 1) * s ** (n - 2))
        sx = 2 * d / r**2
        exact = [e, dP_ds * sx, 0.0, d2P_ds2 * sx * sx + dP_ds * 2 / r**2, 0.0, dP_ds * 2 / r**2]
        if skipped:
            np.testing.assert_array_equal(got, 0.0)
            assert abs(exact[0]) < 1e-24 and abs(exact[1]) < 1e-17
            assert max(abs(exact[3]), abs(exact[5])) < 1e-14
        else:
            np.testing.assert_allclose(got, exact, rtol=1e-10, atol=0)


@pytest.mark.parametrize("exponent", EXPONENTS)
@pytest.mark.parametrize("weight", [0.5, 100.0, 1e6])
def test_the_penalty_of_many_points_among_many_discs_is_the_formula(exponent, weight):
    """Called on an array of points, the penalty sums the discs near each point (a grid): the
    formula over all of 3,000 discs to rounding (the terms left out are below 1e-26 W)."""
    rng = np.random.default_rng(exponent)
    obs = np.column_stack([rng.uniform(0.0, 30.0, (3000, 2)), rng.uniform(0.03, 0.8, 3000)])
    pen = obstacle_penalty(obs, weight, exponent)
    xy = np.vstack([rng.uniform(-1.0, 31.0, (400, 2)), obs[:50, :2], [[np.inf, 0.0]]])
    got, want = pen(xy), dense(pen, xy)
    assert got.shape == (451,) and got[-1] == 0.0
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-24 * weight)
    assert pen(xy.reshape(11, 41, 2)).shape == (11, 41) and pen(xy[0]).shape == ()
    assert np.isnan(pen([np.nan, 1.0]))


def test_penalty_is_a_sum_over_obstacles():
    xy = np.array([0.85, 0.02])
    single = [terms(obstacle_penalty([o], 100.0, 2), *xy) for o in OBSTACLES]
    np.testing.assert_allclose(terms(obstacle_penalty(OBSTACLES), *xy), np.sum(single, axis=0))


def test_clearance_of_a_path():
    xy = np.array([[0.0, 0.0], [0.4, -0.1], [0.4, 0.3]])
    c = clearance(xy, OBSTACLES)
    dist = np.hypot(xy[:, None, 0] - OBSTACLES[:, 0], xy[:, None, 1] - OBSTACLES[:, 1])
    np.testing.assert_allclose(c, dist.min(axis=0) - OBSTACLES[:, 2], rtol=1e-15)
    assert c[0] == pytest.approx(0.05, abs=1e-15)  # (0.4, -0.1) is 0.15 below (0.4, 0.05)
    assert as_obstacle_array([]).shape == (0, 3)


def test_obstacles_are_data_not_code():
    """Solving with 0, 2, 7 and 1 obstacles, other weights and exponents compiles nothing new."""
    base = OptimalControlProblem.create("unicycle")
    kern = Flow(base).kernels
    start, goal = [0.0, 0.0, 0.0], [1.0, 0.2, 0.0]
    z0 = np.array([*start, *EXTREMAL_COSTATE[4]])  # a path through case 4's obstacle field
    brief = ShootingSettings(samples=0, root=RootSettings(max_iterations=5))
    first = solve_shooting(base, 0.0, start, 1.0, goal, settings=brief)
    assert first.success
    free_cost = Flow(base)(0.0, z0, 1.0).cost
    n_adaptive = len(kern.erk_adaptive.signatures)
    n_penalty = len(penalty_terms.signatures)
    assert n_adaptive >= 1
    costs = []
    for obstacles, weight, exponent in [
        (OBSTACLES[:2], 100.0, 2),
        (OBSTACLES, 100.0, 2),
        (OBSTACLES[[0]], 30.0, 1),
        ([], 100.0, 3),
    ]:
        problem = OptimalControlProblem.create(
            "unicycle", obstacles, weight=weight, exponent=exponent
        )
        flow = Flow(problem)
        assert flow.kernels is kern  # one module per model, whatever the obstacles
        r = solve_shooting(problem, 0.0, start, 1.0, goal, settings=brief, flow=flow)
        assert r.root.iterations >= 1 or r.success
        costs.append(flow(0.0, z0, 1.0, sensitivity="costate").cost)
    assert len(kern.erk_adaptive.signatures) == n_adaptive
    assert len(penalty_terms.signatures) == n_penalty
    # The obstacle data really were used: from case 4's extremal costate the flow with all seven
    # obstacles is that extremal (cost 5.663874), the others are other paths, and with no
    # obstacles the flow is the obstacle-free one exactly.
    assert costs[1] == pytest.approx(CASES[4].reference_cost, rel=1e-5)
    assert costs[3] == free_cost
    assert min(abs(c - free_cost) for c in costs[:3]) > 1e-3
