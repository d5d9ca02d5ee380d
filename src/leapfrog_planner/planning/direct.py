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
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import checks
from ..errors import ModelError, ScenarioError, SettingsError, require_integer
from .direct_arcs import (
    arc_clearance,
    arc_end_state,
    controls_from_states,
    unicycle_to_wheel,
    wheel_to_unicycle,
)

__all__ = ["DirectResult", "DirectTranscription", "cached_transcription", "multistart_guesses",
           "richardson", "solve_direct", "straight_line_guess"]  # fmt: skip

_MODELS = ("unicycle", "diff-drive")  # the direct method writes its own dynamics for these

_CASADI_MISSING = "the direct method needs casadi: pip install 'leapfrog-planner[dev]'"


def load_casadi():
    """Import casadi lazily so that the rest of the library works without it."""
    try:
        import casadi
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(_CASADI_MISSING) from exc
    return casadi


@dataclass(frozen=True)
class DirectResult:
    """Outcome of one direct solve.

    ``controls`` are in the model's own units: ``(v, omega)`` for the unicycle,
    ``(omega_R, omega_L)`` for the diff-drive. ``states[k]`` is the state at ``t[k]``; the
    control ``controls[k]`` is held constant on ``[t[k], t[k+1]]``.
    """

    success: bool
    status: str
    message: str
    cost: float
    t: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    min_clearance: float
    iterations: int
    solve_time: float
    # |x(T) - goal| of the start state driven by the returned controls exactly (each interval an
    # arc), not by the transcription's RK4 step: the check of the mesh's own error.
    end_state_error: float = math.nan


@dataclass(frozen=True)
class DirectCase:
    """What a solve is given: end states, horizon, obstacle rows, penalty weight and exponent,
    and the control bounds (per control ``(lo, hi)`` or ``None``; ``None``: no bounds).
    :meth:`DirectTranscription.solve` checks them; :func:`solve_direct` checks the ends,
    horizon and obstacles first and leaves the rest to its solves."""

    start: np.ndarray
    goal: np.ndarray
    horizon: float
    obstacles: np.ndarray
    weight: float
    exponent: float
    control_bounds: Any = None


@dataclass(frozen=True)
class StartPoint:
    """IPOPT's start point ``x0`` and the bounds ``lbx``, ``ubx`` of the NLP's variables (the
    node states, then the controls, flat)."""

    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray


# --------------------------------------------------------------------------- validation


def check_state(value: Any, name: str) -> np.ndarray:
    return checks.vector(value, 3, name, " [x, y, heading]")


def check_horizon(value: Any) -> float:
    return checks.real(value, "horizon", gt=0)


def check_obstacles(value: Any) -> np.ndarray:
    return checks.obstacles(value)


def check_positive(
    value: Any, name: str, *, allow_zero: bool = False, error: type[ValueError] = ScenarioError
) -> float:
    bound = {"ge": 0.0} if allow_zero else {"gt": 0.0}
    return checks.real(value, name, error=error, **bound)


