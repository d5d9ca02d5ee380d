"""Initial paths: the shortest paths round the obstacles in several homotopy classes, their
ways of meeting the end poses, three-point turns and waypoint paths."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ... import checks
from ...errors import ScenarioError, require_integer
from .curve import SmoothCurve
from .ends import (
    FORWARD,
    Drive,
    EndModes,
    PoseCurve,
    Turn,
    angle_of,
    end_modes,
    near_branch,
    points_away,
    with_turns,
)
from .geometry import (
    clean_polyline,
    end_state,
    midpoints,
    point_text,
    segment_distance,
    tolerance,
)
from .path import InitialPath, path_from_curve, smooth_path
from .tangent_graph import TangentGraph

#: At most this many obstacles get barrier rays (``2**MAX_RELEVANT`` Dijkstra runs).
MAX_RELEVANT = 6
#: Paths longer than this factor times the shortest path are dropped.
MAX_DETOUR = 3.0
#: Margin factors tried when the smoothed curve of a path cuts into an obstacle.
_RETRY_MARGIN_FACTORS = (2.0, 4.0)
#: A class is re-planned with a larger margin among the obstacles whose inflated disc comes
#: within this many times that margin of the class's path (a tangent graph of a few dozen discs
#: instead of all of them); its path is then checked against every obstacle.
_RETRY_BAND = 5.0
#: Paths are first planned among the obstacles that a path this many times the straight
#: distance long could touch (an ellipse round the ends), the ellipse grown until it holds the
#: paths found (:func:`_plan`).
_ROUTE_STRING = 1.05
#: Times mid-leg points are inserted (at the same margin) before the margin is increased.
_MIDPOINT_ROUNDS = 2
#: Margins tried, as fractions of the requested one, until some path exists; then margin 0.
_MARGIN_FALLBACK = (1.0, 0.5, 0.25, 0.125, 0.0625)


#: A cusp point is used only this many start-goal distances away at most.
_CUSP_REACH = 2.0
#: Cusp points along the start (goal) heading, as fractions of the start-goal distance.
_CUSP_STEPS = (0.25, 0.5)


def _cusp_points(S, G, e0: np.ndarray, m1: np.ndarray, chord: float) -> list[np.ndarray]:
    """Where a three-point turn may reverse: along the start's line of motion ``e0`` (backing
    out, or driving on, a quarter or half of the chord), along the goal's ``m1`` (driving past
    the goal and back in), and where the two lines meet ahead of both ends."""
    points = [S[:2] + f * chord * e0 for f in _CUSP_STEPS]
    points += [G[:2] - f * chord * m1 for f in _CUSP_STEPS]
    M = np.column_stack([e0, m1])
    if abs(np.linalg.det(M)) > 1e-3:
        a, b = np.linalg.solve(M, G[:2] - S[:2])
        if 0.0 < a <= _CUSP_REACH * chord and 0.0 < b <= _CUSP_REACH * chord:
            points.append(S[:2] + a * e0)
    return points


def _cusp_paths(S, G, obs, margin, tol, until=math.inf) -> list[tuple[np.ndarray, InitialPath]]:
    """Three-point turns: drive from the start along its heading (forwards, and also
    backwards) to a cusp point (:func:`_cusp_points`), turn there in place as far as needed,
    and drive the other way into the goal, arriving along its heading. Each leg goes round the
    obstacles by its shortest way; cusp points inside an inflated obstacle are skipped, and
    no turn is begun, nor its second leg, after ``until`` (a time of ``time.perf_counter``).
    Returns ``(cusp point, path)`` pairs."""
    chord = math.hypot(*(G[:2] - S[:2]))
    out = []
    for reverse in (False, True):
        off0, off1 = (math.pi, 0.0) if reverse else (0.0, math.pi)
        e0 = np.array([math.cos(S[2] + off0), math.sin(S[2] + off0)])  # leaving the start
        m1 = np.array([math.cos(G[2] + off1), math.sin(G[2] + off1)])  # arriving at the goal
        for C in _cusp_points(S, G, e0, m1, chord):
            if min(math.hypot(*(C - S[:2])), math.hypot(*(C - G[:2]))) <= tol or (
                obs.shape[0] and np.any(np.hypot(*(C - obs[:, :2]).T) <= obs[:, 2] + margin)
            ):
                continue
            path = _cusp_path(S, G, C, off0, off1, obs, margin, tol, reverse, until)
            if path is None:
                return out
            out.append((C, path))
    return out


def _cusp_path(S, G, C, off0, off1, obs, margin, tol, reverse, until) -> InitialPath | None:
    """Drive (heading = tangent - ``off0``) from the start to ``C``, turn in place, drive
    (heading = tangent - ``off1``) to the goal; None when a leg would begin after ``until``."""
    if time.perf_counter() >= until:
        return None
    first = _route(S[:2], C, obs, margin, tol)
    if time.perf_counter() >= until:
        return None
    second = _route(C, G[:2], obs, margin, tol)
    h0 = S[2] + off0
    first, _ = with_turns(first, h0, angle_of(first[-1] - first[-2]), obs, tol, None)
    one = SmoothCurve(first, h0, angle_of(first[-1] - first[-2]), free_end=True)
    at_cusp = one.theta1 - off0  # the heading on arriving at the cusp
    h2 = near_branch(angle_of(second[1] - second[0]), at_cusp + off1)
    h3 = G[2] + off1
    second, _ = with_turns(second, h2, h3, obs, tol, None)
    two = SmoothCurve(second, h2, h3)
    pieces = [Drive(one, off0), Turn(C, at_cusp, h2 - off1), Drive(two, off1)]
    poly = np.vstack([first, second[1:]])
    modes = EndModes(reverse=reverse, cusp=True)
    return path_from_curve(poly, PoseCurve(pieces), S, G, obs, "", tol, None, modes)


# --------------------------------------------------------------------------- planning


@dataclass(frozen=True)
class _Candidate:
    signature: tuple[int, ...]
    graph_length: float
    nodes: np.ndarray
    order: int
    graph: TangentGraph = field(repr=False)

    @property
    def polyline(self) -> np.ndarray:
        return self.graph.polyline(self.nodes)


def _plan(
    S: np.ndarray, G: np.ndarray, obs: np.ndarray, margin: float, k: int, tol: float
) -> list[_Candidate] | None:
    """The first ``k`` of :func:`_plan_among` every obstacle (None when there is no path),
    planned among the obstacles that a path of length ``s`` could touch: those that meet the
    ellipse ``|p - S| + |p - G| <= s`` (``s`` first :data:`_ROUTE_STRING` times the chord).

    Paths no longer than ``s`` lie in the ellipse: they clear the obstacles outside it, wind
    round none of them, and more obstacles only make paths longer. So when the ``k``-th path
    found is no longer than ``s``, and the obstacles outside would not be among the barriers
    (:func:`_barriers`), the first ``k`` are those of every obstacle. Otherwise ``s`` grows to
    what they need, and again. No path among these obstacles means none among all. At 1,000
    obstacles a tangent graph of a few hundred discs instead of all of them."""
    S2, G2 = S[:2], G[:2]
    R, dS, dG = _inflated(obs, S2, G2, margin)
    reach = dS + dG - 2.0 * R  # |p - S| + |p - G| >= reach on the inflated disc
    s = _ROUTE_STRING * math.hypot(*(G2 - S2)) + tol
    while True:
        near = np.flatnonzero(reach <= s)
        if near.size == obs.shape[0]:
            cands = _plan_among(S, G, obs, margin, k, tol)
            return None if cands is None else cands[:k]
        cands = _plan_among(S, G, obs[near], margin, k, tol)
        if cands is None:
            return None
        need = _string_needed(cands, S2, G2, obs, R, near, reach, k, tol)
        if need <= s:
            m = obs.shape[0]
            return [replace(c, signature=_widened(c.signature, near, m)) for c in cands[:k]]
        s = _ROUTE_STRING * need + tol


def _string_needed(cands, S2, G2, obs, R, near, reach, k, tol) -> float:
    """The ellipse's string that the first ``k`` of ``cands`` (planned among the obstacles
    ``near``) need to be those of every obstacle: the ``k``-th path's length (or the longest
    detour kept, with fewer), and the reach of any obstacle outside that would be a barrier."""
    shortest = cands[0].graph_length
    need = cands[k - 1].graph_length if len(cands) >= k else MAX_DETOUR * shortest + tol
    graph = cands[0].graph
    if k > 1 and math.hypot(*(G2 - S2)) > tol:
        candidates = np.ones(obs.shape[0], bool)  # those outside may be active: assume so
        candidates[near] = False
        candidates[near[graph.active]] = True
        idx = np.flatnonzero(candidates)
        top = _barriers(S2, G2, obs[idx, :2], R[idx], cands[0].polyline, shortest, idx, tol)
        need = max(need, float(np.max(reach[top], initial=0.0)))
    return need


def _barriers(S2, G2, C, R, shortest_path, shortest, index, tol) -> np.ndarray:
    """The obstacles (of ``index``) whose barrier rays split the paths into classes: of those
    whose centre projects inside the chord and whose inflated disc comes closer than the
    shortest path's length to the chord or to that path, the :data:`MAX_RELEVANT` closest."""
    chord = G2 - S2
    e = chord / math.hypot(*chord)
    proj = (C - S2) @ e
    to_chord = segment_distance(S2[None, :], G2[None, :], C)[0]
    to_path = segment_distance(shortest_path[:-1], shortest_path[1:], C).min(axis=0)
    relevance = np.minimum(to_chord, to_path) - R
    L = math.hypot(*chord)
    pick = np.flatnonzero((proj > tol) & (proj < L - tol) & (relevance < shortest))
    return index[pick[np.lexsort((index[pick], relevance[pick]))][:MAX_RELEVANT]]


