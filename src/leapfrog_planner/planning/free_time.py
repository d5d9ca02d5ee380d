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
from scipy.optimize import brentq

from .. import checks
from ..bvp.shooting import ShootingSettings
from ..integrate.flow import Flow, Trajectory
from ..integrate.problem import OptimalControlProblem
from .bounded import MAX_HALVINGS, resolve
from .leapfrog import Arcs
from .results import PlanResult, piecewise_trajectory
from .scenario import Scenario
from .status import FreeTimeReport, PlanStatus, TimeStep

#: Plans at a root before the search gives up on a plan returning the extremal it continued.
ROUNDS = 3
#: ``|k + H|`` at most this times ``max(1, k)`` meets the free-time condition.
CONDITION_TOL = 1e-8
#: The junctions of a planned extremal that the continuation in ``T`` starts from.
JUNCTIONS = 16
#: The largest change of ``T`` in one secant step, as a factor.
STEP_FACTOR = 8.0


class FixedHorizonPlans(Protocol):
    """What the free-time search needs of the planner: a plan at a horizon, and the problem
    and final solves' settings of an answer's obstacle weight."""

    def plan_at(self, horizon: float) -> PlanResult: ...

    def problem_at(self, weight: float) -> OptimalControlProblem: ...

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


class _Stuck(RuntimeError):
    """The continuation in ``T`` failed to reach a horizon even in small steps."""


class _Met(Exception):
    """Raised inside Brent's method when a point meets the condition: no need to go on."""


class TimeSearch:
    """The root of ``k + H(T)`` along one family of extremals (step 2 of the module's method)."""

    def __init__(self, problem, settings: ShootingSettings, k: float, limits, ends, first: Arcs):
        self.problem, self.settings, self.k, self.ends = problem, settings, k, ends
        lo, hi = limits
        self.limits = (max(lo, checks.HORIZON_RANGE[0]), min(hi, checks.HORIZON_RANGE[1]))
        self.flow = Flow(problem, settings.integrator)
        self.points = [self._point(first)]

    def _point(self, arcs: Arcs) -> _Point:
        tr = piecewise_trajectory(self.flow, arcs, 401)
        H = float(np.mean(tr.hamiltonian[tr.at_step]))
        clearance = float(np.min(self.problem.penalty.clearance(tr.x[:, :2]), initial=np.inf))
        return _Point(float(arcs.t[-1]), arcs, H, float(tr.cost[-1]), clearance)

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
            arcs = resolve(self.problem, base.arcs, self.problem, (0.0, T1), self.ends, self.settings)
            if arcs is None:
                if len(targets) > MAX_HALVINGS:
                    raise _Stuck(f"the continuation in T stopped between {base.T:.6g} and {T1:.6g}")
                targets.append(math.sqrt(base.T * T1))
                continue
            base = self._point(arcs)
            self.points.append(base)
            targets.pop()
        return base

    def solve(self) -> tuple[_Point, str]:
        """The point where ``k + H = 0``, or the bound it lies beyond (and which bound)."""
        a = self.points[0]
        if self.met(a):
            return a, ""
        lo, hi = self.limits
        T = a.T * math.sqrt(-a.H / self.k) if a.H < 0 else a.T / 2
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
            ua, ub = a.T**-2, b.T**-2  # the secant in 1/T^2
            u = ub - self.g(b) * (ub - ua) / (self.g(b) - self.g(a))
            T = u**-0.5 if u > 0 else b.T * STEP_FACTOR
            a = b

    def _bracketed(self, a: _Point, b: _Point) -> _Point:
        def g(u):
            p = self.at(u**-0.5)
            if self.met(p):
                raise _Met
            return self.g(p)

        try:
            u = brentq(g, a.T**-2, b.T**-2, xtol=1e-300, rtol=4 * np.finfo(float).eps)
            return self.at(u**-0.5)
        except _Met:
            return self.points[-1]


def first_horizon(scenario: Scenario, shortest_path: float, effort: float) -> float:
    """Where the search starts: the user's guess, else the shortest initial path (at least a
    tenth of a metre) at the cruise speed, inside the bounds."""
    free = scenario.free_time
    if free.guess is not None:
        return free.guess
    lo, hi = free.limits()
    speed = math.sqrt(free.time_weight / effort)
    T = max(shortest_path, 0.1) / speed
    return float(np.clip(T, max(lo, checks.HORIZON_RANGE[0]), min(hi, checks.HORIZON_RANGE[1])))


