"""Initial paths on occupancy-grid maps: the shortest route of the robot's centre in several
homotopy classes, shortest first, as :func:`.initial_paths` finds them round discs.

The robot is a disc of ``radius``; a route keeps ``radius + margin`` from every blocked cell
(:class:`.MapClearance`'s closed squares) where it can. The work is done on the map's grid in
units of cells (the compiled kernels are :mod:`.map_grid`); routes come back in world metres.

Method
------
1. Per map (cached on the :class:`.MapClearance`; 0.2 s for 2000 x 2000 cells): the exact
   distance ``d`` from every cell's centre to the blocked squares (a separable distance
   transform in the squares' own metric, :func:`.map_grid.clearance_field`), and the obstacles
   of the signature: the 8-connected components of the blocked cells that do not touch the
   map's edge (a route winds round no other), each represented by its cell nearest its centroid.
2. Per threshold ``T = (radius + margin) / resolution`` (cached; 0.1 s for 2000 x 2000 cells):
   the connected components of the cells with ``d >= T``, and the search graph. Cells with
   ``d >= T`` are its nodes; a move to one of the eight neighbours keeps ``T`` when both cells
   do (a diagonal move when the two cells beside it do too; else it is measured). On larger maps
   (more than :data:`GRAPH_NODES` cells) the nodes are blocks of ``f x f`` cells, each at its
   clearest cell, joined to their neighbours by the straight segments that an exact test
   passes (:func:`.map_grid.segment_ok`), so every edge is clear; ``f`` is at most
   :data:`BLOCK_OF_THRESHOLD` times ``T`` (or 2), so that a passage is seldom missed (on the
   benchmark's map, blocks of 5 cells give the lengths of blocks of 2 within 1 %, 4 times
   faster; with ``T = 2`` cells, blocks of 2 those of single cells within 0.3 %).
3. Ends. An end nearer a wall than ``T`` gets a *zone*: there the threshold starts at the end's
   own clearance and grows by half a cell per cell away from the end, up to ``T``, so the route
   may leave the wall at about 30 degrees. A small Dijkstra over the cells round each end
   (:func:`.map_grid.end_field`) joins it to the graph's nodes near it.
4. Shortest paths: A* from the start's nodes towards the goal's, continued (Dijkstra ordered by
   the A* key) until the key exceeds ``beta`` times the shortest length, gives the exact
   distances ``dS`` of every node that a route ``beta`` times the shortest could visit (an
   ellipse round the ends); the same from the goal gives ``dG``. The shortest route passes the
   node of least ``dS + dG``. ``beta`` is 1.25, then 1.6 and ``max_detour`` while fewer than
   ``k`` classes are found (:data:`DETOURS`; each ellipse is about twice the last).
5. Other homotopy classes, by the disc version's barrier rays: the obstacles as the search sees
   them (components of the cells with ``d < T``: obstacles nearer each other than ``2 T`` are
   one, no route passes between them) whose representative projects inside the chord, the
   :data:`MAX_RELEVANT` nearest the chord or the shortest route, each cast two rays
   perpendicular to the chord. The node of least ``dS + dG`` on a ray
   (:func:`_ray_via`) gives the shortest route through that ray, which passes the
   obstacle on that side: the shortest path from the start to it, then on to the goal. (A route
   made of two shortest paths may miss the shortest of its class; the classes found are then
   still distinct and each route clear, only "near-shortest".)
6. Simplification. Of each signature's shortest grid path (the end's cells, the nodes, the
   other end's cells): any-angle line-of-sight shortcuts (:func:`.map_grid.shortcut`); the
   ``k`` shortest of these are then pulled taut like a string (:func:`.map_grid.pull`), given a
   vertex amid each segment, pulled again and shortcut again. Each step keeps the thresholds
   (exact tests); one that changes a route's signature is undone. The route's clearance is
   then measured exactly along its segments (:func:`.map_grid.polyline_distance`). Routes
   longer than ``max_detour`` times the shortest are dropped; the rest come sorted by length.
7. Margins. Start and goal are first looked up in the connected components of the cells that
   keep ``radius`` (cached): not connected, no route (in well under a millisecond once cached).
   With no route at ``margin``, it is halved four times, then 0, as for discs; when the blocks
   miss a route that the cells' components say exists, blocks half as large are searched.

Signature: ``signature[j]`` is the winding number round obstacle ``j``'s representative point
(step 1) of the route closed by the straight chord from goal back to start (0: the route passes
``j`` on the same side as the chord, +-1 on the other; a point on the chord counts +-1), as
:func:`.geometry.homotopy_signature` computes it for discs. Equal signatures, same class.

Measured (``benchmarks/bench_map_routes.py``, ``tests/test_map_routes.py``): a maze's route
within 1 % below a 32-neighbour fine-grid Dijkstra, a corridor's within 0.2 % of the exact
length; queries on 2000 x 2000 cells in a few tens of milliseconds (the median).
"""

