"""The planner's search as data: which Leapfrog runs to make, from the runs made so far.

A run is asked for by a :class:`RunRequest`: an initial path, the obstacle weight, the round
(:class:`Round`: Leapfrog's partitions and the value of the model's planning aid), the stage
that asks and why. Stages are pure functions of the runs so far (:data:`STAGES`); the planner
asks each in turn until it asks for nothing more, runs what it asks, and moves to the next
round (:func:`next_round`) when the stages of a round are done:

1. ``paths``: the initial paths of least estimated cost, one per family (:func:`select_paths`),
   and in the same batch ``more paths``: the next ones, while estimated within ``EXTRA_GATE``
   times the cheapest (and at least ``min_extra_paths`` of them), each stopped once a sweep
   (its second or a later one) leaves it ``ABANDON_FACTOR`` times dearer than the cheapest
   collision-free extremal of the first.
2. ``wider margin``: initial paths at the penalty's own margin, where those at the robot's
   margin led to no extremal, or were estimated far dearer than the extremals they led to.
3. ``penalty-timed``: still no extremal (an end in the penalty's grip): the paths followed at
   the pace the penalty sets.
4. ``weight raised``: every extremal passes through an obstacle: their paths again with the
   obstacle weight raised (x4, up to three times; by more for a model that drives dearer than
   the unicycle: :func:`raised_weight`).

Rounds: the first at the settings' partitions and the aid's first value (on a long route, more
partitions, halved down to more arcs: :func:`route_round`); when its answer falls short, the
same stages with twice the partitions (``finer_doublings`` times), and on a long route then
with twice the fewest arcs (:func:`finer_round`); when no run clears the obstacles and the
model has a planning aid, the stages again at its next value.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..errors import ModelError, ScenarioError
from ..integrate.problem import OptimalControlProblem
from ..model.aid import PlanningAid
from .answer import Chosen
from .initial_path import InitialPath
from .leapfrog.settings import MAX_PARTITIONS
from .path_ranking import estimated_costs, penalty_margin, penalty_timed
from .runs import LeadersBound, PathRun, Round, RunRequest
from .scenario import Scenario
from .settings import PlannerSettings
from .status import PlanStatus

log = logging.getLogger(__name__)

#: When no extremal clears the obstacles and some passed through one, those initial paths are
#: planned again with the obstacle weight raised by this factor, at most ``WEIGHT_RAISES`` times
#: (64 W in all; see docs/tuning.md), or by a larger factor for a model that drives dearer than
#: the unicycle (:func:`raised_weight`).
WEIGHT_FACTOR = 4.0
WEIGHT_RAISES = 3

#: When every initial path, followed at its own pace, is estimated at more than this many times
#: the cheapest collision-free extremal found, the paths at the penalty's margin whose estimate
#: is below that extremal's cost are run too (see docs/tuning.md).
WIDER_WHEN = 4.0

#: More paths run while estimated within this factor of the cheapest path, and each of them
#: stops when a sweep leaves it this many times dearer than the cheapest collision-free
#: extremal of the first paths: on the general preset (seed 1) the best known optimum on
#: 98.6% of 500 layouts (97.4% with a gate of 2, 94.4% from the three best-ranked paths
#: alone; a path's optimum is 0.01 to 0.7 times its estimate), at about 1.2 times the median
#: time of a gate of 2 (docs/tuning.md). Where the gate lets fewer than ``min_extra_paths`` (1)
#: through, the next-ranked run anyway: on the metric preset (a 10 m room, seed 1) the best
#: known optimum on 195 of 200 layouts against 191, at a median time ratio of 1.03 there and
#: 1.00 on the general preset (the same 200 answers).
EXTRA_GATE = 2.5
ABANDON_FACTOR = 3.0

#: A long route (:func:`route_round`) starts at this many partitions at least, and its levels
#: are halved down to this many arcs at least: on the office maze of 100 x 100 m (routes of 15
#: to 120 m at 0.5 m/s) 8 of 10 queries converged against 4 of 10 (docs/tuning.md).
LONG_ROUTE_PARTITIONS = 32
LONG_ROUTE_ARCS = 16


class Search:
    """What the stages read: the scenario, the settings, the initial paths (those run first
    and the extra ones: :func:`select_paths`), the model's planning aid, the first round
    (:func:`settings_round` fitted to the route: :func:`route_round`), the problem of each
    round (for estimates), initial paths at other margins (planned once) and the answer the
    runs so far give (``choose``)."""

    def __init__(
        self,
        scenario: Scenario,
        settings: PlannerSettings,
        paths: tuple[list[InitialPath], list[InitialPath]],
        aid: PlanningAid | None,
        problem_of: Callable[[Round], OptimalControlProblem],
        paths_at: Callable[..., list[InitialPath]],
        choose: Callable[[list[PathRun]], Chosen],
    ):
        self.scenario, self.settings, self.aid = scenario, settings, aid
        self.paths, self.extras = paths
        self.problem_of, self.paths_at, self.choose = problem_of, paths_at, choose
        self._wider: dict[float, list[InitialPath]] = {}
        self._weighted: dict[float, list[InitialPath]] = {}
        self.first = route_round(settings_round(settings, aid), scenario, settings, self.paths)

    def request(self, path, rnd: Round, stage: str, reason: str, raises: int = 0, **more):
        weight = raised_weight(self.scenario, raises)
        label = path.label + rnd.suffix(self.aid.parameter if self.aid else "")
        return RunRequest(path, rnd, stage, reason, weight, raises, label, **more)

    def estimates(self, paths: list[InitialPath], rnd: Round) -> np.ndarray:
        s = self.scenario
        return estimated_costs(self.problem_of(rnd), paths, s.horizon, ends=(s.start, s.goal))

    def wider_paths(self, margin: float) -> list[InitialPath]:
        """Initial paths at ``margin``, labelled with it; none when every gap closes at it."""
        if margin not in self._wider:
            try:
                wide = self.paths_at(margin)
            except ScenarioError:
                wide = []
            label = f", margin {margin:.3g}"
            self._wider[margin] = [replace(p, label=p.label + label) for p in wide]
        return self._wider[margin]

    def ranked_at(self, weight: float) -> list[InitialPath]:
        """The initial paths of least estimated cost at obstacle weight ``weight``."""
        if weight not in self._weighted:
            self._weighted[weight] = self.paths_at(weight=weight)
        return self._weighted[weight]


def raised_weight(scenario: Scenario, raises: int) -> float:
    """The obstacle weight after ``raises`` raises: ``W f^k`` with ``f = max(4, s^(1/3))``,
    where ``s`` (:func:`effort_scale`) is how much dearer the model drives straight ahead than
    the unicycle, so the last raise reaches at least ``W s``. The penalty deflects a motion
    only where it is large beside the control effort: a TurtleBot3's differential drive
    (wheels of 3.3 cm) pays 1836 times the unicycle's effort for the same motion, and at 0.5
    m/s on its own map its extremals at weights 4, 16 and 64 all passed through walls
    (docs/tuning.md)."""
    factor = max(WEIGHT_FACTOR, effort_scale(scenario) ** (1.0 / WEIGHT_RAISES)) if raises else 1.0
    return float(scenario.weight) * factor**raises


def effort_scale(scenario: Scenario) -> float:
    """The model's least effort of driving straight ahead over the unicycle's (1/2): 1 for
    the unicycle and the car, ``2 / r^2`` for the differential drive with wheels of radius
    ``r`` (:mod:`..model.cruise`); 1 for a model that cannot drive straight ahead."""
    from ..model import get_model  # SymPy: only when a weight is raised
    from ..model.cruise import straight_effort

    try:
        return 2.0 * straight_effort(get_model(scenario.model), scenario.model_parameters)
    except ModelError:
        return 1.0


def settings_round(settings: PlannerSettings, aid: PlanningAid | None) -> Round:
    """The first round as the settings set it: their partitions and fewest arcs, and the
    planning aid's first value."""
    lf = settings.leapfrog
    first = None if aid is None else aid.values[0]
    return Round(
        partitions=lf.partitions, fewest_arcs=lf.fewest_arcs, aid=first, reason="the initial paths"
    )


