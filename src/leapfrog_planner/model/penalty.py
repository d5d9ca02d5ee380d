"""The obstacle penalty ``P(x, y) = sum_j W exp(-(s_j)^n)``, ``s_j = |(x, y) - c_j|^2 / r_j^2``.

Obstacles are data: an ``(m, 3)`` array of ``[cx, cy, r]`` rows. The compiled loops below give the
value, gradient and Hessian, so a new scenario never compiles anything.
"""

import math

import numpy as np
from numba import njit


@njit(cache=True)
def penalty_terms(x, y, obs, weight, exponent, want_hessian):
    """Return ``(P, Px, Py, Pxx, Pxy, Pyy)`` at ``(x, y)``; the Hessian is 0 unless asked for."""
    P = 0.0
    Px = 0.0
    Py = 0.0
    Pxx = 0.0
    Pxy = 0.0
    Pyy = 0.0
    n = exponent
    # An obstacle with s^n > 60 + ln W adds at most e^-60 = 1e-26 to P, and (s^(n-1) and 1/r
    # factors included) below 1e-17 to its derivatives even for small discs: far below the
    # rounding of the other terms of the canonical system. Near the paths of the paper cases,
    # most obstacles within exp's underflow range (s^n < 746) are that far.
    far = 60.0 + (math.log(weight) if weight > 1.0 else 0.0)
    for j in range(obs.shape[0]):
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