from __future__ import annotations

import math
import weakref
from collections import OrderedDict
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ... import checks
from ...errors import ScenarioError, require_integer
from ...world import MapClearance
from . import map_grid as mg
from .geometry import homotopy_signature, midpoints, segment_distance

#: The search graph has about this many nodes at most: blocks of ``f x f`` cells on larger maps.
GRAPH_NODES = 1 << 16
#: ... but the blocks are at most this fraction of the threshold wide (a passage just wider than
#: the threshold's twice is then seldom missed by the blocks' segments), or 2 cells.
BLOCK_OF_THRESHOLD = 1 / 1.2
#: At most this many obstacles cast barrier rays (step 5).
MAX_RELEVANT = 6
#: The bounds on the routes' lengths searched first, times the shortest (step 5); then
#: ``max_detour``. Each round searches an ellipse round start and goal about twice as large.
DETOURS = (1.25, 1.6)
#: Margins tried, as fractions of the requested one, before margin 0 (step 7).
MARGIN_FALLBACK = (1.0, 0.5, 0.25, 0.125, 0.0625)
#: Passes of :func:`.map_grid.pull`.
PULL_PASSES = 8
#: The least threshold (cells): a route never touches a blocked cell.
MIN_THRESHOLD = 1e-6
#: Search graphs and connected components kept per map (the most recently used).
GRAPHS_KEPT, LABELS_KEPT = 4, 4


@dataclass(frozen=True, eq=False)
class MapRoute:
    """A route from start to goal: ``points`` ``(N, 2)`` world ``x, y`` (read-only, first the
    start, last the goal), its ``length`` (metres), homotopy ``signature`` (module docstring),
    ``clearance`` (the least distance of its segments to the blocked cells, less the radius:
    metres) and the ``margin`` it was planned with. (Compared by identity, as the package's
    other records of arrays.)"""

    points: np.ndarray
    length: float
    signature: tuple[int, ...]
    clearance: float
    margin: float


class _Graph(NamedTuple):
    f: int  # block size (cells)
    nu: np.ndarray  # node positions, padded grid coordinates
    nv: np.ndarray
    ok: np.ndarray  # whether the node keeps the threshold
    edges: np.ndarray  # (Hc, Wc) uint8, bit k: move k (map_grid.DI, DJ)


