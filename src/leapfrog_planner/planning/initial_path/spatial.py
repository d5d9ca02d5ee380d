"""A uniform grid over discs for the tangent graph and the clearance checks: each cell lists
(in increasing disc index) every disc whose bounding box, grown by a pad, touches it, so that a
point, segment or disc is only tested against the discs near it. Memory is linear in the number
of discs (times the cells a disc covers); the tests themselves are the brute-force ones, so the
answers are the same."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit
from ...model.grid import cell_lists, grid_layout


class DiscGrid(NamedTuple):
    """Discs ``(C, R)`` in a uniform grid of ``nx * ny`` cells of size ``h`` from ``(ox, oy)``;
    the discs of cell ``c`` are ``items[starts[c]:starts[c + 1]]``. The record the compiled
    loops below read (build it with :func:`disc_grid`)."""

    C: np.ndarray  # (m, 2) centres, C-contiguous
    R: np.ndarray  # (m,) radii
    starts: np.ndarray  # (nx * ny + 1,) int64
    items: np.ndarray  # int64 indices into C and R
    ox: float
    oy: float
    h: float
    nx: int
    ny: int


def disc_grid(C: np.ndarray, R: np.ndarray, pad: float = 0.0) -> DiscGrid:
    """The grid of the discs ``(C, R)``, each registered in the cells its box grown by ``pad``
    touches."""
    C = np.ascontiguousarray(C, dtype=np.float64).reshape(-1, 2)
    R = np.ascontiguousarray(R, dtype=np.float64).reshape(-1)
    # Cells about the size of a typical disc, but no more than a few per disc.
    typical = 2.0 * float(np.median(R + pad)) if R.size else 1.0
    lo, h, nx, ny = grid_layout(C, R + pad, typical)
    # Registered a little beyond the box, so that rounding never loses a disc.
    reach = (R + pad) * (1.0 + 1e-12) + 1e-9 * h
    starts, items = cell_lists(C, reach, lo, h, nx, ny)
    return DiscGrid(C, R, starts, items, float(lo[0]), float(lo[1]), h, nx, ny)


@njit(cache=True, error_model="numpy")
def _cell(v, o, h, n):
    # Clamped in floating point first: a huge (or infinite) v has no int64 cell.
    k = (v - o) / h
    if k < 1.0:
        return 0
    if k >= n - 1:
        return n - 1
    return int(k)


@njit(cache=True, error_model="numpy")
def disc_pairs(grid, pad):
    """Pairs ``(i, j)``, ``i != j``, of discs whose boxes (grown by ``pad``) may overlap: a
    superset of the pairs at centre distance ``< R_i + R_j + 2 pad``, each ordered pair once."""
    C, R, starts, items = grid.C, grid.R, grid.starts, grid.items
    ox, oy, h, nx, ny = grid.ox, grid.oy, grid.h, grid.nx, grid.ny
    m = R.size
    stamp = np.full(m, -1, np.int64)
    cap = 16 * m + 16
    pi = np.empty(cap, np.int64)
    pj = np.empty(cap, np.int64)
    n = 0
    for i in range(m):
        r = R[i] + pad
        for iy in range(_cell(C[i, 1] - r, oy, h, ny), _cell(C[i, 1] + r, oy, h, ny) + 1):
            for ix in range(_cell(C[i, 0] - r, ox, h, nx), _cell(C[i, 0] + r, ox, h, nx) + 1):
                c = iy * nx + ix
                for k in range(starts[c], starts[c + 1]):
                    j = items[k]
                    if j == i or stamp[j] == i:
                        continue
                    stamp[j] = i
                    if n == cap:
                        cap *= 2
                        pi = np.concatenate((pi, np.empty(cap - n, np.int64)))
                        pj = np.concatenate((pj, np.empty(cap - n, np.int64)))
                    pi[n] = i
                    pj[n] = j
                    n += 1
    # Sorted by (i, j), as an m x m scan would give them.
    order = np.argsort(pi[:n] * m + pj[:n])
    return pi[:n][order], pj[:n][order]


@njit(cache=True, error_model="numpy", inline="always")
def _closer(dx, dy, r):
    """``hypot(dx, dy) < r``, without the square root (False for nan, and for ``r <= 0``)."""
    return r > 0.0 and dx * dx + dy * dy < r * r


@njit(cache=True, error_model="numpy", inline="always")
def _point_inside(x, y, grid, tol):
    """Whether ``(x, y)`` lies deeper than ``tol`` inside some disc of its cell."""
    fx, fy = (x - grid.ox) / grid.h, (y - grid.oy) / grid.h
    if not (0.0 <= fx < grid.nx and 0.0 <= fy < grid.ny):
        return False  # outside every disc's box (nan too)
    c = min(int(fy), grid.ny - 1) * grid.nx + min(int(fx), grid.nx - 1)
    C, R = grid.C, grid.R
    for k in range(grid.starts[c], grid.starts[c + 1]):
        j = grid.items[k]
        if _closer(x - C[j, 0], y - C[j, 1], R[j] - tol):
            return True
    return False


@njit(cache=True, error_model="numpy")
def points_inside(xy, grid, tol):
    """Per point, whether it lies deeper than ``tol`` inside some disc
    (``hypot(p - c) < R - tol``)."""
    out = np.zeros(xy.shape[0], np.bool_)
    for p in range(xy.shape[0]):
        out[p] = _point_inside(xy[p, 0], xy[p, 1], grid, tol)
    return out


@njit(cache=True, error_model="numpy")
def segments_cut(a, b, grid, tol):
    """Per segment ``a[e] -> b[e]``, whether some disc comes closer to it than ``R - tol`` (the
    distance formula of ``_segment_distance_loops``), testing only the discs of the cells that
    the segment crosses."""
    E = a.shape[0]
    out = np.zeros(E, np.bool_)
    stamp = np.full(grid.R.size, -1, np.int64)
    for e in range(E):
        out[e] = _segment_cut(a[e, 0], a[e, 1], b[e, 0], b[e, 1], e, stamp, grid, tol)
    return out


@njit(cache=True, error_model="numpy")
def _segment_cut(ax, ay, bx, by, e, stamp, grid, tol):
    """Whether some disc comes closer than ``R - tol`` to the segment ``a -> b``; ``stamp``
    (one entry per disc, never ``e`` before) marks the discs tested, each once."""
    C, R, starts, items = grid.C, grid.R, grid.starts, grid.items
    ox, oy, h, nx, ny = grid.ox, grid.oy, grid.h, grid.nx, grid.ny
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    x_lo, x_hi = min(ax, bx), max(ax, bx)
    y_lo, y_hi = min(ay, by), max(ay, by)
    if not (x_hi >= ox and y_hi >= oy and x_lo <= ox + nx * h and y_lo <= oy + ny * h):
        return False  # outside the grid, or nan (no disc is closer than nan)
    kx0 = _cell(x_lo, ox, h, nx) if x_lo == x_lo else 0
    kx1 = _cell(x_hi, ox, h, nx) if x_hi == x_hi else nx - 1
    for kx in range(kx0, kx1 + 1):
        # The segment's y range over this column (all of it for a vertical segment).
        if abx != 0.0 and x_lo == x_lo:
            xa = max(x_lo, ox + kx * h)
            xb = min(x_hi, ox + (kx + 1) * h)
            ya = ay + (xa - ax) / abx * aby
            yb = ay + (xb - ax) / abx * aby
            c_lo, c_hi = min(ya, yb), max(ya, yb)
        else:
            c_lo, c_hi = y_lo, y_hi
        if c_lo == c_lo and c_hi == c_hi:
            ky0 = max(_cell(c_lo, oy, h, ny) - 1, 0)
            ky1 = min(_cell(c_hi, oy, h, ny) + 1, ny - 1)
        else:
            ky0, ky1 = 0, ny - 1
        for ky in range(ky0, ky1 + 1):
            c = ky * nx + kx
            for k in range(starts[c], starts[c + 1]):
                j = items[k]
                if stamp[j] == e:
                    continue
                stamp[j] = e
                acx, acy = C[j, 0] - ax, C[j, 1] - ay
                t = (acx * abx + acy * aby) / den
                if np.isnan(t):
                    t = 0.0
                t = t if t > 0.0 else 0.0
                t = t if t < 1.0 else 1.0
                if _closer(acx - t * abx, acy - t * aby, R[j] - tol):
                    return True
    return False


@njit(cache=True, error_model="numpy", nogil=True)
def common_tangents(grid, act, sigma, sgn, prune, tol):
    """One family of common tangents of the pairs ``act[a] < act[b]`` of discs, in
    ``np.triu_indices`` order: outer (``sigma = 1``) or inner (``sigma = -1``), on the side
    ``sgn``. Returns the tangent points ``Ti, Tj`` and the discs ``ci, cj``. With ``prune``,
    only the tangents whose ends lie in no disc and that no disc cuts (the grid's discs,
    deeper than ``tol``), so that memory grows with the free tangents, not with the pairs."""
    C, R = grid.C, grid.R
    k = act.size
    cap = 4 * k + 16
    T = np.empty((cap, 4))
    cc = np.empty((cap, 2), np.int64)
    n = 0
    stamp = np.full(R.size, -1, np.int64)
    tested = 0
    for a in range(k):
        i = act[a]
        for b in range(a + 1, k):
            j = act[b]
            wx, wy = C[j, 0] - C[i, 0], C[j, 1] - C[i, 1]
            d = math.hypot(wx, wy)
            ux, uy = wx / d, wy / d
            cosb = (R[i] - sigma * R[j]) / d
            if not abs(cosb) < 1.0 - 1e-12:
                continue
            # u turned by sgn * acos(cosb): its cosine is cosb, its sine sgn * sqrt(1 - cosb^2)
            sinb = sgn * math.sqrt(1.0 - cosb * cosb)
            vx, vy = ux * cosb - uy * sinb, ux * sinb + uy * cosb
            tix, tiy = C[i, 0] + R[i] * vx, C[i, 1] + R[i] * vy
            tjx, tjy = C[j, 0] + sigma * R[j] * vx, C[j, 1] + sigma * R[j] * vy
            if prune:
                if _point_inside(tix, tiy, grid, tol) or _point_inside(tjx, tjy, grid, tol):
                    continue
                tested += 1
                if _segment_cut(tix, tiy, tjx, tjy, tested, stamp, grid, tol):
                    continue
            if n == cap:
                cap *= 2
                T = np.concatenate((T, np.empty((cap - n, 4))))
                cc = np.concatenate((cc, np.empty((cap - n, 2), np.int64)))
            T[n, 0], T[n, 1], T[n, 2], T[n, 3] = tix, tiy, tjx, tjy
            cc[n, 0], cc[n, 1] = i, j
            n += 1
    return T[:n, :2].copy(), T[:n, 2:].copy(), cc[:n, 0].copy(), cc[:n, 1].copy()
