"""The obstacle penalty ``P(x, y) = sum_j W exp(-(s_j)^n)``, ``s_j = |(x, y) - c_j|^2 / r_j^2``.

Obstacles are data: an ``(m, 3)`` array of ``[cx, cy, r]`` rows. The compiled loops below give the
value, gradient and Hessian, so a new scenario never compiles anything.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit
from ..world.field import MapField, field_penalty_terms, no_field
from .grid import cell_lists, grid_layout


@njit(cache=True, inline="always")
def far_bound(weight):
    """The ``s^n`` beyond which an obstacle's term of :func:`penalty_terms` is skipped.

    An obstacle with ``s^n > 60 + ln W`` adds at most ``e^-60 = 1e-26`` to P, and (``s^(n-1)``
    and ``1/r`` factors included) below 1e-17 to its derivatives even for small discs: far below
    the rounding of the other terms of the canonical system. Near the paths of the paper cases,
    most obstacles within exp's underflow range (``s^n < 746``) are that far."""
    return 60.0 + (math.log(weight) if weight > 1.0 else 0.0)


#: The plain loop's ``items``: none, so obstacle ``k`` is the ``k``-th (a global array is a
#: constant of the compiled code).
_ALL = np.zeros(0, np.int64)


@njit(cache=True, inline="always")
def _summed_terms(x, y, obs, items, lo, hi, weight, n, want_hessian):
    """The loop of :func:`penalty_terms` and :func:`grid_penalty_terms`: the terms of the
    obstacles ``items[lo:hi]`` (of ``lo`` to ``hi - 1`` when ``items`` is empty), in order."""
    P = Px = Py = Pxx = Pxy = Pyy = 0.0
    far = far_bound(weight)
    for k in range(lo, hi):
        j = items[k] if items.size else k
        inv_r2 = 1.0 / (obs[j, 2] * obs[j, 2])
        dx = x - obs[j, 0]
        dy = y - obs[j, 1]
        s = (dx * dx + dy * dy) * inv_r2
        # s^(n-1) without pow(): numba's float ** (run-time int) calls it, which made this
        # loop twice as slow. n = 2 (the default) and n = 1 are exact; larger n multiply.
        if n == 2:
            sn1 = s
        else:
            sn1 = 1.0
            for _ in range(n - 1):
                sn1 *= s
        if sn1 * s > far:  # negligible: skip the exp
            continue
        e = weight * math.exp(-(sn1 * s))
        if e == 0.0:
            continue
        P += e
        dP_ds = -n * sn1 * e
        sx = 2.0 * dx * inv_r2
        sy = 2.0 * dy * inv_r2
        Px += dP_ds * sx
        Py += dP_ds * sy
        if want_hessian:
            # d2P/ds2 = e (n^2 s^(2n-2) - n(n-1) s^(n-2)); the second term vanishes for n = 1.
            d2 = n * n * sn1 * sn1 * e
            if n > 1:
                sn2 = 1.0
                for _ in range(n - 2):
                    sn2 *= s
                d2 -= n * (n - 1) * sn2 * e  # for n = 2: 2e, as with pow
            Pxx += d2 * sx * sx + dP_ds * 2.0 * inv_r2
            Pxy += d2 * sx * sy
            Pyy += d2 * sy * sy + dP_ds * 2.0 * inv_r2
    return P, Px, Py, Pxx, Pxy, Pyy


@njit(cache=True)
def penalty_terms(x, y, obs, weight, exponent, want_hessian):
    """Return ``(P, Px, Py, Pxx, Pxy, Pyy)`` at ``(x, y)``; the Hessian is 0 unless asked for."""
    return _summed_terms(x, y, obs, _ALL, 0, obs.shape[0], weight, exponent, want_hessian)


class ObstacleGrid(NamedTuple):
    """The obstacles and a uniform grid over them, as the compiled kernels read them.

    Cell ``(ix, iy)`` (row-major, ``nx * ny`` cells of size ``h`` from ``(ox, oy)``) lists in
    ``items[starts[c]:starts[c + 1]]``, in increasing index, every obstacle whose influence disc
    (where its term is not skipped as negligible, for ``weight`` and ``exponent``) touches it:
    the penalty summed over a point's cell is the plain loop's sum, in the same order.
    """

    obstacles: np.ndarray  # (m, 3) rows [cx, cy, r]
    starts: np.ndarray  # (nx * ny + 1,) int64
    items: np.ndarray  # int64
    ox: float
    oy: float
    h: float
    nx: int
    ny: int
    weight: float  # the largest weight the grid holds for
    exponent: int
    field: MapField  # a map's penalty field (world/field.py), added to the discs' sum


def obstacle_grid(
    obstacles, weight: float, exponent: int, field: MapField | None = None
) -> ObstacleGrid:
    """The grid of ``obstacles`` for the penalty with ``weight`` and ``exponent`` (valid for
    any weight up to ``weight``: the influence discs only shrink with the weight), with a map's
    ``field`` (none by default)."""
    obs = as_obstacle_array(obstacles).view()
    obs.setflags(write=False)  # one compiled type, whatever the caller's array
    far = far_bound(float(weight))
    # s^n <= far where |p - c| <= r far^(1/2n); a little more, so that rounding loses nothing.
    reach = obs[:, 2] * far ** (0.5 / exponent) * (1.0 + 1e-9) if obs.shape[0] else np.zeros(0)
    typical = float(np.median(reach)) if reach.size else 1.0
    lo, h, nx, ny = grid_layout(obs[:, :2], reach, typical)
    starts, items = cell_lists(obs[:, :2], reach + 1e-9 * h, lo, h, nx, ny)
    field = no_field() if field is None else field
    return ObstacleGrid(
        obs,
        starts,
        items,
        float(lo[0]),
        float(lo[1]),
        h,
        nx,
        ny,
        float(weight),
        int(exponent),
        field,
    )


