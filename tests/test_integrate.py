"""The compiled flow: Runge-Kutta kernels, error control, variational equations, blow-ups.

Sensitivities are compared with finite differences of a fixed-step flow: an adaptive step
sequence changes under perturbation, so its finite differences would mix in the controller.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from conftest import CASES, EXTREMAL_COSTATE, fd_jacobian, rel_err
from leapfrog_planner import Flow, FlowStatus, IntegratorSettings, OptimalControlProblem
from leapfrog_planner.compiled.abi import StepControl
from leapfrog_planner.integrate.tableaux import get_tableau
from leapfrog_planner.model.penalty import penalty_terms

NON_DEFAULT_DD = {"wheel_radius": 0.7, "axle_length": 1.3}


def problem(model="unicycle", obstacles=(), **parameters):
    return OptimalControlProblem.create(model, obstacles, parameters=parameters or None)


def fixed_kernel_run(flow: Flow, method: str, z0, t0, t1, steps: int) -> np.ndarray:
    """``[z(t1), cost]`` from the generated fixed-step kernel with any tableau.

    ``IntegratorSettings(method="dp5" | "dop853", steps=N)`` runs the adaptive integrator (it
    ignores ``steps``), so the fixed-step order of the embedded pairs is measured on the
    kernel ``erk_fixed`` directly, with the tableau's propagating weights ``b``.
    """
    dynamics = flow.dynamics._replace(tableau=get_tableau(method).record())
    Y0 = np.concatenate([np.asarray(z0, float), [0.0]])
    Y, status, acc, rejected = flow.kernels.erk_fixed(
        Y0, float(t0), float(t1), 0, dynamics, steps, dynamics.no_samples
    )
    assert status == FlowStatus.OK and acc == steps and rejected == 0
    return Y


# --------------------------------------------------------------------------- orders


ORDER_Z0 = np.array([-1.0, 2.0, np.pi / 2, -1.0, 1.0, 0.5])  # unicycle, no obstacles
ORDER_T = 2.0


@pytest.fixture(scope="module")
def order_setup():
    flow = Flow(problem(), IntegratorSettings(method="rk4"))
    reference = fixed_kernel_run(flow, "dop853", ORDER_Z0, 0.0, ORDER_T, 600)
    return flow, reference


@pytest.mark.parametrize(
    ("method", "order", "steps"),
    [
        ("rk4", 4, [16, 32, 64, 128, 256]),
        ("dp5", 5, [16, 32, 64, 128]),
        ("dop853", 8, [6, 8, 11, 16, 22]),
    ],
)
def test_fixed_step_convergence_order(order_setup, method, order, steps):
    """Slope of log(error) against log(N) over errors from ~1e-5 down to ~1e-12.

    The reference is DOP853 with 600 steps (error ~1e-15). The state, costate and cost are all
    in the error. DOP853 shows slightly more than 8 pre-asymptotically (its 8th-order error
    constants are small), which is why its N range stops where rounding would start.
    """
    flow, reference = order_setup
    errors = np.array(
        [
            np.max(np.abs(fixed_kernel_run(flow, method, ORDER_Z0, 0.0, ORDER_T, n) - reference))
            for n in steps
        ]
    )
    assert np.all(errors < 1e-4) and np.all(errors > 1e-13), errors  # above rounding
    assert np.all(np.diff(errors) < 0)
    slope = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.3, (slope, errors)


def test_rk4_flow_is_the_fixed_step_kernel(order_setup):
    flow, _ = order_setup
    for n in (16, 64):
        r = Flow(problem(), IntegratorSettings(method="rk4", steps=n))(0.0, ORDER_Z0, ORDER_T)
        Y = fixed_kernel_run(flow, "rk4", ORDER_Z0, 0.0, ORDER_T, n)
        assert r.ok and r.steps == n and r.rejected == 0
        np.testing.assert_array_equal(r.z, Y[:6])
        assert r.cost == Y[6]


# --------------------------------------------------------------------------- error control


@pytest.fixture(scope="module")
def case4_flow_reference(extremal):
    """Case 4's extremal (from shooting), its accurate end state and the flow's conditioning."""
    c = CASES[4]
    z0 = np.concatenate([c.start, extremal(4).costate0])
    flow = Flow(c.problem())
    reference = fixed_kernel_run(flow, "dop853", z0, 0.0, 1.0, 4000)  # error ~3e-11
    phi = flow(0.0, z0, 1.0, sensitivity="full").sensitivity
    return flow, z0, reference, np.linalg.norm(phi, 2)


def scipy_rhs(flow):
    K = flow.kernels

    def rhs(t, Y):
        out = np.empty((1, Y.size))
        K.rhs_along(np.ascontiguousarray(Y[None, :]), *flow.dynamics.equation, out)
        return out[0]

    return rhs


@pytest.mark.parametrize(("method", "scipy_method"), [("dp5", "RK45"), ("dop853", "DOP853")])
def test_adaptive_integrators_meet_their_tolerance_on_case_4(
    case4_flow_reference, method, scipy_method
):
    """Error control on paper case 4's extremal, which skims seven obstacles.

    A global error of 100 rtol is not reachable here by any local error control: the flow
    amplifies local errors by up to |Phi(1, 0)| ~ 4e4, and SciPy's solve_ivp, with the same
    controller, takes exactly the same steps and makes exactly the same error (checked below).
    So the bound is rtol |Phi|_2; the observed errors are 170 to 6500 rtol.
    """
    flow, z0, reference, cond = case4_flow_reference
    assert 1e4 < cond < 1e5
    errors = []
    for rtol in (1e-6, 1e-8, 1e-10):
        r = flow.with_settings(IntegratorSettings(method, rtol=rtol, atol=rtol))(0.0, z0, 1.0)
        assert r.ok
        err = np.max(np.abs(r.z - reference[:6]))
        errors.append(err)
        assert err <= rtol * cond, (rtol, err / rtol)
        assert abs(r.cost - reference[6]) <= 1e3 * rtol
        s = solve_ivp(
            scipy_rhs(flow), (0.0, 1.0), np.concatenate([z0, [0.0]]), method=scipy_method,
            rtol=rtol, atol=rtol,
        )  # fmt: skip
        assert s.success
        assert r.steps == s.t.size - 1
        assert np.max(np.abs(r.z - s.y[:6, -1])) <= rtol
    assert errors[0] > errors[2]


@pytest.mark.parametrize("method", ["dp5", "dop853"])
def test_adaptive_integrators_meet_their_tolerance_on_case_1(method):
    """On a well-conditioned extremal (case 1, |Phi| ~ 12) the global error is < 100 rtol."""
    c = CASES[1]
    z0 = np.concatenate([c.start, EXTREMAL_COSTATE[1]])
    flow = Flow(c.problem())
    reference = fixed_kernel_run(flow, "dop853", z0, 0.0, 1.0, 1000)
    default_tol = flow.with_settings(IntegratorSettings(method))
    for rtol in (1e-6, 1e-8, 1e-10):
        r = flow.with_settings(IntegratorSettings(method, rtol=rtol, atol=rtol))(0.0, z0, 1.0)
        assert r.ok
        assert np.max(np.abs(r.z - reference[:6])) <= 100 * rtol
        assert abs(r.cost - reference[6]) <= 100 * rtol
        # The per-call override gives the same as settings with that tolerance.
        again = default_tol(0.0, z0, 1.0, rtol=rtol, atol=rtol)
        np.testing.assert_array_equal(again.z, r.z)


def hairer_initial_step(rhs, t0, y0, t1, f0, order, rtol, atol):
    """Hairer, Norsett and Wanner's starting step (II.4), as SciPy's select_initial_step."""
    direction = np.sign(t1 - t0)
    scale = atol + np.abs(y0) * rtol
    d0 = np.sqrt(np.mean((y0 / scale) ** 2))
    d1 = np.sqrt(np.mean((f0 / scale) ** 2))
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, abs(t1 - t0))
    f1 = rhs(t0 + direction * h0, y0 + direction * h0 * f0)
    d2 = np.sqrt(np.mean(((f1 - f0) / scale) ** 2)) / h0
    h1 = (
        max(1e-6, h0 * 1e-3)
        if d1 <= 1e-15 and d2 <= 1e-15
        else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    )
    return min(100 * h0, h1, abs(t1 - t0))


def kernel_initial_step(flow, Y, t0, t1, order, tol):
    rhs = scipy_rhs(flow)
    tableau = flow.dynamics.tableau._replace(error_order=order)
    dynamics = flow.dynamics._replace(tableau=tableau)
    control = StepControl(tol, tol, 1)
    return flow.kernels._initial_step(Y, rhs(t0, Y), t0, t1, 0, dynamics, control)


def test_initial_step_forward_is_hairers(case4_flow_reference):
    flow, z0, _, _ = case4_flow_reference
    Y = np.concatenate([z0, [0.0]])
    f0 = scipy_rhs(flow)(0.0, Y)
    for order, tol in [(7, 1e-8), (4, 1e-6)]:
        expected = hairer_initial_step(scipy_rhs(flow), 0.0, Y, 1.0, f0, order, tol, tol)
        got = kernel_initial_step(flow, Y, 0.0, 1.0, order, tol)
        assert got == pytest.approx(expected, rel=1e-12)


def test_initial_step_backward_is_hairers(case4_flow_reference):
    flow, z0, reference, _ = case4_flow_reference
    Y = np.concatenate([reference[:6], [0.0]])
    f0 = scipy_rhs(flow)(1.0, Y)
    expected = hairer_initial_step(scipy_rhs(flow), 1.0, Y, 0.0, f0, 7, 1e-8, 1e-8)
    got = kernel_initial_step(flow, Y, 1.0, 0.0, 7, 1e-8)
    assert got == pytest.approx(expected, rel=1e-12)


def test_backward_integration_inverts_the_forward_flow():
    c = CASES[1]
    z0 = np.concatenate([c.start, EXTREMAL_COSTATE[1]])
    flow = Flow(c.problem())
    fwd = flow(0.0, z0, 1.0)
    back = flow(1.0, fwd.z, 0.0)
    assert fwd.ok and back.ok
    np.testing.assert_allclose(back.z, z0, rtol=0, atol=1e-9)
    assert back.cost == pytest.approx(-fwd.cost, rel=1e-10)
    assert fwd.cost == pytest.approx(10.3232019170, rel=1e-9)


def test_trajectory_rows(case4_flow_reference):
    flow, z0, _, _ = case4_flow_reference
    r = flow(0.0, z0, 1.0, samples=101)
    tr = r.trajectory
    assert r.ok and tr is not None
    assert tr.at_step.sum() == r.steps + 1  # every accepted step, and the start
    assert tr.t[0] == 0.0 and tr.t[-1] == 1.0 and np.all(np.diff(tr.t) > 0)
    assert np.all(np.isin(np.linspace(0.0, 1.0, 101), tr.t))
    np.testing.assert_array_equal(np.concatenate([tr.x[-1], tr.lam[-1]]), r.z)
    assert tr.cost[0] == 0.0 and tr.cost[-1] == r.cost
    assert np.all(np.diff(tr.cost) > 0)  # the running cost is positive
    np.testing.assert_array_equal(tr.x[0], CASES[4].start)
    # Fixed steps: the rows at the steps are exactly the kernel's states.
    rk = flow.with_settings(IntegratorSettings("rk4", steps=50))(0.0, z0, 1.0, samples=11)
    assert rk.trajectory.at_step.sum() == 51
    np.testing.assert_allclose(rk.trajectory.t[rk.trajectory.at_step], np.linspace(0, 1, 51))


@pytest.mark.parametrize("backward", [False, True])
def test_dense_output_is_the_cubic_hermite_interpolant(case4_flow_reference, backward):
    """Between steps: SciPy's CubicHermiteSpline on the same steps (to rounding), and the flow
    integrated to the sample time itself (to the interpolation error)."""
    from scipy.interpolate import CubicHermiteSpline

    flow, z0, _, _ = case4_flow_reference
    fwd = flow(0.0, z0, 1.0)
    t0, t1, start = (1.0, 0.0, fwd.z) if backward else (0.0, 1.0, z0)
    r = flow(t0, start, t1, samples=57)
    tr = r.trajectory
    steps = tr.at_step
    Zs = np.column_stack([tr.x, tr.lam, tr.cost])
    dZ = np.empty_like(Zs[steps])
    flow.kernels.rhs_along(Zs[steps], *flow.dynamics.equation, dZ)
    spline = CubicHermiteSpline(
        tr.t[steps][:: -1 if backward else 1],
        Zs[steps][:: -1 if backward else 1],
        dZ[:: -1 if backward else 1],
        axis=0,
    )
    inner = ~steps
    assert inner.sum() >= 40
    np.testing.assert_allclose(Zs[inner], spline(tr.t[inner]), rtol=1e-12, atol=1e-12)
    for i in np.flatnonzero(inner)[::10]:
        direct = flow(t0, start, tr.t[i])
        # measured: up to 2.2e-5 on the costates where the path grazes an obstacle
        np.testing.assert_allclose(Zs[i, :6], direct.z, rtol=0, atol=1e-4)


# --------------------------------------------------------------------------- sensitivities


SENSITIVITY_CASES = {
    # Case 4's extremal: passes 0.008 from the obstacles' edges.
    "unicycle-case4": ("unicycle", {}, CASES[4].obstacles, [0, 0, 0, *EXTREMAL_COSTATE[4]]),
    # Non-default wheels; this costate drives the robot straight through obstacle 1.
    "diff-drive-case4": ("diff-drive", NON_DEFAULT_DD, CASES[4].obstacles, [0, 0, 0, -8, 20, 3]),
    "unicycle-free": ("unicycle", {}, (), [*CASES[1].start, *EXTREMAL_COSTATE[1]]),
    "diff-drive-free": ("diff-drive", NON_DEFAULT_DD, (), [*CASES[1].start, *EXTREMAL_COSTATE[1]]),
}


@pytest.mark.parametrize("name", list(SENSITIVITY_CASES))
def test_variational_equations_match_finite_differences(name):
    model, params, obstacles, z0 = SENSITIVITY_CASES[name]
    prob = problem(model, obstacles, **params)
    z0 = np.array(z0, dtype=float)
    flow = Flow(prob, IntegratorSettings(method="rk4", steps=400))
    full = flow(0.0, z0, 1.0, sensitivity="full", samples=401)
    assert full.ok
    if len(obstacles):  # the path really is in the penalty's range, where it is steep
        assert np.max(prob.penalty(full.trajectory.x[:, :2])) > 10.0
    Phi = full.sensitivity
    Phi_fd = fd_jacobian(lambda z: flow(0.0, z, 1.0).z, z0, 1e-6)
    assert rel_err(Phi, Phi_fd) < 1e-6
    # The costate seed gives the costate columns; an explicit seed gives Phi @ seed.
    costate = flow(0.0, z0, 1.0, sensitivity="costate")
    np.testing.assert_allclose(costate.sensitivity, Phi[:, 3:], rtol=1e-12, atol=1e-12)
    seed = np.random.default_rng(3).normal(size=(6, 2))
    explicit = flow(0.0, z0, 1.0, sensitivity=seed)
    np.testing.assert_allclose(explicit.sensitivity, Phi @ seed, rtol=1e-10, atol=1e-10)
    # The flow itself does not depend on which sensitivities ride along.
    np.testing.assert_allclose(costate.z, full.z, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(flow(0.0, z0, 1.0).z, full.z, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("name", ["unicycle-case4", "diff-drive-case4"])
def test_adaptive_sensitivities_are_accurate(name):
    """The adaptive flow's Phi (internal differentiation) against a fine fixed-step Phi."""
    model, params, obstacles, z0 = SENSITIVITY_CASES[name]
    prob = problem(model, obstacles, **params)
    adaptive = Flow(prob)(0.0, np.array(z0, float), 1.0, sensitivity="full")
    fine = Flow(prob, IntegratorSettings("rk4", steps=4000))(
        0.0, np.array(z0, float), 1.0, sensitivity="full"
    )
    assert adaptive.ok and fine.ok
    Phi = adaptive.sensitivity
    assert rel_err(Phi, fine.sensitivity) < 1e-6
    # The canonical system is Hamiltonian, so Phi is symplectic, Phi^T Jc Phi = Jc, and (Liouville)
    # det Phi = 1. Here |Phi|^2 ~ 1e9 to 3e11: the identity holds to ~1e-15 of it.
    Jc = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    assert np.max(np.abs(Phi.T @ Jc @ Phi - Jc)) < 1e-12 * np.max(np.abs(Phi)) ** 2
    assert np.linalg.det(Phi) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("model", ["unicycle", "diff-drive"])