def arcs_of(tr: Trajectory, pieces: int = JUNCTIONS) -> Arcs:
    """A planned extremal as ``pieces`` arcs of equal length (states and costates read off its
    trajectory: each arc then integrates accurately however long the horizon)."""
    t = np.linspace(tr.t[0], tr.t[-1], pieces + 1)
    keep = np.append(np.diff(tr.t) > 0, True)
    col = lambda a: np.column_stack(  # noqa: E731
        [np.interp(t, tr.t[keep], a[keep, i]) for i in range(a.shape[1])]
    )
    X, lam = col(tr.x), col(tr.lam)
    X[0], X[-1] = tr.x[0], tr.x[-1]
    return Arcs(t, X, lam[:-1])


def plan_free_time(plans: FixedHorizonPlans, scenario: Scenario, T0: float) -> PlanResult:
    """The free-time answer of ``scenario`` (the module's method), starting at ``T0``."""
    t_begin = time.perf_counter()
    free = scenario.free_time
    result = plans.plan_at(T0)
    steps = [_step(result, free.time_weight, "plan")]
    planned = [result]
    for _ in range(ROUNDS):
        if result.status is not PlanStatus.CONVERGED:
            break
        found = _cheapest_root(plans, scenario, result, steps)
        if found is None or found.T == result.task.horizon:
            break
        result = plans.plan_at(found.T)
        steps.append(_step(result, free.time_weight, "plan"))
        planned.append(result)
        if _same(result, found):
            break
    return _answer(planned, steps, scenario, time.perf_counter() - t_begin)


def _cheapest_root(plans, scenario: Scenario, result: PlanResult, steps: list) -> _Point | None:
    """Step 2 for the answer of ``result`` and each of its alternatives that converged: the
    root of the family whose cost with the price of time is least there (among those that keep
    the margin, if any does). The horizons solved are added to ``steps``."""
    free, k = scenario.free_time, scenario.free_time.time_weight
    ends = (scenario.start, scenario.goal)
    families = [(result.trajectory, result.weight)] + [
        (a.trajectory, a.weight)
        for a in result.alternatives
        if a.status is PlanStatus.CONVERGED and a.trajectory is not None
    ]
    roots = []
    for trajectory, weight in families:
        problem = plans.problem_at(weight)
        search = TimeSearch(problem, plans.shooting, k, free.limits(), ends, arcs_of(trajectory))
        try:
            roots.append(search.solve()[0])
        except _Stuck:
            pass
        steps += [TimeStep(p.T, p.H, p.V + k * p.T, "continued") for p in search.points[1:]]
    clear = [p for p in roots if p.clearance >= scenario.margin]
    return min(clear or roots, key=lambda p: p.V + k * p.T, default=None)


def _step(result: PlanResult, k: float, source: str) -> TimeStep:
    T = result.task.horizon
    return TimeStep(T, _hamiltonian(result), result.cost + k * T, source)


def _hamiltonian(result: PlanResult) -> float:
    tr = result.trajectory
    if tr is None or not result.optimal:
        return math.nan
    return float(np.mean(tr.hamiltonian[tr.at_step]))


def _same(result: PlanResult, found: _Point) -> bool:
    """Whether the plan at the root returned the extremal continued there."""
    if result.status is not PlanStatus.CONVERGED:
        return False
    return abs(result.cost - found.V) <= 1e-7 * max(1.0, abs(found.V))


def _answer(planned: list[PlanResult], steps, scenario: Scenario, wall: float) -> PlanResult:
    """The cheapest converged plan (with the price of time) that meets the free-time
    condition or rests on a bound; else the cheapest plan, failed, saying why."""
    free = scenario.free_time
    k, (lo, hi) = free.time_weight, free.limits()

    def report(r: PlanResult) -> FreeTimeReport:
        T, H = r.task.horizon, _hamiltonian(r)
        bound = "shortest" if T <= lo and k + H > 0 else "longest" if T >= hi and k + H < 0 else ""
        return FreeTimeReport(k, free.cruise_speed, T, k + H, bound, tuple(steps))

    def total(r: PlanResult) -> float:
        return r.cost + k * r.task.horizon if math.isfinite(r.cost) else math.inf

    good = [
        r for r in planned
        if r.status is PlanStatus.CONVERGED
        and (report(r).bound or abs(report(r).condition) <= CONDITION_TOL * max(1.0, k))
    ]  # fmt: skip
    best = min(good or planned, key=total)
    rep = report(best)
    message = best.message
    if best.status is PlanStatus.CONVERGED and not good:
        best = replace(best, status=PlanStatus.FAILED, optimal=False)
        message = f"no plan met the free-time condition (|k + H| = {abs(rep.condition):.2e}); {message}"
    elif rep.bound:
        message += f"; T = {rep.horizon:.6g} rests on its {rep.bound} bound"
    else:
        message += f"; free final time T = {rep.horizon:.6g} (k + H = {rep.condition:.1e})"
    task = replace(scenario, horizon=rep.horizon)
    return replace(
        best, cost=total(best), free_time=rep, message=message, wall_time_s=wall, task=task,
    )  # fmt: skip
