"""The Newton-type root solvers (roots/): NM, the paper's MNM, NLEQ-ERR, and their statuses.

Scalar and two-dimensional test functions, each built to provoke one behaviour. The shooting
versions of these checks are in test_shooting.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leapfrog_planner import SettingsError
from leapfrog_planner.roots import (
    FunctionSystem,
    ModifiedNewtonStep,
    RootSettings,
    RootStatus,
    solve_least_squares,
    solve_root,
)

METHODS = ["newton", "modified-newton", "nleq-err"]


def scalar(f, df):
    return FunctionSystem(f, df)


ARCTAN = scalar(np.arctan, lambda x: 1.0 / (1.0 + x**2))
SQRT2 = scalar(lambda x: x**2 - 2.0, lambda x: 2.0 * x)
NO_ROOT = scalar(lambda x: x**2 + 1.0, lambda x: 2.0 * x)  # |F| has a local minimum at 0


def freudenstein_roth(x):
    """Root (5, 4). Its Jacobian is singular on the lines x2 = -0.8968 and x2 = 2.23, and |F|
    has a local minimum (|F| ~ 7) on the first, at (11.41, -0.8968), into which descent falls."""
    x1, x2 = x
    return np.array(
        [-13.0 + x1 + ((5.0 - x2) * x2 - 2.0) * x2, -29.0 + x1 + ((x2 + 1.0) * x2 - 14.0) * x2]
    )


def freudenstein_roth_jac(x):
    _, x2 = x
    return np.array([[1.0, 10.0 * x2 - 3.0 * x2**2 - 2.0], [1.0, 3.0 * x2**2 + 2.0 * x2 - 14.0]])


FR = FunctionSystem(freudenstein_roth, freudenstein_roth_jac)


def non_increasing(norms) -> bool:
    return bool(np.all(np.diff(norms) <= 0.0))


# --------------------------------------------------------------------------- NM against MNM


def test_arctan_from_2_newton_diverges_and_mnm_converges():
    nm = solve_root(ARCTAN, [2.0], "newton")
    assert nm.status is RootStatus.DIVERGED
    assert abs(nm.x[0]) > 1e8  # the Newton iterates alternate in sign and grow
    assert np.all(np.diff(nm.residual_norms) > 0)
    np.testing.assert_array_equal(nm.step_sizes, 1.0)  # never damped
    mnm = solve_root(ARCTAN, [2.0], "modified-newton")
    assert mnm.status is RootStatus.CONVERGED and mnm.success
    assert abs(mnm.x[0]) <= 1e-10 and mnm.residual_norm <= 1e-10
    assert non_increasing(mnm.residual_norms)
    assert mnm.step_sizes[0] < 1.0  # the first step had to be damped
    nleq = solve_root(ARCTAN, [2.0], "nleq-err")
    assert nleq.status is RootStatus.CONVERGED and abs(nleq.x[0]) <= 1e-10


def mnm_reference_step(fun, jac, x):
    """One step of Stoer and Bulirsch's modified Newton method, written from spec section 3."""
    F, J = fun(x), jac(x)
    d = np.linalg.solve(J, F)
    sv = np.linalg.svd(J, compute_uv=False)
    gamma = sv[-1] / sv[0]
    h = lambda s: float(fun(s) @ fun(s))  # noqa: E731
    Dh = 2.0 * J.T @ F
    trials = []
    for m in range(ModifiedNewtonStep().max_halvings + 1):
        trials.append((h(x - 2.0**-m * d), 2.0**-m))
        if trials[-1][0] <= h(x) - 2.0**-m * gamma / 4 * np.linalg.norm(d) * np.linalg.norm(Dh):
            break
    best_h, lam = min(trials)
    return x - lam * d, lam


