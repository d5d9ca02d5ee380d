"""Pontryagin's minimum principle, applied symbolically to a vehicle model.

With ``H = L_u(x, u) + P(x, y) + lambda^T f(x, u)`` the control law comes from ``dH/du = 0``
(it must have exactly one solution, and ``d2H/du2`` must be positive definite so that it is a
minimum), and the canonical system is ``xdot = dH/dlambda``, ``lambdadot = -dH/dx``.

The obstacle penalty ``P`` is kept as an undefined function here: it is data (obstacle arrays),
evaluated by compiled loops, so the symbolic part only ever depends on the vehicle model.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

from ..errors import ModelError
from . import get_model
from .base import VehicleModel


@dataclass(frozen=True)
class CanonicalSystem:
    """The Pontryagin boundary value problem of a model, as SymPy expressions.

    The equations are written at the control ``u`` (the model's control symbols), which on an
    extremal is ``u*(z)``: the unconstrained minimiser :attr:`control_law` for a free control,
    its smooth clip for a bounded one (see :mod:`.bounds`). :meth:`jacobian` is the derivative
    along ``u = u*(z)``, through the slopes ``du*/ds``.
    """

    model: VehicleModel
    costates: tuple[sp.Symbol, ...]
    penalty: sp.Expr  # P(x, y), an undefined function of the position
    hamiltonian: sp.Expr  # L_u + P + lambda^T f, with u free
    control_law: tuple[sp.Expr, ...]  # s(x, lambda): dH/du = 0, no bounds
    slopes: tuple[sp.Expr, ...]  # du*/ds per control: 1 if it has no bounds, else a symbol
    state_equations: tuple[sp.Expr, ...]  # xdot = dH/dlambda at u
    costate_equations: tuple[sp.Expr, ...]  # lambdadot = -dH/dx at u, including -grad P
    running_cost: sp.Expr  # L_u(x, u), without P

    @property
    def z(self) -> tuple[sp.Symbol, ...]:
        return (*self.model.states, *self.costates)

    def without_penalty(self, exprs):
        """Expressions with P set to zero: the part the generated code computes symbolically."""
        return [e.subs(self.penalty, 0).doit() for e in exprs]

    def on_law(self, exprs):
        """Expressions at ``u = s(z)``, the control law without bounds."""
        sub = dict(zip(self.model.controls, self.control_law, strict=True))
        return [sp.sympify(e).subs(sub) for e in exprs]

    def rhs(self) -> list[sp.Expr]:
        """The model part of ``zdot = G(z, u)`` (the penalty terms are added by compiled code)."""
        return self.without_penalty([*self.state_equations, *self.costate_equations])

    def jacobian(self) -> sp.Matrix:
        """The model part of ``DG = dG/dz`` along ``u = u*(z)``, for the variational equations:
        ``G_z + G_u diag(slopes) ds/dz``."""
        G, z, u = sp.Matrix(self.rhs()), sp.Matrix(self.z), sp.Matrix(self.model.controls)
        ds_dz = sp.diag(*self.slopes) * sp.Matrix(self.control_law).jacobian(z)
        return G.jacobian(z) + G.jacobian(u) * ds_dz

    def model_hamiltonian(self) -> sp.Expr:
        """``H(x, lambda, u)`` without the penalty (which is added numerically)."""
        return self.hamiltonian.subs(self.penalty, 0)

    def describe(self) -> str:
        """Readable text of H, the control law and the state and costate equations."""
        m = self.model
        lines = [f"model: {m.name}  ({m.description})"]
        if m.parameters:
            pars = ", ".join(
                f"{s} = {n} (default {d:g})"
                for s, n, d in zip(m.parameters, m.parameter_names, m.defaults, strict=True)
            )
            lines.append(f"parameters: {pars}")
        lines += [
            "",
            "Hamiltonian:",
            f"  H = {sp.sstr(self.hamiltonian)}",
            "",
            "control law (dH/du = 0; a bounded control is clipped smoothly to its bounds):",
        ]
        lines += [
            f"  {u} = {sp.sstr(e)}" for u, e in zip(m.controls, self.control_law, strict=True)
        ]
        lines += ["", "state equations (at the control u):"]
        lines += [
            f"  d{x}/dt = {sp.sstr(e)}" for x, e in zip(m.states, self.state_equations, strict=True)
        ]
        lines += ["", "costate equations (at the control u):"]
        lines += [
            f"  d{lam}/dt = {sp.sstr(e)}"
            for lam, e in zip(self.costates, self.costate_equations, strict=True)
        ]
        lines += [
            "",
            "P(x, y) = sum_j W exp(-(|(x, y) - c_j|^2 / r_j^2)^n)  (obstacle penalty, compiled)",
        ]
        return "\n".join(lines)


@cache
def _derive_cached(model: VehicleModel) -> CanonicalSystem:
    xs, us = model.states, model.controls
    lams = tuple(sp.Symbol(f"lambda_{i + 1}", real=True) for i in range(len(xs)))
    penalty = sp.Function("P")(xs[0], xs[1])
    costate_terms = sum(lam * f for lam, f in zip(lams, model.dynamics, strict=True))
    H = model.running_cost + penalty + costate_terms

    grad_u = [sp.diff(H, u) for u in us]
    hess_u = sp.hessian(H, us)
    if hess_u.free_symbols & set(us):
        raise ModelError(
            f"model {model.name!r}: d2H/du2 depends on u, so dH/du = 0 may have several solutions"
        )
    if hess_u.is_positive_definite is not True:
        raise ModelError(
            f"model {model.name!r}: d2H/du2 = {sp.sstr(hess_u)} is not positive definite,"
            " so dH/du = 0 is not a minimum"
        )
    sols = sp.solve(grad_u, us, dict=True)
    if len(sols) != 1 or set(sols[0]) != set(us):
        raise ModelError(f"model {model.name!r}: dH/du = 0 has no unique solution for {us}")
    law = [sp.simplify(sols[0][u]) for u in us]
    slopes = [sp.Integer(1)] * len(us)
    for i, *_ in model.control_bounds:  # saturated smoothly at run time (see .bounds)
        slopes[i] = sp.Symbol(f"du_ds_{i + 1}", positive=True)

    # No simplify here: it turns cos^2 into cos(2 theta), which reads worse and computes
    # slower; factor keeps the products visible.
    xdot = tuple(sp.factor(sp.diff(H, lam)) for lam in lams)
    ldot = tuple(sp.factor(-sp.diff(H, x)) for x in xs)
    return CanonicalSystem(
        model=model,
        costates=lams,
        penalty=penalty,
        hamiltonian=H,
        control_law=tuple(law),
        slopes=tuple(slopes),
        state_equations=xdot,
        costate_equations=ldot,
        running_cost=model.running_cost,
    )


def derive(model: str | VehicleModel) -> CanonicalSystem:
    """Apply Pontryagin's minimum principle to ``model`` (a name or a :class:`VehicleModel`)."""
    return _derive_cached(get_model(model))