def route_round(first: Round, scenario: Scenario, settings: PlannerSettings, paths) -> Round:
    """The first round of a plan whose initial paths are ``paths``: ``first`` (the settings'
    partitions and fewest arcs), or, on a map where the shortest of them is at least
    ``settings.long_route`` of the penalty's length scales long, at least
    :data:`LONG_ROUTE_PARTITIONS` partitions halved down to at least :data:`LONG_ROUTE_ARCS`
    arcs: on such a route the arcs of fewer partitions cross many walls and corridors, too long
    for the local problems, and the levels merged further too long for the final solves."""
    if not settings.long_route or scenario.map is None or not paths:
        return first
    scale = scenario.map.obstacles(scenario.robot_radius).length
    route = min(p.length for p in paths) / scale
    if route < settings.long_route:
        return first
    q = max(first.partitions, LONG_ROUTE_PARTITIONS)
    arcs = max(first.fewest_arcs, LONG_ROUTE_ARCS)
    log.info("a route of %.0f length scales: q = %d, halved down to %d arcs", route, q, arcs)
    why = f"a route of {route:.0f} length scales: q = {q}, halved down to {arcs} arcs"
    return replace(first, partitions=q, fewest_arcs=arcs, reason=f"{first.reason} ({why})")


def family(path: InitialPath) -> tuple:
    """Paths of one family tend to one optimum: a class path's family is its homotopy class
    and direction (variants that only add a turn in place at an end are one family). Each
    three-point turn is a family of its own: turns at other cusps lead to other optima (taken
    one per direction, 4 of 540 general and car layouts came out up to 60% dearer)."""
    m = path.modes
    return ("three-point turn", path.label) if m.cusp else ("class", path.signature, m.reverse)


