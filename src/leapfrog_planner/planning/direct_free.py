"""The direct method with the final time free.

The problem: minimise ``J = integral over [0, T] of (k + 1/2 |u|^2 + P(x)) dt`` over the
controls *and* the horizon ``T``, where ``k > 0`` is the price of time (``time_weight``) and
``P`` the disc obstacle penalty of :mod:`.direct`. Without a price of time (``k = 0``) the
minimum-energy problem has no optimum in ``T`` (going slower is always cheaper); with one, the
optimum balances time against effort.

It is the same RK4 multiple-shooting transcription as :func:`.direct.solve_direct`
(:class:`.direct.DirectTranscription` with ``free_time=True``: ``T`` is the NLP's last variable
and the step ``T / N`` varies with it), with the same multistart: the built-in guesses solved on
a coarse mesh, each distinct coarse optimum (with its own ``T``) refined on the full one. The
mesh error is again O(h^2) in both the cost and ``T``: :func:`.direct.richardson` on meshes
``N`` and ``2N`` extrapolates either.

A check in closed form: in free space, between two poses on one line with the heading along it,
the optimum drives straight at constant speed. The unicycle spends ``k + v^2/2`` per unit time,
so ``v* = sqrt(2k)``, ``T* = D / sqrt(2k)`` and ``J* = D sqrt(2k)`` over a distance ``D``; the
diff-drive with wheel radius ``r`` spends ``k + v^2/r^2`` (both wheels at ``v/r``), so
``v* = r sqrt(k)``, ``T* = D / (r sqrt(k))`` and ``J* = 2 D sqrt(k) / r``. With constant controls
RK4 is exact, so the transcription meets these on any mesh.
"""

from __future__ import annotations

from .direct import DirectCase, DirectResult, solve_case
from .direct_inputs import check_free_time, check_model, check_obstacles, check_state

__all__ = ["solve_direct_free"]


def solve_direct_free(
    start,
    goal,
    obstacles,
    time_weight: float,
    *,
    horizon_guess: float,
    horizon_bounds=None,
    weight: float = 100.0,
    exponent: float = 2,
    intervals: int = 100,
    model: str = "unicycle",
    multistart: bool = True,
    control_bounds=None,
    guesses=None,
    coarse_intervals: int | None = 40,
    **kw,
) -> DirectResult:
    """Solve the free-final-time problem with the price of time ``time_weight`` (``k``, finite
    and > 0) by the direct method.

    ``horizon_guess`` is the first guess of ``T`` (of every built-in guess and every state array
    in ``guesses``); ``horizon_bounds`` ``(lo, hi)``, ``0 < lo < hi`` and finite, bound ``T``
    (default: the guess / 100 to the guess * 100). A result whose ``T`` lies on a bound says so
    in its message. The rest is as :func:`.direct.solve_direct`: the multistart, the coarse
    mesh, ``control_bounds`` and the extra keywords of the transcription (``substeps``,
    ``wheel_radius``, ``axle_length``, ``tol``, ``max_iter``).

    The result's ``cost`` is the whole ``J``, ``k T`` included; its ``horizon`` is the optimal
    ``T``, and ``t`` runs from 0 to it.
    """
    check_model(model)
    start, goal = check_state(start, "start"), check_state(goal, "goal")
    obstacles = check_obstacles(obstacles)
    k, guess, bounds = check_free_time(time_weight, horizon_guess, horizon_bounds)
    case = DirectCase(start, goal, guess, obstacles, weight, exponent, control_bounds, k, bounds)
    kw = {**kw, "free_time": True}
    return solve_case(case, intervals, model, multistart, guesses, coarse_intervals, kw)