@pytest.mark.parametrize(
    ("system", "fun", "jac", "x0"),
    [
        (ARCTAN, np.arctan, lambda x: np.array([[1.0 / (1.0 + x[0] ** 2)]]), [2.0]),
        (ARCTAN, np.arctan, lambda x: np.array([[1.0 / (1.0 + x[0] ** 2)]]), [-7.5]),
        (FR, freudenstein_roth, freudenstein_roth_jac, [0.5, -2.0]),
        (FR, freudenstein_roth, freudenstein_roth_jac, [15.0, -2.0]),
    ],
)
def test_mnm_step_is_the_papers_rule(system, fun, jac, x0):
    """The first MNM iterate equals the spec's rule: smallest m passing the test, best 2^-k."""
    expected, lam = mnm_reference_step(fun, jac, np.array(x0))
    r = solve_root(system, x0, "modified-newton", RootSettings(max_iterations=1))
    assert r.iterations == 1
    assert r.step_sizes[0] == lam
    np.testing.assert_allclose(r.x, expected, rtol=1e-13, atol=1e-15)


@settings(max_examples=60)
@given(x0=st.floats(-60.0, 60.0).filter(lambda v: abs(v) > 1e-3))
def test_mnm_merit_never_increases_on_arctan(x0):
    r = solve_root(ARCTAN, [x0], "modified-newton")
    assert non_increasing(r.residual_norms)
    assert r.status is RootStatus.CONVERGED  # arctan has one root and no other minimum of |F|
    assert abs(r.x[0]) < 1e-10


@settings(max_examples=60)
@given(x0=st.tuples(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0)))
def test_mnm_merit_never_increases_on_freudenstein_roth(x0):
    r = solve_root(FR, list(x0), "modified-newton")
    assert r.residual_norms.size == r.iterations + 1
    assert non_increasing(r.residual_norms)
    if r.success:
        np.testing.assert_allclose(r.x, [5.0, 4.0], atol=1e-9)
    else:  # caught in the valley of the local minimum, where DF is singular
        assert r.status in (
            RootStatus.LINE_SEARCH_FAILED,
            RootStatus.SINGULAR_JACOBIAN,
            RootStatus.MAX_ITERATIONS,
        )
        assert r.residual_norm > 6.99 and abs(r.x[1] + 0.8968) < 1e-3


def test_freudenstein_roth_from_the_classical_start():
    """From (0.5, -2) Newton finds the root; MNM descends into the valley of |F| instead."""
    nm = solve_root(FR, [0.5, -2.0], "newton")
    assert nm.success
    np.testing.assert_allclose(nm.x, [5.0, 4.0], atol=1e-10)
    mnm = solve_root(FR, [0.5, -2.0], "modified-newton")
    assert not mnm.success
    assert non_increasing(mnm.residual_norms)
    assert mnm.residual_norms[0] == pytest.approx(np.linalg.norm(freudenstein_roth([0.5, -2.0])))
    assert mnm.residual_norm > 6.99 and abs(mnm.x[1] + 0.8968) < 1e-3


def test_newton_converges_quadratically():
    r = solve_root(SQRT2, [1.0], "newton", RootSettings(tol=1e-14))
    assert r.success and r.x[0] == pytest.approx(np.sqrt(2.0), rel=1e-15)
    e = r.residual_norms
    ratios = e[2:] / e[1:-1] ** 2
    assert np.all(ratios[:-1] < 1.0)  # |F_{k+1}| <= C |F_k|^2 with C = 1/(2 sqrt 2) ~ 0.35
    assert e[-2] < 1e-7


# --------------------------------------------------------------------------- statuses


@pytest.mark.parametrize("method", METHODS)
def test_status_converged(method):
    r = solve_root(SQRT2, [1.0], method)
    assert r.status is RootStatus.CONVERGED and r.success
    assert r.x[0] == pytest.approx(np.sqrt(2.0), abs=1e-10 / 2.8)  # |F| <= 1e-10, F' ~ 2.8
    assert r.residual_norms[-1] == r.residual_norm <= 1e-10
    assert r.residual_norms[0] == pytest.approx(1.0)
    assert r.iterations == r.step_sizes.size == r.residual_norms.size - 1
    assert r.jac_evals >= r.iterations and r.f_evals >= r.jac_evals
    assert str(r.status) == "converged"


@pytest.mark.parametrize("method", METHODS)
def test_status_max_iterations(method):
    r = solve_root(SQRT2, [100.0], method, RootSettings(max_iterations=2))
    assert r.status is RootStatus.MAX_ITERATIONS and not r.success
    assert r.iterations == 2 and r.residual_norms.size == 3
    x = 100.0
    for _ in range(2):  # two undamped Newton steps: far from the root every method takes them
        x -= (x * x - 2.0) / (2.0 * x)
    assert r.x[0] == pytest.approx(x, rel=1e-12) and 25.0 < x < 25.1
    np.testing.assert_array_equal(r.step_sizes, 1.0)


