"""Leapfrog's driver, in the shape of an iterative solve: :func:`init` fits the initial path's
arcs, :func:`step` sweeps once and decides the level, :func:`terminate` says when ``q = 2``, when
the level of ``fewest_arcs`` has ended, or when the sweep budget is reached,
:func:`postprocess` runs the final solve (and its retry) and returns the
:class:`LeapfrogSolution`."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from ..._blas import blas_single_threaded
from ...integrate.flow import Flow
from ...integrate.problem import OptimalControlProblem
from ...roots import RootResult
from ..path_ranking import PathGuide
from .arcs import Arcs, Junctions
from .final import FinalSolution, FinalSolver
from .levels import Level, LevelState, idle, next_level
from .local import LocalSolver
from .settings import LeapfrogSettings
from .stop import LateBound, Snapshot, StopRule
from .sweep import InitialFit, SweepRecord, fit_initial_path, sweep


class LeapfrogStatus(StrEnum):
    """How a run of Leapfrog ended."""

    CONVERGED = "converged"  # an extremal from start to goal (its validation is the planner's)
    SEGMENT_FAILED = "segment-failed"  # an initial segment's two-point problem failed
    FINAL_FAILED = "final-failed"  # the sweeps ended; the final solve failed
    # The extremal of a problem with planning aids (smoothed or relaxed bounds, the car's turn
    # assist) did not continue to the problem itself (see :mod:`..bounded`).
    CONTINUATION_STOPPED = "continuation-stopped"
    # Stopped after a sweep left it dearer than a bound (``stop_above``): another path's
    # extremal is far cheaper (see :mod:`..search`).
    ABANDONED = "abandoned"
    # Not started: a plan's time limit had passed (see :func:`leapfrog`'s ``deadline``).
    OUT_OF_TIME = "out-of-time"


@dataclass(frozen=True)
class LeapfrogSolution:
    """What the algorithm produced for one initial path (before validation)."""

    status: LeapfrogStatus
    message: str
    costate0: np.ndarray | None  # lambda(0) of the final extremal
    # The final extremal as its solver found it: one arc (simple shooting) or the junctions of
    # multiple shooting, whose re-integration arc by arc checks it where one long shot from
    # lambda(0) is too ill-conditioned to reach the goal to 1e-8 (long horizons, tight turns).
    extremal: Arcs | None
    final_solver: str | None  # "shooting" or "multiple-shooting"
    initial_cost: float
    max_costate_jump: float  # at the junctions when the sweeps ended (before the final solve)
    history: tuple[SweepRecord, ...]
    newton_iterations: int
    f_evals: int
    cost_increases: int  # sweeps whose piecewise cost rose (should stay 0)
    sweep_time_s: float
    final_time_s: float
    final_root: RootResult | None
    # The last piecewise extremal whose arcs meet at their junctions (the last level with
    # q > 2, or the initial path's arcs): a feasible motion from start to goal even when the
    # final solve fails. None when the initial path's segments failed.
    arcs: Arcs | None = None
    # How the initial path's segments were solved: segments per strategy ("warm", "path
    # costate", "weight continuation", "end-state continuation", "affine guess"), "failed"
    # (every strategy failed) and "split" (segments split in two after failing).
    fit_strategies: dict[str, int] = field(default_factory=dict)
    # The initial segment whose two-point problem failed every strategy (None otherwise).
    failed_segment: int | None = None

    @property
    def success(self) -> bool:
        return self.status is LeapfrogStatus.CONVERGED


@dataclass
class State:
    """A run between sweeps: the current level, the last level with ``q > 2`` (multiple
    shooting's junctions), the level's state and the record of every sweep."""

    arcs: Junctions
    last_multi: Junctions
    level: LevelState
    initial_cost: float
    history: list[SweepRecord] = field(default_factory=list)
    increases: int = 0
    at_fewest: bool = False  # the level's move was FINAL: the final solves start from it

    def last_cost(self) -> float:
        return self.history[-1].cost if self.history else self.initial_cost


@blas_single_threaded
def leapfrog(
    problem: OptimalControlProblem,
    t: np.ndarray,
    X: np.ndarray,
    *,
    guide: PathGuide | None = None,
    settings: LeapfrogSettings | None = None,
    flow: Flow | None = None,
    progress: Callable[[SweepRecord], None] | None = None,
    stop_above: float | LateBound = np.inf,
    deadline: float = np.inf,
) -> LeapfrogSolution:
    """Run Leapfrog from the junctions ``(t, X)`` of a feasible path from ``X[0]`` to ``X[-1]``.

    ``guide`` is that path followed in time (:class:`.path_ranking.PathGuide`): its costates
    start the initial segments' shooting, and its states split a segment whose two-point
    problem fails. ``flow`` is reused for the stage it was built for (the final solves or the
    local problems). ``progress`` is called after each sweep. A sweep that leaves the piecewise
    cost above ``stop_above`` ends the run (``abandoned``); a :class:`LateBound` (the extremals
    of runs in other threads) is asked after each sweep, and waited for before the final solve,
    and a run abandoned once it is known as it would have been with it from the start (at the
    first sweep above it, with what it had then). Past ``deadline`` (a
    ``time.perf_counter()`` value) no further sweep starts: the final solves run from the
    level reached, without refining its junctions, and by multiple shooting only on a level of
    at most :data:`.final.LATE_ARCS` arcs (a plan's time limit); a run asked for past
    it does not start (a plan's runs queue for its threads: on a map, 15 of 17 runs started
    after a limit of 120 s, each fitted its initial path and tried a final solve from it, and
    the plan took 261 s).
    """
    if time.perf_counter() >= deadline:
        return _out_of_time()
    settings = settings or LeapfrogSettings()
    t, X = np.asarray(t, dtype=float), np.asarray(X, dtype=float)
    local, final = _solvers(problem, t, X, guide, settings, flow, deadline)
    t_start = time.perf_counter()
    fit = fit_initial_path(local, t, X)
    if not fit.success:
        return _failed(fit, local, time.perf_counter() - t_start)
    state = init(fit)
    stop = StopRule(stop_above)
    while not terminate(state, settings) and time.perf_counter() < deadline:
        step(state, local, settings, progress)
        if stop.asks(state.last_cost(), len(state.history)):
            lost = stop.judge(_snapshot(state, local, time.perf_counter() - t_start))
            if lost is not None:
                return _abandoned(lost, stop.bound)
    lost = stop.before_final()
    if lost is not None:
        return _abandoned(lost, stop.bound)
    return postprocess(state, local, final, settings, progress, t_start)


def _solvers(problem, t, X, guide, settings, flow, deadline) -> tuple[LocalSolver, FinalSolver]:
    """The local and final solvers of a run, each with its flow (``flow`` reused where its
    settings fit); the final solver begins no refinement past ``deadline``."""
    final_integrator = settings.final_shooting.integrator
    final_flow = flow if flow is not None and flow.settings == final_integrator else None
    final_flow = final_flow or Flow(problem, final_integrator)
    if flow is None or flow.settings != settings.shooting.integrator:
        flow = Flow(problem, settings.shooting.integrator)
    local = LocalSolver(problem, flow, settings, guide)
    start, goal = X[0].copy(), X[-1].copy()
    ends = (float(t[0]), float(t[-1]))
    return local, FinalSolver(local, final_flow, start, goal, *ends, deadline)


def init(fit: InitialFit) -> State:
    """The initial path's arcs as the first level."""
    arcs = fit.arcs
    return State(arcs, arcs, LevelState(), float(arcs.cost.sum()))


def terminate(state: State, settings: LeapfrogSettings) -> bool:
    return state.arcs.q <= 2 or state.at_fewest or len(state.history) >= settings.max_sweeps


def _sweep(state: State, level: Junctions, local: LocalSolver, progress) -> SweepRecord:
    """One sweep over ``level``, recorded in ``state``."""
    before = state.last_cost()
    rec = sweep(level, local, len(state.history) + 1)
    state.increases += rec.cost > before + 1e-9 * max(1.0, abs(before))
    state.history.append(rec)
    if progress is not None:
        progress(rec)
    return rec


def step(state: State, local: LocalSolver, settings: LeapfrogSettings, progress) -> None:
    """One sweep of the current level, then the level's next move (:func:`next_level`)."""
    before = state.last_cost()
    rec = _sweep(state, state.arcs, local, progress)
    move, state.level = next_level(rec, before, state.level, settings)
    if move is Level.REFINE:
        state.arcs = state.arcs.refined(local.flow)
    elif move is Level.HALVE:
        state.last_multi = state.arcs
        state.arcs = state.arcs.halved()
    elif move is Level.FINAL:
        state.last_multi = state.arcs
        state.at_fewest = True


def postprocess(state, local, final, settings, progress, t_start) -> LeapfrogSolution:
    """The final solve; if it fails after the sweeps reached ``q = 2``, or the fewest arcs the
    run keeps (``fewest_arcs``: a long route), from a level left with a large costate jump,
    that level swept on (at most :func:`retry_sweeps` more sweeps, until its jump is below
    ``final_retry_jump`` or a sweep no longer lowers the cost) and the final solve again. (A
    run that spent ``max_sweeps`` before reaching its last level is not retried, nor one whose
    last sweep at that level moved no junction: another would repeat it; no retry sweep
    begins past the final solver's deadline, a plan's time limit.)"""
    sweep_time = time.perf_counter() - t_start
    arcs, level = state.arcs, _multi_level(state)
    final_jump = arcs.max_jump()
    t_final = time.perf_counter()
    retry_time, first_failure, swept = 0.0, None, len(state.history)
    found = final.solve(arcs.lam0[0], level)
    last = state.history[-1] if state.history else None
    stuck = last is not None and last.q == level.q and idle(last)
    if (
        not found.success
        and settings.final_retry_sweeps
        and ((arcs.q == 2 and level.q > 2) or state.at_fewest)
        and not stuck
        and time.perf_counter() < final.deadline
    ):
        t_more = time.perf_counter()
        first_failure = found.root
        for _ in range(retry_sweeps(level.q, settings)):
            if time.perf_counter() >= final.deadline:
                break
            before = state.last_cost()
            rec = _sweep(state, level, local, progress)
            if rec.max_costate_jump < settings.final_retry_jump or not rec.cost < before:
                break
        retry_time = time.perf_counter() - t_more
        final_jump = level.max_jump()
        found = final.solve(level.lam0[0], level)
    final_time = time.perf_counter() - t_final - retry_time
    more = len(state.history) - swept
    extremal = found.extremal
    return LeapfrogSolution(
        status=LeapfrogStatus.CONVERGED if found.success else LeapfrogStatus.FINAL_FAILED,
        message=_message(found, first_failure, more, level.q, state),
        costate0=None if extremal is None else extremal.lam0[0].copy(),
        extremal=extremal,
        final_solver=found.solver,
        initial_cost=state.initial_cost,
        max_costate_jump=final_jump,
        history=tuple(state.history),
        newton_iterations=local.count.iterations,
        f_evals=local.count.f_evals,
        cost_increases=state.increases,
        sweep_time_s=sweep_time + retry_time,
        final_time_s=final_time,
        final_root=found.root,
        arcs=(arcs if arcs.q > 2 or arcs is level else level).frozen(),
        fit_strategies=dict(local.strategies.counts),
    )


#: A level of more than 4 arcs (a long route's fewest: ``fewest_arcs``) is swept on up to this
#: many times ``final_retry_sweeps``: there Leapfrog converges slowly (its slowest error mode
#: by about ``1 - c / q^2`` a sweep), and office maze routes needed 92 to 200 more sweeps
#: (docs/tuning.md); at q = 4 the budget stays ``final_retry_sweeps``.
LONG_LEVEL_RETRIES = 20


def retry_sweeps(q: int, settings: LeapfrogSettings) -> int:
    """The most sweeps a level of ``q`` arcs is swept on after failed final solves."""
    return settings.final_retry_sweeps * (LONG_LEVEL_RETRIES if q > 4 else 1)


def _multi_level(state: State) -> Junctions:
    """The junctions the final multiple shooting starts from: the level swept last, unless the
    sweeps reached ``q = 2`` (then the level before). A run that ends by ``max_sweeps`` or its
    deadline above the fewest arcs hands over the level it was sweeping, not the one before its
    last halving or refinement (its sweeps since then are the run's best)."""
    return state.arcs if state.arcs.q > 2 else state.last_multi


def _message(found: FinalSolution, first_failure, more: int, q: int, state: State) -> str:
    root = found.root
    if not found.success:
        msg = f"final solve failed ({root.status}: {root.message})"
        if first_failure is not None:
            msg += f", also after {more} more sweeps at q = {q}"
        return msg
    msg = f"converged by {found.solver} after {len(state.history)} sweeps"
    if first_failure is not None:
        msg += (
            f" ({more} of them at q = {q} after the final solves had failed:"
            f" {first_failure.status})"
        )
    return msg


def _failed(fit: InitialFit, local: LocalSolver, sweep_time: float) -> LeapfrogSolution:
    """A run whose initial path's segments could not all be solved."""
    return _without_arcs(
        LeapfrogStatus.SEGMENT_FAILED, fit.message, local, sweep_time,
        fit_strategies=dict(local.strategies.counts), failed_segment=fit.failed_segment,
    )  # fmt: skip


def _out_of_time() -> LeapfrogSolution:
    """A run not started: the plan's time limit had passed."""
    return _without_arcs(LeapfrogStatus.OUT_OF_TIME, "not started: the time limit had passed")


def _without_arcs(status, message: str, local: LocalSolver | None = None, sweep_time=0.0, **more):
    """A run that ended before its first sweep, with ``local``'s counts (none without it)."""
    return LeapfrogSolution(
        status=status,
        message=message,
        costate0=None,
        extremal=None,
        final_solver=None,
        initial_cost=np.inf,
        max_costate_jump=float("nan"),
        history=(),
        newton_iterations=0 if local is None else local.count.iterations,
        f_evals=0 if local is None else local.count.f_evals,
        cost_increases=0,
        sweep_time_s=sweep_time,
        final_time_s=0.0,
        final_root=None,
        **more,
    )


def _snapshot(state: State, local: LocalSolver, time_s: float) -> Snapshot:
    """The run after a sweep, as much of it as an abandoned run reports."""
    arcs = _multi_level(state)
    return Snapshot(
        state.last_cost(), tuple(state.history), arcs.frozen(), arcs.max_jump(),
        state.initial_cost, state.increases, local.count.iterations, local.count.f_evals,
        dict(local.strategies.counts), time_s,
    )  # fmt: skip


def _abandoned(at: Snapshot, bound: float) -> LeapfrogSolution:
    """A run stopped after a sweep that left it dearer than ``bound``: its arcs (a piecewise
    extremal from start to goal) are kept."""
    return LeapfrogSolution(
        status=LeapfrogStatus.ABANDONED,
        message=f"abandoned after sweep {len(at.sweeps)} at cost {at.cost:.6g}, above {bound:.6g}",
        costate0=None,
        extremal=None,
        final_solver=None,
        initial_cost=at.initial_cost,
        max_costate_jump=at.max_jump,
        history=at.sweeps,
        newton_iterations=at.iterations,
        f_evals=at.f_evals,
        cost_increases=at.increases,
        sweep_time_s=at.time_s,
        final_time_s=0.0,
        final_root=None,
        arcs=at.arcs,
        fit_strategies=at.fit_strategies,
    )
