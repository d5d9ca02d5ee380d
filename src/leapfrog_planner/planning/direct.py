"""Direct method (CasADi + IPOPT) for the planner's optimal control problem.

This is the independent cross-check for the indirect (Leapfrog) solver: it shares no code with
it, only the problem statement (the README's minimum-energy problem and obstacle penalty). The
problem is transcribed by RK4 multiple shooting: controls are piecewise constant on ``N``
intervals, the node states are decision variables, and the running cost is integrated as an extra
quadrature state inside the same RK4 step, so the dynamics and the cost are discretised
consistently.

Accuracy: for the returned controls the cost is integrated to O(h^4), but the optimal cost of the
transcription converges to the true optimum only at O(h^2), because piecewise-constant controls
approximate the smooth optimal control to O(h). Use :func:`richardson` on meshes ``N`` and ``2N``
(it assumes order 2) for reference-quality costs; on the paper cases it agrees with the
reference optima to about 1e-6.

The NLP is built once per model, number of obstacles, ``N`` and number of RK4 substeps; start,
goal (equal bounds on the end nodes), horizon, obstacles, penalty and control bounds are inputs,
so repeated solves never rebuild anything. casadi is imported only when a solver is built.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import ScenarioError, SettingsError, require_integer
from .direct_arcs import (
    arc_clearance,
    arc_end_state,
    controls_from_states,
    unicycle_to_wheel,
    wheel_to_unicycle,
)
from .direct_inputs import (
    DirectResult,
    check_free_time,
    check_guess,
    check_horizon,
    check_model,
    check_obstacles,
    check_positive,
    check_state,
    distinct_guesses,
    multistart_guesses,
    resample_guess,
    straight_line_guess,
)

__all__ = ["DirectResult", "DirectTranscription", "cached_transcription", "multistart_guesses",
           "richardson", "solve_direct", "straight_line_guess"]  # fmt: skip

_CASADI_MISSING = "the direct method needs casadi: pip install 'leapfrog-planner[dev]'"


def load_casadi():
    """Import casadi lazily so that the rest of the library works without it."""
    try:
        import casadi
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(_CASADI_MISSING) from exc
    return casadi


@dataclass(frozen=True)
class DirectCase:
    """What a solve is given: end states, horizon, obstacle rows, penalty weight and exponent,
    and the control bounds (per control ``(lo, hi)`` or ``None``; ``None``: no bounds).
    :meth:`DirectTranscription.solve` checks them; :func:`solve_direct` checks the ends,
    horizon and obstacles first and leaves the rest to its solves. A free-time case (of a
    transcription with ``free_time=True``) also has the price of time ``k`` and the bounds of
    ``T``; its ``horizon`` is the guess of ``T``."""

    start: np.ndarray
    goal: np.ndarray
    horizon: float
    obstacles: np.ndarray
    weight: float
    exponent: float
    control_bounds: Any = None
    time_weight: float | None = None
    horizon_bounds: tuple[float, float] | None = None


@dataclass(frozen=True)
class StartPoint:
    """IPOPT's start point ``x0`` and the bounds ``lbx``, ``ubx`` of the NLP's variables (the
    node states, then the controls, flat; last ``T`` if the final time is free)."""

    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray


# --------------------------------------------------------------------------- transcription


class DirectTranscription:
    """RK4 multiple-shooting NLP for one model, obstacle count, mesh and substep count.

    The NLP is built and handed to IPOPT (``casadi.nlpsol``) once, in the constructor. Its
    parameters are the horizon, the penalty weight and exponent and the obstacle array; start and
    goal are fixed through the bounds of the first and last node. Every :meth:`solve` is a call
    of the same compiled solver, so warm solves for new scenarios do not rebuild anything.

    Decision variables are the ``N+1`` node states and ``N`` piecewise-constant controls.
    Each interval is integrated with ``substeps`` RK4 steps, carrying the running cost as a
    fourth (quadrature) state so that the cost is integrated by the same scheme as the motion.
    Heading is a plain real variable: it is never wrapped.

    With ``free_time=True`` the horizon ``T`` is a decision variable too (the last one, boxed by
    the case's ``horizon_bounds``; ``solve``'s ``horizon`` is its guess) and the objective holds
    ``k T`` besides the integral, with the price of time ``k`` (``solve``'s ``time_weight``) the
    NLP's first parameter in place of the horizon: the step ``T / (N substeps)`` then varies
    with the variable ``T``.
    """

    def __init__(
        self,
        n_obstacles: int,
        intervals: int = 100,
        *,
        model: str = "unicycle",
        substeps: int = 1,
        wheel_radius: float = 1.0,
        axle_length: float = 2.0,
        tol: float = 1e-10,
        max_iter: int = 3000,
        free_time: bool = False,
    ) -> None:
        self.n_obstacles = require_integer("n_obstacles", n_obstacles, 0)
        self.intervals = require_integer("intervals", intervals, 1)
        self.model = check_model(model)
        self.substeps = require_integer("substeps", substeps, 1)
        self.wheel_radius = check_positive(wheel_radius, "wheel_radius", error=SettingsError)
        self.axle_length = check_positive(axle_length, "axle_length", error=SettingsError)
        self.tol = check_positive(tol, "tol", error=SettingsError)
        self.max_iter = require_integer("max_iter", max_iter, 1)
        if not isinstance(free_time, bool):
            raise SettingsError(f"free_time: expected True or False, got {free_time!r:.40}")
        self.free_time = free_time
        self._solver = self._build()

    # The symbolic model: state derivative and running cost for one (x, u). Both models spend
    # 1/2 |u|^2 on their own controls; the diff-drive maps wheel speeds to (v, omega).
    def _rhs(self, ca, x, u, weight, exponent, obstacles):
        if self.model == "unicycle":
            v, omega = u[0], u[1]
        else:
            r, b = self.wheel_radius, self.axle_length
            v = r * (u[0] + u[1]) / 2
            omega = r * (u[0] - u[1]) / b
        effort = (u[0] ** 2 + u[1] ** 2) / 2
        penalty = 0
        for j in range(self.n_obstacles):
            cx, cy, rad = obstacles[3 * j], obstacles[3 * j + 1], obstacles[3 * j + 2]
            s = ((x[0] - cx) ** 2 + (x[1] - cy) ** 2) / rad**2
            penalty += weight * ca.exp(-(s**exponent))
        xdot = ca.vertcat(v * ca.cos(x[2]), v * ca.sin(x[2]), omega)
        return xdot, effort + penalty

    def _build(self):
        ca = load_casadi()
        n, m = self.intervals, self.n_obstacles
        horizon = ca.SX.sym("T")
        weight = ca.SX.sym("W")
        exponent = ca.SX.sym("n")
        obstacles = ca.SX.sym("obs", 3 * m)
        params = ca.vertcat(horizon, weight, exponent, obstacles)

        # One interval as a casadi Function: x_k, u_k -> x_{k+1}, integral of L over the interval.
        x = ca.SX.sym("x", 3)
        u = ca.SX.sym("u", 2)
        h = horizon / (n * self.substeps)

        def f(xx):
            return self._rhs(ca, xx, u, weight, exponent, obstacles)

        xk, qk = x, 0
        for _ in range(self.substeps):
            k1, l1 = f(xk)
            k2, l2 = f(xk + h / 2 * k1)
            k3, l3 = f(xk + h / 2 * k2)
            k4, l4 = f(xk + h * k3)
            xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            qk = qk + h / 6 * (l1 + 2 * l2 + 2 * l3 + l4)
        step = ca.Function("rk4_interval", [x, u, params], [xk, qk])

        # The N intervals are one mapped call; ``expand`` below turns the NLP into a flat SX graph.
        # That makes the build slower (about 2 s for N=200 and 7 obstacles, once) but every IPOPT
        # iteration 2-3 times faster than on the MX graph, which is what repeated solves need.
        states = ca.MX.sym("X", 3, n + 1)
        controls = ca.MX.sym("U", 2, n)
        params_mx = ca.MX.sym("p", params.numel())
        variables = ca.vertcat(ca.vec(states), ca.vec(controls))
        step_params, time_cost = params_mx, 0
        if self.free_time:  # T the last variable; the first parameter the price of time k
            horizon_mx = ca.MX.sym("T")
            variables = ca.vertcat(variables, horizon_mx)
            step_params = ca.vertcat(horizon_mx, params_mx[1:])
            time_cost = params_mx[0] * horizon_mx
        x_next, q = step.map(n)(states[:, :n], controls, step_params)
        defects = x_next - states[:, 1:]

        nlp = {"x": variables, "p": params_mx, "f": ca.sum2(q) + time_cost, "g": ca.vec(defects)}
        options = {
            "print_time": False,
            # Quiet by design: the library never prints. lam_p (sensitivity to the parameters)
            # is not needed, and its gradient w.r.t. the exponent is NaN where s**n underflows.
            "show_eval_warnings": False,
            "calc_lam_p": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "expand": True,
            "ipopt.tol": self.tol,
            "ipopt.max_iter": self.max_iter,
        }
        return ca.nlpsol("leapfrog_direct", "ipopt", nlp, options)

    def solve(
        self,
        start,
        goal,
        horizon,
        obstacles,
        *,
        weight: float = 100.0,
        exponent: float = 2,
        guess_states=None,
        guess_controls=None,
        control_bounds=None,
        time_weight=None,
        horizon_bounds=None,
    ) -> DirectResult:
        """Solve one scenario from one initial guess.

        ``control_bounds`` gives ``(lo, hi)`` or ``None`` per control (in the model's units):
        box constraints on the piecewise-constant controls.

        A free-time transcription needs the price of time ``time_weight`` (finite, > 0); then
        ``horizon`` is the guess of ``T`` and ``horizon_bounds`` ``(lo, hi)`` its bounds
        (default: the guess / 100 to the guess * 100). A fixed-time one refuses both.

        ``guess_states`` is an ``(N+1, 3)`` array; without it the straight line with interpolated
        heading is used. ``guess_controls`` is ``(N, 2)`` in the model's units; without it the
        controls are derived from the state guess. The guess's end nodes are replaced by start
        and goal, which are imposed exactly.
        """
        case = self._case(start, goal, horizon, obstacles, weight, exponent, control_bounds)
        case = self._free_time(case, time_weight, horizon_bounds)
        states0, controls0 = self._first_guess(case, guess_states, guess_controls)
        point = self._start_point(case, states0, controls0)
        first = case.time_weight if self.free_time else case.horizon
        params = np.concatenate(([first, case.weight, case.exponent], case.obstacles.ravel()))

        tic = time.perf_counter()
        sol = self._solver(x0=point.x0, p=params, lbx=point.lbx, ubx=point.ubx, lbg=0.0, ubg=0.0)
        solve_time = time.perf_counter() - tic
        return self._result(case, sol, self._solver.stats(), solve_time)

    def _case(
        self, start, goal, horizon, obstacles, weight, exponent, control_bounds
    ) -> DirectCase:
        """The scenario checked, with as many obstacles as this transcription was built for."""
        start, goal = check_state(start, "start"), check_state(goal, "goal")
        horizon, obstacles = check_horizon(horizon), check_obstacles(obstacles)
        weight = check_positive(weight, "weight", allow_zero=True)
        exponent = check_positive(exponent, "exponent")
        case = DirectCase(start, goal, horizon, obstacles, weight, exponent, control_bounds)
        if len(case.obstacles) != self.n_obstacles:
            raise ScenarioError(
                f"this transcription was built for {self.n_obstacles} obstacles, "
                f"got {len(case.obstacles)}"
            )
        return case

    def _free_time(self, case: DirectCase, time_weight, horizon_bounds) -> DirectCase:
        """``case`` with the price of time and the bounds of ``T`` checked (its horizon the
        guess of ``T``); refused unless the final time is free."""
        if not self.free_time:
            if time_weight is not None or horizon_bounds is not None:
                raise SettingsError(
                    "time_weight, horizon_bounds: only for a free-time transcription"
                )
            return case
        k, guess, bounds = check_free_time(time_weight, case.horizon, horizon_bounds)
        return replace(case, horizon=guess, time_weight=k, horizon_bounds=bounds)

    def _first_guess(
        self, case: DirectCase, guess_states, guess_controls
    ) -> tuple[np.ndarray, ...]:
        """The guess's states, its end nodes replaced by start and goal (default: the straight
        line), and controls in the model's units (default: derived from the states)."""
        n = self.intervals
        if guess_states is None:
            states0, _ = straight_line_guess(case.start, case.goal, case.horizon, n)
        else:
            states0 = check_guess(guess_states, "guess_states", (n + 1, 3))
        states0[0], states0[-1] = case.start, case.goal
        if guess_controls is None:
            controls0 = controls_from_states(states0, case.horizon)
            if self.model == "diff-drive":
                controls0 = unicycle_to_wheel(controls0, self.wheel_radius, self.axle_length)
        else:
            controls0 = check_guess(guess_controls, "guess_controls", (n, 2))
        return states0, controls0

    def _start_point(self, case: DirectCase, states0, controls0) -> StartPoint:
        """IPOPT's start point and bounds: the end nodes fixed to start and goal, the controls
        boxed by the case's control bounds (the guess's controls clipped into them)."""
        n = self.intervals
        lbx = np.full(3 * (n + 1) + 2 * n, -np.inf)
        ubx = -lbx
        lbx[:3] = ubx[:3] = case.start
        lbx[3 * n : 3 * n + 3] = ubx[3 * n : 3 * n + 3] = case.goal
        for i, bound in enumerate(case.control_bounds or ()):
            if bound is not None:
                lbx[3 * (n + 1) + i :: 2], ubx[3 * (n + 1) + i :: 2] = bound
                controls0[:, i] = np.clip(controls0[:, i], *bound)
        x0 = np.concatenate((states0.ravel(), controls0.ravel()))
        if self.free_time:
            lo, hi = case.horizon_bounds
            x0, lbx, ubx = np.append(x0, case.horizon), np.append(lbx, lo), np.append(ubx, hi)
        return StartPoint(x0, lbx, ubx)

    def _result(self, case: DirectCase, sol, stats, solve_time: float) -> DirectResult:
        """IPOPT's solution ``sol`` and ``stats`` as a :class:`DirectResult`; the clearance and
        the end state's error are measured along the exact arcs of the controls."""
        n = self.intervals
        w = np.asarray(sol["x"], dtype=float).ravel()
        horizon = float(w[-1]) if self.free_time else case.horizon
        states = w[: 3 * (n + 1)].reshape(n + 1, 3)
        controls = w[3 * (n + 1) : 3 * (n + 1) + 2 * n].reshape(n, 2)
        unicycle = (
            controls
            if self.model == "unicycle"
            else wheel_to_unicycle(controls, self.wheel_radius, self.axle_length)
        )
        status = str(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False))
        iterations = int(stats.get("iter_count", -1))
        message = f"IPOPT: {status} after {iterations} iterations"
        if self.free_time and min(abs(horizon / b - 1.0) for b in case.horizon_bounds) < 1e-6:
            message += f"; T = {horizon:g} is at a bound, {case.horizon_bounds}"
        end = arc_end_state(case.start, unicycle, horizon)
        return DirectResult(
            success=success,
            status=status,
            message=message,
            cost=float(sol["f"]),
            t=np.linspace(0.0, horizon, n + 1),
            states=states,
            controls=controls,
            min_clearance=arc_clearance(states, unicycle, horizon, case.obstacles),
            iterations=iterations,
            solve_time=solve_time,
            end_state_error=float(np.linalg.norm(end - case.goal)),
            horizon=horizon,
        )