@pytest.mark.parametrize("method", METHODS)
def test_status_singular_jacobian(method):
    """F'(0) = 0 for x^2 - 1: no Newton direction."""
    r = solve_root(scalar(lambda x: x**2 - 1.0, lambda x: 2.0 * x), [0.0], method)
    assert r.status is RootStatus.SINGULAR_JACOBIAN
    assert r.iterations == 0 and r.x[0] == 0.0 and r.F[0] == -1.0
    # A merely ill-conditioned Jacobian counts too (cond > max_cond).
    A = np.diag([1.0, 1e-14])
    r = solve_root(FunctionSystem(lambda x: A @ x - 1.0, lambda x: A), [0.0, 0.0], method)
    assert r.status is RootStatus.SINGULAR_JACOBIAN
    assert "cond" in r.message


@pytest.mark.parametrize("x0", [2.0, 0.3, -3.0])
def test_status_line_search_failed_mnm(x0):
    """x^2 + 1 has no root; MNM walks down |F| to its minimum at 0 and cannot go further."""
    r = solve_root(NO_ROOT, [x0], "modified-newton")
    assert r.status is RootStatus.LINE_SEARCH_FAILED
    assert non_increasing(r.residual_norms)
    # Stopped next to the minimum (how close depends on max_halvings), never past |F| = 1.
    assert abs(r.x[0]) < 1e-2 and 1.0 <= r.residual_norm <= 1.0 + 1e-4
    assert r.residual_norm < r.residual_norms[0]


@pytest.mark.parametrize("x0", [2.0, 0.3])
def test_status_line_search_failed_nleq_err(x0):
    r = solve_root(NO_ROOT, [x0], "nleq-err")
    assert r.status is RootStatus.LINE_SEARCH_FAILED
    assert "damping" in r.message
    assert r.residual_norm >= 1.0


@pytest.mark.parametrize("method", METHODS)
def test_status_non_finite(method):
    with np.errstate(invalid="ignore", divide="ignore"):
        # At the start: log(-1) is NaN, 1/0 is inf.
        r = solve_root(scalar(np.log, lambda x: 1.0 / x), [-1.0], method)
        assert r.status is RootStatus.NON_FINITE and r.iterations == 0
        assert np.all(np.isnan(r.F))
        r = solve_root(scalar(lambda x: 1.0 / x, lambda x: -1.0 / x**2), [0.0], method)
        assert r.status is RootStatus.NON_FINITE
        # After a step: Newton on sqrt(x) - 0.1 from 4 jumps to x = -3.6.
        r = solve_root(
            scalar(lambda x: np.sqrt(x) - 0.1, lambda x: 0.5 / np.sqrt(x)), [4.0], "newton"
        )
    assert r.status is RootStatus.NON_FINITE
    assert r.iterations == 1 and r.x[0] == pytest.approx(-3.6, rel=1e-12)


def test_status_diverged():
    r = solve_root(ARCTAN, [2.0], "newton", RootSettings(divergence=1e3))
    assert r.status is RootStatus.DIVERGED
    assert np.linalg.norm(r.x) > 1e3 * (1.0 + 2.0)
    assert r.iterations == 4  # 2 -> -3.54 -> 13.95 -> -279.3 -> 1.2e5: out of the bound 3000
    assert r.x[0] == pytest.approx(1.2e5, rel=0.05)


@pytest.mark.parametrize("method", METHODS)
def test_a_nan_jacobian_gives_a_status_not_an_exception(method):
    r = solve_root(FunctionSystem(lambda x: x - 1.0, lambda x: np.array([[np.nan]])), [0.0], method)
    assert r.status in (RootStatus.NON_FINITE, RootStatus.SINGULAR_JACOBIAN)


# --------------------------------------------------------------------------- stall


