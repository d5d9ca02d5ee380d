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
from .bounds import smooth_clip


@dataclass(frozen=True)
class CanonicalSystem:
    """The Pontryagin boundary value problem of a model, as SymPy expressions."""

    model: VehicleModel
    costates: tuple[sp.Symbol, ...]
    penalty: sp.Expr  # P(x, y), an undefined function of the position
    hamiltonian: sp.Expr  # L_u + P + lambda^T f, with u free
    control_law: tuple[sp.Expr, ...]  # u*(x, lambda)
    state_equations: tuple[sp.Expr, ...]  # xdot with u = u*
    costate_equations: tuple[sp.Expr, ...]  # lambdadot with u = u*, including -grad P
    running_cost: sp.Expr  # L_u(x, u*(x, lambda)), without P

    @property
    def z(self) -> tuple[sp.Symbol, ...]:
        return (*self.model.states, *self.costates)

    def without_penalty(self, exprs):
        """Expressions with P set to zero: the part the generated code computes symbolically."""
        return [e.subs(self.penalty, 0).doit() for e in exprs]

    def rhs(self) -> list[sp.Expr]:
        """The model part of ``zdot = G(z)`` (the penalty terms are added by compiled code)."""
        return self.without_penalty([*self.state_equations, *self.costate_equations])

    def jacobian(self) -> sp.Matrix:
        """The model part of ``DG = dG/dz``, for the variational equations."""
        return sp.Matrix(self.rhs()).jacobian(sp.Matrix(self.z))

    def hamiltonian_on_extremal(self) -> sp.Expr:
        """``H(x, lambda, u*(x, lambda))`` without the penalty (which is added numerically)."""
        sub = dict(zip(self.model.controls, self.control_law, strict=True))
        return self.hamiltonian.subs(sub).subs(self.penalty, 0)

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
            "control law (dH/du = 0):",
        ]
        lines += [
            f"  {u} = {sp.sstr(e)}" for u, e in zip(m.controls, self.control_law, strict=True)
        ]
        lines += ["", "state equations:"]
        lines += [
            f"  d{x}/dt = {sp.sstr(e)}" for x, e in zip(m.states, self.state_equations, strict=True)
        ]
        lines += ["", "costate equations:"]
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
    for i, lo, hi in model.control_bounds:  # saturate smoothly (see .bounds)
        law[i] = smooth_clip(law[i], lo, hi, model.smoothing)
    law = tuple(law)
    on_law = dict(zip(us, law, strict=True))

    # No simplify here: it turns cos^2 into cos(2 theta), which reads worse and computes
    # slower; factor keeps the products of the control law visible.
    xdot = tuple(sp.factor(sp.diff(H, lam).subs(on_law)) for lam in lams)
    ldot = tuple(sp.factor((-sp.diff(H, x)).subs(on_law)) for x in xs)
    return CanonicalSystem(
        model=model,
        costates=lams,
        penalty=penalty,
        hamiltonian=H,
        control_law=law,
        state_equations=xdot,
        costate_equations=ldot,
        running_cost=model.running_cost.subs(on_law),
    )


def derive(model: str | VehicleModel) -> CanonicalSystem:
    """Apply Pontryagin's minimum principle to ``model`` (a name or a :class:`VehicleModel`)."""
    return _derive_cached(get_model(model))
