"""What a plan hands back, from the runs of Leapfrog it made: one run per initial path and
obstacle weight (:class:`PathRun`), the answer chosen among them (:func:`choose_answer`) and the
message that says why (:func:`plan_message`).

Converged: the collision-free extremal at the lowest obstacle weight, the cheapest of those,
checked against the other runs' collision-free iterates (a cheaper one is said). Otherwise the
best collision-free motion computed, marked as not optimal.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..integrate.flow import Flow, Trajectory
from ..integrate.problem import OptimalControlProblem
from ..model.bounds import bound_parameters
from .bounded import STOPPED
from .leapfrog import LeapfrogSolution, LeapfrogStatus
from .path_ranking import estimated_costs, path_states
from .results import PlanStatus, Validation, piecewise_trajectory
from .runs import PathRun
from .scenario import Scenario

#: A collision-free iterate of another path this much cheaper (relative) than a converged
#: extremal is reported in the message: 3 of 315 converged plans (default and general presets,
#: T = 0.1 to 100), two of them at T = 10.
CHEAPER_BY = 1e-3


@dataclass(frozen=True)
class Answer:
    """The trajectory a plan returns, its validation (extremals only) and where it came from."""

    trajectory: Trajectory
    validation: Validation | None
    source: str
    # Converged only: a collision-free Leapfrog iterate of another path that costs less than
    # the extremal, as (its run, its cost): a cheaper optimum exists that no run converged to.
    cheaper: tuple[PathRun, float] | None = None


@dataclass(frozen=True)
class Context:
    """What choosing the answer needs of the plan: the scenario and its problem, the samples of
    a returned trajectory, and the flow of the problem at an obstacle weight."""

    scenario: Scenario
    problem: OptimalControlProblem
    samples: int
    flow_of: Callable[[OptimalControlProblem], Flow]
    robot: OptimalControlProblem  # the scenario's own problem (no turn assist, its bounds)


@dataclass(frozen=True)
class Chosen:
    """A plan's answer: its status, the run it rests on and the trajectory returned."""

    status: PlanStatus
    run: PathRun
    answer: Answer


def choose_answer(runs: list[PathRun], ctx: Context) -> Chosen:
    """The status, the run it rests on, and the trajectory returned.

    Converged: the collision-free extremal at the lowest obstacle weight (the scenario's own
    when any path clears there), the cheapest of those, checked against the other runs'
    collision-free iterates that the robot can make (an iterate of the car with its turn
    assist is cheaper by turning where the car cannot). Otherwise a motion the robot can make
    first: the cheapest collision-free piecewise extremal of the sweeps (at the lowest weight),
    else the cheapest initial path followed as timed; only then one it cannot (a forward-only
    robot's iterate with its bounds relaxed), which the source says. Marked as not optimal."""
    clear = [r for r in runs if r.clear]
    if clear:
        best = min(clear, key=lambda r: (r.weight, r.validation.cost))
        v = best.validation
        rivals = [r for r in runs if r.weight == best.weight and r is not best]
        below = (1.0 - CHEAPER_BY) * v.cost
        found = next(
            (
                (r, tr)
                for r, tr in clear_iterates(rivals, ctx, below)
                if not unlike_robot(r.iterate_problem, tr, ctx)
            ),
            None,
        )
        cheaper = None if found is None else (found[0], float(found[0].run.arcs.cost.sum()))
        return Chosen(PlanStatus.CONVERGED, best, Answer(v.trajectory, v, "extremal", cheaper))
    extremals = [r for r in runs if r.extremal]
    status = PlanStatus.COLLIDES if extremals else PlanStatus.FAILED
    first = found = None  # the first collision-free iterate, and the first the robot can make
    for r, tr in clear_iterates(runs, ctx):  # (each integrated once)
        first = first or (r, tr)
        if not unlike_robot(r.iterate_problem, tr, ctx):
            found = (r, tr)
            break
    path_run, path_answer = _initial_path(runs, ctx)
    if found is None and unlike_robot(path_run.guide.problem, path_answer.trajectory, ctx):
        found = first
    if found is None:
        return Chosen(status, path_run, path_answer)
    r, tr = found
    what = f"Leapfrog iterate (q = {r.run.arcs.t.size - 1})"
    return Chosen(status, r, Answer(tr, None, _not_optimal(what, r.iterate_problem, tr, ctx)))


