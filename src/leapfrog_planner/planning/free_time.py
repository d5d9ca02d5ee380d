"""Free final time: the robot chooses how long to take, at a price ``k`` on each second.

The cost is ``J = k T + V(T)``, where ``V(T)`` is the optimal cost of the fixed-horizon problem
(energy and penalty). On an extremal of that autonomous problem the Hamiltonian ``H`` is
constant, and it is the rate at which the optimal cost changes with the horizon:
``dV/dT = H``. So ``dJ/dT = k + H``, and Pontryagin's condition for a free final time,
``H + k = 0`` (the Hamiltonian of ``J`` vanishes), is where that rate is zero. The method stays
indirect:

1. plan the fixed-horizon problem at a first horizon ``T0`` (the user's guess, else the
   shortest initial path at the cruise speed): the whole search, which picks the extremal;
2. find the root of ``g(T) = k + H(T)`` along that extremal's family, and those of the plan's
   alternatives near it in cost (:class:`.time_family.TimeSearch`: continuation in ``T`` by
   shooting, secant steps in ``1/T^2``, then Brent's method). A family that ran out of its
   solves while still heading below the cheapest root found is given more (:func:`_extended`);

3. plan again at the root ``T*``: the whole search (with the scenario's own initial paths, as a
   fixed-T plan there: the plans at a first horizon have at least :data:`FREE_TIME_PATHS`), so
   that an extremal of another family, cheaper there, is not missed. When it returns the
   extremal continued (the same cost), that plan is the answer; when it finds a cheaper one,
   step 2 follows that one; at most :data:`ROUNDS` times.

When the root lies beyond the bounds of ``T``, the answer is at the bound (``k + H`` then has
the sign that pushes against it, as the bound's multiplier requires), and the report says so.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from ..bvp.shooting import ShootingSettings
from ..integrate.problem import OptimalControlProblem
from .bounded import arcs_of
from .leapfrog import Arcs
from .outcome import unreachable
from .results import PlanResult, Validation
from .scenario import Scenario
from .scenario_time import top_speed
from .status import FreeTimeReport, PathOutcome, PlanStatus, TimeStep
from .time_family import (
    CONDITION_TOL,
    MAX_SOLVES,
    STEP_FACTOR,
    OutOfSolves,
    Stuck,
    TimePoint,
    TimeSearch,
    first_step,
)

#: The initial paths of the plans at a horizon, at least: the extremals they find are the
#: families followed in T, and with the default three the cheapest family was missed on 3 of
#: 80 random layouts (general preset, seed 1, cruise speed 1) where six found it.
FREE_TIME_PATHS = 6
#: Plans at a root before the search gives up on a plan returning the extremal it continued.
ROUNDS = 3
#: The horizons where the first is sought, as multiples of the shortest path at cruise speed.
FIRST_GRID = np.geomspace(0.5, 8.0, 9)
#: Alternatives are continued when their cost with the price of time is at most this many
#: times the answer's at the first horizon.
ALTERNATIVE_FACTOR = 1.5
#: Times a family that made its solves while heading below the cheapest root found is allowed
#: :data:`.time_family.MAX_SOLVES` more (:func:`_extended`).
EXTENSIONS = 3
#: Where the plan at the first horizon finds no extremal, these multiples of it are planned
#: (and in its place where it is shorter than the top speed allows: :func:`least_time`).
RETRIES = (1.6, 2.5)


class FixedHorizonPlans(Protocol):
    """What the free-time search needs of the planner: a plan at a horizon, the problem of an
    answer's obstacle weight, and the shooting settings of the continuation in ``T``."""

    def plan_at(
        self, horizon: float, deadline: float = math.inf, wide: bool = True
    ) -> PlanResult: ...

    def problem_at(self, weight: float) -> OptimalControlProblem: ...

    def progress_note(self, note: str) -> None: ...

    def validate(self, problem: OptimalControlProblem, arcs: Arcs) -> Validation | None: ...

    @property
    def shooting(self) -> ShootingSettings: ...


def first_horizon(scenario: Scenario, shortest: float, effort: float, estimate) -> float:
    """Where the search starts: the user's guess, else the horizon of least estimated cost with
    the price of time, ``estimate(T) + k T`` (``estimate``: the least estimated cost of the
    initial paths followed in ``T``) on a grid about the shortest path's length (at least a
    tenth of a metre) at the cruise speed, inside the bounds."""
    free = scenario.free_time
    if free.guess is not None:
        return free.guess
    lo, hi = free.limits()
    speed = math.sqrt(free.time_weight / effort)
    grid = np.clip(max(shortest, 0.1) / speed * FIRST_GRID, lo, hi)
    costs = [estimate(T) + free.time_weight * T for T in grid]
    return float(grid[int(np.argmin(costs))])


