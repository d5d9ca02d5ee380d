"""Re-plan a moved task from a previous answer: the step of a receding-horizon loop.

``replan(previous, start=..., goal=..., obstacles=..., horizon=...)`` solves the task
``previous`` records with those changes, warm from the previous extremal: the guess is the
extremal's tail from the point nearest the new start (for a time-invariant problem, the tail of
an optimal motion is optimal from where it stands), stretched to the new horizon, solved by
:func:`.bounded.resolve` (simple shooting from its costate, else multiple shooting from its
trajectory); where that fails, the ends move to the new ones in :data:`STEPS` steps. The answer
is validated as every plan's answer is (re-integrated, reaching the goal, keeping the margin);
otherwise, and when the change is large (an end moved further than :data:`LARGE` of the path's
length, an obstacle onto the previous path, a failed previous plan, a free final time), the
moved task is planned in full. The result's ``replan`` says which: ``"warm"`` or ``"full"``, and
its message why a full plan was made. A warm result holds the moved task's extremal and its
checks; it has no sweeps, alternatives or search of its own, and its Newton iterations and
function evaluations are not counted (0).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np

from ..errors import SettingsError
from .bounded import arcs_of, resolve
from .leapfrog import Arcs
from .planner import Planner
from .rerun import recorded, recorded_settings, recorded_task, with_call
from .results import PlanResult, Validation
from .runs import touches
from .scenario import Scenario
from .settings import PlannerSettings
from .status import MAX_MOVE, PlanStatus, path_moved

#: A start further from the previous path, or a goal moved further, than this fraction of the
#: path's length is a new task: planned in full.
LARGE = 0.25
#: Where the change in one jump fails, the ends move to the new ones in this many steps.
STEPS = 4


def replan(
    previous: PlanResult,
    start: Sequence[float] | np.ndarray | None = None,
    goal: Sequence[float] | np.ndarray | None = None,
    obstacles: Sequence[Sequence[float]] | np.ndarray | None = None,
    *,
    horizon: float | None = None,
) -> PlanResult:
    """The plan of the task ``previous`` records with a new ``start``, ``goal``, ``obstacles``
    (rows ``[x, y, radius]``) or ``horizon`` (None: unchanged), warm from the previous extremal
    when the change is small, else in full; the result's ``replan`` is ``"warm"`` or ``"full"``.

    For a robot that moved along the previous answer, give the state it reached as ``start``
    and the time left as ``horizon`` (the arrival time kept): the previous extremal's tail is
    then the answer, found in milliseconds."""
    t_begin = time.perf_counter()
    if not isinstance(previous, PlanResult):
        raise SettingsError(f"replan: expected a PlanResult, got {type(previous).__name__}")
    scenario, settings = _recorded(previous)
    changes = {"start": start, "goal": goal, "obstacles": obstacles, "horizon": horizon}
    moved = dataclasses.replace(scenario, **{k: v for k, v in changes.items() if v is not None})
    planner = Planner(moved, settings)
    tau, why = _warm_start(previous, moved, planner)
    if not why:
        result, why = _warm(planner, previous, tau)
        if result is not None:
            wall = time.perf_counter() - t_begin
            result = dataclasses.replace(result, wall_time_s=wall, time_final_s=wall)
            return with_call(recorded(result, settings, "replan"), "replan(<result>)")
    full = planner.plan()
    message = f"{full.message}; re-planned in full ({why})"
    return with_call(dataclasses.replace(full, replan="full", message=message), "replan(<result>)")


def _recorded(previous: PlanResult) -> tuple[Scenario, PlannerSettings]:
    """The task and the settings ``previous`` records (:func:`.rerun.recorded_task`); for a
    fixed horizon, its task as it is, without its ``[solver]`` table (the settings rule), which
    saves reading the scenario again from its tables (0.3 ms of a warm re-plan's 5)."""
    if previous.task is None or previous.settings is None or previous.task.free_time is not None:
        return recorded_task(previous)
    return dataclasses.replace(previous.task, solver={}), recorded_settings(previous)


def _warm_start(previous: PlanResult, moved: Scenario, planner: Planner) -> tuple[float, str]:
    """Where on the previous extremal the moved task starts (its time), and why no warm start
    is tried (empty: one is)."""
    tr = previous.trajectory
    if previous.status is not PlanStatus.CONVERGED or tr is None or not previous.optimal:
        return 0.0, "the previous result has no extremal to start from"
    if previous.free_time is not None or moved.free_time is not None:
        return 0.0, "a free final time is planned in full"
    xy = tr.x[:, :2]
    length = float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))
    turn = np.angle(np.exp(1j * (tr.x[:, 2] - moved.start[2])))
    i = int(np.argmin(np.sum((xy - moved.start[:2]) ** 2, axis=1) + turn**2))
    off = float(np.linalg.norm(xy[i] - moved.start[:2]))
    shift = float(np.linalg.norm(tr.x[-1, :2] - moved.goal[:2]))
    if max(off, shift) > LARGE * max(length, 1e-9):
        what = "the goal moved" if shift >= off else "the start lies"
        return 0.0, f"{what} {max(off, shift):.3g} away, over {LARGE:g} of the path's length"
    clearance = planner.problem.penalty.clearance(xy[i:])
    if clearance.size and float(clearance.min()) < 0.0:
        return 0.0, "an obstacle lies on the previous path"
    return float(tr.t[i]), ""