def _widened(signature: tuple[int, ...], near: np.ndarray, m: int) -> tuple[int, ...]:
    """A signature over the obstacles ``near`` as one over all ``m`` (0 round the others)."""
    out = np.zeros(m, np.int64)
    out[near] = signature
    return tuple(out.tolist())


def _plan_among(
    S: np.ndarray, G: np.ndarray, obs: np.ndarray, margin: float, k: int, tol: float
) -> list[_Candidate] | None:
    """Shortest paths round the inflated obstacles, one per homotopy class, shortest first: the
    shortest path, and the shortest paths that pass each barrier obstacle (:func:`_barriers`)
    on a given side, for every choice of sides."""
    S2, G2 = S[:2], G[:2]
    C = obs[:, :2]
    R = _inflated(obs, S2, G2, margin)[0]
    graph = TangentGraph(S2, G2, C, R, tol)
    lengths, paths, plen = graph.search(np.zeros(graph.src.size, np.int64), np.zeros(1, np.int64))
    if not np.isfinite(lengths[0]):
        return None
    shortest = float(lengths[0])

    chord = G2 - S2
    L = math.hypot(*chord)
    if k > 1 and graph.active.size and L > tol:
        e = chord / L
        nrm = np.array([-e[1], e[0]])
        act = graph.active
        poly0 = graph.polyline(paths[0, : plen[0]])
        rel = _barriers(S2, G2, C[act], R[act], poly0, shortest, act, tol)
        if rel.size:
            origins = np.repeat(C[rel], 2, axis=0)
            dirs = np.tile(np.stack([nrm, -nrm]), (rel.size, 1))
            lo = np.minimum(np.min(C - R[:, None], axis=0), np.minimum(S2, G2))
            hi = np.maximum(np.max(C + R[:, None], axis=0), np.maximum(S2, G2))
            bits = graph.crossings(origins, dirs, 2.0 * math.hypot(*(hi - lo)) + 1.0)
            pattern = np.arange(1 << rel.size)[:, None]
            side = (pattern >> np.arange(rel.size)[None, :]) & 1
            masks = (1 << (2 * np.arange(rel.size)[None, :] + side)).sum(axis=1)
            more = graph.search(bits, masks.astype(np.int64))
            width = max(paths.shape[1], more[1].shape[1])
            lengths, paths, plen = (
                np.concatenate(x)
                for x in zip(
                    (lengths, _widen(paths, width), plen),
                    (more[0], _widen(more[1], width), more[2]),
                    strict=True,
                )
            )

    # Shortest first (ties: the unconstrained search, then pattern order); then the first of
    # each distinct node path, then the first of each signature.
    found = np.flatnonzero(lengths <= MAX_DETOUR * shortest + tol)  # finite and no long detour
    found = found[np.argsort(lengths[found], kind="stable")].tolist()
    found = list({paths[j, : plen[j]].tobytes(): j for j in reversed(found)}.values())[::-1]
    sigs = graph.signatures(paths[found], plen[found], obs).tolist()
    first = {tuple(sig): j for sig, j in reversed(list(zip(sigs, found, strict=True)))}
    out = [
        _Candidate(sig, float(lengths[j]), paths[j, : plen[j]], j, graph)
        for sig, j in first.items()
    ]
    return sorted(out, key=lambda c: (c.graph_length, c.order))


