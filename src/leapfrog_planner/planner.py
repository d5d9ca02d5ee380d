"""Plan a scenario: initial feasible paths, Leapfrog from each, the cheapest validated extremal.

``plan(scenario)`` is the one-call entry point; :class:`Planner` keeps the compiled flow and the
settings for reuse across scenarios with the same model (obstacles are data: nothing recompiles).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields, replace

import numpy as np

from ._blas import held_by_parent, single_threaded_blas
from .errors import ScenarioError, SettingsError, require_integer
from .initial_path import InitialPath, initial_paths
from .integrate.flow import Flow
from .leapfrog import LeapfrogSettings, SweepRecord, leapfrog
from .path_ranking import PathGuide, rank_paths
from .results import LeapfrogResult, PathOutcome, PlanStatus, validate
from .scenario import Scenario, load_scenario

log = logging.getLogger(__name__)

# A result whose re-integrated end state misses the goal by more than this is not converged.
END_STATE_TOLERANCE = 1e-8


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
    initial_paths: int = 3  # initial paths tried, in different homotopy classes
    # Candidates (the shortest paths in different homotopy classes) from which the initial paths
    # are picked by estimated cost (see path_ranking): on paper case 4 the path that leads to the
    # cheapest optimum is only the fifth shortest.
    candidate_paths: int = 8
    # Obstacle inflation of the initial paths: small, since optimal paths squeeze through gaps
    # (paper case 3's optimum passes two obstacles 0.066 apart with 0.033 clearance).
    margin: float = 0.02
    samples: int = 1001  # points of the returned dense trajectory
    # Initial paths run in parallel threads (the compiled flow releases the GIL): 0 means one per
    # path, all at once; 1 runs them one after the other. Results do not depend on it. Paths take
    # unequal times (paper case 4: 69, 107 and 105 ms alone), and a pool of one thread per core
    # leaves a core idle while the other finishes its second path; with one thread per path the
    # cores share the work to the end. Measured on 2 cores, 6 interleaved rounds of 5 plans:
    # paper case 4, 195 -> 176 ms mean of the medians (3 threads faster or equal in every round);
    # case 3, 160 -> 158.
    threads: int = 0
    leapfrog: LeapfrogSettings = LeapfrogSettings()

    def __post_init__(self):
        require_integer("initial_paths", self.initial_paths)
        require_integer("candidate_paths", self.candidate_paths)
        require_integer("threads", self.threads, 0)
        if not self.margin >= 0:
            raise SettingsError(f"margin must be >= 0, got {self.margin}")
        require_integer("samples", self.samples, 2)

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
        self.flow = Flow(self.problem, self.settings.leapfrog.final_shooting.integrator)
        self.progress = progress
        self._progress_lock = threading.Lock()

    def initial_paths(self) -> list[InitialPath]:
        """The ``initial_paths`` candidates of least estimated cost, cheapest first."""
        s, st = self.scenario, self.settings
        candidates = initial_paths(
            s.start,
            s.goal,
            s.obstacles,
            k=max(st.initial_paths, st.candidate_paths),
            margin=st.margin,
            waypoints=s.waypoints,
        )
        if len(candidates) < 2:  # nothing to rank: the estimate took 0.6 ms of paper case 1's 9
            return candidates
        ranked = rank_paths(self.problem, candidates, s.horizon)
        return [path for _, path in ranked[: st.initial_paths]]

    def plan(self) -> LeapfrogResult:
        with single_threaded_blas():
            return self._plan()

    def _plan(self) -> LeapfrogResult:
        s, st = self.scenario, self.settings
        t_begin = time.perf_counter()
        paths = self.initial_paths()
        t_paths = time.perf_counter() - t_begin
        T0, T1 = 0.0, float(s.horizon)

        def run_path(k: int, path: InitialPath) -> tuple:
            """Leapfrog from ``path``, then the validation of its answer: (path, run, initial
            junctions, validation or None, validation time)."""
            self._emit(PlanEvent("path", k, len(paths), path.label))
            t, X = path.junctions(st.leapfrog.partitions, s.horizon, T0)

            def on_sweep(rec):
                self._emit(PlanEvent("sweep", k, len(paths), path.label, rec))

            with held_by_parent():
                run = leapfrog(
                    self.problem,
                    t,
                    X,
                    guide=PathGuide(self.problem, path, s.horizon, T0),
                    settings=st.leapfrog,
                    flow=self.flow,
                    progress=on_sweep,
                )
                log.info("path %s: %s", path.label, run.message)
                # Validated here, in the path's own thread: the re-integration overlaps the
                # other paths' sweeps.
                t_val = time.perf_counter()
                v = None
                if run.success:
                    v = validate(
                        self.problem, T0, s.start, T1, s.goal, run.costate0, samples=st.samples
                    )
            return path, run, (t, X), v, time.perf_counter() - t_val

        workers = min(len(paths), st.threads or len(paths))
        if workers > 1:
            with ThreadPoolExecutor(workers, thread_name_prefix="leapfrog-path") as pool:
                runs = list(pool.map(run_path, range(len(paths)), paths))
        else:
            runs = [run_path(k, path) for k, path in enumerate(paths)]
        t_runs = time.perf_counter() - t_begin - t_paths
        self._emit(PlanEvent("final", len(paths) - 1, len(paths), ""))
        checked = [c[:4] for c in runs]
        ok = [c for c in checked if _valid(c[3])]
        best = min(ok, key=lambda c: c[3].cost) if ok else checked[0]
        t_val = sum(c[4] for c in runs)
        return self._result(best, checked, t_paths, t_runs, t_val, time.perf_counter() - t_begin)

    def _emit(self, event: PlanEvent):
        if self.progress is not None:
            with self._progress_lock:  # paths run in threads: one event at a time
                self.progress(event)

    def _result(self, best, checked, t_paths, t_runs, t_val, wall) -> LeapfrogResult:
        path, run, junctions, v = best
        s = self.scenario
        info = self.problem.model
        status = (
            PlanStatus.CONVERGED if v is not None and np.isfinite(v.cost) else PlanStatus.FAILED
        )
        nan = float("nan")
        # The runs' wall time (paths in parallel threads, each validated in its thread), split
        # in the ratio of the parts' own times.
        sweeps = sum(r.sweep_time_s for _, r, _, _ in checked)
        finals = sum(r.final_time_s for _, r, _, _ in checked)
        share = t_runs / max(sweeps + finals + t_val, 1e-300)
        alternatives = tuple(
            PathOutcome(
                label=p.label,
                status=PlanStatus.CONVERGED if _valid(vv) else PlanStatus.FAILED,
                cost=vv.cost if _valid(vv) else nan,
                initial_cost=r.initial_cost,
                sweeps=len(r.history),
                message=r.message,
            )
            for p, r, _, vv in checked
            if p is not path
        )
        return LeapfrogResult(
            status=status,
            message=run.message if v is not None else f"{run.message} (initial path {path.label})",
            scenario=s.name,
            model=info.name,
            state_names=info.states,
            control_names=info.controls,
            method=self.settings.leapfrog.method,
            final_solver=run.final_solver,
            initial_path=path.label,
            costate0=run.costate0,
            trajectory=v.trajectory if v else None,
            cost=v.cost if v else nan,
            energy=v.energy if v else nan,
            penalty=v.penalty if v else nan,
            clearance=v.clearance
            if v
            else self.problem.penalty.clearance(path.curve(np.linspace(0, 1, 501))[0]),
            end_state_error=v.end_state_error if v else float("inf"),
            max_costate_jump=run.max_costate_jump,
            max_dH_du=v.max_dH_du if v else nan,
            hamiltonian_variation=v.hamiltonian_variation if v else nan,
            initial_cost=run.initial_cost,
            history=run.history,
            initial_junctions=junctions,
            newton_iterations=sum(r.newton_iterations for _, r, _, _ in checked),
            f_evals=sum(r.f_evals for _, r, _, _ in checked),
            cost_increases=run.cost_increases,
            time_initial_path_s=t_paths,
            time_sweeps_s=sweeps * share,
            time_final_s=finals * share,
            time_validation_s=t_val * share,
            wall_time_s=wall,
            alternatives=alternatives,
        )


def _valid(v) -> bool:
    """A validated extremal: re-integrated without failure, reaching the goal."""
    return v is not None and np.isfinite(v.cost) and v.end_state_error <= END_STATE_TOLERANCE


def plan(scenario: Scenario | str, *, progress=None, **options) -> LeapfrogResult:
    """Plan ``scenario`` (an object, a file or a built-in name) with Leapfrog.

    Options: ``method`` (``newton``, ``modified-newton``, ``nleq-err``), ``partitions``,
    ``initial_paths``, ``final`` (``auto``, ``shooting``, ``multiple-shooting``), and the other
    fields of :class:`PlannerSettings` and :class:`LeapfrogSettings`.
    """
    return Planner(scenario, progress=progress, **options).plan()