def select_paths(
    ranked: list[tuple[float, InitialPath]],
    first: int,
    extra: tuple[int, int],
    turns_ranked: bool,
) -> tuple[list[InitialPath], list[InitialPath]]:
    """The paths to run first and the extra ones, from ``(estimate, path)`` pairs cheapest
    first: the ``first`` best-ranked, one per family while there are families left (then by
    rank), and after them up to ``extra[0]`` more estimated within ``EXTRA_GATE`` times the
    cheapest, at least ``extra[1]`` of them (the next-ranked) whatever their estimate.
    Three-point turns are ranked with the others where ``turns_ranked`` (an end heading
    points away from the chord); elsewhere the best one runs first besides them, and only
    when it is estimated cheapest of all (:meth:`.Planner.initial_paths`)."""
    most, least = extra
    cheapest = ranked[0][0]
    pool = [(c, p) for c, p in ranked if turns_ranked or not p.modes.cusp]
    families: set = set()
    distinct, repeats = [], []
    for c, p in pool:
        (repeats if family(p) in families else distinct).append((c, p))
        families.add(family(p))
    pool = distinct + repeats
    paths = [p for _, p in pool[:first]]
    extras = [p for c, p in pool[first : first + most] if c <= EXTRA_GATE * cheapest]
    beyond = [p for _, p in pool[first:] if p not in extras]  # (in rank order)
    extras += beyond[: max(0, min(least, most) - len(extras))]
    if not turns_ranked and ranked[0][1].modes.cusp:
        paths.append(ranked[0][1])
    return paths, extras


def search_notes(
    scenario: Scenario, settings: PlannerSettings, asked: int, ran: int, cut: bool
) -> tuple[str, ...]:
    """What a plan's message adds about its search: fewer initial paths ran than ``asked``
    (:func:`fewer_paths_note`), and the time limit cut it short (``cut``), whatever the
    answer."""
    notes = [fewer_paths_note(scenario, asked, ran)]
    if cut:
        notes.append(f"the time limit of {settings.time_limit:g} s cut the search short")
    return tuple(n for n in notes if n)


def fewer_paths_note(scenario: Scenario, asked: int, ran: int) -> str:
    """Why a plan ran fewer initial paths than the ``asked`` (an ``initial_paths`` other than
    the default, which asks for up to 3): waypoints allow one way round the obstacles, and
    elsewhere there may be fewer distinct ways than asked. ``""`` when none is due."""
    if ran >= asked or asked == PlannerSettings().initial_paths:
        return ""
    why = (
        "the waypoints fix the way round the obstacles"
        if scenario.waypoints is not None and len(scenario.waypoints)
        else "no more distinct paths round the obstacles were found"
    )
    return f"{ran} initial path{'s' if ran > 1 else ''} ran, not the {asked} asked: {why}"


Stage = Callable[[Search, Round, list[PathRun]], list[RunRequest]]


def _asked(runs: list[PathRun], stage: str) -> list[PathRun]:
    return [r for r in runs if r.request.stage == stage]


def ranked_paths(search: Search, rnd: Round, runs: list[PathRun]) -> list[RunRequest]:
    """The initial paths of least estimated cost (:meth:`.Planner.initial_paths`) and the
    extra ones (:func:`select_paths`, stage ``more paths``), raced against them: each extra
    stops at the first sweep (from its second) that leaves it ``ABANDON_FACTOR`` times dearer
    than their cheapest collision-free extremal. The extras follow the first paths in one
    batch (with the default ``threads``, one per run, all start at once; with fewer, as
    threads free up); the bound is known when the first paths have all ended, and a run
    judged then as if it had known it from its start (:class:`.leapfrog.stop.StopRule`): the
    answer does not depend on which run ends first."""
    if runs:
        return []
    race = LeadersBound(len(search.paths), ABANDON_FACTOR) if search.extras else None
    first = [search.request(p, rnd, "paths", rnd.reason, leads=race) for p in search.paths]
    why = (
        f"estimated within {EXTRA_GATE:g} times the cheapest path; stopped when"
        f" {ABANDON_FACTOR:g} times dearer than the first paths' cheapest extremal"
    )
    extra = [search.request(p, rnd, "more paths", why, stop_above=race) for p in search.extras]
    return first + extra


