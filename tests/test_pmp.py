"""Pontryagin's principle applied symbolically (pmp.py) and the kernels generated from it.

The derived control laws and canonical systems are compared with the spec's formulas written
out by hand (sections 1 and 4), and the compiled kernels with independent SymPy evaluations.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from leapfrog_planner import Flow, ModelError, OptimalControlProblem, VehicleModel, derive
from leapfrog_planner.compiled.kernels import model_info

finite = st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False)
z_points = st.lists(finite, min_size=6, max_size=6).map(np.array)
wheel_radius = st.floats(0.2, 2.0)
axle_length = st.floats(0.3, 3.0)


def kernels(model: str):
    return Flow(OptimalControlProblem.create(model)).kernels


def all_parameters(model: str, robot=()) -> np.ndarray:
    """The kernels' parameter vector: the robot's (in order) and the controls' bounds (off)."""
    info = model_info(model)
    return np.array(info.parameter_values(dict(zip(info.robot_parameters, robot, strict=True))))


def spec_canonical(model: str, z, p):
    """``(zdot, running cost rate, u)`` of the spec's model, by hand, without obstacles.

    Unicycle: ``v = -(l1 cos th + l2 sin th)``, ``omega = -l3`` (spec section 1). Diff-drive
    (section 4), ``v = r (wR + wL) / 2``, ``omega = r (wR - wL) / b``, cost ``(wR^2 + wL^2) / 2``:
    ``dH/dwR = wR + r/2 (l1 c + l2 s) + r/b l3 = 0`` and
    ``dH/dwL = wL + r/2 (l1 c + l2 s) - r/b l3 = 0``.
    In both, ``l3dot = -dH/dth = l1 v sin th - l2 v cos th`` and ``l1dot = l2dot = 0``.
    """
    x, y, th, l1, l2, l3 = z
    c, s = np.cos(th), np.sin(th)
    if model == "unicycle":
        v, w = -(l1 * c + l2 * s), -l3
        u = np.array([v, w])
        cost = (v * v + w * w) / 2
    else:
        r, b = p[:2]  # the robot's parameters come first
        a = -(r / 2) * (l1 * c + l2 * s)
        wr, wl = a - (r / b) * l3, a + (r / b) * l3
        u = np.array([wr, wl])
        v, w = r * (wr + wl) / 2, r * (wr - wl) / b
        cost = (wr * wr + wl * wl) / 2
    zdot = np.array([v * c, v * s, w, 0.0, 0.0, l1 * v * s - l2 * v * c])
    return zdot, cost, u


# --------------------------------------------------------------------------- derivation


def test_unicycle_control_law_is_the_spec_one():
    sysm = derive("unicycle")
    x, y, th = sysm.model.states
    l1, l2, l3 = sysm.costates
    v, w = sysm.control_law
    assert sp.simplify(v - (-(l1 * sp.cos(th) + l2 * sp.sin(th)))) == 0
    assert sp.simplify(w - (-l3)) == 0
    # The costate equations carry -grad P, with P kept as an undefined function.
    P = sysm.penalty
    assert sp.simplify(sysm.costate_equations[0] + sp.Derivative(P, x)) == 0
    assert sp.simplify(sysm.costate_equations[1] + sp.Derivative(P, y)) == 0
    # Numerically: the derived running cost on the law is (v^2 + omega^2) / 2.
    at = {th: 0.3, l1: -1.5, l2: 2.0, l3: 0.7}
    vv = 1.5 * np.cos(0.3) - 2.0 * np.sin(0.3)
    (cost,) = sysm.on_law([sysm.running_cost])
    assert float(cost.subs(at)) == pytest.approx((vv**2 + 0.7**2) / 2, rel=1e-14)


@pytest.mark.parametrize("model", ["unicycle", "diff-drive"])
@settings(max_examples=40, deadline=None)
@given(z=z_points, r=wheel_radius, b=axle_length)
def test_generated_rhs_is_the_spec_canonical_system(model, z, r, b):
    """``model_augmented`` (k = 0) against the canonical system written out by hand."""
    K = kernels(model)
    p = all_parameters(model, (r, b) if model == "diff-drive" else ())
    out = np.empty(7)
    K.model_augmented(z, p, np.zeros(0), 0, out)
    zdot, cost, u_spec = spec_canonical(model, z, p)
    scale = 1.0 + np.max(np.abs(zdot))
    np.testing.assert_allclose(out[:6], zdot, rtol=0, atol=1e-13 * scale)
    assert out[6] == pytest.approx(cost, rel=1e-13, abs=1e-13)
    u = np.empty(2)
    K.controls(z, p, u)
    np.testing.assert_allclose(u, u_spec, rtol=0, atol=1e-13 * (1.0 + np.max(np.abs(u_spec))))


# --------------------------------------------------------------------------- stationarity


@pytest.fixture(scope="module")
def sympy_dH_du():
    """dH/du of each model as a NumPy function of (x, lambda, u, parameters), from SymPy alone.

    ``P`` is set to zero first: the penalty does not depend on ``u``.
    """
    out = {}
    for name in ("unicycle", "diff-drive"):
        sysm = derive(name)
        m = sysm.model
        H = sysm.hamiltonian.subs(sysm.penalty, 0)
        grad = [sp.diff(H, u) for u in m.controls]
        hess = sp.hessian(H, m.controls)
        args = [*m.states, *sysm.costates, *m.controls, *m.parameters]
        out[name] = (
            sp.lambdify(args, grad, "numpy"),
            sp.lambdify(args, H, "numpy"),
            sp.lambdify(args, hess, "numpy"),
        )
    return out