@settings(max_examples=40)
@given(
    z=st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6).map(np.array),
    xy=st.tuples(st.floats(0.2, 1.8), st.floats(-0.5, 0.5)),
    exponent=st.sampled_from([1, 2, 3]),
)
def test_canonical_jacobian_matches_finite_differences_of_the_rhs(model, z, xy, exponent):
    """``canonical_jac`` plus the penalty Hessian against 5-point differences of ``G(z)``.

    ``G`` is ``model_augmented`` (k = 0) with ``-grad P`` from ``penalty_terms`` added to the
    first two costate rates, exactly as the integrator assembles it.
    """
    prob = OptimalControlProblem.create(
        model,
        CASES[4].obstacles,
        exponent=exponent,
        parameters=NON_DEFAULT_DD if model == "diff-drive" else None,
    )
    flow = Flow(prob)
    K = flow.kernels
    pen = prob.penalty
    p = flow.dynamics.equation.parameters
    z = z.copy()
    z[:2] = xy  # positions among the obstacles, where the penalty terms matter

    def G(zz):
        out = np.empty(7)
        K.model_augmented(zz, p, np.zeros(0), 0, out)
        _, Px, Py, *_ = penalty_terms(zz[0], zz[1], pen.obstacles, pen.weight, exponent, False)
        out[3] -= Px
        out[4] -= Py
        return out[:6]

    J = np.empty((6, 6))
    K.canonical_jac(z, p, J)
    _, _, _, Pxx, Pxy, Pyy = penalty_terms(z[0], z[1], pen.obstacles, pen.weight, exponent, True)
    J[3:5, 0:2] -= np.array([[Pxx, Pxy], [Pxy, Pyy]])
    J_fd = fd_jacobian(G, z, 1e-5)
    np.testing.assert_allclose(J, J_fd, rtol=0, atol=1e-6 * max(1.0, np.max(np.abs(J))))
    # model_augmented's sensitivity block is the model Jacobian times the seed (row-major S).
    S = np.random.default_rng(0).normal(size=(6, 3))
    out = np.empty(7 + 18)
    K.model_augmented(z, p, S.ravel(), 3, out)
    Jm = np.empty((6, 6))
    K.canonical_jac(z, p, Jm)
    np.testing.assert_allclose(out[7:].reshape(6, 3), Jm @ S, rtol=1e-12, atol=1e-12)