def least_time(scenario: Scenario, shortest: float) -> float:
    """The time the shortest initial path (``shortest`` long) takes at the top speed
    (:func:`.scenario_time.top_speed`); 0 where nothing bounds the speed."""
    vmax = top_speed(scenario.model, scenario.model_parameters, scenario.control_bounds)
    return 0.0 if vmax is None else shortest / vmax


@dataclass(frozen=True)
class _Root:
    """A family's free-time optimum: the point, the bound it rests on (``""``: none), the plan
    whose answer or alternative the family came from (``path``: that alternative; None: the
    answer), and the problem it solves."""

    point: TimePoint
    bound: str
    source: PlanResult
    problem: OptimalControlProblem
    path: PathOutcome | None = None

    def total(self, k: float) -> float:
        return self.point.total(k)


def plan_free_time(
    plans: FixedHorizonPlans,
    scenario: Scenario,
    T0: float,
    deadline: float = math.inf,
    least: float = 0.0,
) -> PlanResult:
    """The free-time answer of ``scenario`` (the module's method), starting at ``T0`` (the
    retries in its place where it is shorter than ``least``: :func:`_first_plan`); past
    ``deadline`` (a ``time.perf_counter()`` reading: the time limit) the search stops with
    what it has: the first plan is always made (cut short itself)."""
    t_begin = time.perf_counter()
    k = scenario.free_time.time_weight
    result, steps = _first_plan(plans, scenario, T0, deadline, least)
    planned, roots = [result], []
    for _ in range(ROUNDS):
        if result.status is not PlanStatus.CONVERGED:
            break
        roots += _family_roots(plans, scenario, result, steps, deadline, roots)
        best = _cheapest(roots, scenario)
        if best is None:  # no family could be followed: plan where the first step aimed
            T = _aimed(result, scenario)
            if T is None:
                break
        elif best.point.T == result.task.horizon:
            break  # the plan was made at the root: it has seen every family there
        else:
            T = best.point.T
        if time.perf_counter() >= deadline:
            break
        result = plans.plan_at(T, deadline, wide=best is None)  # at a root: as a fixed-T plan
        steps.append(_step(result, k, "plan"))
        planned.append(result)
        if best is not None and not _cheaper(result, best, k):
            break
    best = _cheapest(roots, scenario)
    if best is None:  # no root: the best plan made, which says it misses the condition
        answer = min(planned, key=lambda r: (r.status is not PlanStatus.CONVERGED, _total(r, k)))
    else:
        answer = _at_root(plans, scenario, best, planned)
    cut = time.perf_counter() >= deadline
    return _reported(answer, steps, scenario, time.perf_counter() - t_begin, cut)


def _aimed(result: PlanResult, scenario: Scenario) -> float | None:
    """Where the first step of a family's search aimed from ``result`` (None: it was there),
    inside the bounds: a plan there starts the search afresh when no family could be followed
    (from a horizon far too short, the extremals fold before they get there)."""
    free, H = scenario.free_time, _hamiltonian(result)
    T0, k = result.task.horizon, free.time_weight
    if not math.isfinite(H):
        return None
    T = first_step(T0, H, k)
    lo, hi = free.limits()
    T = float(np.clip(T, max(lo, T0 / STEP_FACTOR), min(hi, T0 * STEP_FACTOR)))
    return None if T == T0 else T


def _first_plan(
    plans, scenario: Scenario, T0: float, deadline: float, least: float = 0.0
) -> tuple[PlanResult, list[TimeStep]]:
    """The plan at ``T0``; where it finds no extremal, at longer horizons (gentler on the
    controls: a bounded turn rate needs time), :data:`RETRIES` of them within the bounds and
    the time limit. A horizon shorter than ``least`` (the shortest initial path at the top
    speed) is not planned but the next one is: a plan there finds no extremal, and only after
    its whole search (general layout 3 with ``|v| <= 1.5``: 0.84 s where 1.11 s is needed,
    31 s to fail); the last is always planned. Start and goal not connected: no retry."""
    k, (_, hi) = scenario.free_time.time_weight, scenario.free_time.limits()
    steps = []
    for factor in (1.0, *RETRIES):
        T = min(T0 * factor, hi)
        if T < least and T < hi and factor != RETRIES[-1]:
            continue
        result = plans.plan_at(T, deadline)
        steps.append(_step(result, k, "plan"))
        if result.status is PlanStatus.CONVERGED or T == hi or time.perf_counter() >= deadline:
            break
        if unreachable(result):  # no horizon joins what the obstacles keep apart
            break
    return result, steps


