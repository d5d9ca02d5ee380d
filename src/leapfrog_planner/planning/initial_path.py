"""Initial feasible paths for the Leapfrog method (spec section 2, step 1).

Leapfrog needs a collision-free path from start to goal, split into ``q`` segments. The initial
path decides which local optimum Leapfrog converges to (spec section 5), so this module returns
several paths that pass the obstacles on different sides, one per homotopy class, shortest first.

Method
------
1. Every obstacle disc ``[cx, cy, r]`` is inflated by ``margin`` (less for a disc that the start
   or goal lies closer to than ``margin``, so that neither end is ever inside an inflated disc).
   Discs inside other inflated discs are dropped.
2. The exact *tangent graph* of the inflated discs: its nodes are the tangent points of the
   lines from start and goal to each circle and of the four common tangents of each pair of
   circles; tangent points inside another inflated disc are dropped. Edges are the tangent
   segments that no inflated disc cuts (a vectorised segment-against-disc test) and the arcs
   between neighbouring tangent points on each circle that no other inflated disc covers. Each
   tangent point is two graph nodes, one per direction of travel round its circle (counter-
   clockwise or clockwise), and segments only join compatible directions, so every path of the
   directed graph is tangent-continuous (G1) and its shortest path from start to goal is the
   exact shortest path round the inflated discs. The search is Dijkstra's algorithm with the
   straight-line distance to the goal as (consistent) A* bound, compiled with numba: one search
   costs a few tens of microseconds, where a call of :func:`scipy.sparse.csgraph.dijkstra`
   costs about 0.1 ms of overhead alone, and step 3 needs up to 65 searches.
3. Other homotopy classes: for the (at most six) obstacles most relevant to the chord and the
   shortest path (centre projecting inside the chord, and ordered by the distance of the
   inflated disc to the chord or the shortest path, which must be less than that path's length),
   two barrier rays start at the centre, perpendicular to the chord, one to each side. Blocking
   one ray of each relevant obstacle, for all ``2**r`` sign patterns, and searching the remaining
   edges gives the shortest path that passes each relevant obstacle on the chosen side. The
   shortest path per *signature* is kept; paths longer than three times the shortest are
   dropped; the ``k`` shortest classes are returned, sorted by the length of their smoothed
   curves. A free straight chord is the graph's shortest path, so it comes first ("straight").
   When no path exists at all, the margin is halved (four times) and finally set to 0 before
   giving up; the label then says which margin was used.
4. Smoothing: the polyline (arcs sampled every 10 degrees) becomes a C1 cubic Hermite spline over
   cumulative chord length. The end derivatives are the unit heading vectors (so the curve leaves
   along the start heading and arrives along the goal heading, with a turn scaled by the first and
   last leg), the interior ones are Catmull-Rom central differences. A start (goal) heading more
   than 90 degrees off the first (last) leg gets a turning arc of radius a quarter of that leg
   first, since the cubic would turn very sharply there (and have a cusp at 180 degrees); the
   arc goes to the side that keeps the homotopy class. The spline's arclength is integrated by
   Gauss-Legendre quadrature on a dense grid and :meth:`InitialPath.curve` is parametrised by
   normalised arclength. When smoothing cuts into an obstacle (negative clearance), mid-leg
   points are inserted (twice at most) and the path is re-planned with twice and four times the
   margin; when nothing helps, the path with the best clearance is kept and its
   ``min_clearance`` shows the problem.

Signature
---------
``signature[j]`` is the winding number round obstacle ``j``'s centre of the closed loop "path,
then the straight chord back from goal to start": 0 when the path passes ``j`` on the same side as
the chord, +1 or -1 when it passes on the other side. For a centre exactly on the chord (where
the winding number is a half-integer) the half turn is rounded away from zero, so the two sides
give +1 and -1.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from ..errors import ScenarioError, SettingsError

__all__ = ["InitialPath", "initial_paths", "plot_initial_paths"]

_TWO_PI = 2.0 * math.pi
#: Arcs of the tangent graph are sampled with at most this angle between polyline vertices.
ARC_STEP = _TWO_PI / 36
#: At most this many obstacles get barrier rays (``2**MAX_RELEVANT`` Dijkstra runs).
MAX_RELEVANT = 6
#: Paths longer than this factor times the shortest path are dropped.
MAX_DETOUR = 3.0
#: Margin factors tried when the smoothed curve of a path cuts into an obstacle.
_RETRY_MARGIN_FACTORS = (2.0, 4.0)
#: Times mid-leg points are inserted (at the same margin) before the margin is increased.
_MIDPOINT_ROUNDS = 2
#: Target number of grid intervals of the arclength table (more for long polylines).
_GRID_INTERVALS = 512
_GL_X, _GL_W = np.polynomial.legendre.leggauss(3)
#: A start (goal) heading more than 90 degrees off the first (last) leg's direction gets a
#: turning arc (cosine of that angle), sampled every 30 degrees at most.
_TURN_COS = 0.0
_TURN_STEP = math.pi / 6
#: Radii of those arcs tried, as fractions of the leg (smaller ones only to keep the class).
_TURN_RADII = (0.25, 0.1, 0.04)
#: Margins tried, as fractions of the requested one, until some path exists; then margin 0.
_MARGIN_FALLBACK = (1.0, 0.5, 0.25, 0.125, 0.0625)


# --------------------------------------------------------------------------- the path


_NO_LEGS = np.zeros(0, dtype=np.int64)

# The curves are built and evaluated at thousands of parameters per path (arclength tables,
# ranking), where NumPy's calls and temporaries on small arrays cost several times more than
# these loops. The loops do the same operations in the same order as NumPy did, so the results
# are the same: hypot is the C library's, as NumPy's; the other transcendental functions and the
# products with the Gauss-Legendre weights (BLAS) stay NumPy's.


@njit(cache=True)
def _hermite_at(knots, width, coef, i, u, deriv, out, r):
    """Point (``deriv = 0``) or ``dp/du`` (1) of leg ``i`` at parameter ``u``, into ``out[r]``."""
    h = width[i]
    t = (u - knots[i]) / h
    for d in range(2):
        c0, c1, c2, c3 = coef[i, 0, d], coef[i, 1, d], coef[i, 2, d], coef[i, 3, d]
        if deriv == 0:
            out[r, d] = ((c3 * t + c2) * t + c1) * t + c0
        else:
            out[r, d] = ((3.0 * c3 * t + 2.0 * c2) * t + c1) / h


@njit(cache=True)
def _interval_of(grid, u):
    """The interval ``[grid[i], grid[i + 1]]`` holding ``u``, clamped to the first and last."""
    return min(max(np.searchsorted(grid, u, side="right") - 1, 0), grid.size - 2)


@njit(cache=True)
def _hermite_eval(knots, width, coef, u, legs, xy, d):
    """Points and ``dp/du`` at parameters ``u`` in legs ``legs`` (empty: found by bisection)."""
    for r in range(u.size):
        i = legs[r] if legs.size else _interval_of(knots, u[r])
        _hermite_at(knots, width, coef, i, u[r], 0, xy, r)
        _hermite_at(knots, width, coef, i, u[r], 1, d, r)


@njit(cache=True)
def _spline(pts, m_first, m_last, intervals, gl_x):
    """Hermite legs through ``pts`` and the arclength grid of :class:`_SmoothCurve`.

    Returns the leg lengths, the knots (cumulative chord length), the coefficients, the grid
    parameters (about ``intervals`` in all, at least two per leg), their legs, the half widths
    of the grid intervals and the speeds ``|dp/du|`` at their Gauss-Legendre nodes ``gl_x``; all
    but the first two are empty when the last knot is not positive. The slopes ``dp/du`` at the
    vertices are ``m_first`` and ``m_last`` at the ends and central differences inside."""
    n = pts.shape[0] - 1
    legs = np.empty(n)
    x = np.empty(n + 1)
    x[0] = 0.0
    for k in range(n):
        legs[k] = math.hypot(pts[k + 1, 0] - pts[k, 0], pts[k + 1, 1] - pts[k, 1])
        x[k + 1] = legs[k] if k == 0 else x[k] + legs[k]
    coef = np.empty((n, 4, 2))
    if not x[n] > 0.0:  # start and goal at the same place
        return legs, x, coef[:0], x[:0], np.empty(0, np.int64), x[:0], np.empty((0, gl_x.size))
    # Per leg, p(t) = c0 + c1 t + c2 t^2 + c3 t^3 with t in [0, 1] across the leg.
    for k in range(n):
        for d in range(2):
            if k == 0:
                ma = m_first[d]
            else:
                ma = (pts[k + 1, d] - pts[k - 1, d]) / (x[k + 1] - x[k - 1])
            if k == n - 1:
                mb = m_last[d]
            else:
                mb = (pts[k + 2, d] - pts[k, d]) / (x[k + 2] - x[k])
            p0, p1, m0, m1 = pts[k, d], pts[k + 1, d], ma * legs[k], mb * legs[k]
            coef[k, 0, d] = p0
            coef[k, 1, d] = m0
            coef[k, 2, d] = 3.0 * (p1 - p0) - 2.0 * m0 - m1
            coef[k, 3, d] = 2.0 * (p0 - p1) + m0 + m1

    scale = intervals / x[n]
    n_sub = np.empty(n, np.int64)
    for k in range(n):
        n_sub[k] = max(2, math.ceil(legs[k] * scale))
    total = n_sub.sum()
    u = np.empty(total + 1)
    leg = np.empty(total + 1, np.int64)
    r = 0
    for k in range(n):
        for j in range(n_sub[k]):
            u[r] = x[k] + legs[k] * (j / n_sub[k])
            leg[r] = k
            r += 1
    u[total] = x[n]
    leg[total] = n - 1
    half = np.empty(total)
    speed = np.empty((total, gl_x.size))
    d = np.empty((1, 2))
    for r in range(total):
        half[r] = 0.5 * (u[r + 1] - u[r])
        mid = 0.5 * (u[r + 1] + u[r])
        for q in range(gl_x.size):
            _hermite_at(x, legs, coef, leg[r], mid + half[r] * gl_x[q], 1, d, 0)
            speed[r, q] = math.hypot(d[0, 0], d[0, 1])
    return legs, x, coef, u, leg, half, speed


@njit(cache=True)
def _unwrap(p):
    """``np.unwrap(p)`` (period 2 pi), with the same operations."""
    up = p.copy()
    high = math.pi
    low = -high
    period = 2.0 * math.pi
    acc = 0.0
    for k in range(p.size - 1):
        dd = p[k + 1] - p[k]
        ddmod = (dd - low) % period + low
        if ddmod == low and dd > 0:
            ddmod = high
        correct = ddmod - dd
        if abs(dd) < high:
            correct = 0.0
        acc = correct if k == 0 else acc + correct
        up[k + 1] = p[k + 1] + acc
    return up


@njit(cache=True)
def _newton_nodes(knots, width, coef, u_grid, cum, target, u, gl_x):
    """For :meth:`_SmoothCurve.parameter`: per parameter ``u`` (an estimate of the arclength
    ``target``), its grid interval, the speed ``|dp/du|`` there, and the half width and the
    speeds at the Gauss-Legendre nodes of the part of the interval below ``u``."""
    n = u.size
    i = np.empty(n, np.int64)
    speed = np.empty(n)
    half = np.empty(n)
    node_speed = np.empty((n, gl_x.size))
    d = np.empty((1, 2))
    for r in range(n):
        i[r] = _interval_of(cum, target[r])
        _hermite_at(knots, width, coef, _interval_of(knots, u[r]), u[r], 1, d, 0)
        speed[r] = math.hypot(d[0, 0], d[0, 1])
        a = u_grid[i[r]]
        half[r] = 0.5 * (u[r] - a)
        mid = 0.5 * (u[r] + a)
        for q in range(gl_x.size):
            v = mid + half[r] * gl_x[q]
            _hermite_at(knots, width, coef, _interval_of(knots, v), v, 1, d, 0)
            node_speed[r, q] = math.hypot(d[0, 0], d[0, 1])
    return i, speed, half, node_speed


@njit(cache=True)
def _newton_step(u_grid, cum, target, u, i, speed, half, weighted):
    """The Newton step of :meth:`_SmoothCurve.parameter` (none where the speed is 0), clipped
    to the grid interval like ``np.clip``."""
    out = np.empty(u.size)
    for r in range(u.size):
        step = 0.0
        if speed[r] > 0.0:
            step = (target[r] - (cum[i[r]] + weighted[r] * half[r])) / speed[r]
        v = u[r] + step
        lo, hi = u_grid[i[r]], u_grid[i[r] + 1]
        v = v if np.isnan(v) or v > lo else lo
        out[r] = v if np.isnan(v) or v < hi else hi
    return out


class _SmoothCurve:
    """A C1 cubic Hermite curve through a polyline, parametrised by normalised arclength.

    The spline parameter ``u`` is cumulative chord length along the polyline; ``dp/du`` is the
    unit heading vector at the two ends and the Catmull-Rom central difference inside.
    """

    __slots__ = (
        "knots",
        "points",
        "coef",
        "width",
        "u_grid",
        "cum",
        "phi",
        "length",
        "theta0",
        "theta1",
        "delta",
        "samples",
    )

    def __init__(self, polyline: np.ndarray, theta0: float, theta1: float, free_end=False):
        """``theta0``, ``theta1``: tangent directions at the ends. With ``free_end`` the curve
        ends along ``theta1`` but its heading there is its own turning from ``theta0`` (no
        whole turns are added), and ``theta1`` becomes that heading."""
        self.theta0 = float(theta0)
        self.theta1 = float(theta1)
        pts = np.array(polyline, dtype=np.float64)
        self.points = pts
        degenerate = pts.shape[0] < 2
        if not degenerate:
            m_first = np.array([math.cos(theta0), math.sin(theta0)])
            m_last = np.array([math.cos(theta1), math.sin(theta1)])
            legs, x, coef, u, leg, half, speed = _spline(
                pts, m_first, m_last, _GRID_INTERVALS, _GL_X
            )
            degenerate = not x[-1] > 0.0
        if degenerate:  # start and goal at the same place
            self.knots = None
            self.length = 0.0
            self.delta = self.theta1 - self.theta0
            self.samples = pts[:1].copy()
            return
        self.knots, self.width, self.coef = x, legs, coef

        # Arclength table on a grid that is dense in every polyline leg (Gauss-Legendre).
        self.cum = np.concatenate(([0.0], np.cumsum((speed @ _GL_W) * half)))
        self.u_grid = u
        self.length = float(self.cum[-1])
        self.samples, d = self._eval(u, leg)

        # Tangent angle, unwrapped along the grid and starting on the branch of theta0.
        phi = _unwrap(np.arctan2(d[:, 1], d[:, 0]))
        phi += _TWO_PI * np.round((self.theta0 - phi[0]) / _TWO_PI)
        self.phi = phi
        # theta1 - phi[-1] is a multiple of 2 pi (up to rounding): the number of extra turns the
        # goal heading asks for beyond the curve's own turning. It is spread linearly over s.
        if free_end:
            self.theta1 = float(phi[-1])
        self.delta = self.theta1 - float(phi[-1])

    def _eval(self, u: np.ndarray, i: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Points and ``dp/du`` at parameters ``u`` in legs ``i`` (default: found by bisection)."""
        xy = np.empty((u.size, 2))
        d = np.empty((u.size, 2))
        _hermite_eval(self.knots, self.width, self.coef, u, _NO_LEGS if i is None else i, xy, d)
        return xy, d

    def parameter(self, s: np.ndarray) -> np.ndarray:
        """Spline parameter at normalised arclength ``s`` (interpolation, then a Newton step)."""
        target = s * self.length
        u = np.interp(target, self.cum, self.u_grid)
        i, speed, half, node_speed = _newton_nodes(
            self.knots, self.width, self.coef, self.u_grid, self.cum, target, u, _GL_X
        )
        # The weighted sums (a BLAS product, which may depend on the rows it gets) of exactly
        # the rows that need them.
        ok = speed > 0.0
        if ok.all():
            weighted = node_speed @ _GL_W
        else:
            weighted = np.zeros_like(u)
            weighted[ok] = node_speed[ok] @ _GL_W
        return _newton_step(self.u_grid, self.cum, target, u, i, speed, half, weighted)

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.knots is None:
            xy = np.repeat(self.points[:1], s.size, axis=0)
            return xy, self.theta0 + s * self.delta
        u = self.parameter(s)
        xy, d = self._eval(u)
        raw = np.arctan2(d[:, 1], d[:, 0])
        near = np.interp(u, self.u_grid, self.phi)
        phi = raw + _TWO_PI * np.round((near - raw) / _TWO_PI)
        return xy, phi + s * self.delta