_TRANSCRIPTIONS: dict[tuple, DirectTranscription] = {}


def cached_transcription(
    n_obstacles: int, intervals: int, *, slot: int = 0, model: str = "unicycle", **kw
) -> DirectTranscription:
    """A :class:`DirectTranscription` built once per arguments and process (building takes 0.3
    to 2 s; a solve reuses it). Concurrent solves need one transcription each (a CasADi solver's
    memory is its own, and its solve releases the GIL): give each thread its own ``slot``.
    Building is not thread-safe: build every slot in one thread first."""
    key = (n_obstacles, intervals, slot, model, tuple(sorted(kw.items())))
    if key not in _TRANSCRIPTIONS:  # (3,200 intervals and 7 obstacles: 18 s and 1.1 GB)
        _TRANSCRIPTIONS[key] = DirectTranscription(n_obstacles, intervals, model=model, **kw)
    return _TRANSCRIPTIONS[key]


def clear_transcriptions() -> None:
    """Free the cached transcriptions (a large mesh holds a gigabyte)."""
    _TRANSCRIPTIONS.clear()


def solve_direct(
    start,
    goal,
    horizon,
    obstacles=(),
    *,
    weight: float = 100.0,
    exponent: float = 2,
    intervals: int = 100,
    model: str = "unicycle",
    multistart: bool = True,
    guesses=None,
    coarse_intervals: int | None = 40,
    control_bounds=None,
    **kw,
) -> DirectResult:
    """Solve a scenario by the direct method, from several initial guesses.

    With ``multistart=True`` every guess of :func:`multistart_guesses` is tried, together with
    every ``(N+1, 3)`` state array in ``guesses``; the cheapest successful result is returned (the
    cheapest overall if none succeeded, so the caller sees the failure). With
    ``multistart=False`` only ``guesses`` are tried, or the straight line if there are none.

    The built-in guesses are first solved on a coarse mesh of ``coarse_intervals`` (when that is
    smaller than ``intervals``; ``None`` disables it), and each distinct coarse local optimum is
    then refined on the full mesh. This is cheaper than solving every guess on the full mesh,
    and it is also more reliable: a coarse optimum lies next to the fine optimum of the same
    extremal, while a raw guess's basin of attraction changes with the mesh.

    ``control_bounds`` (``(lo, hi)`` or ``None`` per control) bounds the controls. Extra
    keywords (``substeps``, ``wheel_radius``, ``axle_length``, ``tol``, ``max_iter``) go to
    :class:`DirectTranscription`, built once per mesh and process (:func:`cached_transcription`)
    and reused for all guesses.
    """
    check_model(model)  # first: another model's states may hold more than three numbers
    start, goal = check_state(start, "start"), check_state(goal, "goal")
    horizon, obstacles = check_horizon(horizon), check_obstacles(obstacles)
    case = DirectCase(start, goal, horizon, obstacles, weight, exponent, control_bounds)
    return solve_case(case, intervals, model, multistart, guesses, coarse_intervals, kw)