def _family_roots(
    plans, scenario: Scenario, result: PlanResult, steps: list, deadline: float, known=()
) -> list[_Root]:
    """Step 2 for the answer of ``result`` and each of its alternatives that converged at a
    cost (with the price of time) near it, until ``deadline``; then for those that made their
    solves while heading below the cheapest root found, with ``known`` (:func:`_extended`).
    The horizons solved are added to ``steps``."""
    free, k = scenario.free_time, scenario.free_time.time_weight
    ends = (scenario.start, scenario.goal)
    T0 = result.task.horizon
    roots, capped, searches = [], [], []
    for cost, trajectory, weight, path in _families(result, k):
        plans.progress_note(f"final time: the extremal of cost {cost:.6g} at T = {T0:.4g}")
        problem = plans.problem_at(weight)
        search = TimeSearch(
            problem, plans.shooting, k, free.limits(), ends, arcs_of(trajectory), deadline
        )
        searches.append(search)
        root, out_of_solves = _followed(search, result, problem, path)
        roots += [root] if root is not None else []
        capped += [(search, problem, path)] if out_of_solves else []
    roots += _extended(capped, [*known, *roots], scenario, result)
    for search in searches:
        steps += [TimeStep(p.T, p.H, p.total(k), "continued") for p in search.points[1:]]
    return roots


def _families(result: PlanResult, k: float) -> list[tuple]:
    """The answer of ``result`` and its alternatives that converged at a cost (with the price
    of time) near it, as (cost, trajectory, weight, the alternative or None for the answer),
    each extremal once."""
    T0 = result.task.horizon
    near = ALTERNATIVE_FACTOR * (result.cost + k * T0)
    families = [(result.cost, result.trajectory, result.weight, None)] + [
        (a.cost, a.trajectory, a.weight, a)
        for a in result.alternatives
        if a.status is PlanStatus.CONVERGED and a.trajectory is not None and a.cost + k * T0 <= near
    ]
    out = []
    for family in families:
        c = family[0]
        if not any(abs(f[0] - c) <= 1e-9 * max(1.0, abs(c)) for f in out):
            out.append(family)  # else the same extremal, found from another path
    return out


def _followed(search: TimeSearch, source: PlanResult, problem, path) -> tuple[_Root | None, bool]:
    """The root of ``search``'s family (None: it stopped without one), and whether it stopped
    for want of solves (it may be allowed more)."""
    try:
        point, bound = search.solve()
        return _Root(point, bound, source, problem, path), False
    except OutOfSolves:
        return None, True
    except Stuck:
        return None, False


def _extended(capped: list, roots: list[_Root], scenario: Scenario, source) -> list[_Root]:
    """The roots of the families ``capped`` ((search, problem, path) that made their solves)
    that head below the cheapest of ``roots`` (:meth:`.TimeSearch.predicted`: a family cut off
    while still getting cheaper is not dropped for a dearer one): the one heading lowest is
    allowed :data:`MAX_SOLVES` more and goes on where it stopped, again while it heads below
    the cheapest root found, at most :data:`EXTENSIONS` times each (the time limit holds)."""
    k = scenario.free_time.time_weight
    found, extensions = [], {id(c[0]): 0 for c in capped}
    while capped:
        best = _cheapest([*roots, *found], scenario)
        family = min(capped, key=lambda c: c[0].predicted())
        search, problem, path = family
        if best is not None and search.predicted() >= best.total(k):
            break
        capped.remove(family)
        extensions[id(search)] += 1
        search.allow(MAX_SOLVES)
        root, out_of_solves = _followed(search, source, problem, path)
        found += [root] if root is not None else []
        if out_of_solves and extensions[id(search)] < EXTENSIONS:
            capped.append(family)
    return found


def _cheapest(roots: list[_Root], scenario: Scenario) -> _Root | None:
    """The root of least cost among those that keep the margin (all, if none does)."""
    k = scenario.free_time.time_weight
    clear = [r for r in roots if r.point.clearance >= scenario.margin]
    return min(clear or roots, key=lambda r: r.total(k), default=None)


def _cheaper(result: PlanResult, root: _Root, k: float) -> bool:
    """Whether the plan at the root's horizon found an extremal cheaper than the root's."""
    if result.status is not PlanStatus.CONVERGED:
        return False
    J = root.total(k)
    return result.cost + k * result.task.horizon < J - 1e-9 * max(1.0, abs(J))


