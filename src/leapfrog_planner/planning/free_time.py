"""Free final time: the robot chooses how long to take, at a price ``k`` on each second.

The cost is ``J = k T + V(T)``, where ``V(T)`` is the optimal cost of the fixed-horizon problem
(energy and penalty). On an extremal of that autonomous problem the Hamiltonian ``H`` is
constant, and it is the rate at which the optimal cost changes with the horizon:
``dV/dT = H``. So ``dJ/dT = k + H``, and Pontryagin's condition for a free final time,
``H + k = 0`` (the Hamiltonian of ``J`` vanishes), is where that rate is zero. The method stays
indirect:

1. plan the fixed-horizon problem at a first horizon ``T0`` (the user's guess, else the
   shortest initial path at the cruise speed): the whole search, which picks the extremal;
2. find the root of ``g(T) = k + H(T)`` along that extremal's family: each new ``T`` is the
   extremal of a known ``T`` stretched to it and solved again by shooting (:func:`.bounded.resolve`;
   a step that fails is halved). ``g`` is close to linear in ``1/T^2`` (in free space
   ``H = -D^2 / (2 T^2)``): secant steps in ``1/T^2`` until the root is bracketed, then Brent's
   method (SciPy's ``brentq``);
3. plan again at the root ``T*``: the whole search, so that an extremal of another family,
   cheaper there, is not missed. When it returns the extremal continued (the same cost), that
   plan is the answer; when it finds a cheaper one, step 2 follows that one; at most
   :data:`ROUNDS` times.

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
from ..integrate.flow import Flow
from ..integrate.problem import OptimalControlProblem
from .bounded import MAX_HALVINGS, arcs_of, resolve
from .leapfrog import Arcs
from .outcome import unreachable
from .results import PlanResult, Validation, piecewise_trajectory
from .scenario import Scenario
from .scenario_time import top_speed
from .status import FreeTimeReport, PlanStatus, TimeStep

#: The initial paths of the plans at a horizon, at least: the extremals they find are the
#: families followed in T, and with the default three the cheapest family was missed on 3 of
#: 80 random layouts (general preset, seed 1, cruise speed 1) where six found it.
FREE_TIME_PATHS = 6
#: Plans at a root before the search gives up on a plan returning the extremal it continued.
ROUNDS = 3
#: ``|k + H|`` at most this times ``max(1, k)`` meets the free-time condition.
CONDITION_TOL = 1e-8
#: The horizons where the first is sought, as multiples of the shortest path at cruise speed.
FIRST_GRID = np.geomspace(0.5, 8.0, 9)
#: A continuation step whose path moves further than this fraction of its length from the path
#: it started from has jumped to another family (measured: a step of 1.5x in T from a path round
#: a disc landed on one through it); it is made again in smaller steps.
MAX_MOVE = 0.15
SHAPE_SAMPLES = 33
#: Shooting solves one family's continuation may make (a family that folds is left there).
MAX_SOLVES = 30
#: Alternatives are continued when their cost with the price of time is at most this many
#: times the answer's at the first horizon.
ALTERNATIVE_FACTOR = 1.5
#: Where the plan at the first horizon finds no extremal, these multiples of it are planned
#: (and in its place where it is shorter than the top speed allows: :func:`least_time`).
RETRIES = (1.6, 2.5)
#: The largest change of ``T`` in one secant step, as a factor.
STEP_FACTOR = 8.0


class FixedHorizonPlans(Protocol):
    """What the free-time search needs of the planner: a plan at a horizon, and the problem
    and final solves' settings of an answer's obstacle weight."""

    def plan_at(self, horizon: float, deadline: float = math.inf) -> PlanResult: ...

    def problem_at(self, weight: float) -> OptimalControlProblem: ...

    def progress_note(self, note: str) -> None: ...

    def validate(self, problem: OptimalControlProblem, arcs: Arcs) -> Validation | None: ...

    @property
    def shooting(self) -> ShootingSettings: ...


@dataclass(frozen=True)
class _Point:
    """An extremal of the fixed-horizon problem at ``T``: its arcs, ``H``, cost ``V`` and
    least clearance (of 401 samples: to rank families, not to validate an answer)."""

    T: float
    arcs: Arcs
    H: float
    V: float
    clearance: float
    xy: np.ndarray  # positions at SHAPE_SAMPLES uniform fractions of T: the path's shape

    def moved(self, other: _Point) -> float:
        """How far the path moved from ``other``'s, relative to the longer path's length."""
        length = max(_length(self.xy), _length(other.xy), 1e-12)
        return float(np.linalg.norm(self.xy - other.xy, axis=1).max()) / length


def _length(xy: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


class _Stuck(RuntimeError):
    """The continuation in ``T`` failed to reach a horizon even in small steps."""


class _Met(Exception):
    """Raised inside Brent's method when a point meets the condition: no need to go on."""

    def __init__(self, point: _Point):
        super().__init__(point.T)
        self.point = point