class _Prepared:
    """Per map: the padded blocked cells, the clearance field, the obstacles (step 1), and the
    caches of search graphs and connected components per threshold."""

    def __init__(self, clear: MapClearance):
        from scipy import ndimage

        self.H, self.W = clear.blocked.shape
        self.blocked = np.pad(clear.blocked, 1, constant_values=clear.unknown_is_occupied)
        self.d = mg.clearance_field(self.blocked)
        lab, n = ndimage.label(clear.blocked, np.ones((3, 3), bool))
        ri, rj, _, edge = mg.component_reps(lab, n)
        self.reps = np.column_stack([rj, ri])[~edge] + 1.5  # padded coordinates of the centres
        self._graphs: OrderedDict = OrderedDict()
        self._labels: OrderedDict = OrderedDict()

    def block(self, T: float) -> int:
        """The block size ``f`` of the search graph for threshold ``T`` (step 2)."""
        by_size = math.ceil(math.sqrt(self.H * self.W / GRAPH_NODES))
        return min(by_size, max(2, math.floor(T * BLOCK_OF_THRESHOLD)))

    def graph(self, T: float, f: int) -> _Graph:
        key = (T, f)
        if key not in self._graphs:
            built = mg.search_graph(self.d, self.blocked, f, T, self.H, self.W)
            self._graphs[key] = _Graph(f, *built)
            if len(self._graphs) > GRAPHS_KEPT:
                self._graphs.popitem(last=False)
        self._graphs.move_to_end(key)
        return self._graphs[key]

    def labels(self, T: float) -> np.ndarray:
        """The 8-connected components of the cells that keep ``T`` (padded, 0: none): cells
        joined by a diagonal move only may be joined or not (:func:`.map_grid.search_graph`),
        so the components may join what the graph does not, never the other way."""
        from scipy import ndimage

        if ("free", T) not in self._labels:
            inside = self.d[1:-1, 1:-1] >= T - mg.EPS  # routes stay on the map
            self._remember(("free", T), np.pad(ndimage.label(inside, np.ones((3, 3), bool))[0], 1))
        return self._labels[("free", T)]

    def obstacles(self, T: float) -> tuple[np.ndarray, np.ndarray]:
        """The obstacles as the search sees them at threshold ``T``: the 8-connected
        components of the map's cells that do not keep ``T`` and do not touch the map's edge,
        each a representative point (padded coordinates) and how far it reaches (cells).
        Obstacles nearer each other than ``2 T`` are one here: no route passes between."""
        from scipy import ndimage

        if ("near", T) not in self._labels:
            lab, n = ndimage.label(self.d[1:-1, 1:-1] < T - mg.EPS, np.ones((3, 3), bool))
            ri, rj, reach, edge = mg.component_reps(lab, n)
            keep = ~edge
            self._remember(("near", T), (np.column_stack([rj, ri])[keep] + 1.5, reach[keep]))
        return self._labels[("near", T)]

    def _remember(self, key, value) -> None:
        self._labels[key] = value
        if len(self._labels) > LABELS_KEPT:
            self._labels.popitem(last=False)


_PREPARED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def prepare_map(clear: MapClearance, radius: float | None = None, margin: float = 0.0) -> None:
    """Do the per-map work of :func:`map_routes` now (it is cached on ``clear``), and with a
    ``radius``, the work for it and ``margin``: the connected components for both thresholds,
    the obstacles and the search graph for ``radius + margin``."""
    prep = _prepared(clear)
    if radius is None:
        return
    radius = checks.real(radius, "radius", ge=0)
    margin = checks.real(margin, "margin", ge=0)
    for m in (0.0, margin):
        T = max((radius + m) / clear.occupancy.resolution, MIN_THRESHOLD)
        prep.labels(T)
    prep.obstacles(T)
    prep.graph(T, prep.block(T))


def _prepared(clear: MapClearance) -> _Prepared:
    if not isinstance(clear, MapClearance):
        raise ScenarioError(f"clear: expected a MapClearance, got {clear!r:.60}")
    if clear not in _PREPARED:
        _PREPARED[clear] = _Prepared(clear)
    return _PREPARED[clear]


class _Ends(NamedTuple):
    """A query's ends at one threshold: positions (padded grid coordinates, rows start and
    goal), their zones (:func:`.map_grid.segment_ok`), and the threshold."""

    P: np.ndarray  # (2, 2)
    zones: np.ndarray  # (2, 4): u, v, base, active
    T: float


def _ends(prep: _Prepared, P: np.ndarray, T: float) -> _Ends | None:
    """The ends' zones at threshold ``T``: the base is the end's clearance on its way to its
    cell's centre; None when an end lies on a blocked cell (or off the map)."""
    zones = np.zeros((2, 4))
    for e in range(2):
        u, v = P[e]
        if not (1.0 <= u < prep.W + 1.0 and 1.0 <= v < prep.H + 1.0):
            return None
        centre = np.array([[u, v], [math.floor(u) + 0.5, math.floor(v) + 0.5]])
        base = mg.polyline_distance(prep.d, prep.blocked, centre)
        if base < MIN_THRESHOLD:
            return None
        zones[e] = (u, v, min(base, T), 1.0 if base < T else 0.0)
    return _Ends(P, zones, T)


