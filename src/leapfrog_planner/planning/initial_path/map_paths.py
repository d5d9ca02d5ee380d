"""Initial paths on a map: the routes of :mod:`.map_routes` (the shortest route per homotopy
class through the map's free space), smoothed and fitted to the end poses as the disc paths are
(forward, reverse, turns in place, three-point turns), their clearance measured against the
map's cells.

Discs given beside a map are not routed round here: the map's routes see the map alone, and the
discs' clearance enters the path's ``min_clearance`` (the planner then prefers paths that clear
both).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ScenarioError
from ...world.obstacle_map import ObstacleMap
from .curve import SmoothCurve
from .ends import (
    Drive,
    EndModes,
    PoseCurve,
    Turn,
    angle_of,
    end_modes,
    near_branch,
    points_away,
)
from .geometry import clean_polyline, end_state, midpoints, point_text, smallest_clearance
from .map_routes import MapRoute, map_routes
from .path import InitialPath, path_from_curve, smooth_path

#: Times mid-leg points are inserted when a smoothed curve cuts a corner into a blocked cell.
MIDPOINT_ROUNDS = 2
#: Cusp points of three-point turns along the start (goal) heading, as fractions of the chord.
CUSP_STEPS = (0.25, 0.5)
#: The clearance of a smoothed curve is measured at points this many cells apart at most.
SAMPLE_CELLS = 0.5

NO_DISCS = np.zeros((0, 3))
NO_DISCS.setflags(write=False)


class Unreachable(ScenarioError):
    """Start and goal lie in parts of the map's free space that the robot cannot pass between."""


def map_initial_paths(
    start, goal, world: ObstacleMap, discs=NO_DISCS, *, k: int = 3, margin: float = 0.05,
    turns: bool = False, where: str = "on the map",
) -> list[InitialPath]:  # fmt: skip
    """Collision-free initial paths on ``world`` in up to ``k`` homotopy classes, shortest first,
    each with its ways of meeting the end poses, then the three-point turns (with ``turns`` or
    where an end heading points away from the chord). Raises :class:`Unreachable` when start and
    goal are not connected for the robot's footprint (``where``: "on the map", "around the
    walls", ... as its message says it)."""
    S, G = end_state(start, "start"), end_state(goal, "goal")
    routes = map_routes(world.route_cells, S[:2], G[:2], world.radius, margin, k=k)
    if not routes:
        raise Unreachable(
            f"start {_point(S)} and goal {_point(G)} are not connected {where} for a robot"
            f" of radius {world.radius:g}"
        )
    tol = 1e-9 * max(1.0, float(np.abs(np.concatenate([S[:2], G[:2]])).max()))
    out = []
    for rank, route in enumerate(routes, start=1):
        name = "straight" if route.points.shape[0] == 2 else f"map route #{rank}"
        if route.margin != margin:
            name += f" (margin {route.margin:g})"
        poly = clean_polyline(np.asarray(route.points, dtype=float), S[:2], G[:2], tol)
        for modes in end_modes(poly, S, G):
            path = _smoothed(poly, S, G, world, discs, tol, route, modes)
            how = modes.describe()
            out.append(replace(path, label=f"{name}, {how}" if how else name))
    if turns or points_away(S, G):
        out += _three_point_turns(S, G, world, discs, routes[0].margin, tol)
    return out


def _point(state) -> str:
    return f"({state[0]:.6g}, {state[1]:.6g})"


def clearance_of(path: InitialPath, world: ObstacleMap, discs) -> float:
    """The least clearance of ``path``'s smoothed curve against the map (a proven lower bound
    between samples half a cell apart) and the discs."""
    n = max(64, int(math.ceil(path.length / (SAMPLE_CELLS * world.occupancy.resolution))) + 1)
    xy, _ = path.curve(np.linspace(0.0, 1.0, min(n, 200_001)))
    clear = world.path_clearance(xy)
    return min(clear, smallest_clearance(xy, discs)) if discs.shape[0] else clear


def _smoothed(poly, S, G, world, discs, tol, route: MapRoute, modes: EndModes) -> InitialPath:
    """The smoothed path of ``poly`` for ``modes``; where it cuts a corner into a blocked cell,
    mid-leg points pull it closer to the polyline (twice at most); the clearest is kept. Its
    homotopy class is the route's, round the map's islands of blocked cells (the planner runs
    one path per class and direction first: with the class of the discs alone, every route of a
    map was one class, and a cheaper route in reverse was never run)."""
    best = None
    for _ in range(MIDPOINT_ROUNDS + 1):
        path = smooth_path(poly, S, G, NO_DISCS, "", tol, route.signature, modes)
        path = replace(path, min_clearance=clearance_of(path, world, discs))
        if best is None or path.min_clearance > best.min_clearance:
            best = path
        if path.min_clearance >= 0.0:
            break
        poly = midpoints(poly)
    return replace(best, signature=route.signature)


def _three_point_turns(S, G, world, discs, margin, tol) -> list[InitialPath]:
    """Drive along the start heading (forwards, or backwards) to a cusp point, turn there in
    place, drive the other way into the goal; each leg the map's shortest route. Cusp points
    that the robot cannot stand on with ``margin`` are skipped."""
    chord = math.hypot(*(G[:2] - S[:2]))
    out = []
    for reverse in (False, True):
        off0, off1 = (math.pi, 0.0) if reverse else (0.0, math.pi)
        e0 = np.array([math.cos(S[2] + off0), math.sin(S[2] + off0)])
        m1 = np.array([math.cos(G[2] + off1), math.sin(G[2] + off1)])
        points = [S[:2] + f * chord * e0 for f in CUSP_STEPS]
        points += [G[:2] - f * chord * m1 for f in CUSP_STEPS]
        for C in points:
            if chord <= tol or float(world.clearance_at(C)) < margin:
                continue
            path = _cusp_path(S, G, C, off0, off1, world, discs, margin, tol, reverse)
            if path is not None:
                label = f"three-point turn at {point_text(C, tol)}, {path.modes.describe()}"
                out.append(replace(path, label=label))
    return out


def _cusp_path(S, G, C, off0, off1, world, discs, margin, tol, reverse) -> InitialPath | None:
    legs = [
        map_routes(world.route_cells, a, b, world.radius, margin, k=1)
        for a, b in ((S[:2], C), (C, G[:2]))
    ]
    if not (legs[0] and legs[1]):
        return None
    first, second = (np.asarray(leg[0].points, dtype=float) for leg in legs)
    h0 = S[2] + off0
    one = SmoothCurve(first, h0, angle_of(first[-1] - first[-2]), free_end=True)
    at_cusp = one.theta1 - off0
    h2 = near_branch(angle_of(second[1] - second[0]), at_cusp + off1)
    two = SmoothCurve(second, h2, G[2] + off1)
    pieces = [Drive(one, off0), Turn(C, at_cusp, h2 - off1), Drive(two, off1)]
    poly = np.vstack([first, second[1:]])
    modes = EndModes(reverse=reverse, cusp=True)
    path = path_from_curve(poly, PoseCurve(pieces), S, G, NO_DISCS, "", tol, (), modes)
    return replace(path, min_clearance=clearance_of(path, world, discs))
