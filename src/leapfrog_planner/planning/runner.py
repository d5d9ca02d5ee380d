"""The planner's executor: each :class:`.runs.RunRequest` run as Leapfrog from its initial path
in its round, continued to the robot's own problem and validated (:class:`Runner`); the
requests of a batch run in parallel threads (the compiled flow releases the GIL)."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from .._blas import held_by_parent
from ..bvp.shooting import ShootingSettings
from ..integrate.flow import Flow, IntegratorSettings
from ..integrate.problem import OptimalControlProblem
from .bounded import continue_to_bounds, exceeded, schedule
from .leapfrog import Arcs, LeapfrogSettings, SweepRecord, leapfrog
from .path_ranking import PathGuide, path_states
from .results import Validation, validate_arcs
from .runs import END_STATE_FACTOR, PathRun, Round, RunRequest
from .scenario import Scenario
from .settings import PlannerSettings

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanEvent:
    """Progress report: ``stage`` is "path" (a new initial path starts), "sweep", "final", or
    "time" (a free final time sought: ``label`` says where)."""

    stage: str
    path_index: int
    paths: int
    label: str
    sweep: SweepRecord | None = None


#: The share of a plan's time limit that its runs may take: past it no sweep begins, so that
#: the runs under way (their sweep and first final solve), the choice of the answer and its
#: checks end within the limit (10,000 discs, a limit of 30 s: these took 3.5 s past the runs).
RUNS_SHARE = 0.85


class Runner:
    """Runs requests for one scenario. ``robot`` is the scenario's own problem; a round runs
    it with the model's planning aid at the round's value, and a request at its obstacle
    weight. Problems and their flows are built once and shared by the threads."""

    def __init__(
        self,
        scenario: Scenario,
        settings: PlannerSettings,
        robot: OptimalControlProblem,
        progress: Callable[[PlanEvent], None] | None = None,
    ):
        self.scenario, self.settings, self.robot = scenario, settings, robot
        self.progress = progress
        self.aid = robot.model.aid
        final = settings.leapfrog.final_shooting
        self._final_integrator = final.integrator
        self.validation = IntegratorSettings(
            "dop853", rtol=final.integrator.rtol, atol=final.integrator.atol
        )
        self.end_tolerance = END_STATE_FACTOR * final.root.tol
        self._lock = threading.Lock()
        self._progress_lock = threading.Lock()
        self._flows: dict[tuple, tuple[OptimalControlProblem, Flow]] = {}
        # When a plan's runs stop (a time.perf_counter() value): no sweep begins after it, and
        # the final solves are cut down (see RUNS_SHARE and leapfrog.final.FinalSolver).
        self.deadline = float("inf")

    def problem_of(self, rnd: Round, weight: float | None = None) -> OptimalControlProblem:
        """The problem Leapfrog solves in round ``rnd``, at obstacle weight ``weight`` (by
        default the scenario's)."""
        problem = self.robot
        if self.aid is not None and rnd.aid is not None:
            problem = problem.with_parameter(self.aid.parameter, rnd.aid)
        if weight is not None and weight != problem.penalty.weight:
            problem = problem.with_weight(weight)
        return self._built(problem)[0]

    def flow_of(self, problem: OptimalControlProblem) -> Flow:
        """The final solves' flow of ``problem`` (built once per weight and parameters)."""
        return self._built(problem)[1]

    def _built(self, problem: OptimalControlProblem) -> tuple[OptimalControlProblem, Flow]:
        key = (problem.penalty.weight, problem.parameters)
        with self._lock:
            if key not in self._flows:
                self._flows[key] = (problem, Flow(problem, self._final_integrator))
            return self._flows[key]

    def problem_at(self, weight: float) -> OptimalControlProblem:
        """The problem an answer at obstacle weight ``weight`` solves (sharp control bounds)."""
        s = self.scenario
        problem = s.problem(s.smoothing_widths[-1]) if s.control_bounds else self.robot
        return problem if weight == problem.penalty.weight else problem.with_weight(weight)

    def validate(self, problem: OptimalControlProblem, arcs: Arcs) -> Validation | None:
        """``arcs`` re-integrated and checked as every answer is (``validate_arcs``); None when
        they miss the goal by more than a run's extremal may."""
        v = validate_arcs(problem, arcs, self.settings.samples, self.validation)
        return v if v.end_state_error <= self.end_tolerance else None

    @property
    def shooting(self) -> ShootingSettings:
        """The final solves' shooting settings (no dense output)."""
        return self.settings.leapfrog.final_solves()

    def has_time_for(self, runs: list[PathRun]) -> bool:
        """Whether the runs' deadline leaves time for more runs as long as the longest of
        ``runs`` so far (a plan's time limit: runs begun just before it fit their initial path
        and try a final solve past it, for an answer that seldom wins)."""
        longest = max((r.time_s for r in runs), default=0.0)
        return time.perf_counter() + longest < self.deadline

    def run_all(self, requests: list[RunRequest]) -> list[PathRun]:
        """:meth:`run` for each request, in parallel threads (see ``threads``)."""
        n = len(requests)
        workers = min(n, self.settings.threads or n)
        args = (requests, range(n), [n] * n)
        if workers > 1:
            with ThreadPoolExecutor(workers, thread_name_prefix="leapfrog-path") as pool:
                return list(pool.map(self.run, *args))
        return list(map(self.run, *args))

    def run(self, request: RunRequest, k: int = 0, paths: int = 1) -> PathRun:
        """Leapfrog from the request's path, continued to the robot's problem (bounds, planning
        aid) and validated; progress names it path ``k`` of ``paths``. A leader of a race
        (``request.leads``) tells it when it ends, however it ends."""
        done = None
        try:
            done = self._run(request, k, paths)
            return done
        finally:
            if request.leads is not None:
                request.leads.ended(done)

    def _run(self, request: RunRequest, k: int, paths: int) -> PathRun:
        t_start = time.perf_counter()
        s = self.scenario
        rnd, path = request.round, request.path
        label = request.label + (f" (obstacle weight {request.weight:g})" if request.raises else "")
        self.emit(PlanEvent("path", k, paths, label))
        lf = self.settings.leapfrog
        if (rnd.partitions, rnd.fewest_arcs) != (lf.partitions, lf.fewest_arcs):
            lf = replace(lf, partitions=rnd.partitions, fewest_arcs=rnd.fewest_arcs)
        t, X = path.junctions(lf.partitions, s.horizon, 0.0)
        if s.start.size > 3:  # a model's further states, from their start to their goal values
            X = np.column_stack([X, path_states(path, t / s.horizon, (s.start, s.goal))[:, 3:]])
            X[0], X[-1] = s.start, s.goal

        def on_sweep(rec):
            self.emit(PlanEvent("sweep", k, paths, label, rec))

        problem = self.problem_of(rnd, request.weight)
        flow = self.flow_of(problem)
        guide = PathGuide(problem, path, s.horizon, 0.0, (s.start, s.goal))
        with held_by_parent():
            run = leapfrog(
                problem, t, X, guide=guide, settings=lf, flow=flow, progress=on_sweep,
                stop_above=request.stop_above, deadline=self.deadline,
            )  # fmt: skip
            iterate_problem = problem
            if s.control_bounds or self.aid is not None:  # on to the problem itself
                run, problem, iterate_problem = self._continued(run, problem, (t, X), guide, lf)
            log.info("path %s: %s", label, run.message)
            # Validated here, in the path's own thread: the re-integration overlaps the other
            # paths' sweeps.
            t0 = time.perf_counter()
            v = None
            if run.success:
                v = validate_arcs(problem, run.extremal, self.settings.samples, self.validation)
            t_val = time.perf_counter() - t0
        return PathRun(
            request=request,
            guide=guide,
            run=run,
            junctions=(t, X),
            validation=v,
            validation_time_s=t_val,
            iterate_problem=iterate_problem,
            end_tolerance=self.end_tolerance,
            margin=s.margin,
            time_s=time.perf_counter() - t_start,
        )

    def _continued(self, run, problem, junctions, guide, lf: LeapfrogSettings):
        """``run`` (Leapfrog with smoothly saturating controls, or with the model's planning
        aid) continued to the scenario's problem; where it failed with bounds, Leapfrog again
        with the bounds relaxed, then continued (see :mod:`.bounded`). Returns the run, the
        problem of its extremal, and the problem of its Leapfrog iterate."""
        s = self.scenario
        relaxed = ()
        if not run.success and s.control_bounds:  # relax the bounds the initial path leaves
            u = guide.trajectory().u
            relaxed = exceeded(s.control_bounds, problem.model.controls, u)
        aid = None
        if self.aid is not None:  # from the aid's value in ``problem`` to the robot's
            name = self.aid.parameter
            aid = (name, problem.parameter(name), self.robot.parameter(name))
        at = schedule(problem, s.control_bounds, s.smoothing_widths, relaxed, aid)
        iterate_problem = problem
        if relaxed:
            t, X = junctions
            iterate_problem = wide = at(0.0)
            guide = PathGuide(wide, guide.path, s.horizon, guide.t0, guide.ends)
            run = leapfrog(
                wide, t, X, guide=guide, settings=lf, flow=self.flow_of(wide),
                deadline=self.deadline,
            )  # fmt: skip
        if not run.success:
            return run, problem, iterate_problem
        steps = 8 if relaxed or aid else len(s.smoothing_widths) - 1
        ends = (s.start, s.goal)
        settings = lf.final_shooting if aid else lf.bounds_solves()
        done = continue_to_bounds(at, run, (0.0, s.horizon), ends, steps, settings, self.deadline)
        return done.run, done.problem, iterate_problem

    def emit(self, event: PlanEvent):
        if self.progress is not None:
            with self._progress_lock:  # paths run in threads: one event at a time
                self.progress(event)