@pytest.mark.parametrize("model", ["unicycle", "diff-drive"])
@settings(max_examples=60, deadline=None)
@given(z=z_points, r=wheel_radius, b=axle_length, du=st.lists(finite, min_size=2, max_size=2))
def test_derived_controls_satisfy_dH_du_zero_and_minimise_H(sympy_dH_du, model, z, r, b, du):
    K = kernels(model)
    params = (r, b) if model == "diff-drive" else ()
    p = all_parameters(model, params)
    u = np.empty(2)
    K.controls(z, p, u)
    grad, H, hess = sympy_dH_du[model]
    g = np.array(grad(*z, *u, *params), dtype=float)
    assert np.max(np.abs(g)) <= 1e-12
    # The generated dH/du kernel agrees (it is what Trajectory.dH_du reports).
    gk = np.empty(2)
    K.dH_du(z, u, p, gk)
    assert np.max(np.abs(gk)) <= 1e-12
    # A minimum, not just a stationary point: d2H/du2 is positive definite and H grows away.
    assert np.all(np.linalg.eigvalsh(np.array(hess(*z, *u, *params), dtype=float)) > 0)
    # H is quadratic in u: H(u* + d) - H(u*) = d^T (d2H/du2) d / 2 > 0 exactly.
    d = np.array(du)
    rise = H(*z, *(u + d), *params) - H(*z, *u, *params)
    quad = 0.5 * d @ np.array(hess(*z, *u, *params), dtype=float) @ d
    assert rise == pytest.approx(quad, rel=1e-9, abs=1e-11 * (1.0 + abs(H(*z, *u, *params))))
    if d @ d > 1e-6:
        assert rise > 0


@pytest.mark.parametrize("model", ["unicycle", "diff-drive"])
def test_hamiltonian_kernel_matches_sympy(model):
    sysm = derive(model)
    m = sysm.model
    (h_law,) = sysm.on_law([sysm.model_hamiltonian()])
    f = sp.lambdify([*m.states, *sysm.costates, *m.parameters], h_law)
    K = kernels(model)
    rng = np.random.default_rng(1)
    params = (0.7, 1.3) if model == "diff-drive" else ()
    for z in rng.uniform(-3, 3, size=(20, 6)):
        h = K.hamiltonian_model(z, all_parameters(model, params))
        assert h == pytest.approx(f(*z, *params), rel=1e-13, abs=1e-13)
        # On the control law H = L + lambda^T f = -L for these models (L quadratic, f linear in u).
        out = np.empty(7)
        K.model_augmented(z, all_parameters(model, params), np.zeros(0), 0, out)
        assert h == pytest.approx(-out[6], rel=1e-12, abs=1e-13)


def test_double_integrator_derivation(double_integrator):
    sysm = derive(double_integrator)
    x1, x2, x3 = double_integrator.states
    l1, l2, l3 = sysm.costates
    assert list(sysm.control_law) == [-l3, -l2]
    rhs = sysm.on_law(sysm.rhs())
    assert [sp.simplify(e) for e in rhs] == [x3, -l2, -l3, 0, 0, -l1]


# --------------------------------------------------------------------------- refusals


def _model(running_cost=None, dynamics=None, controls=None, states=None, **kw):
    x, y, th = sp.symbols("x y theta", real=True)
    v, w = sp.symbols("v omega", real=True)
    states = states or (x, y, th)
    controls = controls or (v, w)
    dynamics = dynamics or (v * sp.cos(th), v * sp.sin(th), w)
    cost = (v**2 + w**2) / 2 if running_cost is None else running_cost
    return VehicleModel(
        name=kw.pop("name", "bad"),
        states=states,
        controls=controls,
        dynamics=dynamics,
        running_cost=cost,
        **kw,
    )


V, W = sp.symbols("v omega", real=True)


@pytest.mark.parametrize(
    ("name", "cost", "message"),
    [
        ("linear-cost", V + W, "not positive definite"),
        ("negative-cost", -(V**2 + W**2) / 2, "not positive definite"),
        ("indefinite-cost", (V**2 - W**2) / 2, "not positive definite"),
        ("semidefinite-cost", V**2 / 2, "not positive definite"),
        ("quartic-cost", (V**4 + W**2) / 2, "depends on u"),
    ],
)
def test_models_without_a_unique_minimising_control_are_refused(name, cost, message):
    model = _model(running_cost=cost, name=name)
    with pytest.raises(ModelError, match=message) as info:
        derive(model)
    assert isinstance(info.value, ValueError)


def test_undeclared_symbols_are_refused():
    k = sp.Symbol("k", positive=True)
    x, y, th = sp.symbols("x y theta", real=True)
    with pytest.raises(ModelError, match="undeclared symbols k"):
        _model(dynamics=(k * V * sp.cos(th), V * sp.sin(th), W))
    with pytest.raises(ModelError, match="undeclared symbols k"):
        _model(running_cost=k * (V**2 + W**2))
    # Declared as a parameter (with a default and a name), the same model is accepted.
    ok = _model(
        running_cost=k * (V**2 + W**2),
        parameters=(k,),
        defaults=(0.5,),
        parameter_names=("k",),
        name="scaled-cost",
    )
    law = derive(ok).control_law
    assert sp.simplify(law[1] - (-sp.Symbol("lambda_3", real=True) / (2 * k))) == 0


def test_structural_refusals():
    x, y = sp.symbols("x y", real=True)
    with pytest.raises(ModelError, match="at least 3 states"):
        _model(states=(x, y), dynamics=(V, W))
    with pytest.raises(ModelError, match="2 dynamics for 3 states"):
        _model(dynamics=(V, W))