def _at_root(plans, scenario: Scenario, root: _Root, planned: list[PlanResult]) -> PlanResult:
    """The answer at ``root``: the plan made there when it returned the same extremal, else the
    root's extremal validated, in place of the answer of the plan its family came from."""
    p = root.point
    for r in planned:
        if r.task.horizon == p.T and abs(r.cost - p.V) <= 1e-7 * max(1.0, abs(p.V)):
            return r
    v = plans.validate(root.problem, p.arcs)
    if v is None or v.trajectory is None:
        return root.source
    clear = v.clearance.size == 0 or float(v.clearance.min()) >= scenario.margin
    return replace(
        _from_path(root.source, root.path),
        status=PlanStatus.CONVERGED if clear else PlanStatus.COLLIDES,
        message="converged by continuation in T" if clear else "the extremal collides",
        final_solver="shooting" if p.arcs.t.size == 2 else "multiple-shooting",
        costate0=p.arcs.lam0[0],
        trajectory=v.trajectory,
        **{f: getattr(v, f) for f in ("cost", "energy", "penalty", "clearance")},
        **{f: getattr(v, f) for f in ("end_state_error", "max_dH_du", "hamiltonian_variation")},
        task=replace(scenario, horizon=p.T, free_time=None),
        optimal=True,
        trajectory_source="extremal",
    )


def _from_path(plan: PlanResult, path: PathOutcome | None) -> PlanResult:
    """``plan`` told as the run from ``path`` (one of its alternatives; None: its answer): its
    label and initial cost, no sweeps or junctions (those of the plan's answer are another
    path's), and the plan's answer among the alternatives in its place."""
    if path is None:
        return plan
    answer = PathOutcome(
        plan.initial_path, plan.status, plan.cost, plan.initial_cost, len(plan.history),
        plan.message, plan.weight, plan.trajectory,
    )  # fmt: skip
    nx = len(plan.state_names)
    return replace(
        plan, initial_path=path.label, initial_cost=path.initial_cost, history=(),
        initial_junctions=(np.zeros(0), np.zeros((0, nx))),
        alternatives=(answer, *(a for a in plan.alternatives if a is not path)),
    )  # fmt: skip


def _total(r: PlanResult, k: float) -> float:
    return r.cost + k * r.task.horizon if math.isfinite(r.cost) else math.inf


def _step(result: PlanResult, k: float, source: str) -> TimeStep:
    return TimeStep(result.task.horizon, _hamiltonian(result), _total(result, k), source)


def _horizon(outcome, T: float) -> float:
    """The horizon of an alternative's extremal (a plan at another ``T`` than the answer's, when
    the answer was continued from it), ``T`` without one."""
    tr = outcome.trajectory
    return T if tr is None else float(tr.t[-1] - tr.t[0])


def _hamiltonian(result: PlanResult) -> float:
    tr = result.trajectory
    if tr is None or not result.optimal:
        return math.nan
    return float(np.mean(tr.hamiltonian[tr.at_step]))


def _reported(r: PlanResult, steps, scenario: Scenario, wall: float, cut: bool) -> PlanResult:
    """``r`` with its cost including the price of time, the report of the search, and failed
    when converged without meeting the free-time condition (or resting on a bound); ``cut``:
    the time limit cut the search short (said in the message)."""
    free = scenario.free_time
    k, (lo, hi) = free.time_weight, free.limits()
    T, H = r.task.horizon, _hamiltonian(r)
    bound = "shortest" if T <= lo and k + H > 0 else "longest" if T >= hi and k + H < 0 else ""
    rep = FreeTimeReport(k, free.cruise_speed, T, k + H, bound, tuple(steps))
    message, status, optimal, source = r.message, r.status, r.optimal, r.trajectory_source
    if status is PlanStatus.CONVERGED and not (
        bound or abs(rep.condition) <= CONDITION_TOL * max(1.0, k)
    ):
        status, optimal = PlanStatus.FAILED, False
        source = f"extremal of the fixed horizon T = {T:.4g}, not optimal"
        message = f"no extremal met the free-time condition (|k + H| = {abs(k + H):.2e}); {message}"
    elif bound:
        message += f"; T = {T:.6g} rests on its {bound} bound"
    elif status is PlanStatus.CONVERGED:
        message += f"; free final time T = {T:.6g} (k + H = {rep.condition:.1e})"
    if cut and "cut the search short" not in message:  # else said by the plan it cut
        message += "; the time limit cut the search short"
    alternatives = tuple(replace(a, cost=a.cost + k * _horizon(a, T)) for a in r.alternatives)
    return replace(
        r, status=status, optimal=optimal, trajectory_source=source, message=message,
        cost=r.cost + k * T, free_time=rep, wall_time_s=wall, task=replace(scenario, horizon=T),
        alternatives=alternatives,
    )  # fmt: skip
