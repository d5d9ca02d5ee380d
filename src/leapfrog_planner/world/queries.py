"""Random planning queries on a map, by the protocol of the ROS 2 navigation stack's planner
benchmark, with the length of each query's shortest path.

The protocol followed. navigation2's ``tools/planner_benchmarking`` (``metrics.py``, then
``process_data.py`` for the table) benchmarks its global planners on a 100 m x 100 m map of
random obstacles (``100by100_20.yaml``: 2000 x 2000 cells of 0.05 m). ``metrics.py`` reads the
*global costmap* (the map with its obstacles inflated), seeds Python's ``random`` (``seed(33)``)
and draws 100 start-goal pairs:

* a start: a cell drawn uniformly (``randint``) among those at least ``side_buffer = 100``
  cells from the map's edges, kept if its cost is below ``max_cost = 210`` (redrawn otherwise),
  placed at the cell's corner ``(col * res, row * res)``; its yaw uniform in ``[0, 2 pi)``;
* a goal: drawn the same way until it is also more than 3.0 m (straight line) from the start;
* the pair is kept only if every planner returns a path; otherwise a new pair is drawn.

``process_data.py`` then reports per planner the mean path length (the sum of the path's
segments), the mean planning time and the mean and largest costmap cost along the paths.

Where this module follows it: uniform draws over the free space, a clearance from obstacles
(the cost below 210), a goal more than ``min_distance`` (3.0 m) from the start, uniform
headings, a fixed seed, pairs the robot can actually travel between. Where it differs:

* the clearance is a distance, not a costmap cost: a point is kept when its exact distance to
  the nearest blocked cell (:class:`~.clearance.MapClearance`) is at least ``clearance``
  (default: the radius 0.2 m plus a margin of 0.1 m). nav2's cost 210 is, with its default
  inflation (``cost_scaling_factor: 3.0``), ``ln(252 / 210) / 3 = 0.06`` m beyond the
  inscribed radius: the margin here is a rounder, slightly safer figure;
* points are uniform over the continuous free space (a cell drawn uniformly among the
  candidates, then a point uniformly in it, then the clearance checked exactly), not cell
  corners; headings are uniform in ``[-pi, pi)``;
* ``border`` (metres, default 0) plays ``side_buffer``: the synthetic maps have an outer wall,
  which the clearance already keeps away from;
* connection is decided by the map, not by planners' success: start and goal must lie in the
  same connected component of the free space eroded by the robot's radius (below), computed
  once per map; a start whose goals all fail is replaced;
* seeded NumPy (``numpy.random.default_rng(seed)``), not Python's ``random``; the draws are
  bounded (``max_draws``): too few valid places raise a one-line
  :class:`~leapfrog_planner.errors.ScenarioError` instead of looping for ever;
* each query carries its straight ``distance`` and its ``shortest`` path length, the reference
  a planner's path length (``process_data.py``'s figure) is measured against.

The eroded free space (:class:`FreeSpace`). A cell is *clear* when its centre is at least the
robot's radius from every blocked cell (exact distance to the nearest cell square, found by a
Euclidean distance transform's nearest cell; the world off the map counts as blocked unless
the clearance says otherwise). On a map of more than ``max_nodes`` cells the search runs on
blocks of ``k x k`` cells (``k`` the smallest that gives at most ``max_nodes`` blocks: 3 on a
1000 x 1000 map, 6 on a 2000 x 2000 one); a block counts as clear when all its cells are, so
the blocks' clear space lies inside the cells'. A passage stays open when its clear width is
``2 k - 1`` cells or more (a door of the synthetic maps, :mod:`.synthetic`, 1 m wide at 0.05 m
a cell: 12 clear cells, enough up to ``k = 6``); a narrower one may count as closed. The
components are those of the clear blocks joined by their sides; the graph joins each clear
block to 16 neighbours (the 8 around it and the 8 a knight's move away) when the blocks the
move crosses are clear too, so the graph's components are exactly the blocks' components.

The shortest path. A query's start and goal are each joined to a clear block near them in
straight sight. A* (Dijkstra's algorithm, ``scipy.sparse.csgraph.dijkstra``, on the lengths
reduced by the straight line to the goal, and bounded by a limit on the detour that grows only
when the goal is not reached) finds the shortest 16-connected path between the blocks. The
path is then pulled taut (greedily on to the farthest point in sight, on the path and again on
it resampled cell by cell) and cut round the corners it wraps (each turn replaced by two points
as far apart as sight allows, twice over: the eroded space's corners are arcs of the radius),
sight being checked every half cell on the clear *cells*. ``shortest`` is the length of that
polyline from start to goal, never less than the straight ``distance``.

How close to the true shortest path of a disc of the radius. Within the homotopy class the
search picks, a few millimetres a corner. The class is that of the shortest 16-connected grid
path, which is up to 2.7% longer than the straight segment it stands for: when two ways round
an obstacle differ by less than that, the longer may be picked. Measured: in a room with one
block, against the exact length (tangents and arcs), within 0.7% (0.06% on average) over 300
queries; on the synthetic maps, blocks of 3 cells against single cells within 1.2% (0.1% on
average). Sight is checked on cells whose centre is clear, so the polyline may graze the eroded
boundary by up to a cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import checks
from ..errors import ScenarioError, require_integer
from .clearance import MapClearance

RADIUS = 0.2  # metres: the robot's default radius
MARGIN = 0.1  # metres beyond the radius a start or goal keeps by default
MIN_DISTANCE = 3.0  # metres: nav2's benchmark wants the goal more than this from the start
MAX_NODES = 150_000  # blocks of the search graph at most (sets the block size k)
CUT_ROUNDS = 2  # passes of :func:`cut_corners`
CUT_COS = math.cos(0.05)  # a turn under 0.05 rad is not cut (it would gain < 1e-5 radius)
CUT_FIRST = 0.25  # cells: the first cut of a corner tried
CUT_STEPS = 3  # halvings of a corner's cut after the doublings
DETOUR = 0.1  # the first search's limit on a path's excess over the straight line, relative
BATCH = 512  # candidate points drawn at a time
GOAL_DRAWS = 50  # goals drawn for one start before the start is replaced
LINK_REACH = 2  # blocks round a point searched for one in straight sight
SIGHT_STEP = 0.5  # cells between the samples of a sight line
# The 16 moves (di, dj) of the graph, each with the blocks it crosses besides its ends.
MOVES = (
    ((0, 1), ()),
    ((1, 0), ()),
    ((1, 1), ((0, 1), (1, 0))),
    ((1, -1), ((0, -1), (1, 0))),
    ((1, 2), ((0, 1), (1, 1))),
    ((2, 1), ((1, 0), (1, 1))),
    ((1, -2), ((0, -1), (1, -1))),
    ((2, -1), ((1, 0), (1, -1))),
)


@dataclass(frozen=True)
class MapQuery:
    """A planning query: ``start`` and ``goal`` poses ``(x, y, heading)`` (metres, radians in
    ``[-pi, pi)``), their straight ``distance`` and the length of the ``shortest`` path between
    them at the robot's radius (metres; module docstring)."""

    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    distance: float
    shortest: float