def check_guess(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    arr = checks.rows(value, shape[1], name, ", ".join(["v"] * shape[1]), error=SettingsError)
    if arr.shape != shape:
        raise SettingsError(f"{name}: expected {shape[0]} rows, got {arr.shape[0]}")
    return arr


def check_model(value: Any) -> str:
    if value not in _MODELS:
        raise ModelError(f"the direct method has no model {value!r} (it has {', '.join(_MODELS)})")
    return value


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
    ) -> None:
        self.n_obstacles = require_integer("n_obstacles", n_obstacles, 0)
        self.intervals = require_integer("intervals", intervals, 1)
        self.model = check_model(model)
        self.substeps = require_integer("substeps", substeps, 1)
        self.wheel_radius = check_positive(wheel_radius, "wheel_radius", error=SettingsError)
        self.axle_length = check_positive(axle_length, "axle_length", error=SettingsError)
        self.tol = check_positive(tol, "tol", error=SettingsError)
        self.max_iter = require_integer("max_iter", max_iter, 1)
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
        x_next, q = step.map(n)(states[:, :n], controls, params_mx)
        defects = x_next - states[:, 1:]

        nlp = {
            "x": ca.vertcat(ca.vec(states), ca.vec(controls)),
            "p": params_mx,
            "f": ca.sum2(q),
            "g": ca.vec(defects),
        }
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
    ) -> DirectResult:
        """Solve one scenario from one initial guess.

        ``control_bounds`` gives ``(lo, hi)`` or ``None`` per control (in the model's units):
        box constraints on the piecewise-constant controls.

        ``guess_states`` is an ``(N+1, 3)`` array; without it the straight line with interpolated
        heading is used. ``guess_controls`` is ``(N, 2)`` in the model's units; without it the
        controls are derived from the state guess. The guess's end nodes are replaced by start
        and goal, which are imposed exactly.
        """
        case = self._case(start, goal, horizon, obstacles, weight, exponent, control_bounds)
        states0, controls0 = self._first_guess(case, guess_states, guess_controls)
        point = self._start_point(case, states0, controls0)
        params = np.concatenate(
            ([case.horizon, case.weight, case.exponent], case.obstacles.ravel())
        )

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
        return StartPoint(np.concatenate((states0.ravel(), controls0.ravel())), lbx, ubx)

    def _result(self, case: DirectCase, sol, stats, solve_time: float) -> DirectResult:
        """IPOPT's solution ``sol`` and ``stats`` as a :class:`DirectResult`; the clearance and
        the end state's error are measured along the exact arcs of the controls."""
        n = self.intervals
        w = np.asarray(sol["x"], dtype=float).ravel()
        states = w[: 3 * (n + 1)].reshape(n + 1, 3)
        controls = w[3 * (n + 1) :].reshape(n, 2)
        unicycle = (
            controls
            if self.model == "unicycle"
            else wheel_to_unicycle(controls, self.wheel_radius, self.axle_length)
        )
        status = str(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False))
        iterations = int(stats.get("iter_count", -1))
        end = arc_end_state(case.start, unicycle, case.horizon)
        return DirectResult(
            success=success,
            status=status,
            message=f"IPOPT: {status} after {iterations} iterations",
            cost=float(sol["f"]),
            t=np.linspace(0.0, case.horizon, n + 1),
            states=states,
            controls=controls,
            min_clearance=arc_clearance(states, unicycle, case.horizon, case.obstacles),
            iterations=iterations,
            solve_time=solve_time,
            end_state_error=float(np.linalg.norm(end - case.goal)),
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


# --------------------------------------------------------------------------- initial guesses


def straight_line_guess(start, goal, horizon, intervals) -> tuple[np.ndarray, np.ndarray]:
    """Straight segment from start to goal, heading interpolated linearly between the two.

    Returns ``(states (N+1, 3), controls (N, 2))`` with unicycle controls ``(v, omega)``. The
    heading is interpolated rather than taken from the chord, so the guess already meets both
    end headings without any wrapping.
    """
    start = check_state(start, "start")
    goal = check_state(goal, "goal")
    horizon = check_horizon(horizon)
    n = require_integer("intervals", intervals, 1)
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    states = start + s * (goal - start)
    return states, controls_from_states(states, horizon)


def _arc(start: np.ndarray, goal: np.ndarray, n: int, offset: float, heading: str) -> np.ndarray:
    """Chord plus a quadratic lateral bump of height ``offset`` (relative to the chord length).

    ``heading="tangent"`` follows the path tangent (unwrapped, shifted by whole turns to start
    next to the start heading); ``heading="interpolated"`` blends start to goal heading.
    """
    chord = goal[:2] - start[:2]
    length = float(np.hypot(*chord))
    if length > 1e-9:
        along, scale = chord / length, length
    else:  # start and goal coincide in position: bump sideways of the start heading
        along, scale = np.array([math.cos(start[2]), math.sin(start[2])]), 1.0
    normal = np.array([-along[1], along[0]])
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    pos = start[:2] + s * chord + offset * scale * 4.0 * s * (1.0 - s) * normal
    if heading == "interpolated":
        theta = start[2] + s[:, 0] * (goal[2] - start[2])
    else:
        tangent = chord + offset * scale * 4.0 * (1.0 - 2.0 * s) * normal
        if length <= 1e-9:
            tangent = tangent + 1e-9 * along  # keep atan2 defined on a degenerate chord
        theta = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
        theta += 2.0 * np.pi * np.round((start[2] - theta[0]) / (2.0 * np.pi))
    return np.column_stack((pos, theta))


def multistart_guesses(start, goal, intervals) -> list[np.ndarray]:
    """The deterministic set of state guesses tried by :func:`solve_direct`.

    The straight line and quadratic lateral arcs peaking at ``+-0.25, +-0.5, +-0.75, +-1.0``
    chord lengths, each once with the heading interpolated between the end headings and once
    with the heading of the path tangent (18 guesses). Both heading choices matter: with fixed
    end headings neighbouring extremals differ in how the heading turns, and the two families
    lead IPOPT to different ones (paper case 1 is found only from tangent headings). The
    offsets are dense because which guess reaches which optimum shifts with the mesh; with only
    +-0.5 and +-1.0, paper cases 3 and 4 miss their best optimum on some meshes.
    """
    start = check_state(start, "start")
    goal = check_state(goal, "goal")
    n = require_integer("intervals", intervals, 1)
    return [
        _arc(start, goal, n, offset, heading)
        for offset in _OFFSETS
        for heading in ("interpolated", "tangent")
    ]


_OFFSETS = (0.0, 0.25, -0.25, 0.5, -0.5, 0.75, -0.75, 1.0, -1.0)


def resample_guess(result: DirectResult, intervals: int) -> tuple[np.ndarray, np.ndarray]:
    """A coarse solution on a finer mesh: states linear in time, controls sampled at midpoints."""
    t = np.linspace(0.0, result.t[-1], intervals + 1)
    states = np.column_stack([np.interp(t, result.t, result.states[:, i]) for i in range(3)])
    mid = (t[:-1] + t[1:]) / 2.0
    index = np.minimum(np.searchsorted(result.t, mid, side="right") - 1, len(result.controls) - 1)
    return states, result.controls[index]


def distinct_guesses(results: list[DirectResult]) -> list[DirectResult]:
    """Successful results, cheapest first, with repeats of the same local optimum dropped."""
    kept: list[DirectResult] = []
    for r in sorted((r for r in results if r.success), key=lambda r: r.cost):
        if not any(
            abs(r.cost - k.cost) <= 1e-6 * (1.0 + abs(k.cost))
            and np.max(np.abs(r.states - k.states)) < 1e-3
            for k in kept
        ):
            kept.append(r)
    return kept


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
    n = require_integer("intervals", intervals, 1)
    if coarse_intervals is not None:
        coarse_intervals = require_integer("coarse_intervals", coarse_intervals, 1)
    user = [] if guesses is None else list(guesses)

    starts: list[tuple[np.ndarray, np.ndarray | None]] = [(g, None) for g in user]
    if multistart:
        starts += _builtin_starts(case, n, coarse_intervals, model, kw)
    if not starts:
        starts = [(straight_line_guess(case.start, case.goal, case.horizon, n)[0], None)]
    transcription = cached_transcription(len(case.obstacles), n, model=model, **kw)
    return best_result(solve_all(transcription, case, starts))


def _builtin_starts(case: DirectCase, n: int, coarse_intervals, model: str, kw: dict) -> list:
    """The starts ``(states, controls or None)`` that the built-in guesses
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
            return [resample_guess(r, n) for r in optima]
        # nothing converged on the coarse mesh: try the raw guesses on the full one
    return [(g, None) for g in multistart_guesses(case.start, case.goal, n)]


def solve_all(transcription: DirectTranscription, case: DirectCase, starts) -> list[DirectResult]:
    """One solve of ``case`` per start ``(states, controls or None)``, in order."""
    return [
        transcription.solve(
            case.start,
            case.goal,
            case.horizon,
            case.obstacles,
            weight=case.weight,
            exponent=case.exponent,
            guess_states=states,
            guess_controls=controls,
            control_bounds=case.control_bounds,
        )
        for states, controls in starts
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