def _inflated(obs: np.ndarray, a: np.ndarray, b: np.ndarray, margin: float):
    """The discs' radii grown by ``margin``, by less where the end ``a`` or ``b`` is closer than
    that to a disc's edge; and the ends' distances to the centres, ``(R, d_a, d_b)``."""
    C, r = obs[:, :2], obs[:, 2]
    da, db = np.hypot(*(C - a).T), np.hypot(*(C - b).T)
    return r + np.clip(np.minimum(margin, np.minimum(da - r, db - r)), 0.0, None), da, db


def _widen(paths: np.ndarray, width: int) -> np.ndarray:
    """Node paths padded with -1 to ``width`` columns."""
    out = np.full((paths.shape[0], width), -1, np.int64)
    out[:, : paths.shape[1]] = paths
    return out


def _smooth_best(poly: np.ndarray, S, G, obs, tol, signature=None, modes=FORWARD) -> InitialPath:
    """The first smoothing with non-negative clearance, else the one with the best clearance."""
    best = None
    for _ in range(_MIDPOINT_ROUNDS + 1):
        path = smooth_path(poly, S, G, obs, "", tol, signature, modes)
        if path.min_clearance >= 0.0:
            return path
        if best is None or path.min_clearance > best.min_clearance:
            best = path
        poly = midpoints(poly)
    return best


