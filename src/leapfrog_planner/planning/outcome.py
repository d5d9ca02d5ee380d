"""A plan's :class:`.results.PlanResult`, from the runs of its search and the answer chosen."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .answer import Chosen, plan_message
from .results import PlanResult, Validation, penalty_integral
from .runs import PathRun, best_of
from .scenario import Scenario


@dataclass(frozen=True)
class Timing:
    """A plan's wall times: planning paths (the initial paths and the search's own work), the
    runs, and the whole plan."""

    paths_s: float
    runs_s: float
    wall_s: float


def _measures(chosen: Chosen, problem, goal: np.ndarray) -> dict:
    """The numbers of the returned trajectory: its validation's for an extremal, else
    computed from the trajectory (a motion that is not an extremal has no conditions to
    check)."""
    v, tr = chosen.answer.validation, chosen.answer.trajectory
    if v is None:
        penalty = penalty_integral(problem, tr)
        cost = float(tr.cost[-1])
        clearance = problem.penalty.clearance(tr.x[:, :2])
        error = float(np.linalg.norm(tr.x[-1] - goal))
        nan = float("nan")
        v = Validation(tr, cost, cost - penalty, penalty, clearance, error, nan, nan)
    names = ("cost", "energy", "penalty", "clearance", "end_state_error", "max_dH_du")
    return {n: getattr(v, n) for n in (*names, "hamiltonian_variation")}


def _times(runs: list[PathRun], runs_s: float) -> dict:
    """The runs' wall time (paths in parallel threads, each validated in its thread), split in
    the ratio of the parts' own times."""
    t_val = sum(r.validation_time_s for r in runs)
    sweeps = sum(r.run.sweep_time_s for r in runs)
    finals = sum(r.run.final_time_s for r in runs)
    share = runs_s / max(sweeps + finals + t_val, 1e-300)
    return {
        "time_sweeps_s": sweeps * share,
        "time_final_s": finals * share,
        "time_validation_s": t_val * share,
    }


def plan_result(
    scenario: Scenario,
    settings: dict,
    method: str,
    runs: list[PathRun],
    chosen: Chosen,
    problem,
    timing: Timing,
    notes: tuple[str, ...] = (),
) -> PlanResult:
    """The result of a plan: ``chosen`` among ``runs``, ``problem`` the returned trajectory's
    (at its run's obstacle weight), ``settings`` the planner's as JSON values, ``notes`` what
    the message adds about the search (:func:`.search.search_notes`)."""
    best, answer = chosen.run, chosen.answer
    run, info, optimal = best.run, problem.model, answer.validation is not None
    lines = [r for r in runs if not any(r.same_line(o) for o in runs[: runs.index(r)])]
    return PlanResult(
        status=chosen.status,
        message="; ".join([plan_message(chosen, runs, scenario.margin), *notes]),
        scenario=scenario.name,
        model=info.name,
        state_names=info.states,
        control_names=info.controls,
        method=method,
        final_solver=run.final_solver if optimal else None,
        initial_path=best.request.label,
        costate0=run.costate0 if optimal else None,
        trajectory=answer.trajectory,
        **_measures(chosen, problem, scenario.goal),
        max_costate_jump=run.max_costate_jump,
        initial_cost=run.initial_cost,
        history=run.history,
        initial_junctions=best.junctions,
        newton_iterations=sum(r.run.newton_iterations for r in runs),
        f_evals=sum(r.run.f_evals for r in runs),
        cost_increases=run.cost_increases,
        time_initial_path_s=timing.paths_s,
        **_times(runs, timing.runs_s),
        wall_time_s=timing.wall_s,
        alternatives=tuple(
            best_of([r for r in runs if r.same_line(line)]).outcome()
            for line in lines
            if not line.same_line(best)
        ),
        weight=best.weight,
        optimal=optimal,
        trajectory_source=answer.source,
        task=scenario,
        settings=settings,
        cheaper_motion=float("nan") if answer.cheaper is None else answer.cheaper[1],
        search=tuple(r.record() for r in runs),
    )


def unreachable_result(
    scenario: Scenario, settings: dict, method: str, problem, message: str, wall_s: float
) -> PlanResult:
    """The result of a plan whose start and goal are not connected: failed, with no motion (no
    initial path exists, so no run was made)."""
    from .status import PlanStatus

    nan, info = float("nan"), problem.model
    ends = (np.array([0.0, scenario.horizon]), np.vstack([scenario.start, scenario.goal]))
    return PlanResult(
        status=PlanStatus.FAILED, message=message, scenario=scenario.name, model=info.name,
        state_names=info.states, control_names=info.controls, method=method,
        final_solver=None, initial_path="none", costate0=None, trajectory=None, cost=nan,
        energy=nan, penalty=nan, clearance=np.zeros(0), end_state_error=nan,
        max_costate_jump=nan, max_dH_du=nan, hamiltonian_variation=nan, initial_cost=nan,
        history=(), initial_junctions=ends, newton_iterations=0, f_evals=0, cost_increases=0,
        time_initial_path_s=wall_s, time_sweeps_s=0.0, time_final_s=0.0,
        time_validation_s=0.0, wall_time_s=wall_s, alternatives=(), weight=scenario.weight,
        optimal=False, trajectory_source="none", task=scenario, settings=settings,
    )  # fmt: skip


def unreachable(result: PlanResult) -> bool:
    """Whether ``result`` says that start and goal are not connected (:func:`unreachable_result`:
    no initial path, so no run and no motion)."""
    return result.trajectory is None and not result.search and result.initial_path == "none"
