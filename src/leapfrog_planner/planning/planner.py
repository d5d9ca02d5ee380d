"""Plan a scenario: initial feasible paths, Leapfrog from each, the cheapest validated extremal.

``plan(scenario)`` is the one-call entry point; :class:`Planner` keeps the compiled flow and the
settings for reuse across scenarios with the same model (obstacles are data: nothing recompiles).
"""

from __future__ import annotations

import copy
import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields, replace

import numpy as np

from .._blas import held_by_parent, single_threaded_blas
from ..errors import ScenarioError, SettingsError, require_integer
from ..integrate.flow import Flow, IntegratorSettings
from ..integrate.problem import OptimalControlProblem
from .answer import (
    END_STATE_FACTOR,
    Answer,
    Context,
    PathRun,
    best_of,
    choose_answer,
    plan_message,
)
from .bounded import continue_to_bounds, exceeded, schedule
from .initial_path import InitialPath, initial_paths, points_away
from .leapfrog import LeapfrogSettings, SweepRecord, leapfrog
from .leapfrog.settings import MAX_PARTITIONS
from .path_ranking import (
    PathGuide,
    drivable,
    estimated_costs,
    path_states,
    penalty_margin,
    penalty_timed,
    rank_paths,
)
from .result_files import plain
from .results import (
    PlanResult,
    PlanStatus,
    penalty_integral,
    validate_arcs,
)
from .scenario import Scenario, load_scenario

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanEvent:
    """Progress report: ``stage`` is "path" (a new initial path starts), "sweep" or "final"."""

    stage: str
    path_index: int
    paths: int
    label: str
    sweep: SweepRecord | None = None


@dataclass(frozen=True)
class PlannerSettings:
    """The planner's settings (the measurements behind the defaults: ``docs/tuning.md``)."""

    initial_paths: int = 3  # paths tried, of least estimated cost (see Planner.initial_paths)
    candidate_paths: int = 8  # homotopy classes planned, from which those are picked
    margin: float = 0.02  # obstacle inflation of the initial paths
    samples: int = 1001  # points of the returned dense trajectory
    # Initial paths run in parallel threads (the compiled flow releases the GIL): 0 means one
    # per path, all at once; 1 runs them one after the other. Results do not depend on it.
    threads: int = 0
    # A plan whose answer falls short (no extremal at all, or a collision-free Leapfrog iterate
    # cheaper than the best extremal) runs its stages again with the partitions doubled, this
    # many times at most: at long horizons the arcs of q = 8 are too long for a stiff penalty.
    finer_doublings: int = 1
    leapfrog: LeapfrogSettings = LeapfrogSettings()

    def __post_init__(self):
        require_integer("initial_paths", self.initial_paths, 1, 32)
        require_integer("candidate_paths", self.candidate_paths, 1, 64)
        require_integer("threads", self.threads, 0, 256)
        require_integer("finer_doublings", self.finer_doublings, 0, 7)
        if not 0 <= self.margin <= 1e6:
            raise SettingsError(f"margin must be between 0 and 1e6, got {self.margin!r}")
        require_integer("samples", self.samples, 2, 1_000_000)

    @classmethod
    def from_options(cls, base: PlannerSettings | None = None, **options) -> PlannerSettings:
        """Settings from flat options (``method``, ``partitions``, ``initial_paths``, ...).

        Keys of :class:`LeapfrogSettings` and of this class are accepted; anything else is an error.
        """
        base = base or cls()
        own = {f.name for f in fields(cls)} - {"leapfrog"}
        lf = {f.name for f in fields(LeapfrogSettings)}
        unknown = sorted(set(options) - own - lf)
        if unknown:
            raise SettingsError(
                f"unknown option {unknown[0]!r} (known: {', '.join(sorted(own | lf))})"
            )
        lf_opts = {k: v for k, v in options.items() if k in lf}
        return replace(
            base,
            leapfrog=replace(base.leapfrog, **lf_opts),
            **{k: v for k, v in options.items() if k in own},
        )