def initial_paths(
    start,
    goal,
    obstacles,
    *,
    k: int = 3,
    margin: float = 0.05,
    waypoints=None,
    turns=False,
    turns_until: float = math.inf,
) -> list[InitialPath]:
    """Collision-free initial paths in up to ``k`` homotopy classes, shortest class first.

    Each class comes with its ways of meeting the end poses (:func:`end_modes`: forward first,
    then, where an end heading points away from the path, reverse and turns in place), all with
    the class's label plus the modes' description. Then the three-point turns
    (:func:`_cusp_paths`, label ``"three-point turn at (x, y), ..."``) where an end heading
    points away from the chord, or always with ``turns``: backing away first can pay elsewhere
    too (a heading towards an obstacle next to the start, or a long horizon in the penalty's
    grip).

    ``start`` and ``goal`` are states ``[x, y, heading]``, ``obstacles`` rows ``[cx, cy, r]``
    (or empty). Paths keep ``margin`` from every obstacle (less only where the start or goal is
    closer than that, or when no path exists otherwise: see the label). The straight chord
    (label ``"straight"``) is a path when it keeps the margin; it is the shortest polyline, so it
    comes first unless the turns that the end headings ask for make its smoothed curve longer
    than another. The result is sorted by smoothed ``length`` and deterministic. With
    ``waypoints`` (rows ``[x, y]``), the only path (with its end modes) passes through them in
    order, each leg the shortest path round the obstacles (label ``"waypoints"``). Raises
    :class:`ScenarioError` for invalid input, an end (or waypoint) inside an obstacle, or when
    no collision-free path exists (even with margin 0). No three-point turn is begun after
    ``turns_until`` (a time of ``time.perf_counter``: a plan's time limit).
    """
    req = _request(start, goal, obstacles, k, margin, waypoints)
    if req.waypoints is not None and req.waypoints.shape[0]:
        return _waypoint_paths(req)
    used, cands = _classes_at_some_margin(req)
    note = "" if used == req.margin else f" (margin {used:g})"
    out = _class_paths(req, cands, used, note)
    if turns or points_away(req.S, req.G):
        out += _turn_paths(req, used, note, turns_until)
    return out


@dataclass(frozen=True)
class _Request:
    """The arguments of :func:`initial_paths`, checked: end states ``S`` and ``G``, obstacle
    rows, number of classes, margin, waypoint rows (None without) and the geometry's
    tolerance."""

    S: np.ndarray
    G: np.ndarray
    obs: np.ndarray
    k: int
    margin: float
    waypoints: np.ndarray | None
    tol: float


