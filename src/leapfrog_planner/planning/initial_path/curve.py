"""The smoothed curve of an initial path: a C1 cubic Hermite spline through its polyline,
parametrised by normalised arclength (compiled loops for its tables and evaluation)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit

TWO_PI = 2.0 * math.pi
#: Target number of grid intervals of the arclength table (more for long polylines).
_GRID_INTERVALS = 512
_GL_X, _GL_W = np.polynomial.legendre.leggauss(3)


_NO_LEGS = np.zeros(0, dtype=np.int64)

# The curves are built and evaluated at thousands of parameters per path (arclength tables,
# ranking), where NumPy's calls and temporaries on small arrays cost several times more than
# these loops. The loops do the same operations in the same order as NumPy did, so the results
# are the same: hypot is the C library's, as NumPy's; the other transcendental functions and the
# products with the Gauss-Legendre weights (BLAS) stay NumPy's.


class Hermite(NamedTuple):
    """The legs of a cubic Hermite spline, as the compiled loops read them: leg ``i`` runs over
    ``[knots[i], knots[i + 1]]``, ``width[i]`` long, with coefficients ``coef[i, :, d]`` of
    ``p_d(t) = c0 + c1 t + c2 t^2 + c3 t^3`` in ``t`` from 0 to 1."""

    knots: np.ndarray  # (n + 1,)
    width: np.ndarray  # (n,)
    coef: np.ndarray  # (n, 4, 2)


@njit(cache=True)
def _hermite_at(spline, i, u, deriv, out, r):
    """Point (``deriv = 0``) or ``dp/du`` (1) of leg ``i`` at parameter ``u``, into ``out[r]``."""
    coef = spline.coef
    h = spline.width[i]
    t = (u - spline.knots[i]) / h
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
def _hermite_eval(spline, u, legs, xy, d):
    """Points and ``dp/du`` at parameters ``u`` in legs ``legs`` (empty: found by bisection)."""
    for r in range(u.size):
        i = legs[r] if legs.size else _interval_of(spline.knots, u[r])
        _hermite_at(spline, i, u[r], 0, xy, r)
        _hermite_at(spline, i, u[r], 1, d, r)


@njit(cache=True)
def _spline(pts, m_first, m_last, intervals, gl_x):
    """Hermite legs through ``pts`` and the arclength grid of :class:`SmoothCurve`.

    Returns the leg lengths, the knots (cumulative chord length), the coefficients, the grid
    parameters (about ``intervals`` in all, at least two per leg), their legs, the half widths
    of the grid intervals and the speeds ``|dp/du|`` at their Gauss-Legendre nodes ``gl_x``; all
    but the first two are empty when the last knot is not positive. The slopes ``dp/du`` at the
    vertices are ``m_first`` and ``m_last`` at the ends and central differences inside."""
    legs, x = _knots(pts)
    if not x[-1] > 0.0:  # start and goal at the same place
        coef = np.empty((0, 4, 2))
        return legs, x, coef, x[:0], np.empty(0, np.int64), x[:0], np.empty((0, gl_x.size))
    spline = Hermite(x, legs, _coefficients(pts, legs, x, m_first, m_last))
    u, leg = _arclength_grid(legs, x, intervals)
    half, speed = _grid_speeds(spline, u, leg, gl_x)
    return legs, x, spline.coef, u, leg, half, speed


@njit(cache=True)
def _knots(pts):
    """The lengths of the polyline's legs and the knots: the cumulative chord length at each
    vertex, from 0."""
    n = pts.shape[0] - 1
    legs = np.empty(n)
    x = np.empty(n + 1)
    x[0] = 0.0
    for k in range(n):
        legs[k] = math.hypot(pts[k + 1, 0] - pts[k, 0], pts[k + 1, 1] - pts[k, 1])
        x[k + 1] = legs[k] if k == 0 else x[k] + legs[k]
    return legs, x


@njit(cache=True)
def _coefficients(pts, legs, x, m_first, m_last):
    """Per leg, p(t) = c0 + c1 t + c2 t^2 + c3 t^3 with t in [0, 1] across the leg: the cubic
    from vertex to vertex whose slopes ``dp/du`` are ``m_first`` and ``m_last`` at the ends of
    the polyline and central differences at its inner vertices (times the leg's length, as
    slopes in ``t``)."""
    n = legs.size
    coef = np.empty((n, 4, 2))
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
    return coef


@njit(cache=True)
def _arclength_grid(legs, x, intervals):
    """The grid of the arclength table: each leg cut into equal parts, about ``intervals`` in
    all (in proportion to its length) and at least two; the parameters from 0 to the last knot,
    and the leg of each (the last parameter's is the last leg)."""
    n = legs.size
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
    return u, leg


@njit(cache=True)
def _grid_speeds(spline, u, leg, gl_x):
    """Per interval of the grid ``u`` (in legs ``leg``): its half width, and the speeds
    ``|dp/du|`` at its Gauss-Legendre nodes ``gl_x``."""
    total = u.size - 1
    half = np.empty(total)
    speed = np.empty((total, gl_x.size))
    d = np.empty((1, 2))
    for r in range(total):
        half[r] = 0.5 * (u[r + 1] - u[r])
        mid = 0.5 * (u[r + 1] + u[r])
        for q in range(gl_x.size):
            _hermite_at(spline, leg[r], mid + half[r] * gl_x[q], 1, d, 0)
            speed[r, q] = math.hypot(d[0, 0], d[0, 1])
    return half, speed


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
def _newton_nodes(spline, u_grid, cum, target, u, gl_x):
    """For :meth:`SmoothCurve.parameter`: per parameter ``u`` (an estimate of the arclength
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
        _hermite_at(spline, _interval_of(spline.knots, u[r]), u[r], 1, d, 0)
        speed[r] = math.hypot(d[0, 0], d[0, 1])
        a = u_grid[i[r]]
        half[r] = 0.5 * (u[r] - a)
        mid = 0.5 * (u[r] + a)
        for q in range(gl_x.size):
            v = mid + half[r] * gl_x[q]
            _hermite_at(spline, _interval_of(spline.knots, v), v, 1, d, 0)
            node_speed[r, q] = math.hypot(d[0, 0], d[0, 1])
    return i, speed, half, node_speed


@njit(cache=True)
def _newton_step(u_grid, cum, target, u, i, speed, half, weighted):
    """The Newton step of :meth:`SmoothCurve.parameter` (none where the speed is 0), clipped
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


class SmoothCurve:
    """A C1 cubic Hermite curve through a polyline, parametrised by normalised arclength.

    The spline parameter ``u`` is cumulative chord length along the polyline; ``dp/du`` is the
    unit heading vector at the two ends and the Catmull-Rom central difference inside.
    """

    __slots__ = (
        "spline",
        "points",
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
            self.spline = None
            self.length = 0.0
            self.delta = self.theta1 - self.theta0
            self.samples = pts[:1].copy()
            return
        self.spline = Hermite(x, legs, coef)

        # Arclength table on a grid that is dense in every polyline leg (Gauss-Legendre).
        self.cum = np.concatenate(([0.0], np.cumsum((speed @ _GL_W) * half)))
        self.u_grid = u
        self.length = float(self.cum[-1])
        self.samples, d = self._eval(u, leg)

        # Tangent angle, unwrapped along the grid and starting on the branch of theta0.
        phi = _unwrap(np.arctan2(d[:, 1], d[:, 0]))
        phi += TWO_PI * np.round((self.theta0 - phi[0]) / TWO_PI)
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
        _hermite_eval(self.spline, u, _NO_LEGS if i is None else i, xy, d)
        return xy, d

    def parameter(self, s: np.ndarray) -> np.ndarray:
        """Spline parameter at normalised arclength ``s`` (interpolation, then a Newton step)."""
        target = s * self.length
        u = np.interp(target, self.cum, self.u_grid)
        i, speed, half, node_speed = _newton_nodes(
            self.spline, self.u_grid, self.cum, target, u, _GL_X
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
        if self.spline is None:
            xy = np.repeat(self.points[:1], s.size, axis=0)
            return xy, self.theta0 + s * self.delta
        u = self.parameter(s)
        xy, d = self._eval(u)
        raw = np.arctan2(d[:, 1], d[:, 0])
        near = np.interp(u, self.u_grid, self.phi)
        phi = raw + TWO_PI * np.round((near - raw) / TWO_PI)
        return xy, phi + s * self.delta
