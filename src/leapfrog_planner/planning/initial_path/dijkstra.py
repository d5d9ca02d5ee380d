"""Shortest paths on the tangent graph with barrier rays (:meth:`.TangentGraph.search`): per
blocking mask, Dijkstra's algorithm ordered by the A* bound, on a binary heap, compiled with
numba (a search costs a few tens of microseconds)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..._jit import njit
from .heap import heap_pop, heap_push


class _Edges(NamedTuple):
    """The graph as :func:`shortest_paths` reads it: the edges in CSR order (edges
    ``indptr[u]`` to ``indptr[u + 1]`` leave node ``u``) with their destinations, weights and
    barrier ``bits``, and per node the straight line to the goal ``togo`` (the A* bound)."""

    indptr: np.ndarray  # (n + 1,) int64
    dst: np.ndarray  # int64
    wgt: np.ndarray
    bits: np.ndarray  # int64
    togo: np.ndarray  # (n,)


class _Labels(NamedTuple):
    """One search's labels per node: distance from the start, predecessor (-1: none), and
    whether the distance is final. Reset by every search."""

    dist: np.ndarray
    pred: np.ndarray  # int64
    done: np.ndarray  # bool


class _Heap(NamedTuple):
    """A binary heap of (key, node) pairs in two arrays, ordered lexicographically; its size
    is kept by the caller."""

    key: np.ndarray
    node: np.ndarray  # int64


@njit(cache=True)
def shortest_paths(indptr, dst, wgt, bits, masks, node_xy):
    """For each mask: the shortest path from node 0 to node 1 without the edges whose ``bits``
    meet the mask (Dijkstra, ordered by the A* bound ``distance + straight line to the goal``,
    which is consistent here): lengths (inf: none), node paths padded with -1 (as wide as the
    longest), path sizes."""
    n = indptr.size - 1
    n_masks = masks.size
    lengths = np.full(n_masks, np.inf)
    flat = np.empty(64, np.int64)  # the paths one after another
    used = 0
    plen = np.zeros(n_masks, np.int64)
    labels = _Labels(np.empty(n), np.empty(n, np.int64), np.empty(n, np.bool_))
    gx, gy = node_xy[1, 0], node_xy[1, 1]
    # Every edge is relaxed at most once, so the heap never holds more than len(dst) + 1 pairs.
    heap = _Heap(np.empty(dst.size + 1), np.empty(dst.size + 1, np.int64))
    togo = np.empty(n)
    for v in range(n):
        togo[v] = math.hypot(node_xy[v, 0] - gx, node_xy[v, 1] - gy)
    edges = _Edges(indptr, dst, wgt, bits, togo)
    for p in range(n_masks):
        _dijkstra(edges, masks[p], labels, heap)
        if not labels.done[1]:
            continue
        lengths[p] = labels.dist[1]
        flat, plen[p] = _append_path(flat, used, labels.pred)
        used += plen[p]
    return lengths, _pad_paths(flat, plen), plen


@njit(cache=True)
def _dijkstra(edges, blocked, labels, heap):
    """One search of :func:`shortest_paths`, from node 0 until node 1 is settled (or nothing is
    left), without the edges whose bits meet ``blocked``: into ``labels``."""
    dist, pred, done = labels
    dist[:] = np.inf
    pred[:] = -1
    done[:] = False
    dist[0] = 0.0
    hk, hn = heap.key, heap.node  # large enough: the heap never grows here
    hk[0] = edges.togo[0]
    hn[0] = 0
    size = 1
    while size > 0:
        u = heap_pop(hk, hn, size)
        size -= 1
        if done[u]:
            continue
        done[u] = True
        if u == 1:
            break
        d = dist[u]
        for e in range(edges.indptr[u], edges.indptr[u + 1]):
            if edges.bits[e] & blocked:
                continue
            v = edges.dst[e]
            nd = d + edges.wgt[e]
            if nd < dist[v]:
                dist[v] = nd
                pred[v] = u
                hk, hn = heap_push(hk, hn, size, nd + edges.togo[v], v)
                size += 1


@njit(cache=True)
def _append_path(flat, used, pred):
    """The path from node 0 to node 1 of ``pred``, written into ``flat`` from ``used`` on (grown
    when full): ``flat`` and the path's size."""
    k = 0
    v = np.int64(1)
    while v != -1:
        k += 1
        v = pred[v]
    if used + k > flat.size:
        grown = np.empty(flat.size + max(flat.size, k), np.int64)
        for i in range(used):
            grown[i] = flat[i]
        flat = grown
    size = k
    v = np.int64(1)
    while v != -1:  # written backwards from the goal
        k -= 1
        flat[used + k] = v
        v = pred[v]
    return flat, size


@njit(cache=True)
def _pad_paths(flat, plen):
    """The paths stored one after another in ``flat``, as rows padded with -1."""
    width = 1
    for p in range(plen.size):
        width = max(width, plen[p])
    paths = np.full((plen.size, width), -1, np.int64)
    used = 0
    for p in range(plen.size):  # element by element: slice assignment compiles for seconds
        for k in range(plen[p]):
            paths[p, k] = flat[used + k]
        used += plen[p]
    return paths