def _request(start, goal, obstacles, k, margin, waypoints) -> _Request:
    """The arguments of :func:`initial_paths` checked (:class:`ScenarioError`), the ends and
    waypoints outside every obstacle."""
    S = end_state(start, "start")
    G = end_state(goal, "goal")
    obs = checks.obstacles(obstacles)
    k = require_integer("k", k, error=ScenarioError)
    margin = checks.real(margin, "margin")
    if margin < 0.0:
        raise ScenarioError(f"margin: must be >= 0, got {margin!r}")
    wps = None if waypoints is None else checks.rows(waypoints, 2, "waypoints", "x, y")
    checks.outside(S, "start", obs)
    checks.outside(G, "goal", obs)
    if wps is not None:
        for i, w in enumerate(wps):
            checks.outside(w, f"waypoints[{i}]", obs)
    return _Request(S, G, obs, k, margin, wps, tolerance(S, G, obs))


def _waypoint_paths(req: _Request) -> list[InitialPath]:
    """The path through the waypoints (each leg routed by :func:`_route`), once per way of
    meeting the end poses, labelled ``"waypoints"`` plus the modes' description."""
    S, G, obs, tol = req.S, req.G, req.obs, req.tol
    poly = _through(np.vstack([S[:2], req.waypoints, G[:2]]), obs, req.margin, tol)
    poly = clean_polyline(poly, S[:2], G[:2], tol)
    variants = [_smooth_best(poly, S, G, obs, tol, None, m) for m in end_modes(poly, S, G)]
    return [
        _relabel(p, ", ".join(filter(None, ("waypoints", p.modes.describe())))) for p in variants
    ]


def _classes_at_some_margin(req: _Request) -> tuple[float, list[_Candidate]]:
    """The margin used and the first ``k`` classes planned with it (:func:`_plan`): the first
    margin of :func:`_fallback_margins` with which some path exists. Raises
    :class:`ScenarioError` when none exists even with margin 0."""
    for m in _fallback_margins(req.margin):
        cands = _plan(req.S, req.G, req.obs, m, req.k, req.tol)
        if cands is not None:
            return m, cands[: req.k]
    raise ScenarioError(
        f"no collision-free initial path from start {checks.fmt_point(req.S[:2])}"
        f" to goal {checks.fmt_point(req.G[:2])}"
        f" round the {req.obs.shape[0]} obstacles (even with margin 0)"
    )


def _fallback_margins(margin: float) -> dict[float, None]:
    """The margins tried in turn, until some path exists: the fractions
    :data:`_MARGIN_FALLBACK` of ``margin``, then 0 (each once)."""
    return dict.fromkeys([margin * f for f in _MARGIN_FALLBACK] + [0.0])


def _class_paths(req: _Request, cands, used: float, note: str) -> list[InitialPath]:
    """The smoothed paths of the classes ``cands`` (planned with margin ``used``), one per way
    of meeting the end poses (:func:`end_modes`). Classes are ordered by the length of their
    first path (then by graph length and search order) and labelled ``"straight"`` (the
    graph's direct start -> goal edge) or ``"visibility #rank"``, plus the margin ``note`` and
    the modes' description."""
    S, G, obs, tol = req.S, req.G, req.obs, req.tol
    retry: dict[tuple[int, float], np.ndarray | None] = {}
    classes = []
    for cand in cands:
        variants = [
            _smoothed_in_class(cand, S, G, obs, tol, used, req.k, retry, modes)
            for modes in end_modes(cand.polyline, S, G)
        ]
        classes.append((variants, cand))
    classes.sort(key=lambda vc: (vc[0][0].length, vc[1].graph_length, vc[1].order))
    out = []
    for rank, (variants, cand) in enumerate(classes, start=1):
        straight = cand.nodes.size == 2  # the direct start -> goal edge of the graph
        name = ("straight" if straight else f"visibility #{rank}") + note
        for path in variants:
            how = path.modes.describe()
            out.append(_relabel(path, f"{name}, {how}" if how else name))
    return out


def _turn_paths(req: _Request, used: float, note: str, until: float) -> list[InitialPath]:
    """The three-point turns (:func:`_cusp_paths`, none begun after ``until``) with margin
    ``used``, labelled by their cusp point and modes, plus the margin ``note``."""
    out = []
    for C, path in _cusp_paths(req.S, req.G, req.obs, used, req.tol, until):
        label = f"three-point turn at {point_text(C, req.tol)}, {path.modes.describe()}"
        out.append(_relabel(path, label + note))
    return out


