"""Step strategies. The iteration loop (:mod:`.loop`) is shared; a method is one of these.

Each ``step`` gets the current iterate with its residual ``F``, Jacobian ``J``, the Newton
correction ``d = J^-1 F``, ``solve(b)`` for further ``J^-1 b`` and ``cond(J)``, and returns a
:class:`Step`: the next iterate, its residual (and Jacobian) if the strategy already evaluated
them, and the damping factor used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..compiled.linear import dot, transpose_times
from ..compiled.status import RootStatus
from ..errors import SettingsError


@dataclass
class Step:
    x: np.ndarray
    lam: float
    F: np.ndarray | None = None
    J: np.ndarray | None = None
    failed: RootStatus | None = None  # set when the strategy cannot produce a next iterate
    message: str = ""


def vnorm(v) -> float:
    """Euclidean norm of a short vector: ``np.linalg.norm``'s generality costs more than the
    arithmetic at this size, and the loop takes several norms per evaluation. Summed in the
    same order as the compiled shooting loop (:func:`..compiled.linear.dot`)."""
    return math.sqrt(dot(v, v))


def _sumsq(A) -> float:
    a = A.ravel()
    return float(a @ a)


class Evaluator:
    """Counts evaluations for the loop; handed to strategies for their trial points.
    ``predicted``: whether the loop predicts the current full Newton step to converge (set by
    the loop each iteration, RootSettings.predict)."""

    def __init__(self, system, tol: float):
        self.system = system
        self.tol = tol
        self.predicted = False
        self.f_evals = 0
        self.jac_evals = 0

    def __call__(self, x, jacobian=False):
        self.f_evals += 1
        self.jac_evals += bool(jacobian)
        F, J = self.system.evaluate(x, jacobian)
        # A sum of squares is finite iff every entry is (and |F| < 1e154): cheaper than isfinite.
        if F is not None and not math.isfinite(F @ F):
            F, J = None, None
        if J is not None and not math.isfinite(_sumsq(J)):
            F, J = None, None  # a NaN Jacobian makes the point as unusable as a NaN residual
        return F, J

    def full_step(self, x):
        """``(F, J)`` at a full Newton step's point ``x``: F alone where the loop predicts
        convergence there, and again with J where it then does not come (the same point
        evaluated twice in a row gives the same F: see ShootingSystem.evaluate). So only an
        iterate with ``|F| <= tol`` ever comes without its Jacobian."""
        if not self.predicted:
            return self(x, jacobian=True)
        F, J = self(x, jacobian=False)
        if F is not None and not vnorm(F) <= self.tol:
            F, J = self(x, jacobian=True)
        return F, J


@dataclass(frozen=True)
class NewtonStep:
    """Classical Newton: the full step ``x+ = x - DF(x)^-1 F(x)``, never damped."""

    name = "newton"

    def start(self):
        return None

    def step(self, evaluate, x, F, J, d, solve, cond, memo) -> Step:
        return Step(x - d, 1.0)


@dataclass(frozen=True)
class ModifiedNewtonStep:
    """Stoer and Bulirsch's modified Newton method (section 5.4), exactly as the paper states it.

    ``d = DF^-1 F``, ``gamma = 1/cond(DF)``, ``h(s) = F^T F``. Find the smallest ``m >= 0`` with
    ``h(x - 2^-m d) <= h(x) - 2^-m (gamma/4) |d| |Dh(x)|``, then take, among ``2^-k`` for
    ``0 <= k <= m``, the step with the smallest ``h``. Hence ``h`` never increases.
    """

    max_halvings: int = 20  # 2^-20 ~ 1e-6: shorter steps only measure noise
    name = "modified-newton"

    def __post_init__(self):
        if self.max_halvings < 1:
            raise SettingsError("max_halvings must be >= 1")

    def start(self):
        return None

    def step(self, evaluate, x, F, J, d, solve, cond, memo) -> Step:
        gamma = 1.0 / cond
        h0 = dot(F, F)
        slope = 0.25 * gamma * vnorm(d) * vnorm(2.0 * transpose_times(J, F))
        best = None
        for m in range(self.max_halvings + 1):
            lam = 2.0**-m
            xt = x - lam * d
            # Fetch the Jacobian with every trial: it costs ~20% more than F alone, while the
            # accepted trial would otherwise be evaluated a second time by the loop. The full
            # step may go without it where it is predicted to converge.
            Ft, Jt = evaluate.full_step(xt) if m == 0 else evaluate(xt, jacobian=True)
            h = dot(Ft, Ft) if Ft is not None else np.inf
            if best is None or h < best[0]:
                best = (h, Step(xt, lam, Ft, Jt))
            if h <= h0 - lam * slope:
                return best[1]
        return Step(
            x,
            0.0,
            failed=RootStatus.LINE_SEARCH_FAILED,
            message=self.failure_message,
        )

    @property
    def failure_message(self) -> str:
        """Why a step failed (also reported by the compiled shooting loop)."""
        return f"no step 2^-m, m <= {self.max_halvings}, decreased |F|^2 enough"


@dataclass
class _NleqMemo:
    lam: float
    dx_prev: np.ndarray | None = None  # previous ordinary Newton correction
    dxbar: np.ndarray | None = None  # simplified correction at the current iterate
    lam_prev: float = 1.0


@dataclass(frozen=True)
class NleqErrStep:
    """Deuflhard's affine-invariant damped Newton method, NLEQ-ERR (error-oriented).

    Damping is judged by the simplified Newton correction ``dxbar = -J_k^-1 F(x_k + lam dx)``,
    which reuses the LU factors of ``J_k``. The predictor ``lam = min(1, mu)`` uses the previous
    step's contraction; the corrector ``mu' = |dx| lam^2 / (2 |dxbar - (1 - lam) dx|)`` replaces a
    trial that fails the restricted monotonicity test ``theta < 1 - lam/4``.
    """

    initial_damping: float = 1.0
    min_damping: float = 1e-6
    xtol: float = 1e-12  # a full step whose simplified correction is below xtol (1 + |x|) is final
    max_trials: int = 30  # damping trials per step
    name = "nleq-err"

    def __post_init__(self):
        if not (0 < self.min_damping < self.initial_damping <= 1):
            raise SettingsError("need 0 < min_damping < initial_damping <= 1")

    def start(self):
        return _NleqMemo(lam=self.initial_damping)

    def step(self, evaluate, x, F, J, d, solve, cond, memo: _NleqMemo) -> Step:
        dx = -d
        ndx = vnorm(dx)
        lam = memo.lam
        if memo.dx_prev is not None and memo.dxbar is not None:
            denom = vnorm(memo.dxbar - dx) * ndx
            mu = (
                np.inf
                if denom == 0
                else (vnorm(memo.dx_prev) * vnorm(memo.dxbar) / denom) * memo.lam_prev
            )
            lam = min(1.0, mu)
        reduced = False  # once reduced in this step, the corrector may not raise lambda again
        for _ in range(self.max_trials):
            if lam < self.min_damping:
                break
            xt = x + lam * dx
            Ft, Jt = evaluate(xt, jacobian=True)  # as in MNM: no second evaluation when accepted
            if Ft is None:
                lam, reduced = lam / 2, True  # outside the domain of F (the flow blew up)
                continue
            dxbar = -solve(Ft)
            if lam == 1.0 and vnorm(dxbar) <= self.xtol * (1.0 + vnorm(xt)):
                # Converged in Deuflhard's sense; the monotonicity test would only measure noise.
                memo.dx_prev, memo.dxbar, memo.lam_prev, memo.lam = dx, dxbar, lam, lam
                return Step(xt, lam, Ft, Jt)
            theta = vnorm(dxbar) / ndx if ndx > 0 else 0.0
            denom = vnorm(dxbar - (1.0 - lam) * dx)
            mu_c = np.inf if denom == 0 else 0.5 * ndx * lam * lam / denom
            if theta >= 1.0 - lam / 4.0:
                lam, reduced = min(mu_c, lam / 2.0), True
                continue
            lam_c = min(1.0, mu_c)
            if not reduced and lam_c >= 4.0 * lam and lam < 1.0:
                lam = lam_c
                continue
            memo.dx_prev, memo.dxbar, memo.lam_prev, memo.lam = dx, dxbar, lam, lam
            return Step(xt, lam, Ft, Jt)
        return Step(
            x,
            0.0,
            failed=RootStatus.LINE_SEARCH_FAILED,
            message=self.failure_message,
        )

    @property
    def failure_message(self) -> str:
        """Why a step failed (also reported by the compiled shooting loop)."""
        return f"no acceptable damping factor >= {self.min_damping:g}"


STRATEGIES = {"newton": NewtonStep, "modified-newton": ModifiedNewtonStep, "nleq-err": NleqErrStep}


def get_strategy(method) -> NewtonStep | ModifiedNewtonStep | NleqErrStep:
    if not isinstance(method, str):
        return method
    try:
        return STRATEGIES[method]()
    except KeyError:
        raise SettingsError(f"unknown method {method!r} (known: {', '.join(STRATEGIES)})") from None
