"""The smooth penalty field of a map: ``P = W exp(-(max(u, 0)^2)^n)``, twice differentiable.

For a disc of radius ``r`` the penalty is ``W exp(-(|p - c|^2 / r^2)^n)``: ``|p - c| / r`` is the
distance from the disc's centre in units of its radius. A map has no centres, so ``u`` is built
from the distance to its blocked cells so that it means the same:

``d``
    the exact signed distance from each cell centre to the blocked cells taken as closed squares
    (:mod:`.distance`; positive outside, negative inside), and to the polygons and walls by
    their geometry (:mod:`.shapes`), less the robot's radius ``rho``: every obstacle grows by
    the footprint, as each disc does;
``dt = G_sigma * d``
    a Gaussian smoothing of width ``sigma = max(0.1 l, 2 h)`` (``h`` the cell size). Without it
    the distance has a ridge (``|y|``) along the middle of every corridor, a kink that Newton's
    method would meet as a Hessian spike of height ``1/h``, and it ripples along walls that are
    not axis-aligned (a staircase of cells). The smoothing rounds both;
``u = m_sigma^-1(l + dt) / l``
    where ``m_sigma(r) = E|x + sigma Z|`` (``|x| = r``, ``Z`` a standard normal 2-vector; the
    mean of a Rice distribution) is what the smoothing makes of the distance to a disc's centre.
    Undoing it, an isolated disc of radius ``l`` gives ``u = |p - c| / l`` exactly: the disc's
    penalty, with the length scale ``l`` in place of its radius;
``coef``
    ``u`` at the cell centres are the coefficients of a tensor-product quintic B-spline (its
    own smoothing, a variance of h^2 / 2 per axis, is counted in ``sigma`` above), so ``u`` is
    C4 everywhere and each evaluation reads 6 x 6 coefficients: O(1)
    whatever the map's size. ``t -> exp(-t^n)`` at ``t = max(u, 0)^2`` is C2 for ``n >= 2``
    (and C3 for the default ``n = 2``); the flow over it reproduces to 1e-13, as over discs.

The field stores ``u`` only: the weight ``W`` and exponent ``n`` stay run-time arguments, so the
continuation on the weight rebuilds nothing, and a new map compiles nothing. Distances are clipped
where the penalty is negligible (``e^-60 W``), and the grid is padded beyond the map by that much
with the map's outside policy (blocked: ``P = W``; free: ``P = 0``); beyond the padding the
evaluator returns that constant, so the field stays C2 there too.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit
from .distance import signed_distance_squares
from .shapes import Shapes, grid_distance

#: The smoothing width: ``sigma = max(SMOOTH_FRACTION * l, SMOOTH_CELLS * h)``.
SMOOTH_FRACTION = 0.1
SMOOTH_CELLS = 2.0
#: The largest weight the field's reach is built for (``P < e^-60 W`` beyond it; above this
#: weight the clipped tail is still below ``e^-70 W``).
WEIGHT_MAX = 1e6
#: The smallest exponent the field is built for (and the smallest that keeps P twice
#: continuously differentiable at ``u = 0``).
EXPONENT_MIN = 2
#: The Gaussian kernel is truncated at this many widths (scipy's default).
TRUNCATE = 4.0


class MapField(NamedTuple):
    """What the compiled evaluator reads (module docstring). Node ``(i, j)`` of ``coef`` lies
    at the world point ``(x0, y0) + R(yaw) (j h, i h)``; ``coef`` are the quintic B-spline
    coefficients of ``u``; beyond the usable nodes ``u = u_out``. An empty ``coef`` (0 x 0) is
    no map at all."""

    coef: np.ndarray  # (ny, nx) float64, read-only
    x0: float
    y0: float
    cos_yaw: float
    sin_yaw: float
    h: float
    u_out: float


def no_field() -> MapField:
    """The field of no map (its penalty is 0 everywhere)."""
    coef = np.zeros((0, 0))
    coef.setflags(write=False)
    return MapField(coef, 0.0, 0.0, 1.0, 0.0, 1.0, 1e3)


def far_u() -> float:
    """The ``u`` beyond which ``P < e^-60 W`` for every weight up to :data:`WEIGHT_MAX` and
    exponent from :data:`EXPONENT_MIN` (the disc penalty's rule for skipping a term)."""
    return (60.0 + math.log(WEIGHT_MAX)) ** (0.5 / EXPONENT_MIN)


def smoothing_width(length: float, resolution: float) -> float:
    """``sigma`` (metres) for the length scale ``l`` on cells of size ``h``."""
    return max(SMOOTH_FRACTION * length, SMOOTH_CELLS * resolution)


# --------------------------------------------------------------------------- calibration


def rice_mean(r, sigma: float) -> np.ndarray:
    """``m_sigma(r) = E|x + sigma Z|`` for ``|x| = r`` and ``Z`` a standard normal 2-vector: the
    Gaussian smoothing (variance ``sigma^2`` per axis) of the distance to a point."""
    from scipy.special import i0e, i1e

    r = np.asarray(r, dtype=float)
    z = r * r / (4.0 * sigma * sigma)
    return sigma * math.sqrt(math.pi / 2.0) * ((1.0 + 2.0 * z) * i0e(z) + 2.0 * z * i1e(z))


class RiceTable(NamedTuple):
    """``r = m_sigma^-1(m)`` tabulated on a uniform grid of ``m`` from ``m0`` by ``dm``; below
    ``m0`` (``r < 1.5 sigma``, deep inside obstacles where ``P > 0.88 W``) the tangent line of
    slope ``slope``; above the table, the asymptote ``m = r + sigma^2 / (2 r)``."""

    m0: float
    dm: float
    r: np.ndarray
    slope: float
    sigma: float


def rice_table(sigma: float, r_max: float, n: int = 8193) -> RiceTable:
    """The inverse of :func:`rice_mean` up to ``r_max``, as a table (8k entries: the linear
    interpolation's error is far below the field's own)."""
    r_low = 1.5 * sigma
    r = np.linspace(r_low, max(r_max, 2.0 * r_low), 4 * n)
    m = rice_mean(r, sigma)
    grid = np.linspace(m[0], m[-1], n)
    slope = (m[1] - m[0]) / (r[1] - r[0])
    return RiceTable(float(grid[0]), float(grid[1] - grid[0]), np.interp(grid, m, r), slope, sigma)


def rice_slope(r, sigma: float) -> np.ndarray:
    """``d m_sigma / d r = sqrt(pi/2) r / (2 sigma) (I0e(z) + I1e(z))``, where
    ``z = r^2 / (4 sigma^2)``."""
    from scipy.special import i0e, i1e

    z = r * r / (4.0 * sigma * sigma)
    return math.sqrt(math.pi / 2.0) * r / (2.0 * sigma) * (i0e(z) + i1e(z))


def polish_inverse(u: np.ndarray, dt: np.ndarray, length: float, table: RiceTable) -> None:
    """Two Newton steps on ``m_sigma(r) = length + dt`` from the table's ``r = length u``, in
    place, where the table was used and P matters. The table's linear interpolation is off by
    up to 1e-7, erratically from node to node (noise at the scale of the cells); after the
    steps the nodes are exact to rounding."""
    m = length + dt.astype(np.float64)
    # Where P matters (u below far_u: beyond it P < e^-60 W) and the table was used: the
    # clipped plateau far from obstacles (most of a large map) is left as it is.
    where = np.flatnonzero((m.ravel() > table.m0) & (u.ravel() < far_u() + 0.5))
    r = u.ravel()[where] * length
    target = m.ravel()[where]
    for _ in range(2):
        r -= (rice_mean(r, table.sigma) - target) / rice_slope(r, table.sigma)
    u.ravel()[where] = r / length


@njit(cache=True)
def _calibrate(dt, length, m0, dm, table, slope, sigma, out):
    """``out = m_sigma^-1(length + dt) / length`` elementwise (:class:`RiceTable`)."""
    n = table.size
    flat_in = dt.ravel()
    flat_out = out.ravel()
    m_top = m0 + dm * (n - 1)
    for k in range(flat_in.size):
        m = length + flat_in[k]
        if m <= m0:
            r = table[0] + (m - m0) / slope
        elif m >= m_top:
            r = 0.5 * (m + math.sqrt(max(m * m - 2.0 * sigma * sigma, 0.0)))
        else:
            t = (m - m0) / dm
            i = min(int(t), n - 2)
            f = t - i
            r = table[i] * (1.0 - f) + table[i + 1] * f
        flat_out[k] = r / length


# --------------------------------------------------------------------------- building


class FieldPlan(NamedTuple):
    """The sizes a field is built with (metres, except ``pad``, in cells)."""

    length: float
    radius: float
    sigma: float
    reach_out: float  # distances beyond this outside the grown obstacles are clipped
    reach_in: float  # ... and beyond this inside them
    pad: int


def field_plan(length: float, radius: float, resolution: float) -> FieldPlan:
    """How far the field must reach for the length scale, the robot's radius and the cells."""
    sigma = smoothing_width(length, resolution)
    slack = TRUNCATE * sigma + 2.0 * resolution
    reach_out = length * (far_u() - 1.0) + slack
    reach_in = length + slack
    pad = int(math.ceil((max(reach_out, reach_in) + radius) / resolution)) + 4
    return FieldPlan(length, radius, sigma, reach_out, reach_in, pad)


def build_field(
    blocked: np.ndarray,
    resolution: float,
    origin: tuple[float, float, float],
    plan: FieldPlan,
    outside_blocked: bool,
    shapes: Shapes | None = None,
) -> MapField:
    """The field of the ``blocked`` cells (row 0 at the bottom) of a map with ``resolution``
    and ``origin`` ``(x, y, yaw)``, and of the polygons and walls of ``shapes`` (their exact
    distance, not their cells), by the steps of the module docstring."""
    from scipy.ndimage import gaussian_filter

    h, pad = float(resolution), plan.pad
    ny, nx = blocked.shape[0] + 2 * pad, blocked.shape[1] + 2 * pad
    grid = np.full((ny, nx), bool(outside_blocked))
    grid[pad:-pad, pad:-pad] = blocked
    cap_in, cap_out = plan.reach_in / h + 1.0, (plan.reach_out + plan.radius) / h + 1.0
    if grid.any():
        d = signed_distance_squares(grid, cap_in, cap_out)
    else:
        d = np.full((ny, nx), cap_out)
    d *= h
    x0, y0, yaw = origin
    c, s = math.cos(yaw), math.sin(yaw)
    gx = gy = (0.5 - pad) * h  # node (0, 0): the centre of map cell (-pad, -pad)
    nodes = (x0 + c * gx - s * gy, y0 + s * gx + c * gy, yaw)
    if shapes is not None and len(shapes):
        reach = plan.reach_out + plan.radius
        np.minimum(d, grid_distance(shapes, nodes, h, d.shape, reach, reach), out=d)
    d -= plan.radius
    np.clip(d, -plan.reach_in, plan.reach_out, out=d)
    s_cells = plan.sigma / h
    dt = gaussian_filter(d, s_cells, mode="nearest", truncate=TRUNCATE)
    # What the kernel really does, and the B-spline's own smoothing (variance (5 + 1) / 12 h^2).
    sigma = math.sqrt(sampled_gaussian_variance(s_cells) + 0.5) * h
    table = rice_table(sigma, plan.length + plan.reach_out + 8.0 * sigma)
    u = np.empty(dt.shape)
    _calibrate(dt, plan.length, table.m0, table.dm, table.r, table.slope, sigma, u)
    polish_inverse(u, dt, plan.length, table)
    coef = np.ascontiguousarray(u)
    coef.setflags(write=False)
    u_out = -1.0 if outside_blocked else 1e3
    return MapField(coef, nodes[0], nodes[1], c, s, h, u_out)


def sampled_gaussian_variance(sigma_cells: float) -> float:
    """The per-axis variance (cells^2) of the sampled, truncated kernel that
    ``scipy.ndimage.gaussian_filter`` applies for ``sigma_cells``."""
    radius = int(TRUNCATE * sigma_cells + 0.5)
    x = np.arange(-radius, radius + 1, dtype=float)
    w = np.exp(-0.5 * (x / sigma_cells) ** 2)
    return float((w * x * x).sum() / w.sum())


# --------------------------------------------------------------------------- evaluation


@njit(cache=True, inline="always")
def _weights(t):
    """The quintic B-spline's weights of the nodes ``j - 2 .. j + 3`` at ``j + t``
    (``0 <= t < 1``), times 120."""
    m = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    t4 = t2 * t2
    t5 = t4 * t
    return (m * m * m * m * m,
            26.0 - 50.0 * t + 20.0 * t2 + 20.0 * t3 - 20.0 * t4 + 5.0 * t5,
            66.0 - 60.0 * t2 + 30.0 * t4 - 10.0 * t5,
            26.0 + 50.0 * t + 20.0 * t2 - 20.0 * t3 - 20.0 * t4 + 10.0 * t5,
            1.0 + 5.0 * t + 10.0 * t2 + 10.0 * t3 + 5.0 * t4 - 5.0 * t5,
            t5)  # fmt: skip


@njit(cache=True, inline="always")
def _slopes(t):
    """Their first derivatives (times 120)."""
    m = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    t4 = t2 * t2
    return (-5.0 * m * m * m * m,
            -50.0 + 40.0 * t + 60.0 * t2 - 80.0 * t3 + 25.0 * t4,
            -120.0 * t + 120.0 * t3 - 50.0 * t4,
            50.0 + 40.0 * t - 60.0 * t2 - 80.0 * t3 + 50.0 * t4,
            5.0 + 20.0 * t + 30.0 * t2 + 20.0 * t3 - 25.0 * t4,
            5.0 * t4)  # fmt: skip


@njit(cache=True, inline="always")
def _curvatures(t):
    """Their second derivatives (times 120)."""
    m = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    return (20.0 * m * m * m,
            40.0 + 120.0 * t - 240.0 * t2 + 100.0 * t3,
            -120.0 + 360.0 * t2 - 200.0 * t3,
            40.0 - 120.0 * t - 240.0 * t2 + 200.0 * t3,
            20.0 + 60.0 * t + 60.0 * t2 - 100.0 * t3,
            20.0 * t3)  # fmt: skip


@njit(cache=True, inline="always")
def _dot6(row, j, w):
    """The weights ``w`` against the six coefficients of ``row`` from column ``j``."""
    return (w[0] * row[j] + w[1] * row[j + 1] + w[2] * row[j + 2] + w[3] * row[j + 3]
            + w[4] * row[j + 4] + w[5] * row[j + 5])  # fmt: skip


@njit(cache=True, inline="always")
def _sum6(a, w):
    return a[0] * w[0] + a[1] * w[1] + a[2] * w[2] + a[3] * w[3] + a[4] * w[4] + a[5] * w[5]


@njit(cache=True)
def _spline(coef, gx, gy, want_hessian):
    """``u`` and its derivatives in grid units at the grid point ``(gx, gy)`` (node ``(i, j)``
    at ``(j, i)``), from the 6 x 6 coefficients around it (weights times 120 per axis)."""
    j0, i0 = int(math.floor(gx)), int(math.floor(gy))
    tx, ty = gx - j0, gy - i0
    wx, dx = _weights(tx), _slopes(tx)
    wy, dy = _weights(ty), _slopes(ty)
    j = j0 - 2
    rows = (coef[i0 - 2], coef[i0 - 1], coef[i0], coef[i0 + 1], coef[i0 + 2], coef[i0 + 3])
    v = (_dot6(rows[0], j, wx), _dot6(rows[1], j, wx), _dot6(rows[2], j, wx),
         _dot6(rows[3], j, wx), _dot6(rows[4], j, wx), _dot6(rows[5], j, wx))  # fmt: skip
    g = (_dot6(rows[0], j, dx), _dot6(rows[1], j, dx), _dot6(rows[2], j, dx),
         _dot6(rows[3], j, dx), _dot6(rows[4], j, dx), _dot6(rows[5], j, dx))  # fmt: skip
    s = 1.0 / 14400.0  # 120^2
    u, ux, uy = _sum6(v, wy) * s, _sum6(g, wy) * s, _sum6(v, dy) * s
    if not want_hessian:
        return u, ux, uy, 0.0, 0.0, 0.0
    cx, cy = _curvatures(tx), _curvatures(ty)
    gg = (_dot6(rows[0], j, cx), _dot6(rows[1], j, cx), _dot6(rows[2], j, cx),
          _dot6(rows[3], j, cx), _dot6(rows[4], j, cx), _dot6(rows[5], j, cx))  # fmt: skip
    return u, ux, uy, _sum6(gg, wy) * s, _sum6(g, dy) * s, _sum6(v, cy) * s


@njit(cache=True)
def field_u(x, y, field, want_hessian):
    """``(u, u_x, u_y, u_xx, u_xy, u_yy)`` at the world point ``(x, y)`` (the Hessian 0 unless
    asked for); ``u_out`` and zero derivatives beyond the field's usable nodes."""
    coef = field.coef
    ny, nx = coef.shape
    c, s, ih = field.cos_yaw, field.sin_yaw, 1.0 / field.h
    dx, dy = x - field.x0, y - field.y0
    gx, gy = (c * dx + s * dy) * ih, (c * dy - s * dx) * ih
    if gx != gx or gy != gy:
        return math.nan, math.nan, math.nan, math.nan, math.nan, math.nan
    if not (2.0 <= gx < nx - 3.0 and 2.0 <= gy < ny - 3.0):
        return field.u_out, 0.0, 0.0, 0.0, 0.0, 0.0
    u, a, b, aa, ab, bb = _spline(coef, gx, gy, want_hessian)
    # The world gradient is R (a, b) / h and the Hessian R H R^T / h^2 (R: rotation by yaw).
    ux, uy = (c * a - s * b) * ih, (s * a + c * b) * ih
    if not want_hessian:
        return u, ux, uy, 0.0, 0.0, 0.0
    ih2 = ih * ih
    hxx = (c * c * aa - 2.0 * c * s * ab + s * s * bb) * ih2
    hxy = (c * s * (aa - bb) + (c * c - s * s) * ab) * ih2
    hyy = (s * s * aa + 2.0 * c * s * ab + c * c * bb) * ih2
    return u, ux, uy, hxx, hxy, hyy


@njit(cache=True)
def field_penalty_terms(x, y, field, weight, exponent, want_hessian):
    """``(P, P_x, P_y, P_xx, P_xy, P_yy)`` of ``P = W exp(-(max(u, 0)^2)^n)`` at ``(x, y)``:
    the same tuple as the disc penalty's ``penalty_terms``; all 0 for :func:`no_field`."""
    if field.coef.shape[0] == 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    u, ux, uy, uxx, uxy, uyy = field_u(x, y, field, want_hessian)
    if u != u:
        return math.nan, math.nan, math.nan, math.nan, math.nan, math.nan
    if u <= 0.0:
        return weight, 0.0, 0.0, 0.0, 0.0, 0.0
    n = exponent
    u2n2 = 1.0  # u^(2n - 2), without pow (as in the disc loop)
    for _ in range(n - 1):
        u2n2 *= u * u
    u2n1 = u2n2 * u
    q = u2n1 * u  # u^(2n)
    if q > 60.0 + (math.log(weight) if weight > 1.0 else 0.0):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    e = weight * math.exp(-q)
    g1 = -2.0 * n * u2n1 * e  # dP/du
    if not want_hessian:
        return e, g1 * ux, g1 * uy, 0.0, 0.0, 0.0
    g2 = e * (4.0 * n * n * u2n1 * u2n1 - 2.0 * n * (2.0 * n - 1.0) * u2n2)  # d2P/du2
    return (e, g1 * ux, g1 * uy, g2 * ux * ux + g1 * uxx, g2 * ux * uy + g1 * uxy,
            g2 * uy * uy + g1 * uyy)  # fmt: skip


@njit(cache=True)
def field_penalty_rows(xy, field, weight, exponent, want_hessian, out):
    """:func:`field_penalty_terms` at each row of ``xy`` (``(N, 2)``) into ``out`` (``(N, 6)``)."""
    for k in range(xy.shape[0]):
        terms = field_penalty_terms(xy[k, 0], xy[k, 1], field, weight, exponent, want_hessian)
        for m in range(6):
            out[k, m] = terms[m]