@dataclass(frozen=True)
class EndModes:
    """How a path meets its end poses.

    ``reverse``: the path is driven backwards (heading = tangent direction + pi). ``turn_start``
    (``turn_goal``): the robot turns in place at the start (goal) between its heading and the
    direction of the first (last) leg, instead of leaving (arriving) along its heading with a
    turning arc. ``cusp``: the path drives (forwards, or backwards with ``reverse``) along the
    start heading to a cusp point, turns there in place as far as needed, and drives the other
    way into the goal along the goal heading: a three-point turn. The default is forward with
    turning arcs where needed.
    """

    reverse: bool = False
    turn_start: bool = False
    turn_goal: bool = False
    cusp: bool = False

    def describe(self) -> str:
        """``""`` for the default, else e.g. ``"reverse, turn in place at start"``."""
        if self.cusp:
            return "reverse, then forward" if self.reverse else "forward, then reverse"
        parts = ["reverse"] if self.reverse else []
        ends = [e for e, on in (("start", self.turn_start), ("goal", self.turn_goal)) if on]
        if ends:
            parts.append("turn in place at " + " and ".join(ends))
        return ", ".join(parts)


FORWARD = EndModes()


class _Drive:
    """A smooth curve driven at constant speed: heading = tangent direction minus ``offset``
    (pi when reversing)."""

    __slots__ = ("curve", "offset")

    def __init__(self, curve: _SmoothCurve, offset: float = 0.0):
        self.curve, self.offset = curve, float(offset)

    @property
    def metric(self) -> float:
        return self.curve.length

    @property
    def samples(self) -> np.ndarray:
        return self.curve.samples

    def evaluate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xy, th = self.curve.evaluate(u)
        return xy, (th - self.offset if self.offset else th)