def solve_case(
    case: DirectCase, intervals, model: str, multistart: bool, guesses, coarse_intervals, kw: dict
) -> DirectResult:
    """:func:`solve_direct`'s solves of a ``case`` whose ends, horizon and obstacles are
    checked: the user's ``guesses`` and, with ``multistart``, the built-in ones (refined from
    the coarse mesh); ``kw`` are the transcription's options (``free_time=True`` for a
    free-time case, as :func:`.direct_free.solve_direct_free`'s)."""
    n = require_integer("intervals", intervals, 1)
    if coarse_intervals is not None:
        coarse_intervals = require_integer("coarse_intervals", coarse_intervals, 1)
    user = [] if guesses is None else list(guesses)

    starts: list[tuple] = [(g, None) for g in user]
    if multistart:
        starts += _builtin_starts(case, n, coarse_intervals, model, kw)
    if not starts:
        starts = [(straight_line_guess(case.start, case.goal, case.horizon, n)[0], None)]
    transcription = cached_transcription(len(case.obstacles), n, model=model, **kw)
    return best_result(solve_all(transcription, case, starts))


def _builtin_starts(case: DirectCase, n: int, coarse_intervals, model: str, kw: dict) -> list:
    """The starts ``(states, controls or None[, horizon])`` that the built-in guesses
    (:func:`multistart_guesses`) give a mesh of ``n`` intervals: each distinct local optimum of
    the guesses on the coarse mesh, resampled to the full one; the raw guesses themselves when
    there is no coarse mesh (None, or not below ``n``) or nothing converged on it. ``kw`` are
    the transcription's options (on the coarse mesh with a tolerance of 1e-6 at the finest)."""
    if coarse_intervals is not None and coarse_intervals < n:
        coarse_kw = {**kw, "tol": max(kw.get("tol", 1e-10), 1e-6)}
        coarse = cached_transcription(
            len(case.obstacles), coarse_intervals, model=model, **coarse_kw
        )
        guesses = multistart_guesses(case.start, case.goal, coarse_intervals)
        optima = distinct_guesses(solve_all(coarse, case, [(g, None) for g in guesses]))
        if optima:
            return [(*resample_guess(r, n), r.horizon) for r in optima]
        # nothing converged on the coarse mesh: try the raw guesses on the full one
    return [(g, None) for g in multistart_guesses(case.start, case.goal, n)]


