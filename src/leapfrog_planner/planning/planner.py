"""Plan a scenario: initial feasible paths, Leapfrog from each, the cheapest validated extremal.

``plan(scenario)`` is the one-call entry point; :class:`Planner` keeps the compiled flows and
the settings for reuse (obstacles are data: nothing recompiles). A plan is a short loop: the
search's stages (:mod:`.search`) ask for runs, the runner (:mod:`.runner`) makes them, and when
no stage of the last round asks for more, the answer is chosen among all the runs
(:mod:`.answer`) and reported (:mod:`.outcome`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._blas import single_threaded_blas
from ..bvp.shooting import ShootingSettings
from ..errors import SettingsError
from ..integrate.flow import Flow
from ..integrate.problem import OptimalControlProblem
from ..model import get_model
from .answer import Chosen, Context, choose_answer
from .free_time import FREE_TIME_PATHS, first_horizon, least_time, plan_free_time
from .initial_path import InitialPath, initial_paths, points_away
from .initial_path.map_paths import Unreachable, map_initial_paths
from .leapfrog import Arcs
from .outcome import Timing, plan_result, unreachable_result
from .path_ranking import drivable, estimated_costs, rank_paths
from .rerun import recorded, recorded_task, with_call
from .result_files import plain
from .results import PlanResult, Validation, validate_arcs
from .runner import PlanEvent, Runner
from .runs import PathRun, Round, RunRequest
from .scenario import Scenario, load_scenario, scenario_from_dict
from .scenario_time import refuse_unreachable
from .search import STAGES, Search, fewer_paths_note, next_round, select_paths
from .settings import PlannerSettings

__all__ = ["PlanEvent", "Planner", "PlannerSettings", "plan"]


class Planner:
    """Leapfrog planner for one scenario; reuse it to re-plan with other settings."""

    def __init__(
        self,
        scenario: Scenario | Mapping[str, Any] | str | Path,
        settings: PlannerSettings | None = None,
        *,
        progress: Callable[[PlanEvent], None] | None = None,
        **options,
    ):
        scenario = as_scenario(scenario)
        refuse_unreachable(scenario)  # at once, not after a search that cannot succeed
        self._setup(scenario, PlannerSettings.of_scenario(scenario, settings, **options), progress)

    def _setup(self, scenario: Scenario, settings: PlannerSettings, progress) -> None:
        self.scenario, self.settings = scenario, settings
        self.runner = Runner(self.scenario, self.settings, self.scenario.problem(), progress)
        self.robot = self.runner.robot  # the scenario's own problem, without planning aids
        aid = self.robot.model.aid
        first = None if aid is None else aid.values[0]
        self.first_round = Round(self.settings.leapfrog.partitions, first, "the initial paths")
        self.problem = self.runner.problem_of(self.first_round)  # what Leapfrog solves first

    @classmethod
    def from_result(
        cls, result: PlanResult, *, progress: Callable[[PlanEvent], None] | None = None
    ) -> Planner:
        """A planner of the scenario ``result`` records, with every setting it records (they
        rule over the scenario's ``[solver]`` table): its :meth:`plan` re-plans the task, and
        gives the recorded answer bit for bit with the same versions on the same machine."""
        scenario, settings = recorded_task(result)
        return cls(scenario, settings, progress=progress)

    @property
    def flow(self) -> Flow:
        """The final solves' flow of :attr:`problem`."""
        return self.runner.flow_of(self.problem)

    @property
    def progress(self) -> Callable[[PlanEvent], None] | None:
        """Called with each :class:`PlanEvent` (None: nothing is reported)."""
        return self.runner.progress

    @progress.setter
    def progress(self, callback: Callable[[PlanEvent], None] | None) -> None:
        self.runner.progress = callback

    def initial_paths(self, margin: float | None = None) -> list[InitialPath]:
        """The paths a plan runs first, keeping ``margin`` (default: the settings') from the
        obstacles: the ``initial_paths`` of least estimated cost, one per family
        (:func:`.search.select_paths`), or fewer where fewer exist (waypoints fix the way round
        the obstacles; two discs leave four ways): the plan's message then says so.

        Where an end heading points away from the chord, three-point turns are ranked with the
        paths of the homotopy classes. Elsewhere they are planned too, but the best one runs
        besides the class paths, and only when it is estimated cheapest of all: backing away
        from an obstacle next to an end looks cheap, and ranked with the others it took the
        place of paths that led to the optimum (docs/tuning.md)."""
        return self.path_selection(margin)[0]

    def path_selection(self, margin=None) -> tuple[list[InitialPath], list[InitialPath]]:
        """The paths a plan runs first (:meth:`initial_paths`) and the extra ones it races
        against them (the ``more paths`` stage of :mod:`.search`)."""
        s, st = self.scenario, self.settings
        k = max(st.initial_paths + st.extra_paths, st.candidate_paths)
        margin = max(st.margin, s.margin) if margin is None else margin
        ends = (s.start[:3], s.goal[:3])  # poses: a model's further states are filled along
        if s.map is not None:
            world = self.problem.penalty.map
            candidates = map_initial_paths(
                *ends, world, s.footprint_obstacles, k=k, margin=margin, turns=True,
                where=s.map.where,
            )  # fmt: skip
        else:
            candidates = initial_paths(
                *ends, s.footprint_obstacles, k=k, margin=margin, waypoints=s.waypoints, turns=True
            )
        ends = (s.start, s.goal)
        keep = [True] * len(candidates)
        if s.control_bounds:  # a robot that cannot reverse is given no path that does
            keep = drivable(self.problem, candidates, s.horizon, s.control_bounds, ends)
        aid = self.robot.model.aid
        if aid and aid.turns_in_place and self.robot.parameter(aid.parameter) == 0.0:
            # nor one that cannot turn in place (the car) one that does so at an end
            keep = [
                k and not (p.modes.turn_start or p.modes.turn_goal)
                for k, p in zip(keep, candidates, strict=True)
            ]
        candidates = [p for p, ok in zip(candidates, keep, strict=True) if ok] or candidates
        if len(candidates) < 2:  # nothing to rank: the estimate took 0.6 ms of paper case 1's 9
            return candidates, []
        ranked = rank_paths(self.problem, candidates, s.horizon, ends)
        turns_ranked = points_away(s.start, s.goal)
        return select_paths(ranked, st.initial_paths, st.extra_paths, turns_ranked)

    def run_path(self, path: InitialPath) -> PathRun:
        """Leapfrog from ``path`` (one of :meth:`initial_paths`, or a user's own) in the plan's
        first round, continued to the robot's problem and validated (BLAS on one thread, as in
        :meth:`plan`: the same bits)."""
        request = RunRequest(
            path, self.first_round, "paths", "asked for", float(self.scenario.weight),
            label=path.label,
        )  # fmt: skip
        with single_threaded_blas():
            return self.runner.run(request)

    def plan(self) -> PlanResult:
        with single_threaded_blas():
            if self.scenario.free_time is None:
                result = self._plan()
            else:  # the time limit is the whole search's, not each plan's
                limit = self.settings.time_limit
                deadline = time.perf_counter() + limit if limit is not None else float("inf")
                T0, least = self._first_horizon()
                result = plan_free_time(self, self.scenario, T0, deadline, least)
        return recorded(result, self.settings, "Planner.plan")

    # ------------------------------------------------------------ a free final time (.free_time)

    def plan_at(self, horizon: float, deadline: float = float("inf")) -> PlanResult:
        """The plan of the scenario with its horizon fixed at ``horizon``, with at least
        :data:`.free_time.FREE_TIME_PATHS` initial paths, cut short at ``deadline`` (a
        ``time.perf_counter()`` reading)."""
        fixed = dataclasses.replace(self.scenario, horizon=horizon, free_time=None)
        paths = max(self.settings.initial_paths, FREE_TIME_PATHS)
        settings = dataclasses.replace(self.settings, initial_paths=paths)
        planner = Planner.__new__(Planner)  # not refused: the search may probe any T
        planner._setup(fixed, settings, self.progress)
        return planner._plan(self.settings.initial_paths, deadline)

    def problem_at(self, weight: float) -> OptimalControlProblem:
        """The problem an answer at obstacle weight ``weight`` solves (sharp control bounds)."""
        s = self.scenario
        problem = s.problem(s.smoothing_widths[-1]) if s.control_bounds else self.robot
        return problem if weight == problem.penalty.weight else problem.with_weight(weight)

    def progress_note(self, note: str) -> None:
        """Reports ``note`` as a :class:`PlanEvent` of stage ``"time"``."""
        self.runner.emit(PlanEvent("time", 0, 1, note))

    def validate(self, problem: OptimalControlProblem, arcs: Arcs) -> Validation | None:
        """``arcs`` re-integrated and checked as every answer is (``validate_arcs``); None when
        they miss the goal by more than a run's extremal may."""
        v = validate_arcs(problem, arcs, self.settings.samples, self.runner.validation)
        return v if v.end_state_error <= self.runner.end_tolerance else None

    @property
    def shooting(self) -> ShootingSettings:
        """The final solves' shooting settings (no dense output)."""
        lf = self.settings.leapfrog
        return dataclasses.replace(lf.final_shooting, samples=0, method=lf.method)

    def _first_horizon(self) -> tuple[float, float]:
        """Where the search starts, and the least horizon the top speed allows for the shortest
        initial path (:func:`.free_time.least_time`)."""
        s = self.scenario
        try:
            paths = self.initial_paths()
        except Unreachable:  # the plan at the provisional horizon says so
            return s.horizon, 0.0
        ends = (s.start, s.goal)

        def estimate(T: float) -> float:
            return float(np.min(estimated_costs(self.problem, paths, T, ends=ends)))

        from ..model.cruise import straight_effort  # SymPy: only for a free horizon

        effort = straight_effort(get_model(s.model), s.model_parameters)
        shortest = min(p.length for p in paths)
        return first_horizon(s, shortest, effort, estimate), least_time(s, shortest)

    def _plan(self, asked: int | None = None, deadline: float | None = None) -> PlanResult:
        """The plan of a fixed horizon; ``asked``: the initial paths the caller asked for
        (default: the settings'), a note in the message when fewer ran; ``deadline``: when
        the search stops (default: the settings' time limit from now)."""
        t_begin = time.perf_counter()
        limit = self.settings.time_limit
        if deadline is None:
            deadline = t_begin + limit if limit is not None else float("inf")
        self.runner.deadline = deadline
        try:
            paths = self.path_selection()
        except Unreachable as exc:
            wall = time.perf_counter() - t_begin
            method = self.settings.leapfrog.method
            settings = plain(self.settings)
            return unreachable_result(self.scenario, settings, method, self.problem, str(exc), wall)
        search = Search(
            self.scenario, self.settings, paths, self.robot.model.aid,
            self.runner.problem_of, self.initial_paths, self.choose,
        )  # fmt: skip
        runs: list[PathRun] = []
        t_runs = 0.0
        rnd = self.first_round
        cut = False  # whether the time limit left work undone
        while rnd is not None and not cut:
            for stage in STAGES:
                while requests := stage(search, rnd, [r for r in runs if r.request.round is rnd]):
                    t0 = time.perf_counter()
                    runs += self.runner.run_all(requests)
                    t_runs += time.perf_counter() - t0
                    cut = time.perf_counter() >= self.runner.deadline
                    if cut:
                        break
                if cut:
                    break
            rnd = None if cut else next_round(search, rnd, runs)
        chosen = self.choose(runs)
        self.runner.emit(PlanEvent("final", len(paths[0]) - 1, len(paths[0]), ""))
        wall = time.perf_counter() - t_begin
        problem = self.runner.problem_of(self.first_round, chosen.run.weight)
        timing = Timing(paths_s=wall - t_runs, runs_s=t_runs, wall_s=wall)
        method = self.settings.leapfrog.method
        result = plan_result(
            self.scenario, plain(self.settings), method, runs, chosen, problem, timing
        )
        notes = [
            fewer_paths_note(self.scenario, asked or self.settings.initial_paths, len(paths[0]))
        ]
        if cut:  # said in the message, whatever the answer
            notes.append(f"the time limit of {limit:g} s cut the search short")
        message = "; ".join([result.message, *filter(None, notes)])
        return dataclasses.replace(result, message=message)

    def choose(self, runs: list[PathRun]) -> Chosen:
        """The answer ``runs`` give (:func:`.answer.choose_answer`)."""
        ctx = Context(
            self.scenario, self.problem, self.settings.samples, self.runner.flow_of, self.robot
        )
        return choose_answer(runs, ctx)


def as_scenario(scenario: Scenario | Mapping[str, Any] | str | Path) -> Scenario:
    """``scenario`` itself, or the scenario of a dict (the tables of a scenario file), of a file
    or of a built-in name."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, Mapping):
        return scenario_from_dict(scenario)
    return load_scenario(scenario)


def plan(
    scenario: Scenario | Mapping[str, Any] | str | Path | PlanResult, *, progress=None, **options
) -> PlanResult:
    """Plan ``scenario`` (an object, a dict of a scenario file's tables, a file or a built-in
    name) with Leapfrog; given a :class:`PlanResult`, re-plan the scenario it records with the
    settings it records (:meth:`Planner.from_result`; no options then).

    Options: ``method`` (``newton``, ``modified-newton``, ``nleq-err``), ``partitions``,
    ``initial_paths``, ``final`` (``auto``, ``shooting``, ``multiple-shooting``), and the other
    fields of :class:`PlannerSettings` and :class:`LeapfrogSettings`.
    """
    if isinstance(scenario, PlanResult):
        if options:
            raise SettingsError(
                f"plan(result): a result re-plans with its recorded settings; got options"
                f" {', '.join(sorted(options))} (plan result.task to change them)"
            )
        result = Planner.from_result(scenario, progress=progress).plan()
        return with_call(result, f"plan(<result of {scenario.scenario!r}>)")
    result = Planner(scenario, progress=progress, **options).plan()
    given = repr(str(scenario)) if not isinstance(scenario, Scenario) else f"<{scenario.name!r}>"
    call = ", ".join([given, *(f"{k}={v!r}" for k, v in options.items())])
    return with_call(result, f"plan({call})")