def _through(points: np.ndarray, obs: np.ndarray, margin: float, tol: float) -> np.ndarray:
    """The polyline through ``points`` in order, each leg routed by :func:`_route`."""
    legs = [_route(a, b, obs, margin, tol) for a, b in zip(points[:-1], points[1:], strict=True)]
    return np.vstack([points[:1]] + [leg[1:] for leg in legs])


def _route(a: np.ndarray, b: np.ndarray, obs: np.ndarray, margin: float, tol: float) -> np.ndarray:
    """The shortest polyline from ``a`` to ``b`` round the inflated obstacles (the margin falls
    back as for a whole path; with no path at all, the straight segment, whose clearance shows
    it)."""
    for m in _fallback_margins(margin):
        poly = _shortest_leg(a, b, obs, m, tol)
        if poly is not None:
            return poly
    return np.vstack([a, b])


def _shortest_leg(a, b, obs, margin: float, tol: float) -> np.ndarray | None:
    """The shortest polyline from ``a`` to ``b`` round the obstacles inflated by ``margin``, or
    None when there is none: the straight segment when no inflated disc cuts it, else
    :func:`_plan`'s shortest path."""
    R = _inflated(obs, a, b, margin)[0]  # as _plan inflates them
    if not np.any(segment_distance(a[None, :], b[None, :], obs[:, :2])[0] < R - tol):
        return np.vstack([a, b])  # (as the graph's direct edge is kept)
    cands = _plan(np.append(a, 0.0), np.append(b, 0.0), obs, margin, 1, tol)
    return None if cands is None else cands[0].polyline


def _smoothed_in_class(cand, S, G, obs, tol, used, k, retry, modes) -> InitialPath:
    """The smoothed path of ``cand``'s class for ``modes``; when it cuts into an obstacle, the
    class is re-planned with larger margins (memoised in ``retry``) and the clearest kept."""
    path = _smooth_best(cand.polyline, S, G, obs, tol, cand.signature, modes)
    if path.min_clearance < 0.0 and used > 0.0:
        for f in _RETRY_MARGIN_FACTORS:
            if (cand.order, f) not in retry:
                retry[cand.order, f] = _replan_class(cand, S, G, obs, used * f, k, tol)
            poly = retry[cand.order, f]
            if poly is not None:
                other = _smooth_best(poly, S, G, obs, tol, cand.signature, modes)
                if other.min_clearance > path.min_clearance:
                    path = other
                if path.min_clearance >= 0.0:
                    break
    return path


def _replan_class(cand, S, G, obs, margin, k, tol) -> np.ndarray | None:
    """The shortest polyline of ``cand``'s class round the obstacles inflated by ``margin``
    (planned among those near the class's path, :data:`_RETRY_BAND`), or None when the
    class is not found at that margin."""
    poly = cand.polyline
    gap = segment_distance(poly[:-1], poly[1:], obs[:, :2]).min(axis=0) - obs[:, 2]
    near = np.flatnonzero(gap < _RETRY_BAND * margin)
    want = tuple(np.asarray(cand.signature)[near].tolist())
    same = [c for c in _plan_among(S, G, obs[near], margin, k, tol) or () if c.signature == want]
    if not same:
        return None
    nodes = same[0].nodes
    full = same[0].graph.signatures(nodes[None, :], np.array([nodes.size]), obs)[0]
    return same[0].polyline if tuple(full.tolist()) == cand.signature else None


def _relabel(path: InitialPath, label: str) -> InitialPath:
    return replace(path, label=label)


def plot_initial_paths(ax, paths, obstacles=None):
    """Draw obstacles, the smoothed curves (solid) and their polylines (dotted) on ``ax``."""
    from matplotlib.patches import Circle

    for cx, cy, r in checks.obstacles(obstacles).tolist():
        ax.add_patch(Circle((cx, cy), r, facecolor="0.75", edgecolor="0.4"))
    s = np.linspace(0.0, 1.0, 400)
    for path in paths:
        xy, _ = path.curve(s)
        (line,) = ax.plot(xy[:, 0], xy[:, 1], label=f"{path.label} (length {path.length:.3f})")
        ax.plot(*path.polyline.T, ls=":", lw=0.8, color=line.get_color())
    ax.set_aspect("equal")
    ax.legend(fontsize="small")
    return ax
