"""What the free-time search (:mod:`.free_time`) asks of a planner: plans of the scenario at
fixed horizons, the problem of an answer, the solves of the continuation in ``T``, and where
to start."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..bvp.shooting import ShootingSettings
from ..integrate.problem import OptimalControlProblem
from ..model import get_model
from .free_time import FREE_TIME_PATHS, first_horizon, least_time, plan_free_time
from .initial_path.map_paths import Unreachable
from .leapfrog import Arcs
from .path_ranking import estimated_costs
from .results import PlanResult, Validation
from .runner import PlanEvent


class FixedHorizons:
    """The :class:`.free_time.FixedHorizonPlans` of the scenario of ``planner`` (a
    :class:`.planner.Planner`, not imported here: it imports this module), whose horizon is
    free."""

    def __init__(self, planner):
        self.planner = planner

    def plan_at(self, horizon: float, deadline: float = math.inf, wide: bool = True) -> PlanResult:
        """The plan of the scenario with its horizon fixed at ``horizon``, with at least
        :data:`.free_time.FREE_TIME_PATHS` initial paths when ``wide`` (else the settings'),
        cut short at ``deadline`` (a ``time.perf_counter()`` reading)."""
        p = self.planner
        fixed = dataclasses.replace(p.scenario, horizon=horizon, free_time=None)
        paths = p.settings.initial_paths
        paths = max(paths, FREE_TIME_PATHS) if wide else paths
        settings = dataclasses.replace(p.settings, initial_paths=paths)
        at = type(p).unrefused(fixed, settings, p.progress)  # the search may probe any T
        return at.plan_fixed(p.settings.initial_paths, deadline)

    def plan(self) -> PlanResult:
        """The free-time search's answer (:func:`.free_time.plan_free_time`); the time limit and
        the wall time are the whole search's, not each plan's."""
        t_begin = time.perf_counter()
        T0, least = self.first_horizon()
        deadline = self.planner.deadline_after(t_begin)
        result = plan_free_time(self, self.planner.scenario, T0, deadline, least)
        return dataclasses.replace(result, wall_time_s=time.perf_counter() - t_begin)

    def problem_at(self, weight: float) -> OptimalControlProblem:
        return self.planner.runner.problem_at(weight)

    @property
    def shooting(self) -> ShootingSettings:
        """The continuation in ``T``'s shooting settings
        (:meth:`.leapfrog.LeapfrogSettings.continued_solves`)."""
        return self.planner.settings.leapfrog.continued_solves()

    def progress_note(self, note: str) -> None:
        """Reports ``note`` as a :class:`.runner.PlanEvent` of stage ``"time"``."""
        self.planner.runner.emit(PlanEvent("time", 0, 1, note))

    def validate(self, problem: OptimalControlProblem, arcs: Arcs) -> Validation | None:
        return self.planner.runner.validate(problem, arcs)

    def first_horizon(self) -> tuple[float, float]:
        """Where the search starts (:func:`.free_time.first_horizon`), and the least horizon the
        top speed allows for the shortest initial path (:func:`.free_time.least_time`)."""
        p, s = self.planner, self.planner.scenario
        try:
            paths = p.initial_paths()
        except Unreachable:  # the plan at the provisional horizon says so
            return s.horizon, 0.0
        ends = (s.start, s.goal)

        def estimate(T: float) -> float:
            return float(np.min(estimated_costs(p.problem, paths, T, ends=ends)))

        from ..model.cruise import straight_effort  # SymPy: only for a free horizon

        effort = straight_effort(get_model(s.model), s.model_parameters)
        shortest = min(path.length for path in paths)
        return first_horizon(s, shortest, effort, estimate), least_time(s, shortest)