#: The car's turn assist while Leapfrog runs (1: turns like a unicycle); continued to the
#: scenario's value (0 by default) afterwards. A car without assist is given no initial path
#: that turns in place at an end: from those, the continuation to 0 failed or ended on dearer
#: extremals (30 scenarios with headings in every direction: 25 converged, 26 without them,
#: and two optima half as dear).
ASSIST = 1.0
#: A car plan with no collision-free extremal (the continuations from ``ASSIST`` stopped: the
#: family of extremals folds before the assist reaches the car's) runs its paths again with
#: this weaker assist: with the goal close behind, 32 -> 38 of 40 converged (docs/tuning.md).
WEAKER_ASSIST = 0.5

#: When no extremal clears the obstacles and some passed through one, those initial paths are
#: planned again with the obstacle weight raised by this factor, at most ``WEIGHT_RAISES`` times
#: (64 W in all; see docs/tuning.md).
WEIGHT_FACTOR = 4.0
WEIGHT_RAISES = 3

#: When every initial path, followed at its own pace, is estimated at more than this many times
#: the cheapest collision-free extremal found, the paths at the penalty's margin whose estimate
#: is below that extremal's cost are run too (see docs/tuning.md).
WIDER_WHEN = 4.0


# Scenario [solver] keys mapped to settings names.
_SOLVER_KEY_MAP = {
    "method": "method",
    "partitions": "partitions",
    "initial_paths": "initial_paths",
    "max_sweeps": "max_sweeps",
    "tolerance": "reduce_tol",
}


