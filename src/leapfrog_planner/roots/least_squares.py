"""A trust-region solve of ``F(x) = 0`` for where Newton's line search stalls: SciPy's
Levenberg-Marquardt (MINPACK's ``lmder``) on ``|F|^2`` with the system's own Jacobian.

A damped Newton step is the linear model's root, shortened until ``|F|`` falls. Far from the
root of a strongly nonlinear system (multiple shooting from a Leapfrog iterate on a long route
through a map's corridors) that direction may lower ``|F|`` only for steps of a few hundredths
of its length, and the line search stalls where the root is near (measured on an office maze:
|F| 0.12, stalled after 4 iterations; Levenberg-Marquardt from the same start: within the
tolerance 1e-5 after 70 trial points and 60 Jacobians, 0.3 s). Levenberg-Marquardt bends its
step towards steepest descent inside a trust region instead, and keeps making progress there.
"""

from __future__ import annotations

import numpy as np

from ..compiled.status import RootStatus
from .loop import RootSettings
from .messages import converged, max_iterations, non_finite, stalled
from .result import RootResult
from .steps import vnorm
from .system import RootSystem

#: A solve whose |F| is above ``STALL_FACTOR`` times the largest of its ``STALL_WINDOW``
#: iterates before (fell by less than 1% in 10) has stalled: on the office maze's runs whose
#: Levenberg-Marquardt failed, |F| stayed flat for hundreds of iterates (0.064 for 370 of them),
#: where every one that converged lowered it by 5% or more in each 10.
STALL_WINDOW = 10
STALL_FACTOR = 0.99


class _Stalled(Exception):
    """|F| no longer falls (:data:`STALL_WINDOW`)."""


class _Root(Exception):
    """A point with ``|F| <= tol`` was evaluated: the solve ends there (MINPACK would go on
    towards ``|F| = 0``, which a root solve to ``tol`` does not need)."""


class _Counted:
    """``F`` and its Jacobian as SciPy asks for them: ``F`` alone at trial points, ``F`` and
    ``J`` at accepted ones (where MINPACK asks for ``J`` after ``F``), each point evaluated
    once; where ``F`` cannot be evaluated, a residual far above the start's (the trust region
    shrinks). Raises :class:`_Root` at a point within ``tol``, :class:`_Stalled` where |F| no
    longer falls."""

    def __init__(self, system: RootSystem, x0: np.ndarray, F0: np.ndarray, tol: float):
        self.system, self.tol = system, tol
        self.worse = np.full(F0.size, 1e3 * (1.0 + vnorm(F0)) / np.sqrt(F0.size))
        self.x, self.F, self.J = x0.copy(), F0, None
        self.f_evals, self.jac_evals = 1, 0
        self.norms: list[float] = []  # |F| at each point where J was asked for

    def fun(self, x):
        if not np.array_equal(x, self.x):
            self.x, (self.F, self.J) = x.copy(), self.system.evaluate(x, False)
            self.f_evals += 1
            self.stop_at_a_root()
        return self.worse if self.F is None else self.F

    def jac(self, x):
        if self.J is None or not np.array_equal(x, self.x):
            self.x, (self.F, self.J) = x.copy(), self.system.evaluate(x, True)
            self.f_evals += 1
            self.jac_evals += 1
            self.stop_at_a_root()
        if self.F is None:
            return np.eye(x.size)
        self.norms.append(vnorm(self.F))
        n, w = self.norms, STALL_WINDOW
        if len(n) > w and n[-1] > STALL_FACTOR * max(n[-1 - w : -1]):  # (as the Newton loop)
            raise _Stalled
        return self.J

    def stop_at_a_root(self):
        if self.F is not None and vnorm(self.F) <= self.tol:
            raise _Root


def solve_least_squares(
    system: RootSystem, x0, settings: RootSettings, max_evaluations: int
) -> RootResult:
    """``F(x) = 0`` by Levenberg-Marquardt from ``x0``: converged when ``|F| <= settings.tol``
    at its last iterate, after at most ``max_evaluations`` trial points (SciPy's ``max_nfev``;
    the Jacobians at the iterates it accepts come on top). Its ``residual_norms`` are ``|F|``
    at the iterates where it evaluated the Jacobian (the first is ``x0``) and at the last;
    ``step_sizes`` are NaN (a trust region has no damping factor)."""
    from scipy.optimize import least_squares  # here: SciPy's optimize takes 0.1 s to import

    x0 = np.array(x0, dtype=float, copy=True).reshape(-1)
    F0, _ = system.evaluate(x0, False)
    if F0 is None:
        return _result(x0, None, RootStatus.NON_FINITE, non_finite(0), [], 1, 0)
    counted = _Counted(system, x0, F0, settings.tol)
    try:
        counted.stop_at_a_root()  # (x0 itself)
        fit = least_squares(
            counted.fun, x0, jac=counted.jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15,
            max_nfev=max_evaluations,
        )  # fmt: skip
        x, out_of_evaluations, creeping = fit.x, fit.status == 0, False
    except _Root:
        x, out_of_evaluations, creeping = counted.x, False, False
    except _Stalled:
        x, out_of_evaluations, creeping = counted.x, False, True
    same = np.array_equal(x, counted.x)
    F = counted.F if same else system.evaluate(x, False)[0]
    evals, jacs = counted.f_evals + (not same), counted.jac_evals
    norms = counted.norms  # at the iterates where J was evaluated, then at the last one:
    if F is not None and not (same and counted.J is not None):
        norms.append(vnorm(F))
    its = max(len(norms) - 1, 0)
    if F is None:
        return _result(x, None, RootStatus.NON_FINITE, non_finite(its), norms, evals, jacs)
    norm = vnorm(F)
    if norm <= settings.tol:
        status, message = RootStatus.CONVERGED, converged(norm, settings.tol, its)
    elif out_of_evaluations:
        status, message = RootStatus.MAX_ITERATIONS, max_iterations(norm, its)
    elif creeping:
        status, message = RootStatus.STALLED, stalled(norm, STALL_FACTOR, STALL_WINDOW)
    else:  # MINPACK's own end: a local minimum of |F|^2 that is no root
        status = RootStatus.STALLED
        message = f"|F| = {norm:.3g}: a least-squares minimum that is no root, {its} iterations"
    return _result(x, F, status, message, norms, evals, jacs)


def _result(x, F, status, message, norms, f_evals, jac_evals) -> RootResult:
    return RootResult(
        x=x,
        F=F if F is not None else np.full(x.shape, np.nan),
        status=status,
        message=message,
        iterations=max(len(norms) - 1, 0),
        f_evals=f_evals,
        jac_evals=jac_evals,
        residual_norms=np.array(norms),
        step_sizes=np.full(max(len(norms) - 1, 0), np.nan),
    )