def solve_all(transcription: DirectTranscription, case: DirectCase, starts) -> list[DirectResult]:
    """One solve of ``case`` per start ``(states, controls or None)``, in order; a start may
    add its own ``horizon`` (a free-time case's guess of ``T``; else the case's)."""
    return [
        transcription.solve(
            case.start,
            case.goal,
            horizon[0] if horizon else case.horizon,
            case.obstacles,
            weight=case.weight,
            exponent=case.exponent,
            guess_states=states,
            guess_controls=controls,
            control_bounds=case.control_bounds,
            time_weight=case.time_weight,
            horizon_bounds=case.horizon_bounds,
        )
        for states, controls, *horizon in starts
    ]


def best_result(results: list[DirectResult]) -> DirectResult:
    """The best of ``results`` by :func:`_better` (the first of equals)."""
    best = None
    for result in results:
        if best is None or _better(result, best):
            best = result
    return best


def richardson(cost_coarse: float, cost_fine: float, order: float = 2.0) -> float:
    """Extrapolate the costs of meshes ``N`` and ``2N`` to a zero step.

    The default order is 2, not 4, on purpose. RK4 integrates a *given* control to O(h^4), but
    the transcription restricts the controls to piecewise constants, which approximate the smooth
    optimal control only to O(h); at an optimum that costs O(h^2). Measured on the paper cases,
    successive differences of the cost shrink by a factor of 4.0 per mesh doubling.
    """
    return cost_fine + (cost_fine - cost_coarse) / (2.0**order - 1.0)


def _better(new: DirectResult, old: DirectResult) -> bool:
    """Success beats failure; among equals the strictly lower finite cost wins (first kept)."""
    if new.success != old.success:
        return new.success
    if not math.isfinite(new.cost):
        return False
    return not math.isfinite(old.cost) or new.cost < old.cost
