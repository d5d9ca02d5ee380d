"""Exact clearance against a map: the Euclidean distance from points to the nearest blocked cell,
each cell the closed square it covers, less the robot's radius (a disc footprint).

Blocked are the occupied cells and, unless told otherwise, the unknown ones; the world beyond
the map counts as unknown space. The distance is exact (to rounding), not a value of a sampled
field: it is the distance to the nearest square among candidates that provably hold it.

How. Only blocked cells with a side on free space (:func:`boundary_cells`) can hold the nearest
point of the blocked region to a point outside it (in the 2 x 2 cells round that point, a free
cell and a blocked one share a side). Their centres go into a k-d tree (SciPy's ``cKDTree``,
built once, in milliseconds). A query takes the ``k`` nearest centres and the exact distance to
each one's square, ``hypot(max(|du| - 1/2, 0), max(|dv| - 1/2, 0))`` in cells; every other
square lies at least ``r_k - sqrt(1/2)`` away (``r_k`` the distance to the ``k``-th centre: a
square reaches at most half its diagonal from its centre), so the smallest of the ``k`` is the
answer once it is within that bound; the points where it is not are asked again with four times
``k``. (The nearest cell *centres* of a Euclidean distance transform do not give this: among the
cells round a point, their nearest squares miss the nearest one about once in 60,000 random
queries, by up to 0.01 cell.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import checks
from ..errors import ScenarioError
from .occupancy import OCCUPIED, OccupancyMap

HALF_DIAGONAL = math.sqrt(0.5)  # how far a unit square reaches from its centre
FIRST_NEIGHBOURS = 8  # the candidates of a first query (9 in 10 points need no more)
SLACK = 1e-9  # cells: the proof's bound is kept by this much against rounding
CHUNK = 1 << 14  # points a query handles at a time (bounds the temporaries)


def boundary_cells(blocked: np.ndarray, outside_blocked: bool) -> np.ndarray:
    """The blocked cells with a side on a free cell (or on the map's edge when the outside is
    free): one of them always holds the nearest blocked point to a point outside the blocked
    region, so the others need not be searched."""
    free = np.pad(~blocked, 1, constant_values=not outside_blocked)
    side_free = free[:-2, 1:-1] | free[2:, 1:-1] | free[1:-1, :-2] | free[1:-1, 2:]
    return blocked & side_free


def square_distance(u, v, cu, cv) -> np.ndarray:
    """Distance from points ``(u, v)`` to the unit squares centred at ``(cu, cv)`` (cells)."""
    du = np.maximum(np.abs(u - cu) - 0.5, 0.0)
    dv = np.maximum(np.abs(v - cv) - 0.5, 0.0)
    return np.hypot(du, dv)


def _nearest_chunk(tree, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.empty(u.size)
    todo = np.arange(u.size)
    k = FIRST_NEIGHBOURS
    while todo.size:
        k = min(k, tree.n)
        q = np.column_stack([u[todo], v[todo]])
        dist, idx = tree.query(q, k=k)
        dist, idx = dist.reshape(todo.size, k), idx.reshape(todo.size, k)
        centres = tree.data[idx]
        best = square_distance(q[:, :1], q[:, 1:], centres[..., 0], centres[..., 1]).min(axis=1)
        done = (
            best <= dist[:, -1] - HALF_DIAGONAL - SLACK if k < tree.n else np.ones_like(best, bool)
        )
        out[todo[done]] = best[done]
        todo = todo[~done]
        k *= 4
    return out


def nearest_square_distance(tree, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Exact distance (cells) from each point ``(u, v)`` to the nearest of the unit squares
    whose centres are the points of the k-d ``tree`` (module docstring)."""
    out = np.empty(u.size)
    for s in range(0, u.size, CHUNK):
        out[s : s + CHUNK] = _nearest_chunk(tree, u[s : s + CHUNK], v[s : s + CHUNK])
    return out