def centre_clearance(blocked: np.ndarray, outside_blocked: bool) -> np.ndarray:
    """Distance (cells, ``float32``) from each cell's centre to the nearest blocked cell's
    square (0 in a blocked cell; ``inf`` when nothing is blocked): the square of the nearest
    blocked *centre* (a Euclidean distance transform), which is the nearest square but for
    rare ties within 0.01 cell (see :mod:`.clearance`)."""
    from scipy import ndimage

    pad = np.pad(blocked, 1, constant_values=outside_blocked)
    if not pad.any():
        return np.full(blocked.shape, np.inf, dtype=np.float32)
    iy, ix = ndimage.distance_transform_edt(~pad, return_distances=False, return_indices=True)
    rows, cols = pad.shape
    dv = np.abs(iy - np.arange(rows, dtype=np.int32)[:, None]).astype(np.float32)
    du = np.abs(ix - np.arange(cols, dtype=np.int32)[None, :]).astype(np.float32)
    d = np.hypot(np.maximum(du - 0.5, 0), np.maximum(dv - 0.5, 0))
    d[pad] = 0.0
    return d[1:-1, 1:-1]


def _clear_blocks(clear_cells: np.ndarray, k: int) -> np.ndarray:
    """Blocks of ``k x k`` cells that are clear (all their cells clear; blocks past the map's
    edge are not)."""
    rows, cols = clear_cells.shape
    big = np.zeros((-(-rows // k) * k, -(-cols // k) * k), dtype=bool)
    big[:rows, :cols] = clear_cells
    return big.reshape(big.shape[0] // k, k, big.shape[1] // k, k).all(axis=(1, 3))


def _shifted(mask: np.ndarray, di: int, dj: int) -> np.ndarray:
    """``out[i, j] = mask[i + di, j + dj]`` (False off the grid)."""
    out = np.zeros_like(mask)
    rows, cols = mask.shape
    src = mask[max(di, 0) : rows + min(di, 0), max(dj, 0) : cols + min(dj, 0)]
    out[max(-di, 0) : rows + min(-di, 0), max(-dj, 0) : cols + min(-dj, 0)] = src
    return out


def block_graph(node: np.ndarray, step: float):
    """The search graph of the clear blocks (``node``: each block's index, -1 if not clear),
    as a CSR matrix of 16 entries a node: the moves of :data:`MOVES` both ways (lengths in
    metres, ``step`` a block's side), and a self-loop of weight 1 in place of each move the
    map does not allow (a self-loop never shortens a path)."""
    from scipy.sparse import csr_matrix

    clear = node >= 0
    count = int(clear.sum())
    ids = node[clear]
    cols = np.empty((count, 2 * len(MOVES)), dtype=np.int32)
    wgt = np.empty((count, 2 * len(MOVES)))
    slot = 0
    for (di, dj), crossed in MOVES:
        for sign in (1, -1):
            ok = _shifted(clear, sign * di, sign * dj)
            for ci, cj in crossed:
                ok &= _shifted(clear, sign * ci, sign * cj)
            dst = _shifted(node, sign * di, sign * dj)[clear]
            good = ok[clear]
            cols[:, slot] = np.where(good, dst, ids)
            wgt[:, slot] = np.where(good, step * math.hypot(di, dj), 1.0)
            slot += 1
    order = np.argsort(ids)  # rows in node order
    indptr = np.arange(0, cols.size + 1, cols.shape[1], dtype=np.int64)
    return csr_matrix((wgt[order].ravel(), cols[order].ravel(), indptr), shape=(count, count))


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """The free space of a map eroded by the robot's ``radius`` (metres), its components and
    its search graph: built once per map and radius (module docstring).

    ``cell_clearance``: each cell centre's distance to the nearest blocked cell (metres);
    ``clear_cells``: the cells whose centre keeps ``radius``; ``k``: the block size (cells);
    ``node``: each block's node index (-1: not clear); ``centre``: each node's block centre
    ``(u, v)`` (cells); ``label``: each node's component."""

    clear: MapClearance
    radius: float = RADIUS
    max_nodes: int = MAX_NODES
    cell_clearance: np.ndarray = field(init=False, repr=False)
    clear_cells: np.ndarray = field(init=False, repr=False)
    k: int = field(init=False)
    node: np.ndarray = field(init=False, repr=False)
    centre: np.ndarray = field(init=False, repr=False)
    label: np.ndarray = field(init=False, repr=False)
    graph: object = field(init=False, repr=False)

    def __post_init__(self):
        from scipy import ndimage

        if not isinstance(self.clear, MapClearance):
            raise ScenarioError(f"clear: expected a MapClearance, got {type(self.clear).__name__}")
        radius = checks.real(self.radius, "radius", ge=0)
        max_nodes = require_integer("max_nodes", self.max_nodes, 1, error=ScenarioError)
        occ = self.clear.occupancy
        cells = centre_clearance(self.clear.blocked, self.clear.unknown_is_occupied)
        cells *= np.float32(occ.resolution)
        clear_cells = cells >= radius
        rows, cols = clear_cells.shape
        k = max(1, math.ceil(math.sqrt(rows * cols / max_nodes)))
        blocks = _clear_blocks(clear_cells, k)
        node = np.full(blocks.shape, -1, dtype=np.int32)
        node[blocks] = np.arange(int(blocks.sum()), dtype=np.int32)
        labels, _ = ndimage.label(blocks)  # joined by their sides, as the graph joins them
        bi, bj = np.nonzero(blocks)  # in node order (row-major, as numbered)
        centre = np.column_stack([(bj + 0.5) * k, (bi + 0.5) * k])
        for name, value in (
            ("radius", radius),
            ("max_nodes", max_nodes),
            ("cell_clearance", cells),
            ("clear_cells", clear_cells),
            ("k", k),
            ("node", node),
            ("centre", centre),
            ("label", labels[blocks].astype(np.int32)),
            ("graph", block_graph(node, k * occ.resolution)),
        ):
            object.__setattr__(self, name, value)

    # ----------------------------------------------------------------- sight and links

    def visible(self, a, b) -> bool:
        """Whether the segment between grid points ``a`` and ``b`` (``(u, v)``, cells) stays
        on clear cells, checked every half cell."""
        au, av, bu, bv = float(a[0]), float(a[1]), float(b[0]), float(b[1])
        rows, cols = self.clear_cells.shape
        if min(au, bu) < 0 or min(av, bv) < 0 or max(au, bu) >= cols or max(av, bv) >= rows:
            return False  # (a segment's extremes are at its ends)
        n = max(2, int(math.ceil(math.hypot(bu - au, bv - av) / SIGHT_STEP)) + 1)
        t = np.arange(n) / (n - 1)
        j = (au + t * (bu - au)).astype(np.intp)  # the floor: the coordinates are >= 0
        i = (av + t * (bv - av)).astype(np.intp)
        return bool(self.clear_cells[i, j].all())

    def link(self, uv) -> int:
        """The node a grid point joins: its own block if clear (a block is convex), else the
        nearest clear block within :data:`LINK_REACH` blocks in straight sight; -1 if none."""
        u, v = float(uv[0]), float(uv[1])
        k = self.k
        bi, bj = int(v // k), int(u // k)
        rows, cols = self.node.shape
        if 0 <= bi < rows and 0 <= bj < cols and self.node[bi, bj] >= 0:
            return int(self.node[bi, bj])
        r = LINK_REACH
        i0, j0 = max(bi - r, 0), max(bj - r, 0)
        window = self.node[i0 : max(bi + r + 1, 0), j0 : max(bj + r + 1, 0)]
        ii, jj = np.nonzero(window >= 0)
        centres = np.column_stack([(jj + j0 + 0.5) * k, (ii + i0 + 0.5) * k])
        for m in np.argsort(np.hypot(centres[:, 0] - u, centres[:, 1] - v), kind="stable"):
            if self.visible((u, v), centres[m]):
                return int(window[ii[m], jj[m]])
        return -1

    def component(self, x, y) -> np.ndarray:
        """The component of each world point (-1: joined to no clear block)."""
        u, v = self.clear.occupancy.world_to_grid(np.ravel(x), np.ravel(y))
        nodes = [self.link(p) for p in zip(u.tolist(), v.tolist(), strict=True)]
        out = np.array([self.label[m] if m >= 0 else -1 for m in nodes], dtype=np.int64)
        return out.reshape(np.shape(x))

    # ----------------------------------------------------------------- paths

    def _search(self, s: int, g: int, straight: float) -> np.ndarray | None:
        """Node path from ``s`` to ``g``: A* as Dijkstra's algorithm on the reduced lengths
        ``w(a, b) - h(a) + h(b)`` (``h``: the straight line to ``g``, a consistent bound, so
        they are not negative; rounding's -1e-16 are set to 0), searched up to a limit on the
        detour that grows until ``g`` is reached. ``straight``: metres from ``s`` to ``g``."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        if self.label[s] != self.label[g]:
            return None
        graph = self.graph
        res = self.clear.occupancy.resolution
        h = np.hypot(*(self.centre - self.centre[g]).T) * res
        slots = graph.indptr[1] - graph.indptr[0]  # each row holds all 16 moves
        data = graph.data - np.repeat(h, slots) + h[graph.indices]
        np.maximum(data, 0.0, out=data)
        reduced = csr_matrix((data, graph.indices, graph.indptr), shape=graph.shape)
        limit = DETOUR * straight + self.k * res
        while True:
            dist, pred = dijkstra(
                reduced, directed=True, indices=s, return_predecessors=True, limit=limit
            )
            if np.isfinite(dist[g]):
                break
            if limit == np.inf:  # cannot be: one component is one piece of the graph
                return None
            limit = limit * 4.0 if limit < 1e9 else np.inf  # the goal is farther: go on
        path = [g]
        while path[-1] != s:
            path.append(int(pred[path[-1]]))
        return np.array(path[::-1])

    def path(self, start, goal) -> np.ndarray | None:
        """A short path (``(m, 2)`` world points, ``start`` and ``goal`` ``(x, y)`` its ends)
        through the clear space, pulled taut (module docstring); None if there is none."""
        occ = self.clear.occupancy
        su, sv = occ.world_to_grid(float(start[0]), float(start[1]))
        gu, gv = occ.world_to_grid(float(goal[0]), float(goal[1]))
        a, b = np.array([su, sv], dtype=float), np.array([gu, gv], dtype=float)
        if self.visible(a, b):
            pts = np.array([a, b])
        else:
            s, g = self.link(a), self.link(b)
            if s < 0 or g < 0:
                return None
            nodes = self._search(s, g, math.hypot(*(b - a)) * occ.resolution)
            if nodes is None:
                return None
            pts = np.vstack([a, self.centre[nodes], b])
            pts = pull_taut(pts, self.visible)
            pts = pull_taut(resample(pts, 1.0), self.visible)
            pts = pull_taut(cut_corners(pts, self.visible), self.visible)
        x, y = occ.grid_to_world(pts[:, 0], pts[:, 1])
        out = np.column_stack([x, y])
        out[0], out[-1] = start[:2], goal[:2]  # the ends exactly, not through the grid
        return out

    def shortest(self, start, goal) -> float:
        """The length of :meth:`path` (metres; ``inf`` when there is none): summed segment by
        segment with ``math.hypot``, so that a straight path is exactly the distance."""
        pts = self.path(start, goal)
        if pts is None:
            return math.inf
        x, y = pts.T.tolist()
        return math.fsum(map(math.hypot, np.diff(x).tolist(), np.diff(y).tolist()))


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline ``points`` with extra points every ``spacing`` (at most) along each
    segment; its own points kept."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        n = max(1, int(math.ceil(math.hypot(*(b - a)) / spacing)))
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + t * (b - a))
    return np.vstack(out)


def pull_taut(points: np.ndarray, visible) -> np.ndarray:
    """The polyline ``points`` pulled taut: from each kept point, on to the farthest later
    point in sight (found by doubling, then halving, the step), given that each point sees the
    next one. ``visible(a, b)`` tells whether two points see each other."""
    keep = [0]
    last = len(points) - 1
    i = 0
    while i < last:
        good, step = i + 1, 1
        while good + step <= last and visible(points[i], points[good + step]):
            good += step
            step *= 2
        while step > 1:  # points[good] is in sight, points[good + step] is not (or is past)
            step //= 2
            if good + step <= last and visible(points[i], points[good + step]):
                good += step
        keep.append(good)
        i = good
    return points[keep]


def _cut(v, ua, ub, most: float, visible) -> float:
    """How far (cells, at most ``most``) from ``v`` along the unit directions ``ua`` and
    ``ub`` the points ``v + d ua`` and ``v + d ub`` still see each other: doubled from
    :data:`CUT_FIRST` while they do, then :data:`CUT_STEPS` halvings; 0 if even
    :data:`CUT_FIRST` fails."""
    lo = min(CUT_FIRST, most)
    if not visible(v + lo * ua, v + lo * ub):
        return 0.0
    while 2 * lo <= most and visible(v + 2 * lo * ua, v + 2 * lo * ub):
        lo *= 2
    hi = min(2 * lo, most)
    for _ in range(CUT_STEPS):
        mid = 0.5 * (lo + hi)
        if visible(v + mid * ua, v + mid * ub):
            lo = mid
        else:
            hi = mid
    return lo


def cut_corners(points: np.ndarray, visible, rounds: int = CUT_ROUNDS) -> np.ndarray:
    """The taut polyline ``points`` shortened round the corners it wraps: each inner point
    ``v`` is replaced by the points ``p`` and ``q`` at the same distance from it along its two
    segments, as far as (up to half the shorter segment; :func:`_cut`) ``p`` sees ``q``;
    ``rounds`` passes. A corner of the eroded space is an arc (the radius round a wall's
    corner): one vertex outside a quarter arc of radius ``r`` adds ``0.43 r`` to the length,
    two add ``0.09 r``, four ``0.02 r``."""
    pts = [np.asarray(p, dtype=float) for p in points]
    for _ in range(rounds):
        out, changed = [pts[0]], False
        for k in range(1, len(pts) - 1):
            v = pts[k]
            ua, ub = out[-1] - v, pts[k + 1] - v
            la, lb = math.hypot(*ua), math.hypot(*ub)
            if la == 0.0 or lb == 0.0 or float(np.dot(ua, ub)) <= -CUT_COS * la * lb:
                out.append(v)  # (almost) no turn here: nothing to gain
                continue
            ua, ub = ua / la, ub / lb
            lo = _cut(v, ua, ub, 0.5 * min(la, lb), visible)
            if lo > 0.0:
                out += [v + lo * ua, v + lo * ub]
                changed = True
            else:
                out.append(v)
        out.append(pts[-1])
        pts = out
        if not changed:
            break
    return np.array(pts)


# --------------------------------------------------------------------------- random queries


@dataclass
class _Draws:
    """Candidate places drawn :data:`BATCH` at a time: a candidate cell uniformly, a point
    uniformly in it and a heading uniformly in ``[-pi, pi)``; the points at least
    ``clearance`` (metres, exact) from the blocked cells and ``border`` (cells) inside the
    map's edges are queued. ``drawn`` counts the candidates drawn so far."""

    space: FreeSpace
    rng: np.random.Generator
    cells: np.ndarray  # flat indices of the candidate cells
    clearance: float
    border: float
    queue: list = field(default_factory=list)
    drawn: int = 0

    def _batch(self) -> None:
        occ = self.space.clear.occupancy
        rows, cols = occ.shape
        flat = self.cells[self.rng.integers(self.cells.size, size=BATCH)]
        offset = self.rng.random((BATCH, 2))
        heading = self.rng.uniform(-math.pi, math.pi, size=BATCH)
        u = flat % cols + offset[:, 0]
        v = flat // cols + offset[:, 1]
        b = self.border
        inside = (u >= b) & (u <= cols - b) & (v >= b) & (v <= rows - b)
        x, y = occ.grid_to_world(u, v)
        ok = inside & (self.space.clear.distance(x, y) >= self.clearance)
        rows_ok = np.column_stack([x, y, heading, u, v])[ok]
        self.queue.extend(rows_ok[::-1].tolist())  # popped from the end: in drawn order
        self.drawn += BATCH

    def next(self, budget: int):
        """The next place ``[x, y, heading, u, v]``; None once ``budget`` candidates are spent."""
        while not self.queue:
            if self.drawn >= budget:
                return None
            self._batch()
        return self.queue.pop()


def _candidate_cells(space: FreeSpace, clearance: float, border: float) -> np.ndarray:
    """Flat indices of the cells that may hold a point ``clearance`` metres from the blocked
    cells (a cell's centre is within half a diagonal of its points) and within ``border``
    cells of the map's edges."""
    occ = space.clear.occupancy
    rows, cols = occ.shape
    near = clearance - occ.resolution * math.sqrt(0.5)
    ok = space.cell_clearance >= near
    j, i = np.arange(cols), np.arange(rows)
    ok &= ((i + 1 > border) & (i < rows - border))[:, None]
    ok &= ((j + 1 > border) & (j < cols - border))[None, :]
    return np.flatnonzero(ok)


def _start_draws(space: FreeSpace, seed: int, clearance: float, border: float) -> _Draws:
    """The draws of :func:`random_queries` (``border`` in metres); a map without a single
    candidate cell is refused."""
    occ = space.clear.occupancy
    cells = _candidate_cells(space, clearance, border / occ.resolution)
    if cells.size == 0:
        raise ScenarioError(
            f"map {occ.name!r}: no free cell is {clearance:g} m from the obstacles"
            f"{f' and {border:g} m inside the edges' if border else ''}: no room for queries"
        )
    rng = np.random.default_rng(seed)
    return _Draws(space, rng, cells, clearance, border / occ.resolution)


def _settings(clear, n, radius, clearance, min_distance, border):
    """The checked arguments of :func:`random_queries`."""
    if not isinstance(clear, MapClearance):
        raise ScenarioError(f"clear: expected a MapClearance, got {type(clear).__name__}")
    n = require_integer("n", n, 1, 1_000_000, error=ScenarioError)
    radius = checks.real(radius, "radius", ge=0)
    clearance = radius + MARGIN if clearance is None else checks.real(clearance, "clearance")
    if clearance < radius:
        raise ScenarioError(f"clearance: must be at least the radius {radius!r}, got {clearance!r}")
    min_distance = checks.real(min_distance, "min_distance", ge=0)
    border = checks.real(border, "border", ge=0)
    return n, radius, clearance, min_distance, border


def _pair(draws: _Draws, space: FreeSpace, min_distance: float, budget: int):
    """A start and a goal in the same component, more than ``min_distance`` apart (up to
    :data:`GOAL_DRAWS` goals for the start); ``False`` to try another start, None once the
    budget is spent."""
    start = draws.next(budget)
    if start is None:
        return None
    s_node = space.link(start[3:])
    if s_node < 0:
        return False
    for _ in range(GOAL_DRAWS):
        goal = draws.next(budget)
        if goal is None:
            return None
        if math.hypot(goal[0] - start[0], goal[1] - start[1]) <= min_distance:
            continue
        g_node = space.link(goal[3:])
        if g_node >= 0 and space.label[g_node] == space.label[s_node]:
            return start, goal
    return False


def random_queries(
    clear: MapClearance,
    n: int,
    seed: int = 0,
    radius: float = RADIUS,
    clearance: float | None = None,
    min_distance: float = MIN_DISTANCE,
    *,
    border: float = 0.0,
    max_draws: int | None = None,
    space: FreeSpace | None = None,
) -> list[MapQuery]:
    """``n`` random queries on ``clear``'s map by nav2's planner-benchmark protocol (module
    docstring): start and goal uniform over the places at least ``clearance`` metres (default:
    ``radius`` + 0.1 m) from the blocked cells and ``border`` metres inside the map's edges,
    the goal more than ``min_distance`` metres from the start and reachable from it by a disc
    of ``radius``, headings uniform in ``[-pi, pi)``; the same ``seed`` gives the same queries.

    At most ``max_draws`` candidate places are drawn (default: 1000 a query, and 5120 more),
    rounded up to a whole batch of :data:`BATCH`; too few valid places raise a one-line
    :class:`~leapfrog_planner.errors.ScenarioError`.
    ``space``: a :class:`FreeSpace` of this map and radius, to reuse (built otherwise)."""
    n, radius, clearance, min_distance, border = _settings(
        clear, n, radius, clearance, min_distance, border
    )
    seed = require_integer("seed", seed, 0, error=ScenarioError)
    budget = 1000 * n + 10 * BATCH if max_draws is None else max_draws
    budget = require_integer("max_draws", budget, 1, error=ScenarioError)
    if space is None:
        space = FreeSpace(clear, radius)
    elif space.clear is not clear or space.radius != radius:
        raise ScenarioError("space: built for another map or radius")
    draws = _start_draws(space, seed, clearance, border)
    out: list[MapQuery] = []
    while len(out) < n:
        pair = _pair(draws, space, min_distance, budget)
        if pair is None:
            raise ScenarioError(
                f"map {clear.occupancy.name!r}: only {len(out)} of {n} queries after"
                f" {draws.drawn} draws (clearance {clearance:g} m, min_distance"
                f" {min_distance:g} m): too few valid places"
            )
        if pair is False:
            continue
        (sx, sy, sh, *_), (gx, gy, gh, *_) = pair
        out.append(
            MapQuery(
                (sx, sy, sh),
                (gx, gy, gh),
                math.hypot(gx - sx, gy - sy),
                space.shortest((sx, sy), (gx, gy)),
            )
        )
    return out
