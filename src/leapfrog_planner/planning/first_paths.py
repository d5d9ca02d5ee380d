"""The initial paths a plan runs first: the candidates of the scenario's world (discs and
polygons, or a map), those the robot can drive, ranked by their estimated cost, the cheapest
of each family (:func:`.search.select_paths`)."""

from __future__ import annotations

from ..integrate.problem import OptimalControlProblem
from .initial_path import InitialPath, initial_paths, points_away
from .initial_path.map_paths import map_initial_paths
from .path_ranking import drivable, rank_paths
from .scenario import Scenario
from .search import select_paths
from .settings import PlannerSettings

#: The share of a plan's time limit that building its paths may take: three-point turns are
#: built until then (each is two shortest paths of its own: 2.4 s among 10,000 discs), and the
#: rest of the limit is left to the runs.
PATHS_SHARE = 0.5


def first_paths(
    scenario: Scenario,
    settings: PlannerSettings,
    problem: OptimalControlProblem,
    robot: OptimalControlProblem,
    margin: float | None = None,
    deadline: float = float("inf"),
) -> tuple[list[InitialPath], list[InitialPath]]:
    """The paths a plan runs first and the extra ones it races against them (the ``more
    paths`` stage of :mod:`.search`), keeping ``margin`` (default: the settings' or the
    scenario's, the wider) from the obstacles. ``problem`` is what Leapfrog solves first (its
    penalty ranks the paths), ``robot`` the scenario's own problem (its planning aid says
    whether the robot turns in place). Raises :class:`.map_paths.Unreachable` where no path
    joins the ends. No three-point turn among discs is begun after ``deadline`` (a time of
    ``time.perf_counter``).

    Where an end heading points away from the chord, three-point turns are ranked with the
    paths of the homotopy classes. Elsewhere they are planned too, but the best one runs besides
    the class paths, and only when it is estimated cheapest of all: backing away from an
    obstacle next to an end looks cheap, and ranked with the others it took the place of paths
    that led to the optimum (docs/tuning.md)."""
    s, st = scenario, settings
    k = max(st.initial_paths + st.extra_paths, st.candidate_paths)
    margin = max(st.margin, s.margin) if margin is None else margin
    ends = (s.start[:3], s.goal[:3])  # poses: a model's further states are filled along
    if s.map is not None:
        world = problem.penalty.map
        candidates = map_initial_paths(
            *ends, world, s.footprint_obstacles, k=k, margin=margin, turns=True, where=s.map.where
        )
    else:
        candidates = initial_paths(
            *ends, s.footprint_obstacles, k=k, margin=margin, waypoints=s.waypoints, turns=True,
            turns_until=deadline,
        )  # fmt: skip
    candidates = _drivable(s, problem, robot, candidates)
    if len(candidates) < 2:  # nothing to rank: the estimate took 0.6 ms of paper case 1's 9
        return candidates, []
    ranked = rank_paths(problem, candidates, s.horizon, (s.start, s.goal))
    extra = (st.extra_paths, st.min_extra_paths)
    return select_paths(ranked, st.initial_paths, extra, points_away(s.start, s.goal))


def _drivable(s: Scenario, problem, robot, candidates: list[InitialPath]) -> list[InitialPath]:
    """The ``candidates`` the robot can drive (all of them where it can drive none): a robot
    that cannot reverse is given no path that does, nor one that cannot turn in place (the
    car) one that does so at an end."""
    keep = [True] * len(candidates)
    if s.control_bounds:
        keep = drivable(problem, candidates, s.horizon, s.control_bounds, (s.start, s.goal))
    aid = robot.model.aid
    if aid and aid.turns_in_place and robot.parameter(aid.parameter) == 0.0:
        keep = [
            k and not (p.modes.turn_start or p.modes.turn_goal)
            for k, p in zip(keep, candidates, strict=True)
        ]
    return [p for p, ok in zip(candidates, keep, strict=True) if ok] or candidates
