"""The one Newton iteration loop shared by every method (the methods differ only in their step)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..compiled.linear import converges_next, newton_correction
from ..compiled.linear import solve as linear_solve
from ..compiled.status import RootStatus
from ..errors import SettingsError, require_integer
from .messages import converged, diverged, max_iterations, non_finite, singular, stalled
from .result import RootResult
from .steps import Evaluator, get_strategy, vnorm


@dataclass(frozen=True)
class RootSettings:
    """``tol``: converged when ``|F| <= tol``. ``max_cond``: above it the Jacobian counts as
    singular. Diverged when ``|x|`` exceeds ``divergence * (1 + |x0|)``. Stalled when
    ``stall_window > 0`` and ``|F|`` is above ``stall_factor`` times the largest of the
    ``stall_window`` norms before it (off by default: a caller with a fallback sets it).
    ``predict``: evaluate F alone (no Jacobian) at a full Newton step where Newton's quadratic
    convergence predicts ``|F| <= tol`` there, and again with the Jacobian where it then does
    not come (see :meth:`.steps.Evaluator.full_step`): the same iterates, fewer variational
    equations, one evaluation more per wrong prediction (Leapfrog's local solves use it)."""

    tol: float = 1e-10
    max_iterations: int = 50
    max_cond: float = 1e13
    divergence: float = 1e8
    stall_window: int = 0
    stall_factor: float = 0.5
    predict: bool = False

    def __post_init__(self):
        if not self.tol > 0:
            raise SettingsError(f"tol must be > 0, got {self.tol}")
        require_integer("max_iterations", self.max_iterations)
        if not self.max_cond > 1:
            raise SettingsError(f"max_cond must be > 1, got {self.max_cond}")
        if not self.divergence > 1:
            raise SettingsError(f"divergence must be > 1, got {self.divergence}")
        require_integer("stall_window", self.stall_window, 0)
        if not 0 < self.stall_factor < 1:
            raise SettingsError(f"stall_factor must be in (0, 1), got {self.stall_factor}")
        if not isinstance(self.predict, bool):
            raise SettingsError(f"predict must be true or false, got {self.predict!r}")


def solve_root(
    system, x0, method="modified-newton", settings: RootSettings | None = None
) -> RootResult:
    """Find ``x`` with ``F(x) = 0``. ``method``: a name or a step strategy object."""
    settings = settings or RootSettings()
    strategy = get_strategy(method)
    evaluate = Evaluator(system, settings.tol)
    memo = strategy.start()
    x = np.array(x0, dtype=float, copy=True).reshape(-1)
    bound = settings.divergence * (1.0 + vnorm(x))
    F, J = evaluate(x, jacobian=True)
    norms: list[float] = []
    lams: list[float] = []

    def done(status, message):
        return RootResult(
            x=x,
            F=F if F is not None else np.full(x.shape, np.nan),
            status=status,
            message=message,
            iterations=len(lams),
            f_evals=evaluate.f_evals,
            jac_evals=evaluate.jac_evals,
            residual_norms=np.array(norms),
            step_sizes=np.array(lams),
        )

    if F is None:
        return done(RootStatus.NON_FINITE, non_finite(0))
    for it in range(settings.max_iterations + 1):
        norms.append(vnorm(F))
        if norms[-1] <= settings.tol:
            return done(RootStatus.CONVERGED, converged(norms[-1], settings.tol, it))
        if it == settings.max_iterations:
            break
        w = settings.stall_window
        # Against the largest of the last w norms, so that classical Newton's excursions (|F|
        # up, then quadratically down) are not taken for creeping.
        if w and it >= w and norms[-1] > settings.stall_factor * max(norms[-1 - w : -1]):
            return done(RootStatus.STALLED, stalled(norms[-1], settings.stall_factor, w))
        if J is None:  # a custom step's iterate given without its Jacobian
            F, J = evaluate(x, jacobian=True)
            if F is None:  # cannot happen for a deterministic F, kept for safety
                return done(RootStatus.NON_FINITE, "F is not finite")
        # Is the full step predicted to converge? Then it goes without J (RootSettings.predict).
        evaluate.predicted = (
            settings.predict and it >= 1 and converges_next(norms[-2], norms[-1], settings.tol)
        )
        d, cond = newton_correction(J, F, settings.max_cond)
        if not cond <= settings.max_cond:
            return done(RootStatus.SINGULAR_JACOBIAN, singular(cond, settings.max_cond))
        # The systems are tiny (3x3 for shooting): a compiled solve is a few microseconds, where
        # SciPy's lu_factor/lu_solve wrappers cost tens; so "reusing the factorisation" for
        # further right-hand sides (NLEQ-ERR's simplified corrections) is reusing J itself.
        step = strategy.step(evaluate, x, F, J, d, lambda b, J=J: linear_solve(J, b), cond, memo)
        if step.failed is not None:
            return done(step.failed, step.message)
        x, F, J = step.x, step.F, step.J
        lams.append(step.lam)
        if not np.isfinite(x).all() or vnorm(x) > bound:
            F = F if F is not None else np.full(x.shape, np.nan)
            return done(RootStatus.DIVERGED, diverged(vnorm(x), bound))
        if F is None:
            F, J = evaluate.full_step(x)
            if F is None:
                return done(RootStatus.NON_FINITE, non_finite(it + 1))
    return done(RootStatus.MAX_ITERATIONS, max_iterations(norms[-1], settings.max_iterations))
