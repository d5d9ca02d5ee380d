"""Sweeps: many scenarios against several methods, in parallel, resumable, one JSON line per pair.

``run_sweep(scenarios, "results.jsonl", SweepSettings(methods=("newton", "modified-newton")))``
plans every (scenario, method) pair not yet in the results file and appends one record per pair
(:mod:`.sweep_store`). Methods:

- ``newton``, ``modified-newton``, ``nleq-err``: the Leapfrog planner with that local solver;
- ``shooting``: plain simple shooting over ``[0, T]`` from the affine costate guess (MNM), the
  baseline that Leapfrog improves on;
- ``direct``: the independent direct method (CasADi + IPOPT, RK4 multiple shooting on
  :data:`DIRECT_INTERVALS` intervals) as a multi-start: the straight line, bent lines (both
  heading choices) and the planner's initial paths (at least three), the cheapest success
  kept. Its cost is reported as is, mesh error included (at 100 intervals about 1e-4 to 1e-3
  relative, and above the true optimum of the same extremal), and its path is re-checked for
  clearance between the mesh nodes. It needs CasADi (the ``bench`` extra); without it the
  method is refused before any work;
- any :class:`SweepMethod` (a name and a picklable function), for one's own solvers.

Every answer is re-integrated and checked the same way (:func:`.results.validate`), so the costs
are comparable. The planner runs with ``SweepSettings.planner`` options; the sweep's default is
``initial_paths=1`` (one Leapfrog run per pair, the inner solver's own merit, several times
faster than the planner's default of three paths) and ``threads=1`` (the sweep is parallel over
pairs already); any planner option may be given instead.

Execution (:mod:`.sweep_exec`): local worker processes, or an existing Dask cluster. Each worker
process loads the compiled kernels once and keeps them. A pair that raises, exceeds its time limit
or kills its worker is recorded as failed with a reason; the sweep goes on.

Record fields: ``scenario``, ``method``, ``status`` (``converged``/``failed``), ``failure``
(``null``, ``solver``, ``collides`` (the path found passes through an obstacle), ``timeout``,
``crash`` or ``error``), ``message``, ``cost``,
``min_clearance``, ``end_state_error``, ``newton_iterations``, ``f_evals``, ``sweeps``,
``final_solver``, ``cheaper_motion`` (Leapfrog only: the cost of a collision-free motion
cheaper than the converged extremal, when one was seen; else ``null``), ``obstacles`` (count),
``scenario_hash`` and ``settings_hash`` (what was run; a resume with other content or settings
is refused), and the timings ``wall_time_s`` (the
solver's own), ``task_time_s`` (in the worker, with setup) and ``warmup_s`` (kernel loading, the
first pair of each worker process only). Timing fields end in ``_s``; the rest is deterministic.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from ..planning.scenario import Scenario
from .engines import DaskEngine, LocalEngine
from .store import ResultStore, StoreError, record_key
from .tasks import (
    BUILTIN_METHODS,
    DEFAULT_PLANNER_OPTIONS,
    FAILURES,
    PairTask,
    SweepError,
    SweepMethod,
    SweepSettings,
    TaskTimeout,
    failure_record,
    run_chunk,
    run_task,
    scenario_hash,
    settings_hash,
)

__all__ = [
    "BUILTIN_METHODS",
    "DEFAULT_PLANNER_OPTIONS",
    "PairTask",
    "SweepError",
    "SweepEvent",
    "SweepMethod",
    "SweepSettings",
    "SweepSummary",
    "TaskTimeout",
    "failure_record",
    "run_chunk",
    "run_sweep",
    "run_task",
    "scenario_hash",
    "settings_hash",
]


@dataclass(frozen=True)
class SweepEvent:
    """Progress: ``record`` just finished; ``done`` of ``total`` pairs (skipped ones included)."""

    done: int
    total: int
    skipped: int
    converged: int
    failed: int
    record: dict | None


@dataclass(frozen=True)
class SweepSummary:
    path: str
    total: int  # pairs in the sweep
    skipped: int  # already in the file when the sweep started
    ran: int
    converged: int  # among the pairs run now
    failed: int
    failures: dict[str, int]  # by reason, among the pairs run now
    wall_time_s: float
    compute_time_s: float  # sum of task_time_s over the pairs run now
    engine: str
    sorted: bool

    @property
    def complete(self) -> bool:
        return self.skipped + self.ran == self.total


# --------------------------------------------------------------------------- the sweep


def _tasks(scenarios: Iterable[Scenario], settings: SweepSettings) -> list[PairTask]:
    scenarios = list(scenarios)
    seen: dict[str, str] = {}
    for sc in scenarios:
        if not isinstance(sc, Scenario):
            raise SweepError(f"expected Scenario objects, got {type(sc).__name__}")
        if sc.name in seen:
            raise SweepError(
                f"two scenarios are named {sc.name!r} ({seen[sc.name]} and {sc.source or 'object'})"
            )
        seen[sc.name] = sc.source or "object"
    hashes = {
        m.name if isinstance(m, SweepMethod) else m: settings_hash(m, settings)
        for m in settings.methods
    }
    options = tuple(sorted(settings.options().items()))
    tasks = []
    for sc in scenarios:
        sh = scenario_hash(sc)
        for m in settings.methods:
            name = m.name if isinstance(m, SweepMethod) else m
            tasks.append(
                PairTask(len(tasks), sc, m, options, float(settings.time_limit), sh, hashes[name])
            )
    return tasks


def _check_resume(store: ResultStore, tasks: list[PairTask]) -> None:
    by_key = {record_key(r): r for r in store.records}
    for t in tasks:
        r = by_key.get(t.key)
        if r is None:
            continue
        if r.get("scenario_hash") != t.scenario_hash:
            raise SweepError(
                f"{store.path}: scenario {t.key[0]!r} was run with other content;"
                " use another results file"
            )
        if r.get("settings_hash") != t.settings_hash:
            raise SweepError(
                f"{store.path}: {t.key[1]} on {t.key[0]!r} was run with other settings;"
                " use another results file"
            )


def run_sweep(
    scenarios: Iterable[Scenario],
    out,
    settings: SweepSettings | None = None,
    *,
    progress: Callable[[SweepEvent], None] | None = None,
) -> SweepSummary:
    """Run every pair not yet in ``out`` (a JSONL file, created or resumed) and append it."""
    settings = settings or SweepSettings()
    t_begin = time.perf_counter()
    tasks = _tasks(scenarios, settings)
    # Connect first: an unreachable cluster leaves no results file behind.
    engine = (
        DaskEngine(settings.scheduler, settings) if settings.scheduler else LocalEngine(settings)
    )
    try:
        store = ResultStore.open(out)
    except StoreError as exc:
        engine.close()
        raise SweepError(str(exc)) from None
    with store, contextlib.closing(engine):
        _check_resume(store, tasks)
        todo = [t for t in tasks if t.key not in store.done]
        skipped = len(tasks) - len(todo)
        counts = {"converged": 0, "failed": 0}
        failures = dict.fromkeys(FAILURES, 0)
        compute = [0.0]

        def on_record(rec: dict) -> None:
            store.append(rec)
            counts[rec["status"]] += 1
            if rec["failure"]:
                failures[rec["failure"]] += 1
            compute[0] += rec.get("task_time_s") or 0.0
            if progress is not None:
                done = skipped + counts["converged"] + counts["failed"]
                progress(
                    SweepEvent(
                        done, len(tasks), skipped, counts["converged"], counts["failed"], rec
                    )
                )

        if progress is not None:
            progress(SweepEvent(skipped, len(tasks), skipped, 0, 0, None))
        if todo:
            engine.run(todo, on_record)
        complete = all(t.key in store.done for t in tasks)
        resorted = False
        if settings.sort and complete and todo:
            store.rewrite_sorted([t.key for t in tasks])
            resorted = True
    return SweepSummary(
        path=str(out),
        total=len(tasks),
        skipped=skipped,
        ran=counts["converged"] + counts["failed"],
        converged=counts["converged"],
        failed=counts["failed"],
        failures={k: v for k, v in failures.items() if v},
        wall_time_s=time.perf_counter() - t_begin,
        compute_time_s=compute[0],
        engine=engine.name,
        sorted=resorted,
    )