# --------------------------------------------------------------------------- blow-ups


@pytest.mark.parametrize("method", ["rk4", "dp5", "dop853"])
@pytest.mark.parametrize("sensitivity", [None, "costate"])
@pytest.mark.parametrize("obstacles", [(), CASES[4].obstacles], ids=["free", "case4"])
def test_blow_up_is_reported_as_non_finite(method, sensitivity, obstacles):
    """Costates ~1e200 overflow at once. Guards fast math against folding NaN/inf tests away."""
    flow = Flow(problem("unicycle", obstacles), IntegratorSettings(method=method))
    r = flow(0.0, [0.0, 0.0, 0.0, 1e200, 1e200, 1e200], 1.0, sensitivity=sensitivity)
    assert r.status == FlowStatus.NON_FINITE
    assert not r.ok
    for bad in (np.nan, np.inf):
        r = flow(0.0, [0.0, bad, 0.0, 1.0, 1.0, 1.0], 1.0, sensitivity=sensitivity)
        assert r.status == FlowStatus.NON_FINITE


def test_fixed_step_blow_up_is_caught_inside_the_loop():
    """Costates 1e100: finite at the start, inf within the first RK4 step (v^2 ~ 1e200, ...)."""
    flow = Flow(problem(), IntegratorSettings(method="rk4", steps=200))
    r = flow(0.0, [0.0, 0.0, 0.0, 1e100, 1e100, 1e100], 1.0)
    assert r.status == FlowStatus.NON_FINITE
    assert r.steps == 1
    assert not np.all(np.isfinite(np.append(r.z, r.cost)))


def test_adaptive_step_limit_is_reported():
    flow = Flow(problem(), IntegratorSettings(method="dop853", max_steps=50))
    r = flow(0.0, [0.0, 0.0, 0.0, 1e3, 1e3, 1e3], 1.0)
    assert r.status == FlowStatus.MAX_STEPS
    assert r.steps == 50


def test_non_finite_sensitivities_are_reported():
    flow = Flow(problem(), IntegratorSettings(method="rk4", steps=200))
    r = flow(0.0, [0.0, 0.0, 0.0, 1e4, 1e4, 1e4], 1.0, sensitivity="costate")
    assert np.all(np.isfinite(r.z))  # the state itself stays finite (|z| ~ 1e6)
    assert r.status == FlowStatus.NON_FINITE or np.all(np.isfinite(r.sensitivity))