def _initial_path(runs: list[PathRun], ctx: Context) -> tuple[PathRun, Answer]:
    """The cheapest initial path followed as timed (a penalty-timed one may be far cheaper than
    the constant-speed paths: at T = 100, 0.86 against 34.8) that keeps the margin from the
    obstacles, as a collision-free iterate must, and a run from it: clearance as every answer
    is checked, at the samples returned (on a map a lower bound between them: on a 70 m route
    of a 100 m office maze, 1001 samples put the cheapest path 2.4 cm into a wall where its
    curve clears by at least 0.3 mm). Where none does, the one that comes nearest, and its
    source says how near."""
    paths = list(dict.fromkeys(r.path for r in runs))  # in order: the scenario's weight first
    s = ctx.scenario
    cost = estimated_costs(ctx.problem, paths, s.horizon, ends=(s.start, s.goal))
    where = np.linspace(0.0, 1.0, ctx.samples)  # the returned samples' points, uniform in time
    gaps = []
    for k in np.argsort(cost, kind="stable"):
        xy = path_states(paths[k], where, (s.start, s.goal))[:, :2]
        gaps.append((min_clearance(ctx.problem, xy), k))
        if gaps[-1][0] >= s.margin:
            break
    gap, k = max(gaps, key=lambda g: g[0])  # the first of equals: the cheapest
    run = next(r for r in runs if r.path is paths[k])
    tr = run.guide.trajectory(ctx.samples)
    what = "initial path"
    if gap < s.margin:
        near = f"{-gap:.3g} inside" if gap < 0.0 else f"within {gap:.3g} of"
        what += f" ({near} an obstacle: none keeps the margin {s.margin:g})"
    return run, Answer(tr, None, _not_optimal(what, run.guide.problem, tr, ctx))


#: Controls beyond a bound by more than this fraction of its range make a motion the robot
#: cannot make (the smooth saturation of the bounded problems leaves a bound by at most
#: ``eps^2 / (4 range)``, under 1% of the range at the widest ``eps``).
BOUND_SLACK = 0.01


def unlike_robot(problem: OptimalControlProblem, tr: Trajectory, ctx: Context) -> str:
    """Why ``tr``, a motion of ``problem``, is not one the robot can make (empty when it is):
    the parameters of its dynamics that differ from the robot's (the car's turn assist), and
    its controls beyond the robot's bounds (planned with the bounds relaxed, or an initial path
    followed as timed that drives faster than the robot can). The bounds and their smoothing
    are judged by the controls alone: they do not change the dynamics."""
    controls = problem.model.controls
    bounds = set(bound_parameters(controls))
    names = problem.model.parameters
    why = [
        f"{name} {mine:g} (the robot's {own:g})"
        for name, mine, own in zip(names, problem.parameters, ctx.robot.parameters, strict=True)
        if name not in bounds and mine != own
    ]
    for c, (lo, hi) in ctx.scenario.control_bounds.items():
        u = tr.u[:, controls.index(c)]
        if u.min() < lo - BOUND_SLACK * (hi - lo) or u.max() > hi + BOUND_SLACK * (hi - lo):
            why.append(f"{c} from {u.min():.3g} to {u.max():.3g} (the robot's {lo:g} to {hi:g})")
    return ", ".join(why)


def _not_optimal(what: str, problem: OptimalControlProblem, tr: Trajectory, ctx: Context) -> str:
    why = unlike_robot(problem, tr, ctx)
    return f"{what} with {why}: not a motion the robot can make" if why else f"{what}, not optimal"


def clear_iterates(runs: list[PathRun], ctx: Context, below: float = np.inf):
    """The last Leapfrog iterates (piecewise extremals: motions from start to goal) of ``runs``
    that clear the obstacles and cost less than ``below``, at the lowest obstacle weight first,
    cheapest first: ``(run, its trajectory)`` pairs, each integrated lazily with the flow of its
    own problem (:attr:`PathRun.iterate_problem`)."""
    for r in sorted(
        (r for r in runs if r.run.arcs is not None and r.run.arcs.cost.sum() < below),
        key=lambda r: (r.weight, float(r.run.arcs.cost.sum())),
    ):
        try:
            tr = piecewise_trajectory(ctx.flow_of(r.iterate_problem), r.run.arcs, ctx.samples)
        except ValueError:
            continue
        if min_clearance(ctx.problem, tr.x[:, :2]) >= ctx.scenario.margin:
            yield r, tr