class Planner:
    """Leapfrog planner for one scenario; reuse it to re-plan with other settings."""

    def __init__(
        self,
        scenario: Scenario | str,
        settings: PlannerSettings | None = None,
        *,
        progress: Callable[[PlanEvent], None] | None = None,
        **options,
    ):
        self.scenario = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        from_file = {_SOLVER_KEY_MAP[k]: v for k, v in self.scenario.solver.items()}
        for key, name in _SOLVER_KEY_MAP.items():
            if name in from_file:  # a bad value in the file is the file's error: name it
                try:
                    PlannerSettings.from_options(settings, **{name: from_file[name]})
                except SettingsError as e:
                    source = self.scenario.source or self.scenario.name
                    raise ScenarioError(f"{source}: solver.{key}: {e}") from None
        self.settings = PlannerSettings.from_options(settings, **{**from_file, **options})
        self.problem = self.scenario.problem()
        self._robot = self.problem  # the scenario's own problem, without the planning aids
        # The car plans first with the turn assist of a unicycle, then continues it to its own.
        names = self.problem.model.parameters
        self._assist = None
        if "turn_assist" in names:
            self._assist_index = names.index("turn_assist")
            self._assist = self.problem.parameters[self._assist_index]
            self.problem = self._with_assist(ASSIST)
        self.flow = Flow(self.problem, self.settings.leapfrog.final_shooting.integrator)
        self.progress = progress
        self._progress_lock = threading.Lock()
        final = self.settings.leapfrog.final_shooting
        self._validation = IntegratorSettings(
            "dop853", rtol=final.integrator.rtol, atol=final.integrator.atol
        )
        self._end_tolerance = END_STATE_FACTOR * final.root.tol
        self._weights_lock = threading.Lock()
        self._weighted = {float(self.scenario.weight): (self.problem, self.flow)}
        self._suffix = ""  # appended to the labels of the paths run (see _finer)
        # Initial paths at the penalty's margin, by margin: planned once, also for _finer's runs
        # (they do not depend on the partitions).
        self._wide_paths: dict[float, list[InitialPath]] = {}

    def initial_paths(self, margin: float | None = None) -> list[InitialPath]:
        """The ``initial_paths`` candidates of least estimated cost, cheapest first, keeping
        ``margin`` (default: the settings') from the obstacles.

        Where an end heading points away from the chord, three-point turns are ranked with the
        paths of the homotopy classes. Elsewhere they are planned too, but the best one runs
        besides the class paths, and only when it is estimated cheapest of all: backing away
        from an obstacle next to an end looks cheap, and ranked with the others it took the
        place of paths that led to the optimum (docs/tuning.md)."""
        s, st = self.scenario, self.settings
        candidates = initial_paths(
            s.start[:3],  # poses: a model's further states are filled along the paths
            s.goal[:3],
            s.footprint_obstacles,
            k=max(st.initial_paths, st.candidate_paths),
            margin=max(st.margin, s.margin) if margin is None else margin,
            waypoints=s.waypoints,
            turns=True,
        )
        ends = (s.start, s.goal)
        keep = [True] * len(candidates)
        if s.control_bounds:  # a robot that cannot reverse is given no path that does
            keep = drivable(self.problem, candidates, s.horizon, s.control_bounds, ends)
        if self._assist == 0.0:  # nor a car one that turns on the spot at an end
            keep = [
                k and not (p.modes.turn_start or p.modes.turn_goal)
                for k, p in zip(keep, candidates, strict=True)
            ]
        candidates = [p for p, ok in zip(candidates, keep, strict=True) if ok] or candidates
        if len(candidates) < 2:  # nothing to rank: the estimate took 0.6 ms of paper case 1's 9
            return candidates
        ranked = [path for _, path in rank_paths(self.problem, candidates, s.horizon, ends)]
        if points_away(s.start, s.goal):  # the turns are among the natural ways there
            return ranked[: st.initial_paths]
        plain = [p for p in ranked if not p.modes.cusp][: st.initial_paths]
        return plain + ranked[:1] if ranked[0].modes.cusp else plain

    def plan(self) -> PlanResult:
        with single_threaded_blas():
            return self._plan()

    def _at_weight(self, weight: float) -> tuple[OptimalControlProblem, Flow]:
        """The problem and its flow with obstacle weight ``weight`` (built once, shared)."""
        with self._weights_lock:
            if weight not in self._weighted:
                problem = self.problem.with_weight(weight)
                self._weighted[weight] = (problem, Flow(problem, self.flow.settings))
            return self._weighted[weight]

    def _flow_of(self, problem: OptimalControlProblem) -> Flow:
        """The final solves' flow of ``problem``: the plan's at its weight, or (a problem with
        other parameters: the bounds relaxed, or the car's turn assist continued) a new one."""
        own, flow = self._at_weight(problem.penalty.weight)
        return flow if problem.parameters == own.parameters else Flow(problem, flow.settings)

    def run_path(self, path: InitialPath, k: int = 0, paths: int = 1, raises: int = 0) -> PathRun:
        """Leapfrog from ``path`` (one of :meth:`initial_paths`, or a user's own) with the
        obstacle weight raised ``raises`` times, and the validation of its answer; progress
        names it path ``k`` of ``paths``."""
        s, st = self.scenario, self.settings
        T0 = 0.0
        weight = float(s.weight) * WEIGHT_FACTOR**raises
        label = path.label + (f" (obstacle weight {weight:g})" if raises else "")
        self._emit(PlanEvent("path", k, paths, label))
        t, X = path.junctions(st.leapfrog.partitions, s.horizon, T0)
        if s.start.size > 3:  # a model's further states, from their start to their goal values
            frac = (t - T0) / s.horizon
            X = np.column_stack([X, path_states(path, frac, (s.start, s.goal))[:, 3:]])
            X[0], X[-1] = s.start, s.goal

        def on_sweep(rec):
            self._emit(PlanEvent("sweep", k, paths, label, rec))

        problem, flow = self._at_weight(weight)
        guide = PathGuide(problem, path, s.horizon, T0, (s.start, s.goal))
        with held_by_parent():
            run = leapfrog(
                problem, t, X, guide=guide, settings=st.leapfrog, flow=flow, progress=on_sweep
            )
            iterate_problem = problem
            if s.control_bounds or self._assist is not None:  # on to the problem itself
                run, problem, iterate_problem = self._continued(run, problem, (t, X), guide, flow)
            log.info("path %s: %s", label, run.message)
            # Validated here, in the path's own thread: the re-integration overlaps the other
            # paths' sweeps.
            t0 = time.perf_counter()
            v = None
            if run.success:
                v = validate_arcs(problem, run.extremal, st.samples, self._validation)
            t_val = time.perf_counter() - t0
        return PathRun(
            path,
            guide,
            run,
            (t, X),
            v,
            weight,
            raises,
            t_val,
            iterate_problem,
            self._end_tolerance,
            s.margin,
        )

    def _continued(self, run, problem, junctions, guide, flow):
        """``run`` (Leapfrog with smoothly saturating controls, or the car with its turn assist)
        continued to the scenario's problem; where it failed with bounds, Leapfrog again with
        the bounds relaxed, then continued (see :mod:`.bounded`). Returns the run, the problem
        of its extremal, and the problem of its Leapfrog iterate."""
        s, st = self.scenario, self.settings
        relaxed = ()
        if not run.success and s.control_bounds:  # relax the bounds the initial path leaves
            u = guide.trajectory().u
            relaxed = exceeded(s.control_bounds, problem.model.controls, u)
        if self._assist is None:
            assist = None
        else:  # from the assist ``problem`` has
            assist = (problem.parameters[self._assist_index], self._assist)
        at = schedule(problem, s.control_bounds, s.smoothing_widths, relaxed, assist)
        iterate_problem = problem
        if relaxed:
            t, X = junctions
            iterate_problem = wide = at(0.0)
            guide = PathGuide(wide, guide.path, s.horizon, guide.t0, guide.ends)
            run = leapfrog(
                wide, t, X, guide=guide, settings=st.leapfrog, flow=Flow(wide, flow.settings)
            )
        if not run.success:
            return run, problem, iterate_problem
        steps = 8 if relaxed or assist else len(s.smoothing_widths) - 1
        ends = (s.start, s.goal)
        done = continue_to_bounds(
            at, run, (0.0, s.horizon), ends, steps, st.leapfrog.final_shooting
        )
        return done.run, done.problem, iterate_problem

    def _run_paths(self, paths: list[InitialPath], raises: int) -> list[PathRun]:
        """:meth:`run_path` for each path, in parallel threads (see ``threads``)."""
        if self._suffix and not raises:  # (the raised runs' paths carry it already)
            paths = [replace(p, label=p.label + self._suffix) for p in paths]
        n = len(paths)
        workers = min(n, self.settings.threads or n)
        args = (paths, range(n), [n] * n, [raises] * n)
        if workers > 1:
            with ThreadPoolExecutor(workers, thread_name_prefix="leapfrog-path") as pool:
                return list(pool.map(self.run_path, *args))
        return list(map(self.run_path, *args))

    def _plan(self) -> PlanResult:
        t_begin = time.perf_counter()
        paths = self.initial_paths()
        t_paths = time.perf_counter() - t_begin
        runs, t_wider = self._stages(paths)
        t_paths += t_wider
        chosen = choose_answer(runs, self._context())
        q = self.settings.leapfrog.partitions
        for k in range(1, self.settings.finer_doublings + 1):
            if q << k > MAX_PARTITIONS or not _falls_short(runs, *chosen):
                break
            log.info("the answer falls short: the stages again with q = %d", q << k)
            more, t_wider = self._finer(q << k)._stages(paths)
            runs, t_paths = runs + more, t_paths + t_wider
            chosen = choose_answer(runs, self._context())
        if self._assist is not None and not any(r.clear for r in runs):
            log.info("no car extremal clears: the paths again, turn assist %g", WEAKER_ASSIST)
            more, t_wider = self._less_assisted()._stages(paths)
            runs, t_paths = runs + more, t_paths + t_wider
            chosen = choose_answer(runs, self._context())
        t_runs = time.perf_counter() - t_begin - t_paths
        self._emit(PlanEvent("final", len(paths) - 1, len(paths), ""))
        return self._result(runs, chosen, t_paths, t_runs, time.perf_counter() - t_begin)

    def _stages(self, paths: list[InitialPath]) -> tuple[list[PathRun], float]:
        """The runs of the plan's stages from ``paths`` (and the time spent planning wider
        paths): the paths; the paths at the penalty's margin (:meth:`_wider_stage`); when still
        no extremal, the paths timed by the penalty; the weight raised where every extremal
        passes through an obstacle."""
        runs = self._run_paths(paths, 0)
        t0 = time.perf_counter()
        wider = self._wider_stage(paths, runs)
        t_wider = time.perf_counter() - t0
        if wider is not None:
            if not any(r.extremal for r in runs):
                paths = wider
            runs += self._run_paths(wider, 0)
        if not any(r.extremal for r in runs) and self.scenario.weight > 0.0:
            # Still none: a start or goal in the penalty's grip. The paths timed by it.
            log.info("no extremal: the paths again, timed by the penalty")
            timed = [penalty_timed(self.problem, p, self.scenario.horizon) for p in paths]
            runs += self._run_paths(timed, 0)
        # No path clears at the scenario's weight, and some extremal passed through an obstacle:
        # those paths again with the weight raised, until one clears (also where a path's run at
        # the last raise failed: a higher weight may still clear), unless every run at the last
        # raise failed (the higher weights are stiffer still).
        for raises in range(1, WEIGHT_RAISES + 1):
            collided = {r.path for r in runs if r.collides}
            last = [r for r in runs if r.raises == raises - 1]
            again = [r.path for r in last if r.path in collided]
            if any(r.clear for r in runs) or not again or not self.scenario.weight > 0.0:
                break
            if raises > 1 and not any(r.extremal for r in last):
                log.info(
                    "no extremal at weight x %g: not raised further", WEIGHT_FACTOR ** (raises - 1)
                )
                break
            log.info("no extremal clears the obstacles: weight x %g", WEIGHT_FACTOR**raises)
            runs += self._run_paths(again, raises)
        return runs, t_wider

    def _finer(self, q: int) -> Planner:
        """This planner with ``q`` partitions, labelling its paths with them. A shallow copy:
        it shares the flows, the progress callback and the paths at the penalty's margin."""
        finer = copy.copy(self)
        finer.settings = PlannerSettings.from_options(self.settings, partitions=q)
        finer._suffix = f", q = {q}"
        return finer

    def _less_assisted(self) -> Planner:
        """This planner for the car with :data:`WEAKER_ASSIST` (a copy with its own problem and
        flows), labelling its paths with it."""
        weaker = copy.copy(self)
        weaker.problem = self._with_assist(WEAKER_ASSIST)
        weaker.flow = Flow(weaker.problem, self.flow.settings)
        weaker._weights_lock = threading.Lock()
        weaker._weighted = {float(self.scenario.weight): (weaker.problem, weaker.flow)}
        weaker._suffix = f"{self._suffix}, turn assist {WEAKER_ASSIST:g}"
        return weaker

    def _with_assist(self, assist: float) -> OptimalControlProblem:
        """The plan's problem (the car's) with the turn assist ``assist``."""
        values = list(self.problem.parameters)
        values[self._assist_index] = assist
        return replace(self.problem, parameters=tuple(values))

    def _context(self) -> Context:
        return Context(
            self.scenario, self.problem, self.settings.samples, self._flow_of, self._robot
        )

    def _estimates(self, paths: list[InitialPath]) -> np.ndarray:
        s = self.scenario
        return estimated_costs(self.problem, paths, s.horizon, ends=(s.start, s.goal))

    def _wider_stage(self, paths: list[InitialPath], runs: list[PathRun]):
        """The paths at the penalty's own distance (:func:`penalty_margin`) to run as well, or
        None. Where the penalty dwarfs the control energy near the obstacles (a long horizon or
        a heavy weight), paths at the robot's margin are poor starts: when no run found an
        extremal, all of them are run; when every path run, followed at its own pace, is
        estimated at more than ``WIDER_WHEN`` times the cheapest collision-free extremal found,
        those estimated cheaper than every path run. (Every path of a homotopy class, that is:
        the three-point turn, run besides them, backs away from the obstacles in its own way
        and is no measure of how poor their margin is.)"""
        wide = penalty_margin(self.scenario)
        if not wide > self.settings.margin:
            return None
        if not any(r.extremal for r in runs):
            log.info("no extremal: initial paths again with margin %.3g", wide)
            return self._wider_paths(wide)
        clear = [r.validation.cost for r in runs if r.clear]
        top = float(self._estimates([p for p in paths if not p.modes.cusp] or paths).min())
        if not (clear and top > WIDER_WHEN * min(clear)):
            return None
        log.info("paths %.3g times the extremal's cost: margin %.3g too", top / min(clear), wide)
        wider = self._wider_paths(wide)
        return [p for p, c in zip(wider, self._estimates(wider), strict=True) if c < top]

    def _wider_paths(self, margin: float) -> list[InitialPath]:
        """Initial paths at ``margin``, labelled with it; none when every gap closes at it."""
        if margin not in self._wide_paths:
            try:
                wide = self.initial_paths(margin)
            except ScenarioError:
                wide = []
            label = f", margin {margin:.3g}"
            self._wide_paths[margin] = [replace(p, label=p.label + label) for p in wide]
        return self._wide_paths[margin]

    def _emit(self, event: PlanEvent):
        if self.progress is not None:
            with self._progress_lock:  # paths run in threads: one event at a time
                self.progress(event)

    def _result(self, runs, chosen, t_paths, t_runs, wall) -> PlanResult:
        status, best, answer = chosen
        s, info, run, v = self.scenario, self.problem.model, best.run, answer.validation
        tr = answer.trajectory
        problem = self._at_weight(best.weight)[0]
        nan = float("nan")
        # The runs' wall time (paths in parallel threads, each validated in its thread), split
        # in the ratio of the parts' own times.
        t_val = sum(r.validation_time_s for r in runs)
        sweeps = sum(r.run.sweep_time_s for r in runs)
        finals = sum(r.run.final_time_s for r in runs)
        share = t_runs / max(sweeps + finals + t_val, 1e-300)
        alternatives = tuple(
            best_of([r for r in runs if r.path is path]).outcome()
            for path in dict.fromkeys(r.path for r in runs)
            if path is not best.path
        )
        if v is not None:
            cost, energy, penalty = v.cost, v.energy, v.penalty
            end_error, clearance = v.end_state_error, v.clearance
        else:
            penalty = penalty_integral(problem, tr)
            cost = float(tr.cost[-1])
            energy, end_error = cost - penalty, float(np.linalg.norm(tr.x[-1] - s.goal))
            clearance = problem.penalty.clearance(tr.x[:, :2])
        return PlanResult(
            status=status,
            message=plan_message(status, best, answer, runs, s.margin),
            scenario=s.name,
            model=info.name,
            state_names=info.states,
            control_names=info.controls,
            method=self.settings.leapfrog.method,
            final_solver=run.final_solver if v is not None else None,
            initial_path=best.path.label,
            costate0=run.costate0 if v is not None else None,
            trajectory=tr,
            cost=cost,
            energy=energy,
            penalty=penalty,
            clearance=clearance,
            end_state_error=end_error,
            max_costate_jump=run.max_costate_jump,
            max_dH_du=v.max_dH_du if v is not None else nan,
            hamiltonian_variation=v.hamiltonian_variation if v is not None else nan,
            initial_cost=run.initial_cost,
            history=run.history,
            initial_junctions=best.junctions,
            newton_iterations=sum(r.run.newton_iterations for r in runs),
            f_evals=sum(r.run.f_evals for r in runs),
            cost_increases=run.cost_increases,
            time_initial_path_s=t_paths,
            time_sweeps_s=sweeps * share,
            time_final_s=finals * share,
            time_validation_s=t_val * share,
            wall_time_s=wall,
            alternatives=alternatives,
            weight=best.weight,
            optimal=v is not None,
            trajectory_source=answer.source,
            task=s,
            settings=plain(self.settings),
            cheaper_motion=nan if answer.cheaper is None else answer.cheaper[1],
        )


def _falls_short(runs: list[PathRun], status: PlanStatus, best: PathRun, answer: Answer) -> bool:
    """No extremal at all, a collision-free iterate cheaper than the best extremal, or no
    extremal from a path of a homotopy class (a three-point turn's alone). (Extremals that only
    pass through obstacles are the weight raises' to mend.)"""
    classes = [r for r in runs if not r.path.modes.cusp]
    return (
        status is PlanStatus.FAILED
        or answer.cheaper is not None
        or not any(r.extremal for r in classes)
    )


def plan(scenario: Scenario | str, *, progress=None, **options) -> PlanResult:
    """Plan ``scenario`` (an object, a file or a built-in name) with Leapfrog.

    Options: ``method`` (``newton``, ``modified-newton``, ``nleq-err``), ``partitions``,
    ``initial_paths``, ``final`` (``auto``, ``shooting``, ``multiple-shooting``), and the other
    fields of :class:`PlannerSettings` and :class:`LeapfrogSettings`.
    """
    return Planner(scenario, progress=progress, **options).plan()
