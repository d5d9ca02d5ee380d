"""A uniform grid over discs, each cell listing the discs that reach it: the bucketing that the
penalty's :class:`~.penalty.ObstacleGrid` and the initial paths' ``DiscGrid`` share.

A disc ``j`` of centre ``C[j]`` reaches the cells that its box ``C[j] +- reach[j]`` touches.
Cell ``(ix, iy)`` is number ``iy * nx + ix`` (row-major); its discs are
``items[starts[c]:starts[c + 1]]``, in increasing index. Memory is linear in the number of
discs (times the cells a disc covers).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

#: Cells per disc, at most (a disc much larger than the others covers several).
CELLS_PER_DISC = 4.0


def grid_layout(C: np.ndarray, extent: np.ndarray, typical: float):
    """``(lo, h, nx, ny)``: the origin ``lo`` and the cells (``nx * ny`` squares of side ``h``)
    of a grid over the boxes ``C +- extent``, with cells no smaller than ``typical`` and no more
    than :data:`CELLS_PER_DISC` per disc (at most ``2^15`` a side)."""
    m = extent.size
    if m:
        lo = np.min(C - extent[:, None], axis=0)
        hi = np.max(C + extent[:, None], axis=0)
    else:
        lo, hi = np.zeros(2), np.ones(2)
    span = np.maximum(hi - lo, 1e-12 * max(1.0, float(np.max(np.abs(hi)))))
    h = max(typical, math.sqrt(float(span[0] * span[1]) / (CELLS_PER_DISC * max(m, 1))))
    nx, ny = (int(min(max(math.ceil(v / h), 1), 1 << 15)) for v in span)
    h = max(h, float(span[0]) / nx, float(span[1]) / ny)
    return lo, h, nx, ny


def cell_lists(C: np.ndarray, reach: np.ndarray, lo: np.ndarray, h: float, nx: int, ny: int):
    """``(starts, items)``: the lists of the discs (boxes ``C +- reach``) per cell, as CSR
    arrays (row-major cells, discs in increasing index)."""
    cells = []
    for k, n in ((0, nx), (1, ny)):
        for edge in (C[:, k] - reach, C[:, k] + reach):
            cells.append(np.clip(np.floor((edge - lo[k]) / h), 0, n - 1).astype(np.int64))
    return _fill(*cells, nx, ny)


@njit(cache=True)
def _fill(ix0, ix1, iy0, iy1, nx, ny):
    count = np.zeros(nx * ny + 1, np.int64)
    for j in range(ix0.size):
        for iy in range(iy0[j], iy1[j] + 1):
            for ix in range(ix0[j], ix1[j] + 1):
                count[iy * nx + ix + 1] += 1
    starts = np.cumsum(count)
    items = np.empty(starts[-1], np.int64)
    fill = starts[:-1].copy()
    for j in range(ix0.size):  # increasing j: each cell's list is sorted
        for iy in range(iy0[j], iy1[j] + 1):
            for ix in range(ix0[j], ix1[j] + 1):
                c = iy * nx + ix
                items[fill[c]] = j
                fill[c] += 1
    return starts, items