@njit(cache=True)
def grid_penalty_terms(x, y, grid, weight, exponent, want_hessian):
    """The map's field plus :func:`penalty_terms` over the obstacles of ``(x, y)``'s grid cell:
    the discs' sum in the same order (the others are skipped there as negligible); all
    obstacles at a nan point."""
    terms = _disc_terms(x, y, grid, weight, exponent, want_hessian)
    if grid.field.coef.shape[0] == 0:  # no map: the discs alone
        return terms
    P, Px, Py, Pxx, Pxy, Pyy = field_penalty_terms(x, y, grid.field, weight, exponent, want_hessian)
    a, b, c, d, e, f = terms
    return P + a, Px + b, Py + c, Pxx + d, Pxy + e, Pyy + f


@njit(cache=True, inline="always")
def _disc_terms(x, y, grid, weight, exponent, want_hessian):
    obs = grid.obstacles
    fx = (x - grid.ox) / grid.h
    fy = (y - grid.oy) / grid.h
    if fx != fx or fy != fy or weight > grid.weight or exponent != grid.exponent:
        # A nan point, or a grid built for another penalty: the plain loop.
        return penalty_terms(x, y, obs, weight, exponent, want_hessian)
    if not (0.0 <= fx < grid.nx and 0.0 <= fy < grid.ny):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    c = min(int(fy), grid.ny - 1) * grid.nx + min(int(fx), grid.nx - 1)
    lo, hi = grid.starts[c], grid.starts[c + 1]
    return _summed_terms(x, y, obs, grid.items, lo, hi, weight, exponent, want_hessian)


@njit(cache=True)
def disc_penalty_values(xy, grid, weight, exponent):
    """The discs' penalty (no map's field) at each row ``[x, y]`` of ``xy``: the value of
    :func:`grid_penalty_terms`, a point's cell visited alone."""
    out = np.empty(xy.shape[0])
    for i in range(xy.shape[0]):
        out[i] = _disc_terms(xy[i, 0], xy[i, 1], grid, weight, exponent, False)[0]
    return out


def penalty_at(x, y, obs, weight, exponent, want_hessian):
    """The penalty terms at ``(x, y)`` for ``obs`` given as an :class:`ObstacleGrid` or as a
    plain ``(m, 3)`` array (compiled code picks the loop by the type)."""
    if isinstance(obs, ObstacleGrid):
        return grid_penalty_terms(x, y, obs, weight, exponent, want_hessian)
    return penalty_terms(x, y, obs, weight, exponent, want_hessian)


def has_penalty(obs) -> bool:
    """Whether ``obs`` (an :class:`ObstacleGrid` or an ``(m, 3)`` array) has any obstacle: a
    disc or a map."""
    if isinstance(obs, ObstacleGrid):
        return obs.obstacles.shape[0] > 0 or obs.field.coef.shape[0] > 0
    return obs.shape[0] > 0


@overload(penalty_at)
def _penalty_at(x, y, obs, weight, exponent, want_hessian):
    if isinstance(obs, types.Array):
        return lambda x, y, obs, weight, exponent, want_hessian: penalty_terms(
            x, y, obs, weight, exponent, want_hessian
        )
    return lambda x, y, obs, weight, exponent, want_hessian: grid_penalty_terms(
        x, y, obs, weight, exponent, want_hessian
    )


@overload(has_penalty)
def _has_penalty(obs):
    if isinstance(obs, types.Array):
        return lambda obs: obs.shape[0] > 0
    return lambda obs: obs.obstacles.shape[0] > 0 or obs.field.coef.shape[0] > 0


def as_obstacle_array(obstacles) -> np.ndarray:
    """Obstacles as a C-contiguous float64 ``(m, 3)`` array (``m`` may be 0)."""
    arr = np.ascontiguousarray(obstacles, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 3))
    return arr.reshape(-1, 3)


def clearance(xy: np.ndarray, obstacles: np.ndarray) -> np.ndarray:
    """Minimum over the path ``xy`` (shape ``(N, 2)``) of distance to each obstacle's edge."""
    obstacles = as_obstacle_array(obstacles)
    if obstacles.shape[0] == 0:
        return np.zeros(0)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if xy.shape[0] * obstacles.shape[0] <= 1 << 16 or not np.all(np.isfinite(xy)):
        d = np.linalg.norm(xy[:, None, :] - obstacles[None, :, :2], axis=2) - obstacles[None, :, 2]
        return d.min(axis=0)
    # The path point nearest each centre (a k-d tree of the points), without an (N, m) array.
    from scipy.spatial import cKDTree

    _, near = cKDTree(xy).query(obstacles[:, :2])
    d = np.linalg.norm(xy[near] - obstacles[:, :2], axis=1) - obstacles[:, 2]
    return d