def _end_window(prep: _Prepared, ends: _Ends, e: int, f: int):
    """:func:`.map_grid.end_field` round end ``e``, far enough to leave its zone and reach
    the nodes of blocks of ``f`` cells."""
    base, active = ends.zones[e, 2], ends.zones[e, 3]
    reach = 2 * f + 2 + ((ends.T - base) / mg.SLOPE + mg.HALF_DIAGONAL if active else 0.0)
    u, v = ends.P[e]
    return mg.end_field(prep.d, u, v, ends.T, ends.zones, reach, prep.H, prep.W)


def _reached(window, cells: np.ndarray) -> np.ndarray:
    """Window distances of padded ``cells`` (rows ``i, j``; ``inf`` outside the window)."""
    i0, j0, dist, _ = window
    a, b = cells[:, 0] - i0, cells[:, 1] - j0
    inside = (a >= 0) & (a < dist.shape[0]) & (b >= 0) & (b < dist.shape[1])
    out = np.full(cells.shape[0], np.inf)
    out[inside] = dist[a[inside], b[inside]]
    return out


def _connected(prep: _Prepared, ends: _Ends) -> bool:
    """Whether start and goal meet in the cells that keep the threshold (its connected
    components), or within the start's window."""
    lab = prep.labels(ends.T)
    seen = []
    for e in range(2):
        i0, j0, dist, _ = window = _end_window(prep, ends, e, 1)
        rows, cols = np.nonzero(np.isfinite(dist))
        seen.append(set(lab[rows + i0, cols + j0].tolist()) - {0})
        if e == 0 and np.isfinite(_reached(window, _end_cells(ends)[1:])[0]):
            return True
    return bool(seen[0] & seen[1])


def _end_cells(ends: _Ends) -> np.ndarray:
    return np.floor(ends.P[:, ::-1]).astype(np.int64)  # rows (i, j) of start and goal


