"""A binary heap of ``(key, node)`` pairs in two arrays, for the compiled searches of
:mod:`.dijkstra` (the tangent graph's) and :mod:`.map_grid` (the map's): ordered by key, ties by
node, so that the pops are the same on every machine. The caller keeps the heap's size."""

from __future__ import annotations

import numpy as np

from ..._jit import njit


@njit(cache=True, inline="always")
def precedes(key_a, node_a, key_b, node_b):
    """The heap's order: by key, ties by node."""
    return key_a < key_b or (key_a == key_b and node_a < node_b)


@njit(cache=True)
def heap_push(hk, hn, size, key, v):
    """Put ``(key, v)`` into the heap of the first ``size`` entries of ``hk, hn`` (doubled
    first when full); returns the arrays (the caller counts one entry more)."""
    if size == hk.size:
        hk = np.concatenate((hk, np.empty(size)))
        hn = np.concatenate((hn, np.empty(size, np.int64)))
    i = size
    while i > 0:
        par = (i - 1) >> 1
        if not precedes(key, v, hk[par], hn[par]):
            break
        hk[i], hn[i] = hk[par], hn[par]
        i = par
    hk[i], hn[i] = key, v
    return hk, hn


@njit(cache=True)
def heap_pop(hk, hn, size):
    """Take the least pair out of the heap of ``size`` entries: its node (the caller then
    counts one entry fewer); the last pair sifts down from the root."""
    u = hn[0]
    size -= 1
    key, val = hk[size], hn[size]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and precedes(hk[c + 1], hn[c + 1], hk[c], hn[c]):
            c += 1
        if not precedes(hk[c], hn[c], key, val):
            break
        hk[i], hn[i] = hk[c], hn[c]
        i = c
    hk[i], hn[i] = key, val
    return u