class TimeSearch:
    """The root of ``k + H(T)`` along one family of extremals (step 2 of the module's method)."""

    def __init__(
        self, problem, settings: ShootingSettings, k: float, limits, ends, first: Arcs,
        deadline: float = math.inf,
    ):  # fmt: skip
        self.problem, self.settings, self.k, self.ends = problem, settings, k, ends
        self.limits, self.deadline = limits, deadline
        self.flow = Flow(problem, settings.integrator)
        self.points = [self._point(first)]
        self.solves = 0

    def _point(self, arcs: Arcs) -> _Point:
        tr = piecewise_trajectory(self.flow, arcs, 401)
        H = float(np.mean(tr.hamiltonian[tr.at_step]))
        clearance = float(np.min(self.problem.penalty.clearance(tr.x[:, :2]), initial=np.inf))
        keep = np.append(np.diff(tr.t) > 0, True)
        s = np.linspace(tr.t[0], tr.t[-1], SHAPE_SAMPLES)
        xy = np.column_stack([np.interp(s, tr.t[keep], tr.x[keep, i]) for i in (0, 1)])
        return _Point(float(arcs.t[-1]), arcs, H, float(tr.cost[-1]), clearance, xy)

    def g(self, p: _Point) -> float:
        return self.k + p.H

    def met(self, p: _Point) -> bool:
        return abs(self.g(p)) <= CONDITION_TOL * max(1.0, self.k)

    def at(self, T: float) -> _Point:
        """The extremal at ``T``, continued from the solved horizon nearest to it."""
        base = min(self.points, key=lambda p: abs(math.log(p.T / T)))
        if base.T == T:
            return base
        targets = [T]
        while targets:
            T1 = targets[-1]
            if self.solves >= MAX_SOLVES:
                raise _Stuck(f"the continuation in T made {MAX_SOLVES} solves")
            if time.perf_counter() >= self.deadline:
                raise _Stuck("the time limit ran out")
            self.solves += 1
            arcs = resolve(self.problem, base.arcs, self.problem, (0, T1), self.ends, self.settings)
            new = None if arcs is None else self._point(arcs)
            if new is None or new.moved(base) > MAX_MOVE:  # failed, or jumped to another family
                if len(targets) > MAX_HALVINGS:
                    raise _Stuck(f"the continuation in T stopped between {base.T:.6g} and {T1:.6g}")
                targets.append(math.sqrt(base.T * T1))
                continue
            base = new
            self.points.append(base)
            targets.pop()
        return base

    def solve(self) -> tuple[_Point, str]:
        """The point where ``k + H = 0``, or the bound it lies beyond (and which bound)."""
        a = self.points[0]
        if self.met(a):
            return a, ""
        lo, hi = self.limits
        T = first_step(a.T, a.H, self.k)
        while True:
            T = float(np.clip(T, max(lo, a.T / STEP_FACTOR), min(hi, a.T * STEP_FACTOR)))
            b = self.at(T)
            if self.met(b):
                return b, ""
            if (self.g(a) > 0) != (self.g(b) > 0):
                return self._bracketed(a, b), ""
            if b.T == lo and self.g(b) > 0:  # still too long at the shortest allowed
                return b, "shortest"
            if b.T == hi and self.g(b) < 0:
                return b, "longest"
            if b.T == a.T or self.g(b) == self.g(a):
                raise _Stuck(f"the secant in T stalled at {b.T:.6g}")
            ua, ub = a.T**-2, b.T**-2  # the secant in 1/T^2
            u = ub - self.g(b) * (ub - ua) / (self.g(b) - self.g(a))
            T = u**-0.5 if u > 0 else b.T * STEP_FACTOR
            a = b

    def _bracketed(self, a: _Point, b: _Point) -> _Point:
        from scipy.optimize import brentq  # only here: SciPy's optimize takes 0.1 s to import

        def g(u):
            p = self.at(u**-0.5)
            if self.met(p):
                raise _Met(p)
            return self.g(p)

        try:
            u = brentq(g, a.T**-2, b.T**-2, xtol=1e-300, rtol=4 * np.finfo(float).eps)
            return self.at(u**-0.5)
        except _Met as met:
            return met.point


def first_step(T: float, H: float, k: float) -> float:
    """Where a search aims first from an extremal at ``T`` with Hamiltonian ``H``: the root of
    ``k + H`` were ``H`` that of free space, ``-c / T^2``; half ``T`` when ``H >= 0``."""
    return T * math.sqrt(-H / k) if H < 0 else T / 2


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
    whose answer or alternative the family came from, and the problem it solves."""

    point: _Point
    bound: str
    source: PlanResult
    problem: OptimalControlProblem

    def total(self, k: float) -> float:
        return self.point.V + k * self.point.T


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
        roots += _family_roots(plans, scenario, result, steps, deadline)
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
        result = plans.plan_at(T, deadline)
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
    plans, scenario: Scenario, result: PlanResult, steps: list, deadline: float
) -> list[_Root]:
    """Step 2 for the answer of ``result`` and each of its alternatives that converged at a
    cost (with the price of time) near it, until ``deadline``. The horizons solved are added
    to ``steps``."""
    free, k = scenario.free_time, scenario.free_time.time_weight
    ends = (scenario.start, scenario.goal)
    T0 = result.task.horizon
    near = ALTERNATIVE_FACTOR * (result.cost + k * T0)
    families = [(result.cost, result.trajectory, result.weight)] + [
        (a.cost, a.trajectory, a.weight)
        for a in result.alternatives
        if a.status is PlanStatus.CONVERGED and a.trajectory is not None and a.cost + k * T0 <= near
    ]
    roots, seen = [], []
    for cost, trajectory, weight in families:
        if any(abs(cost - c) <= 1e-9 * max(1.0, abs(c)) for c in seen):
            continue  # the same extremal, found from another path
        seen.append(cost)
        plans.progress_note(f"final time: the extremal of cost {cost:.6g} at T = {T0:.4g}")
        problem = plans.problem_at(weight)
        search = TimeSearch(
            problem, plans.shooting, k, free.limits(), ends, arcs_of(trajectory), deadline
        )
        try:
            point, bound = search.solve()
            roots.append(_Root(point, bound, result, problem))
        except _Stuck:
            pass
        steps += [TimeStep(p.T, p.H, p.V + k * p.T, "continued") for p in search.points[1:]]
    return roots


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
        root.source,
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