def _seeds(prep: _Prepared, graph: _Graph, window) -> tuple[np.ndarray, np.ndarray]:
    """The graph's nodes whose cell an end's window reaches, and their distances from it."""
    i0, j0, dist, _ = window
    f, Wc = graph.f, graph.edges.shape[1]
    a = np.arange((i0 - 1) // f, (i0 + dist.shape[0] - 2) // f + 1)
    b = np.arange((j0 - 1) // f, (j0 + dist.shape[1] - 2) // f + 1)
    nodes = (a[:, None] * Wc + b[None, :]).ravel()
    nodes = nodes[graph.ok[nodes]]
    cells = np.column_stack([graph.nv[nodes], graph.nu[nodes]]).astype(np.int64)
    cost = _reached(window, cells)
    good = np.isfinite(cost)
    return nodes[good], cost[good]


def _window_chain(window, cell) -> list[tuple[float, float]]:
    """The centres of the cells from an end's cell to ``cell`` (padded ``(i, j)``) in its
    window, in that order."""
    i0, j0, dist, pred = window
    w = dist.shape[1]
    q = (cell[0] - i0) * w + cell[1] - j0
    out = []
    while q >= 0:
        out.append((j0 + q % w + 0.5, i0 + q // w + 0.5))
        q = pred[q]
    return out[::-1]


def _node_chain(pred: np.ndarray, q: int) -> list[int]:
    """The nodes from ``q`` back to its seed through ``pred``."""
    out = [q]
    while pred[out[-1]] >= 0:
        out.append(int(pred[out[-1]]))
    return out


class _Search(NamedTuple):
    """One search: the graph, the ends' windows, seeds and distance fields."""

    graph: _Graph
    windows: tuple
    dS: np.ndarray
    predS: np.ndarray
    dG: np.ndarray
    predG: np.ndarray
    shortest: float
    via: int  # the node of the shortest route (-1: only the direct route)


def _search(prep: _Prepared, graph: _Graph, ends: _Ends, beta: float, both: bool):
    """Steps 3 and 4: the ends' windows and the two distance fields (the goal's only when
    ``both``); None when no route is found."""
    windows = tuple(_end_window(prep, ends, e, graph.f) for e in range(2))
    (sS, cS), (sG, cG) = (_seeds(prep, graph, w) for w in windows)
    direct = _reached(windows[0], _end_cells(ends)[1:])[0] + _last_leg(ends)
    if not (sS.size and sG.size) and not np.isfinite(direct):
        return None
    args = (graph.edges, graph.nu, graph.nv)
    dS, predS, best = mg.path_field(*args, sS, cS, sG, cG, *ends.P[1], beta, beta * direct)
    if not np.isfinite(min(best, direct)):
        return None
    bound = beta * min(best, direct) + mg.EPS
    dG, predG = np.full_like(dS, np.inf), np.full_like(predS, -1)
    if both:
        dG, predG, _ = mg.path_field(*args, sG, cG, sS, cS, *ends.P[0], np.inf, bound)
    total = dS[sG] + cG
    via = int(sG[np.argmin(total)]) if sG.size and np.isfinite(total.min()) else -1
    return _Search(graph, windows, dS, predS, dG, predG, min(best, direct), via)


def _last_leg(ends: _Ends) -> float:
    """From the goal's cell centre to the goal."""
    u, v = ends.P[1]
    return math.hypot(u - math.floor(u) - 0.5, v - math.floor(v) - 0.5)


def _via_path(ends: _Ends, s: _Search, q: int) -> np.ndarray:
    """The grid path through node ``q``: start, its window's cells to its seed, the nodes to
    ``q`` and on to a goal's seed, the goal's window's cells, the goal (padded coordinates)."""
    g = s.graph
    first = _node_chain(s.predS, q)[::-1]
    second = _node_chain(s.predG, q)
    nodes = first + second[1:]
    ends_cells = [(int(g.nv[n]), int(g.nu[n])) for n in (nodes[0], nodes[-1])]
    pts = [tuple(ends.P[0])] + _window_chain(s.windows[0], ends_cells[0])
    pts += [(g.nu[n], g.nv[n]) for n in nodes[1:-1]]
    pts += _window_chain(s.windows[1], ends_cells[1])[::-1] + [tuple(ends.P[1])]
    return _dedup(np.array(pts, float))


def _direct_path(ends: _Ends, s: _Search) -> np.ndarray | None:
    """The route inside the start's window to the goal's cell, if it reaches it."""
    cell = _end_cells(ends)[1]
    if not np.isfinite(_reached(s.windows[0], cell[None, :])[0]):
        return None
    pts = [tuple(ends.P[0])] + _window_chain(s.windows[0], cell) + [tuple(ends.P[1])]
    return _dedup(np.array(pts, float))


def _dedup(poly: np.ndarray) -> np.ndarray:
    keep = np.ones(poly.shape[0], bool)
    keep[1:] = np.any(poly[1:] != poly[:-1], axis=1)
    out = poly[keep]
    return out if out.shape[0] >= 2 else np.vstack([out, out])


# --------------------------------------------------------------------------- classes


def _relevant(prep: _Prepared, ends: _Ends, poly: np.ndarray, shortest: float) -> np.ndarray:
    """The obstacles that cast barrier rays (step 5): of those whose representative projects
    inside the chord and that come closer than the shortest length to the chord or to the
    shortest route, the :data:`MAX_RELEVANT` closest (ties by index)."""
    S2, G2 = ends.P
    L = math.hypot(*(G2 - S2))
    C, reach = prep.obstacles(ends.T)
    if L < 1e-9 or C.shape[0] == 0:
        return np.zeros(0, np.int64)
    proj = (C - S2) @ ((G2 - S2) / L)
    to_chord = segment_distance(S2[None, :], G2[None, :], C)[0]
    to_path = segment_distance(poly[:-1], poly[1:], C).min(axis=0)
    relevance = np.minimum(to_chord, to_path) - reach
    pick = np.flatnonzero((proj > 0.0) & (proj < L) & (relevance < shortest))
    return pick[np.lexsort((pick, relevance[pick]))][:MAX_RELEVANT]


def _vias(prep: _Prepared, ends: _Ends, s: _Search, poly: np.ndarray) -> list[int]:
    """The nodes of the candidate routes: the shortest route's, then per relevant obstacle the
    best node on each of its two rays (:func:`_ray_via`), each node once."""
    out = [s.via] if s.via >= 0 else []
    chord = ends.P[1] - ends.P[0]
    L = math.hypot(*chord)
    if L < 1e-9 or not np.isfinite(s.dG).any():
        return out
    nrm = np.array([-chord[1], chord[0]]) / L
    origins = prep.obstacles(ends.T)[0]
    for c in _relevant(prep, ends, poly, s.shortest).tolist():
        for side in (1.0, -1.0):
            q = _ray_via(prep, s, origins[c], side * nrm)
            if q >= 0 and q not in out:
                out.append(q)
    return out


def _ray_via(prep: _Prepared, s: _Search, origin: np.ndarray, direction: np.ndarray) -> int:
    """The node of least ``dS + dG`` among the blocks that the ray from ``origin`` along the
    unit vector ``direction`` crosses inside the map, sampled every half block (the first on
    ties); -1 when the fields reach none of them."""
    f, Wc = s.graph.f, s.graph.edges.shape[1]
    reach = math.hypot(prep.H, prep.W) + 2.0
    p = origin + np.arange(0.0, reach, 0.5 * f)[:, None] * direction
    p = p[np.all((p >= 1.0) & (p < np.array([prep.W, prep.H]) + 1.0), axis=1)]
    nodes = ((p[:, 1].astype(np.int64) - 1) // f) * Wc + (p[:, 0].astype(np.int64) - 1) // f
    total = s.dS[nodes] + s.dG[nodes]
    return int(nodes[np.argmin(total)]) if total.size and np.isfinite(total.min()) else -1


def _signature(prep: _Prepared, poly: np.ndarray) -> tuple[int, ...]:
    if prep.reps.shape[0] == 0:
        return ()
    obs = np.column_stack([prep.reps, np.zeros(prep.reps.shape[0])])
    return homotopy_signature(poly, obs, 1e-9 * (prep.H + prep.W))


def _shortcut(prep: _Prepared, ends: _Ends, raw: np.ndarray, want: tuple) -> np.ndarray:
    """Step 6, first part: the grid path ``raw`` shortcut (or, should that change its
    signature ``want``, ``raw`` itself)."""
    cut = mg.shortcut(prep.d, prep.blocked, raw, ends.T, ends.zones)
    return cut if _signature(prep, cut) == want else raw


def _taut(prep: _Prepared, ends: _Ends, cut: np.ndarray, want: tuple) -> np.ndarray:
    """Step 6, second part: ``cut`` pulled taut, given a vertex amid each segment and pulled
    again (a vertex resting on a corner can then move round it), shortcut again (or, should
    that change its signature ``want``, ``cut`` itself)."""
    args, thr = (prep.d, prep.blocked), (ends.T, ends.zones)
    taut = mg.pull(*args, cut, *thr, PULL_PASSES)
    taut = mg.shortcut(*args, mg.pull(*args, midpoints(taut), *thr, PULL_PASSES), *thr)
    return taut if _signature(prep, taut) == want else cut


def _length(poly: np.ndarray) -> float:
    return float(np.hypot(*np.diff(poly, axis=0).T).sum())


def _classes(prep: _Prepared, ends: _Ends, s: _Search, k: int, max_detour: float) -> list:
    """The shortest candidate route of each signature, ``(length, order, polyline,
    signature)``: the shortest grid path of each, shortcut; the ``k`` shortest of those pulled
    taut; none longer than ``max_detour`` times the shortest, shortest first."""
    raws = [] if (direct := _direct_path(ends, s)) is None else [direct]
    if s.via >= 0:
        raws.append(_via_path(ends, s, s.via))
    raws += [_via_path(ends, s, q) for q in _vias(prep, ends, s, raws[-1]) if q != s.via]
    shortest_raw: dict[tuple[int, ...], tuple] = {}  # per signature, the shortest grid path
    for order, raw in enumerate(raws):
        cand = (_length(raw), order, raw, _signature(prep, raw))
        if cand[3] not in shortest_raw or cand[:2] < shortest_raw[cand[3]][:2]:
            shortest_raw[cand[3]] = cand
    cut = [(o, _shortcut(prep, ends, raw, sig), sig) for _, o, raw, sig in shortest_raw.values()]
    cut.sort(key=lambda c: (_length(c[1]), c[0]))
    out = [(o, _taut(prep, ends, poly, sig), sig) for o, poly, sig in cut[:k]]
    out = sorted(((_length(p), o, p, sig) for o, p, sig in out), key=lambda c: c[:2])
    limit = max_detour * out[0][0] + 1e-9 * (prep.H + prep.W)
    return [c for c in out if c[0] <= limit]


def _plan(prep: _Prepared, graph: _Graph, ends: _Ends, k: int, max_detour: float) -> list:
    """The classes found on ``graph`` (:func:`_classes`), searched to :data:`DETOURS` times
    the shortest and then, while fewer than ``k`` are found, to ``max_detour``; empty when
    there is no route."""
    betas = [1.0] if k == 1 else sorted({min(b, max_detour) for b in DETOURS} | {max_detour})
    found: list = []
    for beta in betas:
        s = _search(prep, graph, ends, beta, both=k > 1)
        if s is None:
            return []
        found = _classes(prep, ends, s, k, max_detour)
        if len(found) >= k:
            break
    return found[:k]


# --------------------------------------------------------------------------- the API


def _margins(margin: float) -> list[float]:
    out = [margin * f for f in MARGIN_FALLBACK] if margin > 0.0 else []
    return out + [0.0]


def map_routes(
    clear: MapClearance,
    start_xy,
    goal_xy,
    radius: float,
    margin: float,
    k: int = 3,
    max_detour: float = 3.0,
) -> list[MapRoute]:
    """Up to ``k`` routes from ``start_xy`` to ``goal_xy`` (world ``x, y``) for a disc robot of
    ``radius`` on ``clear``'s map, in different homotopy classes, each the shortest found in its
    class, none longer than ``max_detour`` times the shortest, shortest first (module
    docstring). They keep ``radius + margin`` from the blocked cells, except near an end that
    is closer than that (it leaves gradually); with no route at ``margin``, the margin falls
    back (halved four times, then 0: :attr:`MapRoute.margin`). Empty when start and goal are
    not connected with margin 0, or lie on a blocked cell or off the map. Deterministic; the
    per-map work is cached on ``clear`` (:func:`prepare_map`). Invalid input raises
    :class:`ScenarioError`."""
    start = checks.vector(start_xy, 2, "start_xy", " [x, y]")
    goal = checks.vector(goal_xy, 2, "goal_xy", " [x, y]")
    radius = checks.real(radius, "radius", ge=0)
    margin = checks.real(margin, "margin", ge=0)
    k = require_integer("k", k, 1, error=ScenarioError)
    max_detour = checks.real(max_detour, "max_detour", ge=1)
    prep = _prepared(clear)
    occ = clear.occupancy
    u, v = occ.world_to_grid(np.array([start[0], goal[0]]), np.array([start[1], goal[1]]))
    P = np.column_stack([u, v]) + 1.0
    ends = _ends(prep, P, max(radius / occ.resolution, MIN_THRESHOLD))
    if ends is None or not _connected(prep, ends):
        return []
    for m in _margins(margin):
        ends = _ends(prep, P, max((radius + m) / occ.resolution, MIN_THRESHOLD))
        if not _connected(prep, ends):
            continue
        found, f = [], prep.block(ends.T)
        while True:
            found = _plan(prep, prep.graph(ends.T, f), ends, k, max_detour)
            if found or f == 1:
                break
            f //= 2  # the blocks missed a passage: smaller ones
        if found:
            return [_route(prep, occ, c, (start, goal), radius, m) for c in found]
    return []


def _route(prep: _Prepared, occ, cand: tuple, ends_xy, radius: float, margin: float) -> MapRoute:
    """A candidate ``(length, order, polyline, signature)`` as a :class:`MapRoute` (its ends
    exactly the query's ``ends_xy``)."""
    length, _, poly, sig = cand
    x, y = occ.grid_to_world(poly[:, 0] - 1.0, poly[:, 1] - 1.0)
    points = np.column_stack([x, y])
    points[[0, -1]] = ends_xy
    points.setflags(write=False)
    gap = mg.polyline_distance(prep.d, prep.blocked, poly) * occ.resolution
    return MapRoute(points, length * occ.resolution, sig, float(gap - radius), margin)