def wider_margin(search: Search, rnd: Round, runs: list[PathRun]) -> list[RunRequest]:
    """The paths at the penalty's own distance (:func:`penalty_margin`). Where the penalty
    dwarfs the control energy near the obstacles (a long horizon or a heavy weight), paths at
    the robot's margin are poor starts: when no run found an extremal, all of them run; when
    every path run, followed at its own pace, is estimated at more than ``WIDER_WHEN`` times
    the cheapest collision-free extremal found, those estimated cheaper than every path run.
    (Every path of a homotopy class, that is: the three-point turn, run besides them, backs
    away from the obstacles in its own way and is no measure of how poor their margin is.)"""
    wide = penalty_margin(search.scenario)
    if _asked(runs, "wider margin") or not wide > search.settings.margin:
        return []
    if not any(r.extremal for r in runs):
        why = f"no extremal from the paths at the robot's margin: margin {wide:.3g}"
        log.info("no extremal: initial paths again with margin %.3g", wide)
        return [search.request(p, rnd, "wider margin", why) for p in search.wider_paths(wide)]
    clear = [r.validation.cost for r in runs if r.clear]
    run = search.paths + search.extras
    plain = [p for p in run if not p.modes.cusp] or run
    top = float(search.estimates(plain, rnd).min())
    if not (clear and top > WIDER_WHEN * min(clear)):
        return []
    why = (
        f"the paths were estimated at {top:.4g}, over {WIDER_WHEN:g} times the extremal's cost"
        f" {min(clear):.4g}"
    )  # (the extremal may cost 0: the goal at the start)
    log.info("%s: margin %.3g too", why, wide)
    wider = search.wider_paths(wide)
    cheaper = [p for p, c in zip(wider, search.estimates(wider, rnd), strict=True) if c < top]
    return [search.request(p, rnd, "wider margin", why) for p in cheaper]


def timed_by_penalty(search: Search, rnd: Round, runs: list[PathRun]) -> list[RunRequest]:
    """Still no extremal (a start or goal in the penalty's grip): the paths timed by it (the
    paths at the wider margin, where those ran in place of the first)."""
    s = search.scenario
    if _asked(runs, "penalty-timed") or any(r.extremal for r in runs) or not s.weight > 0.0:
        return []
    wider = _asked(runs, "wider margin")
    replaced = wider and not any(r.extremal for r in _asked(runs, "paths"))
    paths = [r.path for r in wider] if replaced else search.paths
    log.info("no extremal: the paths again, timed by the penalty")
    problem = search.problem_of(rnd)
    timed = [penalty_timed(problem, p, s.horizon) for p in paths]
    why = "no extremal yet: the paths followed at the pace the penalty sets"
    return [search.request(p, rnd, "penalty-timed", why) for p in timed]


def weight_raised(search: Search, rnd: Round, runs: list[PathRun]) -> list[RunRequest]:
    """No path clears at the scenario's weight, and some extremal passed through an obstacle:
    those paths again with the weight raised, until one clears (also where a path's run at the
    last raise failed: a higher weight may still clear), and, where a raise is by more than
    :data:`WEIGHT_FACTOR`, the paths ranked first at the raised weight (the penalty's share of
    the estimates changes their order); unless every run at the last raise failed (the higher
    weights are stiffer still) at a weight that gives the penalty at least the role it has for
    the unicycle (``W s``: :func:`raised_weight`)."""
    raises = 1 + max((r.raises for r in runs), default=0)
    if raises > WEIGHT_RAISES or any(r.clear for r in runs) or not search.scenario.weight > 0:
        return []
    collided = [r.path for r in runs if r.collides]
    last = [r for r in runs if r.raises == raises - 1]
    again = list(dict.fromkeys(r.path for r in last if any(r.path is c for c in collided)))
    if not again:
        return []
    s = search.scenario
    before = raised_weight(s, raises - 1)
    if raises > 1 and not any(r.extremal for r in last) and before >= s.weight * effort_scale(s):
        log.info("no extremal at weight %g: not raised further", before)
        return []
    weight = raised_weight(s, raises)
    log.info("no extremal clears the obstacles: weight %g", weight)
    why = "every extremal found passes through an obstacle"
    asked = [search.request(p, rnd, "weight raised", why, raises) for p in again]
    if weight > WEIGHT_FACTOR * before:  # a larger raise ranks the paths anew
        why += f"; ranked first at weight {weight:.6g}"
        run = {p.label for p in again}
        ranked = [p for p in search.ranked_at(weight) if p.label not in run]
        asked += [search.request(p, rnd, "weight raised", why, raises) for p in ranked]
    return asked