class _Turn:
    """A turn in place at ``xy`` from heading ``theta0`` to ``theta1``."""

    __slots__ = ("xy", "theta0", "theta1")

    def __init__(self, xy: np.ndarray, theta0: float, theta1: float):
        self.xy, self.theta0, self.theta1 = np.array(xy[:2], dtype=float), theta0, theta1

    @property
    def metric(self) -> float:
        return abs(self.theta1 - self.theta0)

    @property
    def samples(self) -> np.ndarray:
        return self.xy[None, :]

    def evaluate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.repeat(self.xy[None, :], u.size, axis=0), self.theta0 + (
            self.theta1 - self.theta0
        ) * u


class _PoseCurve:
    """Poses ``(x, y, heading)`` at normalised time ``s`` along a sequence of pieces, each a
    drive along a smooth curve (:class:`_Drive`) or a turn in place (:class:`_Turn`).

    Time is shared in proportion to the unicycle's own metric (its cost is ``1/2 (v^2 +
    omega^2)``): a turn of ``rho`` radians takes the time of ``rho`` units of path. A single
    forward drive gives the curve's own poses, unchanged.
    """

    __slots__ = ("pieces", "shares", "length", "samples")

    def __init__(self, pieces: list):
        pieces = [p for p in pieces if not (isinstance(p, _Turn) and p.metric == 0.0)]
        self.pieces = pieces
        metric = np.array([p.metric for p in pieces])
        total = metric.sum()
        cum = np.concatenate(([0.0], np.cumsum(metric))) / total if total > 0.0 else None
        if cum is None:
            cum = np.linspace(0.0, 1.0, len(pieces) + 1)
        cum[-1] = 1.0
        self.shares = cum
        self.length = float(sum(p.metric for p in pieces if isinstance(p, _Drive)))
        self.samples = np.vstack([p.samples for p in pieces])

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(self.pieces) == 1:
            return self.pieces[0].evaluate(s)
        xy = np.empty((s.size, 2))
        th = np.empty(s.size)
        k = np.clip(np.searchsorted(self.shares, s, side="right") - 1, 0, len(self.pieces) - 1)
        for j, piece in enumerate(self.pieces):
            at = k == j
            if at.any():
                a, b = self.shares[j], self.shares[j + 1]
                u = np.clip((s[at] - a) / (b - a), 0.0, 1.0) if b > a else np.zeros(at.sum())
                xy[at], th[at] = piece.evaluate(u)
        return xy, th