@pytest.mark.parametrize("method", ["newton", "modified-newton"])
def test_a_creeping_iteration_stops_as_stalled_when_asked(method):
    """x^2 + 1 has no root: NM wanders and MNM creeps towards |F| = 1. With a stall window they
    stop early with their own status; without one they run on (NLEQ-ERR's damping fails here
    first, after 2 iterations, whatever the window)."""
    on = solve_root(NO_ROOT, [2.0], method, RootSettings(max_iterations=50, stall_window=3))
    assert on.status is RootStatus.STALLED
    assert "last 3 iterations" in on.message
    assert 3 <= on.iterations < 50
    norms = on.residual_norms
    assert norms[-1] > 0.5 * norms[-4:-1].max()  # the rule that fired
    # ... and it did not fire at an earlier iteration
    assert all(norms[k] <= 0.5 * norms[k - 3 : k].max() for k in range(3, norms.size - 1))
    off = solve_root(NO_ROOT, [2.0], method, RootSettings(max_iterations=50))
    assert off.status is not RootStatus.STALLED


def test_a_converging_iteration_never_stalls():
    """Quadratic convergence halves |F| every iteration: the window never fires. Nor does it
    when classical Newton first climbs (Freudenstein-Roth from (6, 3): |F| up 60%, then down)."""
    r = solve_root(SQRT2, [10.0], "newton", RootSettings(stall_window=1, stall_factor=0.9))
    assert r.success
    r = solve_root(FR, [6.0, 3.0], "newton", RootSettings(stall_window=3))
    assert r.success
    assert r.residual_norms[1] > 1.5 * r.residual_norms[0]


# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    "kw",
    [{"tol": 0.0}, {"max_iterations": 0}, {"max_iterations": 2.5}, {"max_cond": 1.0},
     {"divergence": 0.5}, {"stall_window": -1}, {"stall_window": 1.5}, {"stall_factor": 1.0},
     {"stall_factor": 0.0}, {"predict": 1}, {"predict": "yes"}],
)  # fmt: skip
def test_bad_root_settings_are_refused(kw):
    with pytest.raises(SettingsError):
        RootSettings(**kw)


def test_unknown_method_and_bad_strategy_options():
    with pytest.raises(SettingsError, match="unknown method"):
        solve_root(SQRT2, [1.0], "secant")
    with pytest.raises(SettingsError):
        ModifiedNewtonStep(max_halvings=0)
    # A strategy object works in place of a name; with 1 halving MNM gives up sooner.
    r = solve_root(ARCTAN, [10.0], ModifiedNewtonStep(max_halvings=1))
    assert r.status is RootStatus.LINE_SEARCH_FAILED
    assert solve_root(ARCTAN, [10.0], ModifiedNewtonStep(max_halvings=30)).success


@pytest.mark.parametrize("method", ["newton", "modified-newton"])
@pytest.mark.parametrize(("system", "x0"), [(SQRT2, [3.0]), (SQRT2, [-40.0]), (FR, [6.0, 4.5])])
def test_predicted_convergence_spares_jacobians_only(system, x0, method):
    """``predict``: the full steps predicted to converge are evaluated without the Jacobian:
    the same iterates, norms and damping, fewer Jacobians, and J wherever an iterate did not
    converge after all (the loop would otherwise fail on a missing J)."""
    plain = solve_root(system, x0, method, RootSettings(tol=1e-9))
    fast = solve_root(system, x0, method, RootSettings(tol=1e-9, predict=True))
    assert fast.status == plain.status == RootStatus.CONVERGED
    for name in ("x", "F", "residual_norms", "step_sizes"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(plain, name), err_msg=name)
    assert fast.jac_evals < plain.jac_evals
    wrong = fast.f_evals - plain.f_evals  # predictions that failed: evaluated again with J
    assert 0 <= wrong < fast.iterations


# --------------------------------------------------------------------------- Levenberg-Marquardt


@pytest.mark.parametrize(
    ("system", "x0", "root"),
    [(ARCTAN, 2.0, 0.0), (ARCTAN, 10.0, 0.0), (SQRT2, 1.0, 2**0.5), (SQRT2, 50.0, 2**0.5)],
)
def test_levenberg_marquardt_converges_where_newton_diverges(system, x0, root):
    """arctan from 2 and 10: Newton's full steps diverge; the trust region's do not. Its norms
    start at |F(x0)|, one per iterate, and end within the tolerance."""
    r = solve_least_squares(system, [x0], RootSettings(tol=1e-10), max_evaluations=100)
    assert r.status is RootStatus.CONVERGED and r.success
    assert abs(r.x[0] - root) < 1e-9 and r.residual_norm <= 1e-10
    assert r.residual_norms[0] == pytest.approx(abs(system.fun(np.array([x0]))[0]))
    assert r.residual_norms.size == r.iterations + 1 and r.residual_norms[-1] <= 1e-10
    assert np.isnan(r.step_sizes).all() and r.step_sizes.size == r.iterations
    assert r.f_evals >= r.jac_evals >= 1 and "<= 1e-10" in r.message