@dataclass(frozen=True, eq=False)
class PathClearance:
    """The clearance of each sample of a path (metres), the least and the sample that has it."""

    values: np.ndarray
    minimum: float
    worst: int

    def is_clear(self, margin: float = 0.0) -> bool:
        """Whether every sample keeps at least ``margin`` beyond the footprint."""
        return self.minimum >= margin


@dataclass(frozen=True, eq=False)
class MapClearance:
    """The exact clearance of points against ``occupancy``, built once (module docstring).

    Blocked are cells valued ``threshold`` or more (100: occupied) and, if
    ``unknown_is_occupied``, the unknown ones and the whole world off the map."""

    occupancy: OccupancyMap
    unknown_is_occupied: bool = True
    threshold: int = OCCUPIED
    blocked: np.ndarray = field(init=False, repr=False)
    tree: object = field(init=False, repr=False)  # scipy.spatial.cKDTree, or None

    def __post_init__(self):
        from scipy.spatial import cKDTree

        if not isinstance(self.occupancy, OccupancyMap):
            raise ScenarioError(f"occupancy: expected an OccupancyMap, got {self.occupancy!r:.60}")
        unknown = bool(self.unknown_is_occupied)
        blocked = self.occupancy.blocked(unknown, self.threshold)
        rows, cols = np.nonzero(boundary_cells(blocked, outside_blocked=unknown))
        centres = np.column_stack([cols + 0.5, rows + 0.5])
        tree = cKDTree(centres, balanced_tree=False, compact_nodes=False) if rows.size else None
        blocked.setflags(write=False)
        object.__setattr__(self, "unknown_is_occupied", unknown)
        object.__setattr__(self, "blocked", blocked)
        object.__setattr__(self, "tree", tree)

    def grid_distance(self, u, v) -> np.ndarray:
        """Exact distance (cells) from grid points ``(u, v)`` to the blocked region: 0 inside it,
        ``inf`` when nothing is blocked."""
        u, v = (np.ravel(a).astype(float) for a in np.broadcast_arrays(u, v))
        rows, cols = self.blocked.shape
        d = np.full(u.size, np.inf)
        on = (u >= 0) & (u < cols) & (v >= 0) & (v < rows)
        d[on] = np.where(self.blocked[v[on].astype(np.int64), u[on].astype(np.int64)], 0.0, np.inf)
        if self.unknown_is_occupied:  # the world off the map is blocked
            edge = np.minimum(np.minimum(u, cols - u), np.minimum(v, rows - v))
            d = np.minimum(d, np.maximum(edge, 0.0))
        ask = np.flatnonzero(d > 0)
        if self.tree is not None and ask.size:
            d[ask] = np.minimum(d[ask], nearest_square_distance(self.tree, u[ask], v[ask]))
        return d

    def distance(self, x, y) -> np.ndarray:
        """Exact distance (metres) from world points ``(x, y)`` (arrays of one shape, or
        scalars) to the nearest blocked cell: 0 in one, ``inf`` when nothing is blocked."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            raise ScenarioError("points: coordinates must be finite")
        u, v = self.occupancy.world_to_grid(x, y)
        return (self.grid_distance(u, v) * self.occupancy.resolution).reshape(x.shape)

    def clearance(self, x, y, radius: float = 0.0) -> np.ndarray:
        """:meth:`distance` less the footprint's ``radius``: below 0 where the robot, centred
        at the point, overlaps a blocked cell (``-radius`` with its centre in one)."""
        radius = checks.real(radius, "radius", ge=0)
        return self.distance(x, y) - radius

    def path_clearance(self, points, radius: float = 0.0) -> PathClearance:
        """The clearance of a path's samples ``points`` (``(N, 2)``, world ``x, y``; ``N >= 1``):
        exact at the samples, not between them (sampled at spacing ``s``, the path's clearance
        between two samples is at least the smaller of theirs less ``s / 2``)."""
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] == 0:
            raise ScenarioError(f"points: expected an (N, 2) array with N >= 1, got {pts.shape}")
        values = self.clearance(pts[:, 0], pts[:, 1], radius)
        values.setflags(write=False)
        worst = int(np.argmin(values))
        return PathClearance(values, float(values[worst]), worst)