@dataclass(frozen=True, eq=False)
class InitialPath:
    """A collision-free initial path from start to goal and its smoothed C1 curve.

    ``polyline`` holds the vertices from start to goal (both included), ``length`` the arclength
    of the smoothed curve, ``signature`` the homotopy class (per obstacle, the winding number of
    the path closed by the reversed straight chord; see the module notes), ``min_clearance`` the
    smallest distance of the smoothed curve to an obstacle edge (``inf`` without obstacles; a
    negative value means the curve enters an obstacle) and ``label`` a short description
    (``"straight"``, ``"visibility #2"``, ``"waypoints"``...). ``start`` and ``goal`` are the
    full end states ``(x, y, heading)``. Compare paths by ``signature``, not with ``==``.
    """

    polyline: np.ndarray
    length: float
    signature: tuple[int, ...]
    min_clearance: float
    label: str
    start: np.ndarray = field(repr=False)
    goal: np.ndarray = field(repr=False)
    _curve: _PoseCurve = field(repr=False)
    modes: EndModes = FORWARD

    @classmethod
    def from_polyline(
        cls, polyline, start, goal, obstacles=None, *, label: str = "custom"
    ) -> InitialPath:
        """Smooth a given polyline from ``start[:2]`` to ``goal[:2]`` (no collision check; a
        turning arc is added at an end whose heading points more than 90 degrees off the leg).

        The first and last vertex must be the start and goal positions (they are set to exactly
        those). ``signature`` and ``min_clearance`` refer to ``obstacles`` (rows ``[cx, cy, r]``).
        """
        S = _state(start, "start")
        G = _state(goal, "goal")
        obs = _obstacles(obstacles)
        poly = _rows(polyline, 2, "polyline", "x, y")
        if poly.shape[0] < 2:
            raise ScenarioError(f"polyline: expected at least 2 vertices, got {poly.shape[0]}")
        tol = _tolerance(S, G, obs)
        for key, p, end in (("first", poly[0], S), ("last", poly[-1], G)):
            if math.hypot(*(p - end[:2])) > tol:
                what = "start" if key == "first" else "goal"
                raise ScenarioError(
                    f"polyline: {key} vertex {_fmt(p)} is not the {what} position {_fmt(end[:2])}"
                )
        return _make_path(_clean(poly, S[:2], G[:2], tol), S, G, obs, label, tol)

    def curve(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(n, 2)`` and headings ``(n,)`` of the path at normalised time ``s``.

        ``s`` is a number or an array of numbers in ``[0, 1]``; the result always has a leading
        axis of length ``n = size(s)``. The path is followed at constant speed along the smoothed
        curve (``s`` is then its normalised arclength), after and before the turns in place of
        its :class:`EndModes`, which take the time of as many units of path as they turn
        radians. Headings are the tangent direction (plus pi when reversing), unwrapped along
        the curve from the start heading; if the goal heading asks for whole extra turns beyond
        the curve's own turning, those are added linearly in ``s``, so heading(0) is the start
        heading and heading(1) the goal heading (both up to rounding).
        """
        s = np.atleast_1d(np.asarray(s, dtype=np.float64)).ravel()
        if s.size and not (s.min() >= -1e-12 and s.max() <= 1.0 + 1e-12):  # also nan
            raise ValueError("s: normalised arclength must lie in [0, 1]")
        return self._curve.evaluate(np.clip(s, 0.0, 1.0))

    def junctions(self, q: int, horizon: float, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Times ``(q + 1,)`` and states ``(q + 1, 3)`` of ``q`` segments at constant speed.

        The times are uniform on ``[t0, t0 + horizon]`` and the junctions uniform in arclength.
        ``X[0]`` and ``X[-1]`` are exactly the start and goal states.
        """
        if isinstance(q, bool) or not isinstance(q, numbers.Integral) or q < 1:
            raise SettingsError(f"q: expected an integer >= 1, got {q!r}")
        horizon = _real(horizon, "horizon", SettingsError)
        t0 = _real(t0, "t0", SettingsError)
        if not horizon > 0.0:
            raise SettingsError(f"horizon: must be > 0, got {horizon!r}")
        q = int(q)
        frac = np.arange(q + 1, dtype=np.float64) / q
        frac[-1] = 1.0
        t = t0 + horizon * frac
        t[0] = t0
        t[-1] = t0 + horizon
        xy, heading = self._curve.evaluate(frac)
        X = np.column_stack([xy, heading])
        X[0] = self.start
        X[-1] = self.goal
        return t, X


# --------------------------------------------------------------------------- validation


def _fmt(p) -> str:
    return "[" + ", ".join(repr(float(v)) for v in p) + "]"


def _real(value, key: str, error=ScenarioError) -> float:
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise error(f"{key}: expected a number, got {type(value).__name__}")
    x = float(value)
    if not math.isfinite(x):
        raise error(f"{key}: must be finite, got {x!r}")
    return x


def _as_float_array(value, key: str, what: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ScenarioError(f"{key}: expected {what}, got {type(value).__name__}") from None
    return arr


def _state(value, key: str) -> np.ndarray:
    arr = _as_float_array(value, key, "3 numbers [x, y, heading]")
    if arr.shape != (3,):
        raise ScenarioError(f"{key}: expected 3 numbers [x, y, heading], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ScenarioError(f"{key}: must be finite, got {_fmt(arr)}")
    return arr


def _rows(value, n: int, key: str, what: str) -> np.ndarray:
    arr = _as_float_array(value, key, f"rows [{what}]")
    if arr.size == 0:
        return np.zeros((0, n))
    if arr.ndim != 2 or arr.shape[1] != n:
        raise ScenarioError(f"{key}: expected rows [{what}], got shape {arr.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
    if bad.size:
        raise ScenarioError(f"{key}[{bad[0]}]: must be finite, got {_fmt(arr[bad[0]])}")
    return arr


def _obstacles(value) -> np.ndarray:
    if value is None:
        return np.zeros((0, 3))
    obs = _rows(value, 3, "obstacles", "cx, cy, r")
    bad = np.flatnonzero(~(obs[:, 2] > 0.0))
    if bad.size:
        raise ScenarioError(f"obstacles[{bad[0]}]: radius must be > 0, got {obs[bad[0], 2]!r}")
    return obs


def _check_outside(p: np.ndarray, key: str, obs: np.ndarray) -> None:
    for j, (cx, cy, r) in enumerate(obs.tolist()):
        if math.hypot(p[0] - cx, p[1] - cy) < r:
            raise ScenarioError(
                f"{key}: {_fmt(p[:2])} is inside obstacles[{j}]"
                f" (center {_fmt((cx, cy))}, radius {r!r})"
            )


def _tolerance(S: np.ndarray, G: np.ndarray, obs: np.ndarray) -> float:
    scale = max(1.0, float(np.max(np.abs(S[:2]))), float(np.max(np.abs(G[:2]))))
    if obs.shape[0]:
        scale = max(scale, float(np.max(np.abs(obs))))
    return 1e-9 * scale


# --------------------------------------------------------------------------- geometry helpers


def _rot(u: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([u[..., 0] * c - u[..., 1] * s, u[..., 0] * s + u[..., 1] * c], axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _segment_distance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distances ``(E, M)`` from points ``c`` ``(M, 2)`` to segments ``a -> b`` ``(E, 2)``."""
    out = np.empty((a.shape[0], c.shape[0]))
    _segment_distance_loops(a, b, c, out)
    return out


@njit(cache=True, error_model="numpy")
def _segment_distance_loops(a, b, c, out):
    # A loop for the tangent graph's thousands of (segment, disc) pairs, without NumPy's
    # temporaries; the same operations as the vectorised formula (projection parameter clipped
    # to [0, 1], and 0 for a segment of length 0, where it is nan).
    for e in range(a.shape[0]):
        abx, aby = b[e, 0] - a[e, 0], b[e, 1] - a[e, 1]
        den = abx * abx + aby * aby
        for j in range(c.shape[0]):
            acx, acy = c[j, 0] - a[e, 0], c[j, 1] - a[e, 1]
            t = (acx * abx + acy * aby) / den
            if np.isnan(t):
                t = 0.0
            t = t if t > 0.0 else 0.0
            t = t if t < 1.0 else 1.0
            out[e, j] = math.hypot(acx - t * abx, acy - t * aby)


def _clean(poly: np.ndarray, S2: np.ndarray, G2: np.ndarray, tol: float) -> np.ndarray:
    """Drop repeated vertices; make the ends exactly the start and goal positions."""
    keep = np.ones(poly.shape[0], bool)
    keep[1:] = np.hypot(*np.diff(poly, axis=0).T) > tol
    out = poly[keep]
    if math.hypot(*(out[-1] - G2)) <= tol and out.shape[0] >= 2:
        out = out.copy()
    else:
        out = np.vstack([out, G2])
    out[0] = S2
    out[-1] = G2
    return out


def _midpoints(poly: np.ndarray) -> np.ndarray:
    out = np.empty((2 * poly.shape[0] - 1, 2))
    out[0::2] = poly
    out[1::2] = 0.5 * (poly[:-1] + poly[1:])
    return out


def _signature(poly: np.ndarray, obs: np.ndarray, tol: float) -> tuple[int, ...]:
    """Winding numbers of (polyline + reversed chord) round each obstacle centre."""
    if obs.shape[0] == 0:
        return ()
    cr, dt = _turn_terms(np.ascontiguousarray(poly), obs)  # one compiled variant
    turn = np.arctan2(cr, dt).sum(axis=1)
    return tuple(_close_and_round(turn, poly[0], poly[-1], obs, tol).tolist())


def _close_and_round(turn: np.ndarray, S2, G2, C: np.ndarray, tol: float) -> np.ndarray:
    """Winding numbers round the centres ``C[:, :2]`` of paths that turn by ``turn`` (shape
    ``(..., m)``) seen from them, closed by the straight chord back from goal to start.

    A centre on the chord sees the chord turn by +-pi; it counts 0 there, so the winding number
    is a half-integer, rounded away from zero (robustly: those are never near an integer).
    """
    cr, dt = _turn_terms(np.array([G2, S2]), C)
    cr, dt = cr[:, 0], dt[:, 0]
    bound = tol * max(math.hypot(*(G2 - S2)), tol)
    w = _round_winding(turn.reshape(-1, cr.size), cr, dt, np.arctan2(cr, dt), bound)
    return w.reshape(turn.shape)


@njit(cache=True)
def _turn_terms(poly, C):
    """Cross and dot products ``(m, n - 1)`` of the vectors from each centre ``C[j, :2]`` to
    consecutive vertices of ``poly``; their arctan2 is the turn of each step seen from there.
    A loop: signatures are needed for every candidate and turning arc, on small arrays."""
    m, n = C.shape[0], max(poly.shape[0] - 1, 0)
    cr = np.empty((m, n))
    dt = np.empty((m, n))
    for j in range(m):
        for i in range(n):
            ax, ay = poly[i, 0] - C[j, 0], poly[i, 1] - C[j, 1]
            bx, by = poly[i + 1, 0] - C[j, 0], poly[i + 1, 1] - C[j, 1]
            cr[j, i] = ax * by - ay * bx
            dt[j, i] = ax * bx + ay * by
    return cr, dt


@njit(cache=True)
def _round_winding(turn, cr, dt, closing, bound):
    # The end of _close_and_round: per centre, on the chord (cross product within ``bound``
    # and behind) or not; then sign(w) floor(|w| + 1/2, or 3/4 on the chord).
    out = np.empty(turn.shape, np.int64)
    for j in range(turn.shape[1]):
        on = abs(cr[j]) <= bound and dt[j] < 0.0
        for p in range(turn.shape[0]):
            w = (turn[p, j] + (0.0 if on else closing[j])) / _TWO_PI
            out[p, j] = np.int64(np.sign(w) * np.floor(abs(w) + (0.75 if on else 0.5)))
    return out


def _clearance(xy: np.ndarray, obs: np.ndarray) -> float:
    if obs.shape[0] == 0:
        return math.inf
    return _clearance_loops(xy, obs)


@njit(cache=True)
def _clearance_loops(xy, obs):
    # The smallest distance of the points to an obstacle edge (nan if any is nan), without an
    # (n, m) temporary. hypot(dx, dy) >= max(|dx|, |dy|), also rounded: when that bound is no
    # closer than the best so far, the (slow) hypot cannot give a new minimum.
    best = np.inf
    for r in range(xy.shape[0]):
        for j in range(obs.shape[0]):
            dx, dy = xy[r, 0] - obs[j, 0], xy[r, 1] - obs[j, 1]
            if max(abs(dx), abs(dy)) - obs[j, 2] >= best:
                continue
            d = math.hypot(dx, dy) - obs[j, 2]
            if d < best or np.isnan(d):
                best = d
                if np.isnan(d):
                    return d
    return best


def _turn_options(poly: np.ndarray, theta: float, frac: float) -> list[np.ndarray]:
    """``[poly]``, or ``poly`` with a turning arc after the start, on either side (the side the
    first leg lies on first), when the start heading points away from the first leg.

    A cubic that leaves a polyline more than 90 degrees off its first leg's direction turns
    sharply (curvature over 9 / leg length, and a cusp at 180 degrees). Instead, the path first
    turns on a circle of radius ``frac`` times the first leg, tangent to the start heading,
    until it heads straight for the leg's end.
    """
    leg = poly[1] - poly[0]
    ell = math.hypot(*leg)
    e = np.array([math.cos(theta), math.sin(theta)])
    if not ell > 0.0 or float(e @ leg) >= _TURN_COS * ell:
        return [poly]
    n = np.array([-e[1], e[0]])
    rho = frac * ell
    out = []
    for side in (1.0, -1.0) if _cross(e, leg) >= 0.0 else (-1.0, 1.0):
        centre = poly[0] + side * rho * n
        w = poly[1] - centre
        tangent = math.atan2(w[1], w[0]) - side * math.acos(rho / math.hypot(*w))
        phi0 = math.atan2(-side * n[1], -side * n[0])
        span = (side * (tangent - phi0)) % _TWO_PI
        pieces = max(2, math.ceil(span / _TURN_STEP))
        phi = phi0 + side * span * np.arange(1, pieces + 1) / pieces
        arc = centre + rho * np.column_stack([np.cos(phi), np.sin(phi)])
        out.append(np.vstack([poly[:1], arc, poly[1:]]))
    return out


def _with_turns(poly, h0, h1, obs, tol, signature) -> tuple[np.ndarray, tuple[int, ...] | None]:
    """``poly`` with the turning arcs that the end tangent directions ``h0``, ``h1`` need, in the
    homotopy class ``signature`` (when given: smaller arcs are tried when the larger ones would
    change it, and none are added when no choice of sides and sizes keeps it), and its signature
    when that was checked (else ``None``)."""
    if poly.shape[0] < 2 or not math.hypot(*(poly[-1] - poly[0])) > tol:
        return poly, None
    for frac in _TURN_RADII:
        for first in _turn_options(poly, h0, frac):
            for last in _turn_options(first[::-1], h1 + math.pi, frac):
                if signature is None:
                    return np.ascontiguousarray(last[::-1]), None
                if _signature(last[::-1], obs, tol) == signature:
                    return np.ascontiguousarray(last[::-1]), signature
    return poly, None


def _points_away(leg: np.ndarray, theta: float) -> bool:
    """Whether direction ``theta`` is more than 90 degrees off ``leg`` (a turning arc is due)."""
    ell = math.hypot(*leg)
    return ell > 0.0 and math.cos(theta) * leg[0] + math.sin(theta) * leg[1] < _TURN_COS * ell


def _near_branch(angle: float, target: float) -> float:
    """``angle`` plus the whole turns that bring it within pi of ``target``."""
    return angle + _TWO_PI * round((target - angle) / _TWO_PI)


def end_modes(poly: np.ndarray, start, goal) -> list[EndModes]:
    """The ways of meeting the end poses worth trying along ``poly``, forward first.

    Only forward when neither end heading points away from its leg (more than 90 degrees off).
    Otherwise also reverse, and at each end that points away in that direction a turn in place
    instead of the turning arc.
    """
    if poly.shape[0] < 2:
        return [FORWARD]
    first, last = poly[1] - poly[0], poly[-1] - poly[-2]
    th0, th1 = float(start[2]), float(goal[2])
    if not (_points_away(first, th0) or _points_away(last, th1)):
        return [FORWARD]
    out = []
    for reverse in (False, True):
        o = math.pi if reverse else 0.0
        turn0 = (False, True) if _points_away(first, th0 + o) else (False,)
        turn1 = (False, True) if _points_away(last, th1 + o) else (False,)
        out += [EndModes(reverse, a, b) for a in turn0 for b in turn1]
    return out


def _make_path(poly, S, G, obs, label, tol, signature=None, modes=FORWARD) -> InitialPath:
    """Smooth ``poly`` for ``modes`` (adding turning arcs where the curve's end directions point
    away from it)."""
    offset = math.pi if modes.reverse else 0.0
    h0, h1 = S[2] + offset, G[2] + offset  # the curve's tangent direction at its ends
    if modes.turn_start and poly.shape[0] >= 2:
        h0 = _near_branch(_direction(poly[1] - poly[0]), h0)
    if modes.turn_goal and poly.shape[0] >= 2:
        h1 = _near_branch(_direction(poly[-1] - poly[-2]), h1)
    poly, sig = _with_turns(poly, h0, h1, obs, tol, signature)
    pieces = [_Turn(S, S[2], h0 - offset), _Drive(_SmoothCurve(poly, h0, h1), offset)]
    pieces.append(_Turn(G, h1 - offset, G[2]))
    return _path(poly, _PoseCurve(pieces), S, G, obs, label, tol, sig, modes)


def _path(poly, curve, S, G, obs, label, tol, signature, modes) -> InitialPath:
    poly = poly.copy()
    for arr in (poly, S, G):
        arr.setflags(write=False)
    return InitialPath(
        polyline=poly,
        length=curve.length,
        signature=_signature(poly, obs, tol) if signature is None else signature,
        min_clearance=_clearance(curve.samples, obs),
        label=label,
        start=S,
        goal=G,
        _curve=curve,
        modes=modes,
    )


def _direction(v: np.ndarray) -> float:
    return math.atan2(v[1], v[0])


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


def _cusp_paths(S, G, obs, margin, tol) -> list[tuple[np.ndarray, InitialPath]]:
    """Three-point turns: drive from the start along its heading (forwards, and also
    backwards) to a cusp point (:func:`_cusp_points`), turn there in place as far as needed,
    and drive the other way into the goal, arriving along its heading. Each leg goes round the
    obstacles by its shortest way; cusp points inside an inflated obstacle are skipped.
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
            out.append((C, _cusp_path(S, G, C, off0, off1, obs, margin, tol, reverse)))
    return out


def _cusp_path(S, G, C, off0, off1, obs, margin, tol, reverse) -> InitialPath:
    """Drive (heading = tangent - ``off0``) from the start to ``C``, turn in place, drive
    (heading = tangent - ``off1``) to the goal."""
    first, second = _route(S[:2], C, obs, margin, tol), _route(C, G[:2], obs, margin, tol)
    h0 = S[2] + off0
    first, _ = _with_turns(first, h0, _direction(first[-1] - first[-2]), obs, tol, None)
    one = _SmoothCurve(first, h0, _direction(first[-1] - first[-2]), free_end=True)
    at_cusp = one.theta1 - off0  # the heading on arriving at the cusp
    h2 = _near_branch(_direction(second[1] - second[0]), at_cusp + off1)
    h3 = G[2] + off1
    second, _ = _with_turns(second, h2, h3, obs, tol, None)
    two = _SmoothCurve(second, h2, h3)
    pieces = [_Drive(one, off0), _Turn(C, at_cusp, h2 - off1), _Drive(two, off1)]
    poly = np.vstack([first, second[1:]])
    modes = EndModes(reverse=reverse, cusp=True)
    return _path(poly, _PoseCurve(pieces), S, G, obs, "", tol, None, modes)


# --------------------------------------------------------------------------- tangent graph


def _active_circles(C: np.ndarray, R: np.ndarray, tol: float) -> np.ndarray:
    """Discs not contained in another disc (of equal discs, the first is kept)."""
    m = R.size
    D = np.hypot(C[:, None, 0] - C[None, :, 0], C[:, None, 1] - C[None, :, 1])
    inside = D + R[:, None] <= R[None, :] + tol  # inside[i, j]: disc i within disc j
    np.fill_diagonal(inside, False)
    mutual = inside & inside.T
    earlier = np.arange(m)[None, :] < np.arange(m)[:, None]
    return ~np.any(inside & (~mutual | earlier), axis=1)


class _TangentGraph:
    """Directed tangent graph of the inflated discs ``(C, R)``; node 0 is the start, 1 the goal.

    Tangent point ``p >= 2`` on circle ``circ[p]`` is node ``2 + 2 (p - 2)`` when travelled
    counter-clockwise and node ``3 + 2 (p - 2)`` when travelled clockwise. Edges are stored in
    CSR order (sorted by source node) with their geometry: a segment ``[ax, ay, bx, by]`` or an
    arc ``[circle, phi0, span, nan]`` (counter-clockwise from angle ``phi0``).
    """

    def __init__(self, S2: np.ndarray, G2: np.ndarray, C: np.ndarray, R: np.ndarray, tol: float):
        self.S2, self.G2, self.C, self.R, self.tol = S2, G2, C, R, tol
        self._polylines: dict[bytes, np.ndarray] = {}
        act = np.flatnonzero(_active_circles(C, R, tol)) if R.size else np.zeros(0, np.int64)
        self.active = act
        xy = [S2[None, :], G2[None, :]]
        circ = [np.array([-1, -1])]
        segs = []  # (point a, orientation a, point b, orientation b) per family of segments
        count = 2

        def add_points(p: np.ndarray, c: np.ndarray) -> np.ndarray:
            nonlocal count
            xy.append(p)
            circ.append(c)
            count += p.shape[0]
            return np.arange(count - p.shape[0], count)

        def orient(p: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
            return np.where(_cross(p - C[c], d) >= 0.0, 1, -1)

        # Tangents from the start (travelled towards the circle) and to the goal (away from it).
        for end, P in ((0, S2), (1, G2)) if act.size else ():
            w = P[None, :] - C[act]
            d = np.hypot(w[:, 0], w[:, 1])
            u = w / np.maximum(d, tol)[:, None]
            out = d > R[act] + tol
            co, Ro, uo = act[out], R[act][out], u[out]
            gamma = np.arccos(np.clip(Ro / d[out], -1.0, 1.0))
            T = np.concatenate([C[co] + Ro[:, None] * _rot(uo, g) for g in (gamma, -gamma)])
            cT = np.concatenate([co, co])
            idx = add_points(T, cT)
            o = orient(T, cT, T - P if end == 0 else P - T)
            ends = np.full(idx.shape, end)
            segs.append((ends, 0 * ends, idx, o) if end == 0 else (idx, o, ends, 0 * ends))
            # An end on a circle (closer to the obstacle than the margin): both directions.
            on = act[~out]
            if on.size:
                idx = add_points(C[on] + R[on][:, None] * u[~out], on)
                ends = np.full(idx.shape, end)
                for o in (np.ones_like(idx), -np.ones_like(idx)):
                    segs.append((ends, 0 * ends, idx, o) if end == 0 else (idx, o, ends, 0 * ends))
        one_way = sum(s[0].size for s in segs)

        # Common tangents of each pair of circles: outer (sigma = +1) and inner (sigma = -1).
        if act.size >= 2:
            ci, cj = np.triu_indices(act.size, 1)
            ci, cj = act[ci], act[cj]
            w = C[cj] - C[ci]
            d = np.hypot(w[:, 0], w[:, 1])
            u = w / d[:, None]
            for sigma in (1.0, -1.0):
                cosb = (R[ci] - sigma * R[cj]) / d
                ok = np.abs(cosb) < 1.0 - 1e-12
                beta = np.arccos(cosb[ok])
                ci_ok, cj_ok = ci[ok], cj[ok]
                for sgn in (1.0, -1.0):
                    n = _rot(u[ok], sgn * beta)
                    Ti = C[ci_ok] + R[ci_ok][:, None] * n
                    Tj = C[cj_ok] + sigma * R[cj_ok][:, None] * n
                    pi, pj = add_points(Ti, ci_ok), add_points(Tj, cj_ok)
                    segs.append((pi, orient(Ti, ci_ok, Tj - Ti), pj, orient(Tj, cj_ok, Tj - Ti)))

        self.xy = np.concatenate(xy)
        self.circ = np.concatenate(circ)
        npts = self.xy.shape[0]
        rel = self.xy - C[np.maximum(self.circ, 0)] if C.shape[0] else self.xy
        self.angle = np.where(self.circ >= 0, np.arctan2(rel[:, 1], rel[:, 0]), 0.0)

        # Tangent points inside another inflated disc are no use.
        keep = np.ones(npts, bool)
        if act.size:
            gap = np.hypot(
                self.xy[:, None, 0] - C[None, act, 0], self.xy[:, None, 1] - C[None, act, 1]
            )
            keep = ~np.any(gap < R[None, act] - tol, axis=1)
            keep[:2] = True

        # Segments: the straight start -> goal one, then tangents, kept when no disc cuts them.
        pa, oa, pb, ob = (
            np.concatenate([[x], *(s[i] for s in segs)]) for i, x in enumerate((0, 0, 1, 0))
        )
        both = np.arange(pa.size) > one_way
        ok = keep[pa] & keep[pb]
        if act.size:
            dist = _segment_distance(self.xy[pa[ok]], self.xy[pb[ok]], C[act])
            ok[ok] = ~np.any(dist < R[act][None, :] - tol, axis=1)
        pa, oa, pb, ob, both = pa[ok], oa[ok], pb[ok], ob[ok], both[ok]
        A, B = self.xy[pa], self.xy[pb]
        seg_geo = np.column_stack([A, B])
        seg_w = np.hypot(*(B - A).T)
        src = [self.node(pa, oa), self.node(pb[both], -ob[both])]
        dst = [self.node(pb, ob), self.node(pa[both], -oa[both])]
        wgt = [seg_w, seg_w[both]]
        geo = [seg_geo, seg_geo[both]]

        # Arcs between neighbouring tangent points of a circle, unless another disc covers them.
        tp = np.flatnonzero(keep & (self.circ >= 0))
        tp = tp[np.lexsort((tp, self.angle[tp], self.circ[tp]))]
        cc = self.circ[tp]
        first = np.ones(tp.size, bool)
        first[1:] = cc[1:] != cc[:-1]
        group = np.cumsum(first) - 1
        g0 = np.flatnonzero(first)
        size = np.diff(np.append(g0, tp.size))[group]
        idx = np.arange(tp.size)
        nxt = g0[group] + (idx - g0[group] + 1) % np.maximum(size, 1)
        valid = size >= 2
        a_pts, b_pts = tp[valid], tp[nxt[valid]]
        wrap = nxt[valid] < idx[valid]
        span = np.where(
            wrap,
            self.angle[b_pts] + _TWO_PI - self.angle[a_pts],
            np.mod(self.angle[b_pts] - self.angle[a_pts], _TWO_PI),
        )
        ca = self.circ[a_pts]
        if act.size >= 2:
            D = np.hypot(C[:, None, 0] - C[None, :, 0], C[:, None, 1] - C[None, :, 1])
            meet = (np.abs(R[:, None] - R[None, :]) < D) & (D < R[:, None] + R[None, :])
            inactive = np.ones(R.size, bool)
            inactive[act] = False
            meet[:, inactive] = False
            np.fill_diagonal(meet, False)
            alpha = np.arctan2(C[None, :, 1] - C[:, None, 1], C[None, :, 0] - C[:, None, 0])
            into = np.mod(alpha[ca] - self.angle[a_pts][:, None], _TWO_PI) < span[:, None]
            free = ~np.any(meet[ca] & into, axis=1)
            a_pts, b_pts, span, ca = a_pts[free], b_pts[free], span[free], ca[free]
        arc_geo = np.column_stack([ca, self.angle[a_pts], span, np.full(span.shape, np.nan)])
        for o, (s_pts, d_pts) in ((1, (a_pts, b_pts)), (-1, (b_pts, a_pts))):
            src.append(self.node(s_pts, np.full(s_pts.shape, o)))
            dst.append(self.node(d_pts, np.full(d_pts.shape, o)))
            wgt.append(R[ca] * span)
            geo.append(arc_geo)
        self.n_seg = seg_w.size + int(both.sum())

        src, dst, wgt, geo = (np.concatenate(x) for x in (src, dst, wgt, geo))
        is_arc = np.arange(src.size) >= self.n_seg
        order = np.lexsort((dst, src))
        self.src, self.dst, self.geo, self.is_arc = (
            src[order],
            dst[order],
            geo[order],
            is_arc[order],
        )
        self.wgt = np.maximum(wgt[order], 1e-6 * tol)  # no zero-length edges
        self.n = 2 + 2 * (npts - 2)
        self.indptr = np.zeros(self.n + 1, np.int64)
        np.cumsum(np.bincount(self.src, minlength=self.n), out=self.indptr[1:])
        nodes = np.arange(self.n)
        pts = self.point(nodes)
        self.node_xy = np.ascontiguousarray(self.xy[pts])
        self.node_circ = self.circ[pts].astype(np.int64)
        self.node_orient = np.where(nodes < 2, 0, 1 - 2 * ((nodes - 2) % 2)).astype(np.int64)
        self.node_angle = self.angle[pts]

    @staticmethod
    def node(p: np.ndarray, o: np.ndarray) -> np.ndarray:
        return np.where(p < 2, p, 2 + 2 * (p - 2) + (o < 0)).astype(np.int64)

    @staticmethod
    def point(v):
        return np.where(v < 2, v, 2 + (v - 2) // 2)

    def search(self, bits: np.ndarray, masks: np.ndarray):
        """Shortest start -> goal paths, one per blocking mask: lengths (``inf`` where there is
        none), node paths (padded with -1) and their sizes.

        ``bits[e]`` has bit ``b`` set when edge ``e`` crosses barrier ``b``; a mask blocks the
        barriers of its set bits.
        """
        return _search(self.indptr, self.dst, self.wgt, bits, masks, self.node_xy)

    def signatures(self, paths: np.ndarray, plen: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """Exact winding numbers ``(P, m)`` of each node path (closed by the reversed chord)
        round each obstacle centre; arcs count with their true turn, not as chords."""
        P, m = plen.size, obs.shape[0]
        found = np.flatnonzero(plen >= 2)
        out = np.zeros((P, m), np.int64)
        if m == 0 or found.size == 0:
            return out
        C = obs[:, :2]
        # Direction angle of every node seen from every centre; a step turns by the difference,
        # taken in (-pi, pi] for a segment (or an arc seen from outside its circle, which stays
        # in a cone narrower than pi), and monotonically for an arc seen from inside its circle.
        rel = self.node_xy[:, None, :] - C[None, :, :]
        angle = np.arctan2(rel[:, :, 1], rel[:, :, 0])
        # Which centres lie inside each circle.
        inside = np.hypot(*(C[None, :, :] - self.C[:, None, :]).transpose(2, 0, 1))
        inside = inside < self.R[:, None]
        turn, first = _step_turns(
            paths, plen, found, angle, self.node_circ, self.node_orient, inside
        )
        total = np.add.reduceat(turn, first, axis=0)
        out[found] = _close_and_round(total, self.S2, self.G2, obs, self.tol)
        return out

    def polyline(self, nodes) -> np.ndarray:
        """The path's vertices: the ends of its segments, with each run of arcs round one circle
        sampled uniformly, every :data:`ARC_STEP` at most (tangent points between them, which
        can be very close together, are not kept). Memoised, and read-only so that no caller
        changes the shared array: planning needs the shortest path's polyline, and smoothing
        needs it again."""
        nodes = np.asarray(nodes, dtype=np.int64)
        key = nodes.tobytes()
        if key not in self._polylines:
            poly = self._polyline(nodes)
            poly.setflags(write=False)
            self._polylines[key] = poly
        return self._polylines[key]

    def _polyline(self, nodes: np.ndarray) -> np.ndarray:
        # Python floats and lists: a path has a few dozen vertices, too few for NumPy's calls.
        xy = self.node_xy[nodes].tolist()
        circ = self.node_circ[nodes].tolist()
        angle = self.node_angle[nodes].tolist()
        nodes = nodes.tolist()
        last = len(nodes) - 1
        parts = [xy[0]]  # vertices, and arcs (circle, first angle, number of angles)
        angles = []  # of all arc samples
        i = 0
        while i < last:
            v0, c = nodes[i], circ[i]
            j = i
            while j < last and v0 >= 2 and nodes[j + 1] >= 2 and circ[j + 1] == c:
                j += 1  # nodes[i .. j] are joined by arcs round circle c
            if j > i:
                o = 1 if (v0 - 2) % 2 == 0 else -1
                span = 0.0
                for t in range(i, j):
                    span += ((angle[t + 1] - angle[t]) * o) % _TWO_PI
                n = math.ceil(span / ARC_STEP)
                if n > 1:
                    parts.append((c, len(angles), n - 1))
                    angles.extend(angle[i] + o * span * k / n for k in range(1, n))
                parts.append(xy[j])
                i = j
            else:
                parts.append(xy[i + 1])
                i += 1
        cos, sin = np.cos(angles).tolist(), np.sin(angles).tolist()  # one call for all arcs
        out = []
        for part in parts:
            if isinstance(part, tuple):
                c, a, n = part
                cx, cy, r = float(self.C[c, 0]), float(self.C[c, 1]), float(self.R[c])
                out.extend([cx + r * cos[k], cy + r * sin[k]] for k in range(a, a + n))
            else:
                out.append(part)
        # Vertices much closer together than arc samples (the two ends of a tiny arc) would
        # make the smoothing turn sharply there: keep only the first of them, and the goal.
        gap = 0.25 * ARC_STEP * float(self.R[self.active].min()) if self.active.size else 0.0
        keep = [out[0]]
        for p in out[1:-1]:
            if math.hypot(p[0] - keep[-1][0], p[1] - keep[-1][1]) > gap:
                keep.append(p)
        if len(keep) > 1 and math.hypot(out[-1][0] - keep[-1][0], out[-1][1] - keep[-1][1]) <= gap:
            keep.pop()
        keep.append(out[-1])
        return _clean(np.array(keep), self.S2, self.G2, self.tol)

    def crossings(self, origins: np.ndarray, dirs: np.ndarray, reach: float) -> np.ndarray:
        """Per edge, bit ``b`` set when it crosses the ray ``origins[b] + t dirs[b]``, t in
        ``[0, reach]``."""
        return _crossings(self.is_arc, self.geo, self.C, self.R, origins, dirs, reach)


@njit(cache=True)
def _crossings(is_arc, geo, C, R, origins, dirs, reach):
    bits = np.zeros(geo.shape[0], np.int64)
    two_pi = 2.0 * math.pi
    for e in range(geo.shape[0]):
        for b in range(origins.shape[0]):
            ox, oy, dx, dy = origins[b, 0], origins[b, 1], dirs[b, 0], dirs[b, 1]
            hit = False
            if not is_arc[e]:
                ax, ay = geo[e, 0], geo[e, 1]
                rx, ry = geo[e, 2] - ax, geo[e, 3] - ay
                sx, sy = dx * reach, dy * reach
                den = rx * sy - ry * sx
                if den != 0.0:
                    qx, qy = ox - ax, oy - ay
                    t = (qx * sy - qy * sx) / den
                    u = (qx * ry - qy * rx) / den
                    hit = (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
            else:
                c = np.int64(geo[e, 0])
                fx, fy = ox - C[c, 0], oy - C[c, 1]
                bb = fx * dx + fy * dy
                disc = bb * bb - (fx * fx + fy * fy - R[c] * R[c])
                if disc >= 0.0:
                    root = math.sqrt(disc)
                    for sgn in range(-1, 2, 2):
                        tt = -bb + sgn * root
                        if 0.0 <= tt <= reach:
                            x = math.atan2(fy + tt * dy, fx + tt * dx) - geo[e, 1]
                            if x - two_pi * np.floor(x / two_pi) <= geo[e, 2]:
                                hit = True
            if hit:
                bits[e] |= np.int64(1) << np.int64(b)
    return bits


@njit(cache=True)
def _step_turns(paths, plen, found, angle, node_circ, node_orient, inside):
    """For :meth:`_TangentGraph.signatures`: the turn ``(steps, m)`` of every step of the paths
    ``found`` seen from each centre (``angle``: directions of the nodes from the centres), and
    the first step of each path. A loop over the steps of a few dozen paths, where NumPy's
    gathers and masks cost more; the same operations as those (``np.round`` is ``rint``)."""
    first = np.empty(found.size, np.int64)
    n_steps = 0
    for k in range(found.size):
        first[k] = n_steps
        n_steps += plen[found[k]] - 1
    m = angle.shape[1]
    turn = np.empty((n_steps, m))
    row = 0
    for k in range(found.size):
        p = found[k]
        for t in range(plen[p] - 1):
            u, v = paths[p, t], paths[p, t + 1]
            cu = node_circ[u]
            arc = u >= 2 and v >= 2 and cu >= 0 and cu == node_circ[v]
            o = np.float64(node_orient[u])
            for j in range(m):
                x = angle[v, j] - angle[u, j]
                if arc and inside[cu, j]:
                    turn[row, j] = o * ((o * x) % _TWO_PI)
                else:
                    turn[row, j] = x - _TWO_PI * np.rint(x / _TWO_PI)
            row += 1
    return turn, first


@njit(cache=True)
def _search(indptr, dst, wgt, bits, masks, node_xy):
    """For each mask: the shortest path from node 0 to node 1 without the edges whose ``bits``
    meet the mask (Dijkstra, ordered by the A* bound ``distance + straight line to the goal``,
    which is consistent here): lengths (inf: none), node paths padded with -1, path sizes."""
    n = indptr.size - 1
    n_masks = masks.size
    lengths = np.full(n_masks, np.inf)
    paths = np.full((n_masks, n), -1, np.int64)
    plen = np.zeros(n_masks, np.int64)
    dist = np.empty(n)
    pred = np.empty(n, np.int64)
    done = np.empty(n, np.bool_)
    gx, gy = node_xy[1, 0], node_xy[1, 1]
    hkey = np.empty(dst.size + 1)
    hval = np.empty(dst.size + 1, np.int64)
    togo = np.empty(n)
    for v in range(n):
        togo[v] = math.hypot(node_xy[v, 0] - gx, node_xy[v, 1] - gy)
    for p in range(n_masks):
        blocked = masks[p]
        dist[:] = np.inf
        pred[:] = -1
        done[:] = False
        dist[0] = 0.0
        # A binary heap of (key, node) pairs in two arrays, ordered lexicographically; every
        # edge is relaxed at most once, so it never holds more than len(dst) + 1 entries.
        hkey[0] = togo[0]
        hval[0] = 0
        size = 1
        while size > 0:
            u = hval[0]
            size -= 1
            if size > 0:
                key = hkey[size]
                val = hval[size]
                i = 0
                while True:
                    c = 2 * i + 1
                    if c >= size:
                        break
                    if c + 1 < size and (
                        hkey[c + 1] < hkey[c] or (hkey[c + 1] == hkey[c] and hval[c + 1] < hval[c])
                    ):
                        c += 1
                    if hkey[c] < key or (hkey[c] == key and hval[c] < val):
                        hkey[i] = hkey[c]
                        hval[i] = hval[c]
                        i = c
                    else:
                        break
                hkey[i] = key
                hval[i] = val
            if done[u]:
                continue
            done[u] = True
            if u == 1:
                break
            d = dist[u]
            for e in range(indptr[u], indptr[u + 1]):
                if bits[e] & blocked:
                    continue
                v = dst[e]
                nd = d + wgt[e]
                if nd < dist[v]:
                    dist[v] = nd
                    pred[v] = u
                    key = nd + togo[v]
                    i = size
                    size += 1
                    while i > 0:
                        par = (i - 1) // 2
                        if key < hkey[par] or (key == hkey[par] and v < hval[par]):
                            hkey[i] = hkey[par]
                            hval[i] = hval[par]
                            i = par
                        else:
                            break
                    hkey[i] = key
                    hval[i] = v
        if not done[1]:
            continue
        lengths[p] = dist[1]
        k = 0
        v = np.int64(1)
        while v != -1:
            k += 1
            v = pred[v]
        plen[p] = k
        v = np.int64(1)
        while v != -1:  # written backwards from the goal
            k -= 1
            paths[p, k] = v
            v = pred[v]
    return lengths, paths, plen


# --------------------------------------------------------------------------- planning


@dataclass(frozen=True)
class _Candidate:
    signature: tuple[int, ...]
    graph_length: float
    nodes: np.ndarray
    order: int
    graph: _TangentGraph = field(repr=False)

    @property
    def polyline(self) -> np.ndarray:
        return self.graph.polyline(self.nodes)


def _plan(
    S: np.ndarray, G: np.ndarray, obs: np.ndarray, margin: float, k: int, tol: float
) -> list[_Candidate] | None:
    """Shortest paths round the inflated obstacles, one per homotopy class, shortest first."""
    S2, G2 = S[:2], G[:2]
    C, r = obs[:, :2], obs[:, 2]
    dS = np.hypot(*(S2[None, :] - C).T)
    dG = np.hypot(*(G2[None, :] - C).T)
    R = r + np.clip(np.minimum(margin, np.minimum(dS - r, dG - r)), 0.0, None)
    graph = _TangentGraph(S2, G2, C, R, tol)
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
        proj = (C[act] - S2) @ e
        poly0 = graph.polyline(paths[0, : plen[0]])
        to_chord = _segment_distance(S2[None, :], G2[None, :], C[act])[0]
        to_path = _segment_distance(poly0[:-1], poly0[1:], C[act]).min(axis=0)
        relevance = np.minimum(to_chord, to_path) - R[act]
        pick = np.flatnonzero((proj > tol) & (proj < L - tol) & (relevance < shortest))
        rel = act[pick[np.lexsort((act[pick], relevance[pick]))][:MAX_RELEVANT]]
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
            lengths, paths, plen = (
                np.concatenate(x) for x in zip((lengths, paths, plen), more, strict=True)
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


def _smooth_best(poly: np.ndarray, S, G, obs, tol, signature=None, modes=FORWARD) -> InitialPath:
    """The first smoothing with non-negative clearance, else the one with the best clearance."""
    best = None
    for _ in range(_MIDPOINT_ROUNDS + 1):
        path = _make_path(poly, S, G, obs, "", tol, signature, modes)
        if path.min_clearance >= 0.0:
            return path
        if best is None or path.min_clearance > best.min_clearance:
            best = path
        poly = _midpoints(poly)
    return best


def initial_paths(
    start, goal, obstacles, *, k: int = 3, margin: float = 0.05, waypoints=None
) -> list[InitialPath]:
    """Collision-free initial paths in up to ``k`` homotopy classes, shortest class first.

    Each class comes with its ways of meeting the end poses (:func:`end_modes`: forward first,
    then, where an end heading points away from the path, reverse and turns in place), all with
    the class's label plus the modes' description.

    ``start`` and ``goal`` are states ``[x, y, heading]``, ``obstacles`` rows ``[cx, cy, r]``
    (or empty). Paths keep ``margin`` from every obstacle (less only where the start or goal is
    closer than that, or when no path exists otherwise: see the label). The straight chord
    (label ``"straight"``) is a path when it keeps the margin; it is the shortest polyline, so it
    comes first unless the turns that the end headings ask for make its smoothed curve longer
    than another. The result is sorted by smoothed ``length`` and deterministic. With
    ``waypoints`` (rows ``[x, y]``), the only path (with its end modes) passes through them in
    order, each leg the shortest path round the obstacles (label ``"waypoints"``). Raises
    :class:`ScenarioError` for invalid input, an end (or waypoint) inside an obstacle, or when
    no collision-free path exists (even with margin 0).
    """
    S = _state(start, "start")
    G = _state(goal, "goal")
    obs = _obstacles(obstacles)
    if isinstance(k, bool | np.bool_) or not isinstance(k, numbers.Integral) or k < 1:
        raise ScenarioError(f"k: expected an integer >= 1, got {k!r}")
    margin = _real(margin, "margin")
    if margin < 0.0:
        raise ScenarioError(f"margin: must be >= 0, got {margin!r}")
    wps = None if waypoints is None else _rows(waypoints, 2, "waypoints", "x, y")
    _check_outside(S, "start", obs)
    _check_outside(G, "goal", obs)
    if wps is not None:
        for i, w in enumerate(wps):
            _check_outside(w, f"waypoints[{i}]", obs)
    tol = _tolerance(S, G, obs)

    if wps is not None and wps.shape[0]:
        poly = _clean(_through(np.vstack([S[:2], wps, G[:2]]), obs, margin, tol), S[:2], G[:2], tol)
        variants = [_smooth_best(poly, S, G, obs, tol, None, m) for m in end_modes(poly, S, G)]
        return [
            _relabel(p, ", ".join(filter(None, ("waypoints", p.modes.describe()))))
            for p in variants
        ]

    used = None
    for m in dict.fromkeys([margin * f for f in _MARGIN_FALLBACK] + [0.0]):
        cands = _plan(S, G, obs, m, int(k), tol)
        if cands is not None:
            used = m
            break
    else:
        raise ScenarioError(
            f"no collision-free initial path from start {_fmt(S[:2])} to goal {_fmt(G[:2])}"
            f" round the {obs.shape[0]} obstacles (even with margin 0)"
        )
    cands = cands[: int(k)]

    retry: dict[float, list[_Candidate] | None] = {}
    classes = []
    for cand in cands:
        variants = [
            _smoothed_in_class(cand, S, G, obs, tol, used, int(k), retry, modes)
            for modes in end_modes(cand.polyline, S, G)
        ]
        classes.append((variants, cand))

    classes.sort(key=lambda vc: (vc[0][0].length, vc[1].graph_length, vc[1].order))
    note = "" if used == margin else f" (margin {used:g})"
    out = []
    for rank, (variants, cand) in enumerate(classes, start=1):
        straight = cand.nodes.size == 2  # the direct start -> goal edge of the graph
        name = ("straight" if straight else f"visibility #{rank}") + note
        for path in variants:
            how = path.modes.describe()
            out.append(_relabel(path, f"{name}, {how}" if how else name))
    if len(end_modes(np.vstack([S[:2], G[:2]]), S, G)) > 1:  # an end heading points away
        for C, path in _cusp_paths(S, G, obs, used, tol):
            label = f"three-point turn at ({C[0]:.3g}, {C[1]:.3g}), {path.modes.describe()}"
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
    for m in dict.fromkeys([margin * f for f in _MARGIN_FALLBACK] + [0.0]):
        cands = _plan(np.append(a, 0.0), np.append(b, 0.0), obs, m, 1, tol)
        if cands is not None:
            return cands[0].polyline
    return np.vstack([a, b])


def _smoothed_in_class(cand, S, G, obs, tol, used, k, retry, modes) -> InitialPath:
    """The smoothed path of ``cand``'s class for ``modes``; when it cuts into an obstacle, the
    class is re-planned with larger margins (memoised in ``retry``) and the clearest kept."""
    path = _smooth_best(cand.polyline, S, G, obs, tol, cand.signature, modes)
    if path.min_clearance < 0.0 and used > 0.0:
        for f in _RETRY_MARGIN_FACTORS:
            if f not in retry:
                retry[f] = _plan(S, G, obs, used * f, k, tol)
            same = [c for c in retry[f] or () if c.signature == cand.signature]
            if same:
                other = _smooth_best(same[0].polyline, S, G, obs, tol, cand.signature, modes)
                if other.min_clearance > path.min_clearance:
                    path = other
                if path.min_clearance >= 0.0:
                    break
    return path


def _relabel(path: InitialPath, label: str) -> InitialPath:
    return replace(path, label=label)


def plot_initial_paths(ax, paths, obstacles=None):
    """Draw obstacles, the smoothed curves (solid) and their polylines (dotted) on ``ax``."""
    from matplotlib.patches import Circle

    for cx, cy, r in _obstacles(obstacles).tolist():
        ax.add_patch(Circle((cx, cy), r, facecolor="0.75", edgecolor="0.4"))
    s = np.linspace(0.0, 1.0, 400)
    for path in paths:
        xy, _ = path.curve(s)
        (line,) = ax.plot(xy[:, 0], xy[:, 1], label=f"{path.label} (length {path.length:.3f})")
        ax.plot(*path.polyline.T, ls=":", lw=0.8, color=line.get_color())
    ax.set_aspect("equal")
    ax.legend(fontsize="small")
    return ax
