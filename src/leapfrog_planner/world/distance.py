"""The exact signed distance from cell centres to the blocked cells of a grid, as squares.

A blocked cell is the closed unit square it covers (the same object the clearance check of
:mod:`.clearance` measures against). The distance from a cell centre to the square at integer
offset ``(a, b)`` is ``sqrt(e(a)^2 + e(b)^2)`` with ``e(a) = max(|a| - 1/2, 0)``: it separates
into a column pass (the 1-D distance to the nearest blocked cell of the column) and a row pass,
the lower envelope of parabolas of Felzenszwalb and Huttenlocher ("Distance transforms of sampled
functions", Theory of Computing 8, 2012) with its sites on the half-integer lattice (a square's
edge lies half a cell from its centre). Both signs in one call: outside the blocked region the
distance to it, inside minus the distance to the free region. O(cells), compiled with numba.
"""

import math

import numpy as np

from .._jit import njit

BIG = 1e20  # beyond any parabola intersection


@njit(cache=True)
def _lower_envelope_sites(xs, vs, m, n, out, v, z):
    """out[q] = min_k (q - xs[k])^2 + vs[k] for q = 0..n-1 (sites sorted by position)."""
    k = 0
    v[0] = 0
    z[0] = -BIG
    z[1] = BIG
    for t in range(1, m):
        ft = vs[t] + xs[t] * xs[t]
        p = v[k]
        s = (ft - (vs[p] + xs[p] * xs[p])) / (2.0 * (xs[t] - xs[p]))
        while s <= z[k]:
            k -= 1
            p = v[k]
            s = (ft - (vs[p] + xs[p] * xs[p])) / (2.0 * (xs[t] - xs[p]))
        k += 1
        v[k] = t
        z[k] = s
        z[k + 1] = BIG
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        out[q] = (q - xs[p]) * (q - xs[p]) + vs[p]


#: A column distance meaning "no such cell in this column".
NONE = 1 << 29


@njit(cache=True)
def _column_distances(blocked):
    """Per cell, the distance (cells) along its column to the nearest blocked cell and to the
    nearest free cell (:data:`NONE` when the column has none): two sweeps, down and up."""
    ny, nx = blocked.shape
    to_blocked = np.empty((ny, nx), np.int32)
    to_free = np.empty((ny, nx), np.int32)
    last_b = np.full(nx, -NONE, np.int64)
    last_f = np.full(nx, -NONE, np.int64)
    for i in range(ny):
        for j in range(nx):
            if blocked[i, j]:
                last_b[j] = i
            else:
                last_f[j] = i
            to_blocked[i, j] = min(i - last_b[j], NONE)
            to_free[i, j] = min(i - last_f[j], NONE)
    last_b[:] = 2 * NONE
    last_f[:] = 2 * NONE
    for i in range(ny - 1, -1, -1):
        for j in range(nx):
            if blocked[i, j]:
                last_b[j] = i
            else:
                last_f[j] = i
            to_blocked[i, j] = min(to_blocked[i, j], last_b[j] - i)
            to_free[i, j] = min(to_free[i, j], last_f[j] - i)
    return to_blocked, to_free


@njit(cache=True)
def _row_pass(column, blocked, inside, cap, sign, out):
    """For the cells with ``blocked == inside``: ``sign`` times the 2-D distance (capped at
    ``cap``) from the column distances ``column`` (to the other kind of cell), row by row."""
    ny, nx = column.shape
    far = 4.0 * (nx + ny + 2.0) ** 2  # above any squared distance on the grid
    m = 2 * nx - 1  # sites: the square edges' 1-D distances on the half-integer lattice
    xs = np.arange(m) * 0.5
    vs = np.empty(m)
    f = np.empty(nx)
    r = np.empty(nx)
    v = np.empty(m, np.int64)
    z = np.empty(m + 1)
    for i in range(ny):
        for j in range(nx):
            t = column[i, j]
            e = t - 0.5 if t >= 1 else 0.0  # to the square's edge, not its centre
            f[j] = far if t >= NONE else e * e
        for k in range(m):
            vs[k] = f[k // 2] if k % 2 == 0 else min(f[k // 2], f[k // 2 + 1])
        _lower_envelope_sites(xs, vs, m, nx, r, v, z)
        for j in range(nx):
            if blocked[i, j] == inside:
                out[i, j] = sign * (min(math.sqrt(r[j]), cap) if r[j] < far else cap)


@njit(cache=True)
def signed_distance_squares(blocked, cap_in, cap_out):
    """The exact signed distance (cells) from every cell centre to the boundary of the union of
    the ``blocked`` cells taken as closed unit squares: positive outside, negative inside,
    clipped to ``[-cap_in, cap_out]`` (module docstring)."""
    to_blocked, to_free = _column_distances(blocked)
    out = np.empty(blocked.shape)
    _row_pass(to_blocked, blocked, False, cap_out, 1.0, out)
    _row_pass(to_free, blocked, True, cap_in, -1.0, out)
    return out
