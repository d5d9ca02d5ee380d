"""The loop's small linear algebra, compiled.

The systems are tiny (3x3 for shooting, up to about 50x50 for multiple shooting). At this size
NumPy's LAPACK wrappers cost more than the arithmetic (about 7 us per call for a 3x3 SVD or
solve, measured), and each Newton iteration needs both cond(DF) (MNM's gamma, the singular test)
and the correction DF^-1 F. numba calls the same LAPACK routines directly, both in one call.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit


@njit(cache=True)
def newton_correction(J, F, max_cond):
    """Return ``(d, cond)``: ``d = J^-1 F`` and the 2-norm condition number of ``J``.

    ``d`` is not computed (NaNs) when ``cond > max_cond``: the caller reports a singular
    Jacobian instead of stepping.
    """
    s = np.linalg.svd(J)[1]
    cond = s[0] / s[-1] if s[-1] > 0.0 else np.inf
    if not cond <= max_cond:
        return np.full(F.size, np.nan), cond
    return np.linalg.solve(J, F), cond


# Dot products with one fixed summation order, shared by the Python loop and the compiled
# shooting loop (the model kernels import them): NumPy's and numba's BLAS may round the same
# 3-element dot product differently, and a last-bit difference in |F| moves the inexact
# integration tolerance, an adaptive step, and then a chaotic Newton orbit.
@njit(cache=True)
def dot(u, v):
    s = 0.0
    for i in range(u.size):
        s += u[i] * v[i]
    return s


@njit(cache=True)
def transpose_times(J, F):
    """``J^T F``."""
    out = np.zeros(J.shape[1])
    for i in range(J.shape[0]):
        for j in range(J.shape[1]):
            out[j] += J[i, j] * F[i]
    return out


# F alone is evaluated where Newton's quadratic convergence predicts convergence with this
# margin: |F_k+1| ~ |F_k|^3 / |F_k-1|^2 <= tol / PREDICT_MARGIN. A wrong prediction costs an
# evaluation, a right one the variational equations (about a quarter of one). Measured on 50
# random scenarios: margin 100 skips J in 10% of the local evaluations for 0.3% more of them,
# 10 in 14% for 0.4% more, 1 in 17% for 1.4% more.
PREDICT_MARGIN = 10.0


@njit(cache=True)
def converges_next(before: float, last: float, tol: float) -> bool:
    """Whether Newton's next iterate is predicted to reach ``|F| <= tol``, from ``|F|`` of the
    last two iterates (``before``, ``last``): the same test in both loops (RootSettings.predict).
    """
    if not before > 0.0:
        return False
    return last * last * last / (before * before) * PREDICT_MARGIN <= tol


@njit(cache=True)
def solve(J, b):
    """``J^-1 b`` through the same LAPACK call as :func:`newton_correction` and the compiled
    shooting loop (NumPy's own LAPACK build may round differently)."""
    return np.linalg.solve(J, b)
