"""Polygons and walls: obstacles given by their geometry, with their exact signed distance.

A **polygon** is a closed ring of vertices, convex or not (its inside by the even-odd rule, so a
ring that crosses itself is still read one way). A **wall** is a thick polyline: the points
within half its ``thickness`` of the line through its vertices. Their union is the obstacle.

:func:`signed_distance` is exact outside the union (the distance to its nearest point) and
negative inside (minus the depth in the deepest single shape: inside, only the sign matters to
the clearance, and the penalty is at its full weight there). The map's penalty field
(:mod:`.field`) takes it at its nodes in place of the cells' distance; the clearance of a motion
takes it at the motion's samples, so polygons are judged by their geometry, never by cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import checks
from .._jit import njit
from ..errors import ScenarioError

POLYGON = 0
WALL = 1
#: At most this many vertices over all shapes (each distance visits every nearby edge).
VERTICES_MAX = 100_000


@dataclass(frozen=True, eq=False)
class Shapes:
    """Polygons (``(k, 2)`` vertex arrays, ``k >= 3``) and walls (``(k, 2)`` vertex arrays,
    ``k >= 2``, with a ``thickness`` each). Construction checks them; the compiled distance
    reads the flat arrays below (world coordinates)."""

    polygons: tuple[np.ndarray, ...] = ()
    walls: tuple[np.ndarray, ...] = ()
    thickness: tuple[float, ...] = ()
    points: np.ndarray = field(init=False, repr=False)  # (V, 2) every vertex, shape by shape
    first: np.ndarray = field(init=False, repr=False)  # (K + 1,) shape k from first[k]
    kind: np.ndarray = field(init=False, repr=False)  # (K,) POLYGON or WALL
    half: np.ndarray = field(init=False, repr=False)  # (K,) half a wall's thickness (0: polygon)
    boxes: np.ndarray = field(init=False, repr=False)  # (K, 4) xmin, xmax, ymin, ymax

    def __post_init__(self):
        polygons = tuple(
            _vertices(p, f"polygons[{i}].points", 3) for i, p in enumerate(self.polygons)
        )
        walls = tuple(_vertices(w, f"walls[{i}].points", 2) for i, w in enumerate(self.walls))
        if len(self.thickness) != len(walls):
            raise ScenarioError(f"walls: {len(walls)} walls but {len(self.thickness)} thicknesses")
        thickness = tuple(
            checks.in_range(
                checks.real(t, f"walls[{i}].thickness", gt=0),
                f"walls[{i}].thickness",
                0.0,
                checks.COORDINATE_MAX,
            )
            for i, t in enumerate(self.thickness)
        )
        for i, p in enumerate(polygons):
            if _ring_area(p) == 0.0:
                raise ScenarioError(f"polygons[{i}].points: the polygon has no area")
        rings = polygons + walls
        count = sum(len(r) for r in rings)
        if count > VERTICES_MAX:
            raise ScenarioError(f"polygons, walls: at most {VERTICES_MAX} vertices, got {count}")
        points = np.concatenate(rings) if rings else np.zeros((0, 2))
        first = np.cumsum([0] + [len(r) for r in rings]).astype(np.int64)
        kind = np.array([POLYGON] * len(polygons) + [WALL] * len(walls), dtype=np.int64)
        half = np.array([0.0] * len(polygons) + [0.5 * t for t in thickness])
        boxes = np.array(
            [[r[:, 0].min(), r[:, 0].max(), r[:, 1].min(), r[:, 1].max()] for r in rings]
        ).reshape(-1, 4)
        boxes[:, 0] -= half
        boxes[:, 1] += half
        boxes[:, 2] -= half
        boxes[:, 3] += half
        for name, value in (("polygons", polygons), ("walls", walls), ("thickness", thickness),
                            ("points", points), ("first", first), ("kind", kind),
                            ("half", half), ("boxes", boxes)):  # fmt: skip
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
            object.__setattr__(self, name, value)

    def __len__(self) -> int:
        return len(self.polygons) + len(self.walls)

    @property
    def box(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of all the shapes (walls with their thickness)."""
        b = self.boxes
        return (float(b[:, 0].min()), float(b[:, 1].max()),
                float(b[:, 2].min()), float(b[:, 3].max()))  # fmt: skip

    def distance(self, x, y) -> np.ndarray:
        """The signed distance (metres) from world points ``(x, y)`` to the shapes' union
        (module docstring): ``inf`` with no shapes."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            raise ScenarioError("points: coordinates must be finite")
        out = np.empty(x.size)
        _points_distance(
            np.ascontiguousarray(x.ravel()), np.ascontiguousarray(y.ravel()), *self.arrays(), out
        )
        return out.reshape(x.shape)

    def arrays(self):
        """The flat arrays the compiled distance reads: points, first, kind, half, boxes."""
        return self.points, self.first, self.kind, self.half, self.boxes

    def to_dict(self) -> dict:
        """The ``polygons`` and ``walls`` arrays of tables of a scenario file."""
        out: dict = {}
        if self.polygons:
            out["polygons"] = [{"points": p.tolist()} for p in self.polygons]
        if self.walls:
            out["walls"] = [
                {"points": w.tolist(), "thickness": t}
                for w, t in zip(self.walls, self.thickness, strict=True)
            ]
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Shapes):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]


def _vertices(points, key: str, least: int) -> np.ndarray:
    out = checks.rows(points, 2, key, "x, y")
    if out.shape[0] < least:
        raise ScenarioError(f"{key}: expected at least {least} [x, y] points, got {out.shape[0]}")
    checks.magnitude(out, key, checks.COORDINATE_MAX)
    return out


def _ring_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2.0)


# --------------------------------------------------------------------------- compiled distance


@njit(cache=True, inline="always")
def _segment_distance2(px, py, ax, ay, bx, by):
    """The squared distance from ``(px, py)`` to the segment ``a b``."""
    dx = bx - ax
    dy = by - ay
    qx = px - ax
    qy = py - ay
    den = dx * dx + dy * dy
    t = 0.0 if den == 0.0 else min(max((qx * dx + qy * dy) / den, 0.0), 1.0)
    ex = qx - t * dx
    ey = qy - t * dy
    return ex * ex + ey * ey


@njit(cache=True)
def _shape_distance(px, py, points, start, stop, kind, half):
    """The signed distance from ``(px, py)`` to one shape (vertices ``start .. stop - 1``)."""
    best = np.inf
    inside = False
    last = stop if kind == POLYGON else stop - 1
    for a in range(start, last):
        b = a + 1 if a + 1 < stop else start
        ax, ay, bx, by = points[a, 0], points[a, 1], points[b, 0], points[b, 1]
        best = min(best, _segment_distance2(px, py, ax, ay, bx, by))
        if kind == POLYGON and (ay > py) != (by > py):
            if px < ax + (py - ay) * (bx - ax) / (by - ay):
                inside = not inside
    d = math.sqrt(best)
    if kind == POLYGON:
        return -d if inside else d
    return d - half


@njit(cache=True, inline="always")
def _box_distance(px, py, box):
    dx = max(box[0] - px, px - box[1], 0.0)
    dy = max(box[2] - py, py - box[3], 0.0)
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def _points_distance(xs, ys, points, first, kind, half, boxes, out):
    """``out[i]``: the signed distance from ``(xs[i], ys[i])`` to the union of the shapes; a
    shape whose box lies farther than the best so far is skipped."""
    for i in range(xs.size):
        best = np.inf
        for k in range(kind.size):
            if _box_distance(xs[i], ys[i], boxes[k]) >= best:
                continue
            d = _shape_distance(xs[i], ys[i], points, first[k], first[k + 1], kind[k], half[k])
            best = min(best, d)
        out[i] = best


@njit(cache=True)
def _grid_distance(points, first, kind, half, boxes, x0, y0, c, s, h, reach, out):
    """``out[i, j] = min(out[i, j], d)`` with ``d`` the signed distance from the node at the
    world point ``(x0, y0) + R (j h, i h)`` (``R`` the rotation of cosine ``c`` and sine ``s``)
    to each shape within ``reach`` metres of its box; the others leave the node as it is."""
    ny, nx = out.shape
    for k in range(kind.size):
        b = boxes[k]
        # The box grown by reach, in grid coordinates: the rotated corners' bounds.
        lo_u = lo_v = np.inf
        hi_u = hi_v = -np.inf
        for cx in (b[0] - reach, b[1] + reach):
            for cy in (b[2] - reach, b[3] + reach):
                u = (c * (cx - x0) + s * (cy - y0)) / h
                v = (c * (cy - y0) - s * (cx - x0)) / h
                lo_u, hi_u = min(lo_u, u), max(hi_u, u)
                lo_v, hi_v = min(lo_v, v), max(hi_v, v)
        j0, j1 = max(0, int(math.floor(lo_u))), min(nx - 1, int(math.ceil(hi_u)))
        i0, i1 = max(0, int(math.floor(lo_v))), min(ny - 1, int(math.ceil(hi_v)))
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                px = x0 + c * j * h - s * i * h
                py = y0 + s * j * h + c * i * h
                d = _shape_distance(px, py, points, first[k], first[k + 1], kind[k], half[k])
                if d < out[i, j]:
                    out[i, j] = d


def grid_distance(shapes: Shapes, origin, h: float, shape, reach: float, cap: float) -> np.ndarray:
    """The signed distance (metres) from the nodes of a grid (node ``(i, j)`` at the world
    point ``origin[:2] + R(origin[2]) (j h, i h)``, ``shape`` rows and columns) to ``shapes``,
    at most ``cap`` (also where every shape is more than ``reach`` away)."""
    out = np.full(shape, float(cap))
    x0, y0, yaw = origin
    _grid_distance(*shapes.arrays(), x0, y0, math.cos(yaw), math.sin(yaw), h, reach, out)
    return out