#: The stages of a round, in order; each is asked until it asks for nothing more.
STAGES: tuple[Stage, ...] = (ranked_paths, wider_margin, timed_by_penalty, weight_raised)


def falls_short(runs: list[PathRun], chosen: Chosen, long_route: bool = False) -> str:
    """Why the answer of ``runs`` falls short (empty when it does not): no extremal at all, none
    that clears the obstacles (also after the round's weight raises: office maze query 26, whose
    first round found only extremals through walls and whose finer one found the optimum), a
    collision-free iterate cheaper than the best extremal, or no extremal from a path of a
    homotopy class (a three-point turn's alone). On a ``long_route`` (levels halved down to
    more than 2 arcs) also: the answer clears only at a raised obstacle weight, or an extremal
    at its weight that passes through an obstacle is cheaper (on the office maze a finer
    round found a cheaper collision-free optimum beside such extremals: docs/tuning.md)."""
    if chosen.status is PlanStatus.FAILED:
        return "no extremal"
    if chosen.status is PlanStatus.COLLIDES:
        return "no extremal clears the obstacles"
    if chosen.answer.cheaper is not None:
        return "a collision-free iterate is cheaper than the extremal"
    if not any(r.extremal for r in runs if not r.path.modes.cusp):
        return "no extremal from a path of a homotopy class"
    if not long_route:
        return ""
    best = chosen.run
    if best.raises:
        return "it clears only at a raised obstacle weight"
    if any(
        r.collides and r.weight == best.weight and r.validation.cost < best.validation.cost
        for r in runs
    ):
        return "a cheaper extremal passes through an obstacle"
    return ""


def next_round(search: Search, rnd: Round, runs: list[PathRun]) -> Round | None:
    """The round after ``rnd``, whose stages are done, or None: the search ends. While the
    answer falls short, finer rounds (:func:`finer_round`); then, while no run clears the
    obstacles, the aid's next value."""
    finer = None if rnd.aid_step else finer_round(search, rnd, runs)
    if finer is not None:
        return finer
    aid = search.aid
    if aid is None or rnd.aid_step + 1 >= len(aid.values) or any(r.clear for r in runs):
        return None
    value = aid.values[rnd.aid_step + 1]
    name = aid.parameter.replace("_", " ")
    log.info("no extremal clears: the paths again, %s %g", name, value)
    reason = f"no extremal cleared the obstacles: {name} {value:g}"
    return replace(search.first, aid=value, reason=reason, aid_step=rnd.aid_step + 1)


def finer_round(search: Search, rnd: Round, runs: list[PathRun]) -> Round | None:
    """The round after ``rnd`` while the answer of ``runs`` falls short (:func:`falls_short`):
    twice the partitions, ``finer_doublings`` times; then, on a long route (levels halved down
    to more than 2 arcs: :func:`route_round`), once more at those partitions with twice the
    fewest arcs (the office maze's routes of 98 to 172 s: 3 of 20 more converge). None when
    the answer does not fall short or no finer round is left."""
    first, doubled, arcs = search.first, rnd.partitions * 2, rnd.fewest_arcs * 2
    long_route = first.fewest_arcs > 2
    if rnd.doublings < search.settings.finer_doublings and doubled <= MAX_PARTITIONS:
        finer = {"partitions": doubled, "doublings": rnd.doublings + 1}
        how = f"twice the partitions, q = {doubled}"
    elif (
        long_route
        and rnd.doublings
        and rnd.fewest_arcs == first.fewest_arcs
        and arcs <= rnd.partitions
    ):
        finer, how = {"fewest_arcs": arcs}, f"twice the fewest arcs, levels halved down to {arcs}"
    else:
        return None
    why = falls_short(runs, search.choose(runs), long_route)
    if not why:
        return None
    log.info("the answer falls short (%s): the stages again with %s", why, how)
    return replace(rnd, reason=f"the answer fell short ({why}): {how}", **finer)