def _solved(planner: Planner, problem, guess: Arcs) -> Arcs | None:
    """The moved task's extremal near ``guess``: in one jump, else the ends moved in steps."""
    s = planner.scenario
    T, settings = float(s.horizon), planner.runner.shooting
    start, goal = np.array(s.start, dtype=float), np.array(s.goal, dtype=float)
    arcs = resolve(problem, guess, problem, (0.0, T), (start, goal), settings)
    if arcs is not None:
        return arcs
    a0, g0, arcs = guess.X[0].copy(), guess.X[-1].copy(), guess
    if np.allclose(a0, start, rtol=0.0, atol=1e-9) and np.allclose(g0, goal, rtol=0.0, atol=1e-9):
        return None  # the ends did not move (the obstacles did): steps would repeat the jump
    for k in range(1, STEPS + 1):
        f = k / STEPS
        ends = (a0 + f * (start - a0), g0 + f * (goal - g0))
        arcs = resolve(problem, arcs, problem, (0.0, T), ends, settings)
        if arcs is None:
            return None
    return arcs


def _jumped(v: Validation, guess: Arcs) -> bool:
    """Whether the warm path left the guess's family (:func:`.status.path_moved` beyond
    :data:`.status.MAX_MOVE`, the start's own move aside): a cold plan might find a cheaper one."""
    tr = v.trajectory
    u = np.linspace(0.0, 1.0, 33)
    new = tr.at(u * tr.t[-1], tr.x[:, :2])
    old = guess.X[:, :2]
    old = np.column_stack([np.interp(u, np.linspace(0, 1, len(old)), old[:, i]) for i in (0, 1)])
    return path_moved(new, old, less_start=True) > MAX_MOVE


def _warm(planner: Planner, previous: PlanResult, tau: float) -> tuple[PlanResult | None, str]:
    """The warm answer, or None and why not."""
    s = planner.scenario
    problem = planner.runner.problem_at(s.weight)
    guess = arcs_of(previous.trajectory, tau)
    arcs = _solved(planner, problem, guess)
    if arcs is None:
        return None, "the warm start did not converge"
    v = planner.runner.validate(problem, arcs)
    if v is None or v.trajectory is None:
        return None, "the warm extremal missed the goal when re-integrated"
    if touches(v.clearance, s.margin):
        return None, f"the warm extremal comes within {float(v.clearance.min()):.3g} of an obstacle"
    if _jumped(v, guess):
        return None, "the warm extremal jumped to another family"
    return _warm_result(previous, s, arcs, v, guess), ""


def _warm_result(previous: PlanResult, s: Scenario, arcs: Arcs, v: Validation, guess: Arcs):
    """The result of the warm extremal ``arcs`` of the moved task ``s`` (validated: ``v``)."""
    one = arcs.t.size == 2
    return dataclasses.replace(
        previous,
        status=PlanStatus.CONVERGED,
        message=f"converged warm from the previous answer ({'simple' if one else 'multiple'}"
        " shooting)",
        final_solver="shooting" if one else "multiple-shooting",
        initial_path="previous answer",
        costate0=arcs.lam0[0].copy(),
        trajectory=v.trajectory,
        **{
            f.name: getattr(v, f.name)
            for f in dataclasses.fields(Validation)
            if f.name != "trajectory"
        },
        max_costate_jump=0.0 if one else float("nan"),
        initial_cost=float("nan"),
        history=(),
        initial_junctions=(guess.t.copy(), guess.X.copy()),
        newton_iterations=0,
        f_evals=0,
        cost_increases=0,
        time_initial_path_s=0.0,
        time_sweeps_s=0.0,
        time_validation_s=0.0,
        alternatives=(),
        weight=s.weight,
        optimal=True,
        trajectory_source="extremal",
        task=s,
        cheaper_motion=float("nan"),
        search=(),
        free_time=None,
        replan="warm",
    )
