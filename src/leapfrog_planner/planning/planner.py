"""Plan a scenario: initial feasible paths, Leapfrog from each, the cheapest validated extremal.

``plan(scenario)`` is the one-call entry point; :class:`Planner` keeps the compiled flows and
the settings for reuse (obstacles are data: nothing recompiles). A plan is a short loop: the
search's stages (:mod:`.search`) ask for runs, the runner (:mod:`.runner`) makes them, and when
no stage of the last round asks for more, the answer is chosen among all the runs
(:mod:`.answer`) and reported (:mod:`.outcome`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .._blas import single_threaded_blas
from ..integrate.flow import Flow
from .answer import Chosen, Context, choose_answer
from .first_paths import PATHS_SHARE, first_paths
from .fixed_horizons import FixedHorizons
from .initial_path import InitialPath
from .initial_path.map_paths import Unreachable
from .outcome import Timing, plan_result, unreachable_result
from .rerun import call_of, recorded, recorded_task, with_call
from .result_files import plain
from .results import PlanResult
from .runner import RUNS_SHARE, PlanEvent, Runner
from .runs import PathRun, RunRequest, Searched
from .scenario import Scenario, as_scenario
from .scenario_time import refuse_unreachable
from .search import STAGES, Search, next_round, route_round, search_notes, settings_round
from .settings import PlannerSettings

__all__ = ["PlanEvent", "Planner", "PlannerSettings", "plan"]

Progress = Callable[[PlanEvent], None] | None


class Planner:
    """Leapfrog planner for one scenario; reuse it to re-plan with other settings."""

    def __init__(
        self, scenario: Scenario | Mapping[str, Any] | str | Path,
        settings: PlannerSettings | None = None, *, progress: Progress = None, **options,
    ):  # fmt: skip
        scenario = as_scenario(scenario)
        refuse_unreachable(scenario)  # at once, not after a search that cannot succeed
        self._setup(scenario, PlannerSettings.of_scenario(scenario, settings, **options), progress)

    @classmethod
    def unrefused(cls, scenario: Scenario, settings: PlannerSettings, progress=None) -> Planner:
        """A planner of ``scenario`` with ``settings`` as they are, even where its horizon is
        too short for the top speed (the free-time search probes such horizons)."""
        planner = cls.__new__(cls)
        planner._setup(scenario, settings, progress)
        return planner

    def _setup(self, scenario: Scenario, settings: PlannerSettings, progress) -> None:
        self.scenario, self.settings = scenario, settings
        self.runner = Runner(self.scenario, self.settings, self.scenario.problem(), progress)
        self.robot = self.runner.robot  # the scenario's own problem, without planning aids
        self.first_round = settings_round(self.settings, self.robot.model.aid)
        self.problem = self.runner.problem_of(self.first_round)  # what Leapfrog solves first
        self.paths_deadline = float("inf")  # when building three-point turns stops

    @classmethod
    def from_result(cls, result: PlanResult, *, progress: Progress = None, **options) -> Planner:
        """A planner of the scenario ``result`` records, with every setting it records (over
        the scenario's ``[solver]``): its :meth:`plan` gives the recorded answer bit for bit
        with the same versions on the same machine."""
        scenario, settings = recorded_task(result, options)
        return cls(scenario, settings, progress=progress)

    @property
    def flow(self) -> Flow:  # the final solves' flow of :attr:`problem`
        return self.runner.flow_of(self.problem)

    @property
    def progress(self) -> Progress:  # called with each PlanEvent
        return self.runner.progress

    @progress.setter
    def progress(self, callback: Progress) -> None:
        self.runner.progress = callback

    def initial_paths(self, margin: float | None = None, weight=None) -> list[InitialPath]:
        """The paths a plan runs first, keeping ``margin`` (default: the settings'): the
        ``initial_paths`` of least estimated cost (at obstacle weight ``weight``, by default
        the scenario's), one per family, or fewer where fewer exist (the plan's message then
        says so): :func:`.first_paths.first_paths`."""
        return self.path_selection(margin, weight)[0]

    def path_selection(self, margin=None, weight=None) -> tuple[list, list]:
        """The paths a plan runs first and the extra ones it races against them."""
        problem = self.runner.problem_of(self.first_round, weight)  # (None: the scenario's)
        return first_paths(
            self.scenario, self.settings, problem, self.robot, margin, self.paths_deadline
        )

    def run_path(self, path: InitialPath) -> PathRun:
        """Leapfrog from ``path`` (one of :meth:`initial_paths`, or a user's own) in the plan's
        first round fitted to its route, continued to the robot's problem and validated (BLAS
        on one thread, as in :meth:`plan`: the same bits)."""
        rnd = route_round(self.first_round, self.scenario, self.settings, [path])
        weight = float(self.scenario.weight)
        request = RunRequest(path, rnd, "paths", "asked for", weight, label=path.label)
        with single_threaded_blas():
            return self.runner.run(request)

    def plan(self) -> PlanResult:
        with single_threaded_blas():
            if self.scenario.free_time is None:
                result = self.plan_fixed()
            else:
                result = FixedHorizons(self).plan()
        return recorded(result, self.settings, "Planner.plan")

    def deadline_after(self, t_begin: float) -> float:  # the time limit after ``t_begin``
        limit = self.settings.time_limit
        return t_begin + limit if limit is not None else float("inf")

    def plan_fixed(self, asked: int | None = None, deadline: float | None = None) -> PlanResult:
        """The plan of a fixed horizon; ``asked``: the initial paths the caller asked for (a
        note when fewer ran); ``deadline``: when the plan must end (default: the time limit
        from now), of which paths and runs take shares (``PATHS_SHARE``, ``RUNS_SHARE``)."""
        t_begin = time.perf_counter()
        end = self.deadline_after(t_begin) if deadline is None else deadline
        self.runner.deadline = t_begin + RUNS_SHARE * (end - t_begin)
        self.paths_deadline = t_begin + PATHS_SHARE * (end - t_begin)
        try:
            return self._planned(t_begin, asked)
        finally:  # a plan's limit is its own: paths and runs asked for afterwards are whole
            self.runner.deadline = self.paths_deadline = float("inf")

    def _planned(self, t_begin: float, asked: int | None) -> PlanResult:
        """:meth:`plan_fixed` once its deadlines are set."""
        s, method, settings = self.scenario, self.settings.leapfrog.method, plain(self.settings)
        try:
            paths = self.path_selection()
        except Unreachable as exc:
            wall = time.perf_counter() - t_begin
            return unreachable_result(s, settings, method, self.problem, str(exc), wall)
        paths_cut = time.perf_counter() >= self.paths_deadline
        searched = self._search(paths)
        chosen = self.choose(searched.runs)
        self.runner.emit(PlanEvent("final", len(paths[0]) - 1, len(paths[0]), ""))
        wall = time.perf_counter() - t_begin
        problem = self.runner.problem_of(self.first_round, chosen.run.weight)
        timing = Timing(paths_s=wall - searched.runs_s, runs_s=searched.runs_s, wall_s=wall)
        asked = asked or self.settings.initial_paths
        notes = search_notes(s, self.settings, asked, len(paths[0]), searched.cut or paths_cut)
        return plan_result(s, settings, method, searched.runs, chosen, problem, timing, notes)

    def _search(self, paths: tuple[list[InitialPath], list[InitialPath]]) -> Searched:
        """The search's loop: each round's stages ask for runs until none asks for more, then
        the next round, if any; the time limit stops it after the runs under way, or before
        runs it leaves no time for."""
        search = self.search(paths)
        runs: list[PathRun] = []
        runs_s, rnd = 0.0, search.first
        while rnd is not None:
            for stage in STAGES:
                while requests := stage(search, rnd, [r for r in runs if r.request.round is rnd]):
                    if runs and not self.runner.has_time_for(runs):  # (the first always run)
                        return Searched(runs, runs_s, cut=True)
                    t0 = time.perf_counter()
                    runs += self.runner.run_all(requests)
                    runs_s += time.perf_counter() - t0
                    if time.perf_counter() >= self.runner.deadline:
                        return Searched(runs, runs_s, cut=True)
            rnd = next_round(search, rnd, runs)
        return Searched(runs, runs_s, cut=False)

    def search(self, paths: tuple[list[InitialPath], list[InitialPath]]) -> Search:
        """What the search's stages read, of a plan whose paths are ``paths``."""
        return Search(
            self.scenario, self.settings, paths, self.robot.model.aid,
            self.runner.problem_of, self.initial_paths, self.choose,
        )  # fmt: skip

    def choose(self, runs: list[PathRun]) -> Chosen:
        """The answer ``runs`` give (:func:`.answer.choose_answer`)."""
        ctx = Context(
            self.scenario, self.problem, self.settings.samples, self.runner.flow_of, self.robot
        )
        return choose_answer(runs, ctx)


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
        planner = Planner.from_result(scenario, progress=progress, **options)
    else:
        planner = Planner(scenario, progress=progress, **options)
    return with_call(planner.plan(), call_of(scenario, options))