def plan_message(chosen: Chosen, runs: list[PathRun], margin: float) -> str:
    """What the plan's message says: how the answer was found, or why none converged and what
    was returned instead."""
    status, best, answer = chosen.status, chosen.run, chosen.answer
    if status is PlanStatus.CONVERGED:
        msg = best.run.message
        if best.raises:
            msg += f"; {_raised(best, runs, margin)}"
        if answer.cheaper is not None:
            other, cost = answer.cheaper
            msg += (
                f"; but path {other.request.label} left a collision-free motion that is not an"
                f" extremal (its Leapfrog iterate) costing {cost:.6g}, less than this"
                f" extremal's {best.validation.cost:.6g}: a cheaper optimum exists that no"
                " run converged to"
            )
        return msg
    if status is PlanStatus.COLLIDES:
        worst = min(r.validation.clearance.min() for r in runs if r.extremal)
        top = max(r.weight for r in runs)
        weights = f"obstacle weight up to {top:g}" if top > 0 else "the obstacle weight is 0"
        if worst < 0.0:
            what = (
                f"every extremal found passes through an obstacle (down to {-worst:.3g}"
                f" inside, {weights})"
            )
        else:
            what = f"every extremal found {_too_close(worst, margin)} ({weights})"
    else:
        what = f"no initial path led to an extremal ({_failures(runs)})"
    return f"{what}; returned: the {answer.source}"


def _raised(best: PathRun, runs: list[PathRun], margin: float) -> str:
    """How the answer ``best``, at a raised obstacle weight, came to be: what its path's
    extremal did at the scenario's weight, or, for a path first ranked at a raised weight
    (:func:`.search.weight_raised`), what every extremal did there."""
    first = next((r for r in runs if r.same_line(best) and r.raises == 0), None)
    w0 = min(r.weight for r in runs)
    if first is not None and first.extremal:
        why = f"the extremal {_too_close(first.validation.clearance.min(), margin)}"
    else:
        why = "every extremal found passed through an obstacle or too close to one"
    return (
        f"the obstacle weight was raised from {w0:g} to {best.weight:g} to clear the"
        f" obstacles (at {w0:g} {why})"
    )


def _failures(runs: list[PathRun]) -> str:
    """Why the paths' runs (at the scenario's weight) failed: the runs that failed the same way
    together, how many, and the first of them. (Each run's message in full made a car's plan
    of 18 failed paths say 3,000 characters.)"""
    tried = [r for r in runs if not r.raises]
    if len(tried) == 1:
        return f"path {tried[0].request.label}: {tried[0].run.message}"
    groups: dict[str, list[PathRun]] = {}
    for r in tried:
        groups.setdefault(_how_failed(r), []).append(r)
    parts = []
    for how, same in groups.items():
        count = f"all {len(same)}" if len(same) == len(tried) else f"{len(same)} of {len(tried)}"
        first = f"{same[0].request.label}{_detail(same[0].run)}"
        parts.append(f"{how} on {count} paths (first: {first})")
    return "; ".join(parts)


def _how_failed(r: PathRun) -> str:
    """A failed run's reason, in the same words for runs that failed the same way."""
    run = r.run
    if run.status is LeapfrogStatus.SEGMENT_FAILED:  # the same strategies, whichever segment
        return run.message.replace(f"initial segment {run.failed_segment}", "an initial segment")
    if run.status is LeapfrogStatus.FINAL_FAILED:
        return "the final solve failed"
    if run.status is LeapfrogStatus.CONTINUATION_STOPPED:
        return STOPPED
    if run.status is LeapfrogStatus.ABANDONED:
        return "stopped, far dearer than the extremal of another path"
    if run.status is LeapfrogStatus.OUT_OF_TIME:
        return "not started: the time limit had passed"
    return "the re-integrated extremal missed the goal"  # one its validation did not confirm


def _detail(run: LeapfrogSolution) -> str:
    """What :func:`_how_failed` leaves out of the first such run: its segment, how its final
    solve failed, or where its continuation stopped."""
    if run.status is LeapfrogStatus.SEGMENT_FAILED:
        return f", segment {run.failed_segment}"
    if run.status is LeapfrogStatus.FINAL_FAILED:
        return f": {run.final_root.status}: {run.final_root.message}"
    if run.status is LeapfrogStatus.CONTINUATION_STOPPED:  # "at 40% (turn assist 0.6)"
        where = run.message[run.message.rfind(STOPPED) + len(STOPPED) :].strip()
        return f", {where}" if where else ""
    return ""


def min_clearance(problem: OptimalControlProblem, xy: np.ndarray) -> float:
    """The least clearance of the points ``xy`` (``(N, 2)``) from ``problem``'s obstacles
    (``inf`` without any)."""
    return float(problem.penalty.clearance(xy).min(initial=np.inf))


def _too_close(clearance: float, margin: float) -> str:
    if clearance < 0.0:
        return f"passed {-clearance:.3g} inside one"
    return f"came within {clearance:.3g} of one, closer than the margin {margin:g}"