def test_levenberg_marquardt_stops_at_the_tolerance_asked():
    """A point within ``tol`` ends the solve (MINPACK alone would go on towards |F| = 0), and a
    start within it is the answer, after one evaluation."""
    loose = solve_least_squares(ARCTAN, [10.0], RootSettings(tol=1e-2), max_evaluations=100)
    tight = solve_least_squares(ARCTAN, [10.0], RootSettings(tol=1e-12), max_evaluations=100)
    assert loose.success and 1e-12 < loose.residual_norm <= 1e-2
    assert loose.f_evals < tight.f_evals
    at = solve_least_squares(SQRT2, [np.sqrt(2.0)], RootSettings(tol=1e-10), max_evaluations=9)
    assert at.success and at.iterations == 0 and at.f_evals == 1 and at.jac_evals == 0


def test_levenberg_marquardt_failure_codes():
    """No root: the least-squares minimum (x^2 + 1 at 0; Freudenstein-Roth's valley at
    (11.41, -0.8968), |F| = 7), said as such. Out of evaluations: max-iterations. F not
    finite at the start: non-finite."""
    settings = RootSettings(tol=1e-10)
    r = solve_least_squares(NO_ROOT, [2.0], settings, max_evaluations=100)
    assert r.status is RootStatus.STALLED and not r.success
    assert abs(r.x[0]) < 1e-6 and r.residual_norm == pytest.approx(1.0)
    assert "least-squares minimum" in r.message
    r = solve_least_squares(FR, [0.5, -2.0], settings, max_evaluations=200)
    assert r.status is RootStatus.STALLED and r.residual_norm == pytest.approx(7.0, rel=1e-3)
    assert abs(r.x[1] + 0.8968) < 1e-3
    r = solve_least_squares(FR, [0.5, -2.0], settings, max_evaluations=3)
    assert r.status is RootStatus.MAX_ITERATIONS and r.residual_norm > 7.0
    with np.errstate(invalid="ignore"):
        r = solve_least_squares(scalar(np.log, lambda x: 1.0 / x), [-1.0], settings, 100)
    assert r.status is RootStatus.NON_FINITE and r.iterations == 0 and np.isnan(r.F).all()


def test_levenberg_marquardt_that_no_longer_lowers_f_has_stalled():
    """1 + exp(-x / 50) / 100 falls towards 1 without end: after STALL_WINDOW iterates that
    lowered |F| by less than 1%, the solve ends as stalled (the office maze's failing ones
    stayed flat for hundreds of iterates), long before its budget of evaluations."""
    from leapfrog_planner.roots.least_squares import STALL_WINDOW

    creep = scalar(lambda x: 1.0 + 1e-2 * np.exp(-x / 50.0), lambda x: -2e-4 * np.exp(-x / 50.0))
    r = solve_least_squares(creep, [0.5], RootSettings(), max_evaluations=500)
    assert r.status is RootStatus.STALLED and r.iterations == STALL_WINDOW
    assert r.f_evals < 50 and r.residual_norm == pytest.approx(1.0, abs=1e-2)
    assert "did not fall below 0.99 times the largest of the last 10" in r.message


def test_levenberg_marquardt_steps_back_from_points_it_cannot_evaluate():
    """sqrt(x) - 0.1 from 4: trial points at x < 0 cannot be evaluated (F is None there); the
    trust region shrinks and the solve still ends at the root 0.01."""

    def fun(x):
        return np.sqrt(x) - 0.1 if x[0] >= 0 else np.array([np.nan])

    system = scalar(fun, lambda x: 0.5 / np.sqrt(x))
    r = solve_least_squares(system, [4.0], RootSettings(tol=1e-12), max_evaluations=200)
    assert r.success and r.x[0] == pytest.approx(0.01, rel=1e-9)
