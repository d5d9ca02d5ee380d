"""The compiled kernels of :mod:`.map_routes`: the exact clearance field of a map's cells, exact
segment tests against the blocked cells, the search graph and its shortest-path fields, and the
simplification of grid paths into polylines with few vertices.

Coordinates. Every kernel works in *padded grid coordinates*: the map's blocked cells with one
ring of cells round them (blocked when the world off the map is, else free), so that the map's
cell ``(i, j)`` is the padded cell ``(i + 1, j + 1)``, the closed square
``[j + 1, j + 2] x [i + 1, i + 2]``, and a point's padded coordinates are its grid coordinates
(:meth:`.OccupancyMap.world_to_grid`) plus one. Distances are in cells.

Exactness. ``d`` (:func:`clearance_field`) is the exact distance from each cell's centre to the
nearest blocked square (as :class:`.MapClearance` measures it, to rounding). A segment is tested
in pieces of at most :data:`PIECE` cells: a piece whose midpoint ``m`` lies in the cell of centre
``c`` keeps at least ``d(c) - |m - c| - half the piece`` from every blocked square (the distance
is 1-Lipschitz); only where that bound is below the threshold are the blocked squares near the
piece measured, exactly (a segment and a square are disjoint convex sets: their distance is met
at a vertex of one of them, unless they meet). So :func:`segment_ok` never passes a segment that
comes closer than its threshold, and :func:`polyline_distance` is exact.
"""

from __future__ import annotations

import math

import numpy as np

from ..._jit import njit
from .heap import heap_pop, heap_push

#: The eight moves of the grid, ``(DI[k], DJ[k])`` (rows, columns); move ``k + 4`` undoes ``k``.
DI = np.array([0, 1, 1, 1, 0, -1, -1, -1], np.int64)
DJ = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int64)
#: Segments are tested in pieces of at most this many cells.
PIECE = 0.5
#: Cells: a distance this much below a threshold still passes it (rounding).
EPS = 1e-9
#: How far a point of a cell is from its centre, at most.
HALF_DIAGONAL = math.sqrt(0.5)
#: Near an end closer to a wall than the threshold, the threshold grows by this much per cell
#: away from the end (from the end's own clearance): the route may leave the wall at 30 degrees.
SLOPE = 0.5


# --------------------------------------------------------------------------- clearance field


@njit(cache=True)
def _column_gaps(blocked):
    """Per cell, how far (cells) its centre is from the nearest blocked square of its column
    (``inf``: none): the nearest blocked row ``i'`` less a half, 0 in a blocked cell."""
    H, W = blocked.shape
    g = np.full((H, W), np.inf)
    for j in range(W):
        last = -1
        for i in range(H):
            if blocked[i, j]:
                last = i
                g[i, j] = 0.0
            elif last >= 0:
                g[i, j] = i - last - 0.5
        last = -1
        for i in range(H - 1, -1, -1):
            if blocked[i, j]:
                last = i
            elif last >= 0 and last - i - 0.5 < g[i, j]:
                g[i, j] = last - i - 0.5
    return g


@njit(cache=True)
def _row_envelope(f, v, z):
    """The lower envelope of the parabolas ``(x - q)^2 + f[q]`` (finite ``f[q]`` only), as in
    Felzenszwalb and Huttenlocher: ``v[:n]`` the parabolas in it, ``z[:n + 1]`` where each takes
    over; returns ``n``."""
    k = -1
    for q in range(f.size):
        if not f[q] < np.inf:
            continue
        s = -np.inf
        while k >= 0:
            p = v[k]
            s = ((f[q] + q * q) - (f[p] + p * p)) / (2.0 * (q - p))
            if s <= z[k]:
                k -= 1
            else:
                break
        k += 1
        v[k] = q
        z[k] = s if k > 0 else -np.inf
        z[k + 1] = np.inf
    return k + 1


@njit(cache=True)
def clearance_field(blocked):
    """Exact distance (cells) from each cell's centre to the nearest blocked square (closed unit
    squares; 0 in a blocked cell, ``inf`` when none is blocked).

    Separable, as a Euclidean distance transform: from a centre to a square ``a`` columns and
    ``b`` rows away the distance is ``hypot(gap(a), gap(b))``, ``gap(a) = max(|a| - 1/2, 0)``.
    Per column the nearest square's gap (:func:`_column_gaps`); per row, the squares ``q`` left
    of ``j`` add ``((j - 1/2) - q)^2``, those right of it ``((j + 1/2) - q)^2``: the lower
    envelope of the parabolas ``(x - q)^2 + g_q^2`` read at ``x = j -+ 1/2`` (each reading
    overestimates the squares on the wrong side, never underestimates), with ``g_j^2`` itself."""
    g = _column_gaps(blocked)
    H, W = blocked.shape
    out = np.empty((H, W))
    v = np.empty(W, np.int64)
    z = np.empty(W + 1)
    f = np.empty(W)
    for i in range(H):
        for q in range(W):
            f[q] = g[i, q] * g[i, q]
        n = _row_envelope(f, v, z)
        if n == 0:
            out[i, :] = np.inf
            continue
        m = 0
        before = np.inf  # the envelope at x = q - 1/2, read one step ago
        for q in range(W + 1):
            x = q - 0.5
            while m + 1 < n and z[m + 1] < x:
                m += 1
            e = (x - v[m]) * (x - v[m]) + f[v[m]]
            if q > 0:
                out[i, q - 1] = math.sqrt(min(f[q - 1], before, e))
            before = e
    return out


# --------------------------------------------------------------------------- exact distances


@njit(cache=True)
def _point_square(x, y, a, b):
    """Distance from ``(x, y)`` to the square ``[a, a + 1] x [b, b + 1]``."""
    dx = max(a - x, x - a - 1.0, 0.0)
    dy = max(b - y, y - b - 1.0, 0.0)
    return math.hypot(dx, dy)


@njit(cache=True)
def _point_segment(x, y, au, av, bu, bv):
    du, dv = bu - au, bv - av
    den = du * du + dv * dv
    t = 0.0 if den == 0.0 else min(max(((x - au) * du + (y - av) * dv) / den, 0.0), 1.0)
    return math.hypot(x - au - t * du, y - av - t * dv)


@njit(cache=True)
def _segment_square(au, av, bu, bv, a, b):
    """Exact distance from the segment ``(au, av) -> (bu, bv)`` to the square
    ``[a, a + 1] x [b, b + 1]``: 0 when they meet (clipped as Liang and Barsky do), else the
    least of the ends to the square and the corners to the segment."""
    t0, t1 = 0.0, 1.0
    for p, dp, lo in ((au, bu - au, a), (av, bv - av, b)):
        if dp == 0.0:
            if p < lo or p > lo + 1.0:
                t0 = 2.0
        else:
            ta, tb = (lo - p) / dp, (lo + 1.0 - p) / dp
            t0 = max(t0, min(ta, tb))
            t1 = min(t1, max(ta, tb))
    if t0 <= t1:
        return 0.0
    best = min(_point_square(au, av, a, b), _point_square(bu, bv, a, b))
    for cu in (a, a + 1.0):
        for cv in (b, b + 1.0):
            best = min(best, _point_segment(cu, cv, au, av, bu, bv))
    return best


@njit(cache=True)
def _near_squares(blocked, au, av, bu, bv, reach):
    """The least distance from a segment to the blocked squares within ``reach`` of it
    (``reach`` when there are none)."""
    H, W = blocked.shape
    i0 = max(int(math.floor(min(av, bv) - reach)), 0)
    i1 = min(int(math.floor(max(av, bv) + reach)), H - 1)
    j0 = max(int(math.floor(min(au, bu) - reach)), 0)
    j1 = min(int(math.floor(max(au, bu) + reach)), W - 1)
    best = reach
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            if blocked[i, j]:
                best = min(best, _segment_square(au, av, bu, bv, float(j), float(i)))
    return best


@njit(cache=True)
def _cone(zones, z, x, y):
    """The threshold of end zone ``z`` at ``(x, y)``: its base, plus :data:`SLOPE` per cell
    beyond half a cell's diagonal from the end."""
    far = max(math.hypot(x - zones[z, 0], y - zones[z, 1]) - HALF_DIAGONAL, 0.0)
    return zones[z, 2] + SLOPE * far


@njit(cache=True)
def _piece_threshold(pu, pv, qu, qv, T, zones):
    """A bound from above on the threshold along a piece: ``T``, or less in an end's zone
    (rows of ``zones``: end ``u, v``, base, active); each cone is convex, so its largest value
    on the piece is at an end."""
    thr = T
    for z in range(zones.shape[0]):
        if zones[z, 3] > 0.0:
            thr = min(thr, max(_cone(zones, z, pu, pv), _cone(zones, z, qu, qv)))
    return thr


@njit(cache=True)
def _piece_bound(d, mu, mv, half):
    """A lower bound on the distance to the blocked squares over a piece of midpoint
    ``(mu, mv)`` and half-length ``half``, and an upper bound at its midpoint."""
    H, W = d.shape
    ci = min(max(int(math.floor(mv)), 0), H - 1)
    cj = min(max(int(math.floor(mu)), 0), W - 1)
    off = math.hypot(mu - cj - 0.5, mv - ci - 0.5)
    return d[ci, cj] - off - half, d[ci, cj] + off


@njit(cache=True)
def segment_ok(d, blocked, au, av, bu, bv, T, zones):
    """Whether the segment keeps its threshold (``T``, less near an end: :func:`_cone`) from
    every blocked square (module docstring). Where a point's lower bound exceeds ``T`` by
    ``s``, the next ``s`` cells of the segment are clear too, and are skipped."""
    L = math.hypot(bu - au, bv - av)
    eu, ev = (bu - au) / max(L, 1e-300), (bv - av) / max(L, 1e-300)
    t = 0.0
    while t < L:
        spare = _piece_bound(d, au + t * eu, av + t * ev, 0.0)[0] - T
        if spare >= PIECE:
            t += spare
            continue
        t1 = min(t + PIECE, L)
        pu, pv, qu, qv = au + t * eu, av + t * ev, au + t1 * eu, av + t1 * ev
        thr = _piece_threshold(pu, pv, qu, qv, T, zones)
        low = _piece_bound(d, 0.5 * (pu + qu), 0.5 * (pv + qv), 0.5 * (t1 - t))[0]
        if low < thr and _near_squares(blocked, pu, pv, qu, qv, thr) < thr - EPS:
            return False
        t = t1
    return True


@njit(cache=True)
def polyline_distance(d, blocked, poly):
    """Exact least distance (cells) from a polyline to the blocked squares (``inf``: none).
    First an upper bound (the pieces' midpoints), then the pieces whose lower bound is below it,
    measured."""
    best = np.inf
    for sweep in range(2):
        for s in range(poly.shape[0] - 1):
            au, av, bu, bv = poly[s, 0], poly[s, 1], poly[s + 1, 0], poly[s + 1, 1]
            L = math.hypot(bu - au, bv - av)
            n = max(1, int(math.ceil(L / PIECE)))
            for k in range(n):
                pu, pv = au + (bu - au) * k / n, av + (bv - av) * k / n
                qu, qv = au + (bu - au) * (k + 1) / n, av + (bv - av) * (k + 1) / n
                low, high = _piece_bound(d, 0.5 * (pu + qu), 0.5 * (pv + qv), 0.5 * L / n)
                if sweep == 0:
                    best = min(best, high)
                elif low < best:
                    best = _near_squares(blocked, pu, pv, qu, qv, best)
        if not best < np.inf:
            break
    return best


# --------------------------------------------------------------------------- search graph


@njit(cache=True)
def component_reps(lab, n):
    """Per component ``1..n`` of the labels ``lab``: the row and column of its cell nearest its
    centroid (the first on ties), how far its cells reach from that cell's centre (cells), and
    whether it touches the map's edge."""
    H, W = lab.shape
    cnt, si, sj = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1)
    edge = np.zeros(n + 1, np.bool_)
    for i in range(H):
        for j in range(W):
            c = lab[i, j]
            if c:
                cnt[c] += 1.0
                si[c] += i
                sj[c] += j
                edge[c] |= i == 0 or j == 0 or i == H - 1 or j == W - 1
    best = np.full(n + 1, np.inf)
    ri, rj = np.zeros(n + 1, np.int64), np.zeros(n + 1, np.int64)
    for i in range(H):
        for j in range(W):
            c = lab[i, j]
            if c:
                dd = (i - si[c] / cnt[c]) ** 2 + (j - sj[c] / cnt[c]) ** 2
                if dd < best[c]:
                    best[c], ri[c], rj[c] = dd, i, j
    reach = np.zeros(n + 1)
    for i in range(H):
        for j in range(W):
            c = lab[i, j]
            if c:
                reach[c] = max(reach[c], math.hypot(i - ri[c], j - rj[c]) + HALF_DIAGONAL)
    return ri[1:], rj[1:], reach[1:], edge[1:]


@njit(cache=True)
def _block_reps(d, f, H, W, T):
    """Per block of ``f x f`` map cells, the cell of largest clearance (the first on ties) as
    padded coordinates of its centre, and whether it keeps ``T``."""
    Hc, Wc = (H + f - 1) // f, (W + f - 1) // f
    nu, nv = np.empty(Hc * Wc), np.empty(Hc * Wc)
    ok = np.zeros(Hc * Wc, np.bool_)
    for a in range(Hc):
        for b in range(Wc):
            best, bi, bj = -1.0, 0, 0
            for i in range(a * f + 1, min(a * f + f, H) + 1):
                for j in range(b * f + 1, min(b * f + f, W) + 1):
                    if d[i, j] > best:
                        best, bi, bj = d[i, j], i, j
            nu[a * Wc + b], nv[a * Wc + b] = bj + 0.5, bi + 0.5
            ok[a * Wc + b] = best >= T - EPS
    return nu, nv, ok


@njit(cache=True)
def search_graph(d, blocked, f, T, H, W):
    """The graph the routes are searched on: a node per block of ``f x f`` map cells at its
    clearest cell (:func:`_block_reps`), joined to its eight neighbours by the straight segments
    that keep ``T`` (bit ``k`` of ``edges`` for move ``k``). With ``f = 1`` the nodes are the
    cells that keep ``T``; a side move keeps ``T`` when both cells do, and so does a diagonal
    move when the two cells beside it do too (the least distance along these segments is at a
    centre): only the other diagonal moves are measured."""
    nu, nv, ok = _block_reps(d, f, H, W, T)
    Hc, Wc = (H + f - 1) // f, (W + f - 1) // f
    edges = np.zeros((Hc, Wc), np.uint8)
    zones = np.zeros((0, 4))
    for a in range(Hc):
        for b in range(Wc):
            u = a * Wc + b
            if not ok[u]:
                continue
            for k in range(4):
                a2, b2 = a + DI[k], b + DJ[k]
                if a2 < 0 or a2 >= Hc or b2 < 0 or b2 >= Wc or not ok[a2 * Wc + b2]:
                    continue
                v = a2 * Wc + b2
                good = f == 1 and (
                    DI[k] == 0 or DJ[k] == 0 or (ok[a2 * Wc + b] and ok[a * Wc + b2])
                )
                if not good:
                    good = segment_ok(d, blocked, nu[u], nv[u], nu[v], nv[v], T, zones)
                if good:
                    edges[a, b] |= np.uint8(1 << k)
                    edges[a2, b2] |= np.uint8(1 << (k + 4))
    return nu, nv, ok, edges


@njit(cache=True)
def path_field(edges, nu, nv, seeds, scost, targets, tcost, hu, hv, beta, bound):
    """Shortest distances from the ``seeds`` (starting at ``scost``) over the graph, ordered by
    the A* key ``distance + straight line to (hu, hv)`` and stopped beyond ``bound``; the bound
    falls to ``beta`` times the best ``distance + tcost`` of a target once one is settled.
    Every node with ``distance + straight line <= bound`` is settled, its distance exact.
    Returns distances (``inf``: not settled), predecessors (-1 at a seed) and the best total."""
    Wc = edges.shape[1]
    flat = edges.ravel()
    dist = np.full(flat.size, np.inf)
    pred = np.full(flat.size, -1, np.int64)
    done = np.zeros(flat.size, np.bool_)
    goal = np.full(flat.size, -1, np.int64)
    goal[targets] = np.arange(targets.size)
    step = DI * Wc + DJ
    hk, hn = np.empty(4096), np.empty(4096, np.int64)
    size = 0
    for s in range(seeds.size):
        dist[seeds[s]] = min(dist[seeds[s]], scost[s])
    for v in seeds:
        hk, hn = heap_push(
            hk, hn, size, dist[v] + math.sqrt((nu[v] - hu) ** 2 + (nv[v] - hv) ** 2), v
        )
        size += 1
    best = np.inf
    while size > 0 and hk[0] <= bound:
        u = heap_pop(hk, hn, size)
        size -= 1
        if done[u]:
            continue
        done[u] = True
        if goal[u] >= 0 and dist[u] + tcost[goal[u]] < best:
            best = dist[u] + tcost[goal[u]]
            bound = min(bound, beta * best + EPS)
        for k in range(8):
            v = u + step[k]
            if not (flat[u] >> k) & 1 or done[v]:
                continue
            nd = dist[u] + math.sqrt((nu[v] - nu[u]) ** 2 + (nv[v] - nv[u]) ** 2)
            if nd < dist[v]:
                dist[v], pred[v] = nd, u
                key = nd + math.sqrt((nu[v] - hu) ** 2 + (nv[v] - hv) ** 2)
                hk, hn = heap_push(hk, hn, size, key, v)
                size += 1
    dist[~done] = np.inf
    return dist, pred, best


@njit(cache=True)
def _cell_ok(d, i, j, T, zones):
    return d[i, j] >= _piece_threshold(j + 0.5, i + 0.5, j + 0.5, i + 0.5, T, zones) - EPS


@njit(cache=True)
def end_field(d, eu, ev, T, zones, reach, H, W):
    """Dijkstra over the map cells within ``reach`` cells of an end ``(eu, ev)`` (a square
    window), from the end's own cell (at the end's distance from its centre), through the cells
    that keep their threshold (``T``, less in the ends' zones): side moves, and diagonal moves
    past two such cells (:func:`search_graph` with ``f = 1``, unmeasured). Returns the window's
    first row and column, its distances ``(h, w)`` and predecessors (flat window indices, -1
    at the end's cell)."""
    ci, cj = int(math.floor(ev)), int(math.floor(eu))
    r = int(math.ceil(reach))
    i0, i1 = max(ci - r, 1), min(ci + r, H)
    j0, j1 = max(cj - r, 1), min(cj + r, W)
    h, w = i1 - i0 + 1, j1 - j0 + 1
    ok = np.zeros((h, w), np.bool_)
    for i in range(h):
        for j in range(w):
            ok[i, j] = _cell_ok(d, i + i0, j + j0, T, zones)
    dist = np.full((h, w), np.inf)
    pred = np.full(h * w, -1, np.int64)
    hk, hn = np.empty(256), np.empty(256, np.int64)
    s = (ci - i0) * w + cj - j0
    dist[ci - i0, cj - j0] = math.hypot(eu - cj - 0.5, ev - ci - 0.5)
    hk, hn = heap_push(hk, hn, 0, dist[ci - i0, cj - j0], s)
    size = 1
    while size > 0:
        key = hk[0]
        u = heap_pop(hk, hn, size)
        size -= 1
        a, b = u // w, u % w
        if key > dist[a, b]:  # a stale copy: the node was pushed again, nearer
            continue
        for k in range(8):
            a2, b2 = a + DI[k], b + DJ[k]
            if a2 < 0 or a2 >= h or b2 < 0 or b2 >= w or not ok[a2, b2]:
                continue
            if DI[k] != 0 and DJ[k] != 0 and not (ok[a2, b] and ok[a, b2]):
                continue
            nd = dist[a, b] + (1.0 if DI[k] == 0 or DJ[k] == 0 else math.sqrt(2.0))
            if nd < dist[a2, b2]:
                dist[a2, b2] = nd
                pred[a2 * w + b2] = u
                hk, hn = heap_push(hk, hn, size, nd, a2 * w + b2)
                size += 1
    return i0, j0, dist, pred


# --------------------------------------------------------------------------- polylines


@njit(cache=True)
def _seen(d, blocked, p, q, T, zones):
    return segment_ok(d, blocked, p[0], p[1], q[0], q[1], T, zones)


@njit(cache=True)
def shortcut(d, blocked, poly, T, zones):
    """Line-of-sight shortcuts, any-angle: from the current point, on to the last vertex
    ``k`` seen before the first that is not (:func:`segment_ok`), then along the leg from
    ``k`` to ``k + 1`` as far as it is seen (bisection to 1/256 of the leg); that point is the
    next vertex and the next current point. Each step sweeps the sight line over the path a
    little, so it never jumps an obstacle: the homotopy class is kept; the legs of ``poly``
    keep the threshold, so the result does."""
    n = poly.shape[0]
    out = [poly[0].copy()]
    k = 0
    while k < n - 1:
        p = out[-1]
        k += 1
        while k + 1 < n and _seen(d, blocked, p, poly[k + 1], T, zones):
            k += 1
        if k == n - 1:
            out.append(poly[k].copy())
            break
        lo, hi = 0.0, 1.0
        for _ in range(8):
            mid = 0.5 * (lo + hi)
            if _seen(d, blocked, p, poly[k] + mid * (poly[k + 1] - poly[k]), T, zones):
                lo = mid
            else:
                hi = mid
        out.append(poly[k] + lo * (poly[k + 1] - poly[k]))
    res = np.empty((len(out), 2))
    for i in range(len(out)):
        res[i] = out[i]
    return res


@njit(cache=True)
def _pull_one(d, blocked, a, x, c, T, zones):
    """How far (a fraction in [0, 1]) vertex ``x`` between ``a`` and ``c`` can move towards its
    nearest point ``y`` on segment ``ac`` with the segments ``a-y``, ``y-c`` and the move
    ``x-y`` clear (all the way, else by bisection to 1/64), and the point it moves to."""
    du, dv = c[0] - a[0], c[1] - a[1]
    den = du * du + dv * dv
    t = 0.0 if den == 0.0 else min(max(((x[0] - a[0]) * du + (x[1] - a[1]) * dv) / den, 0.0), 1.0)
    tu, tv = a[0] + t * du - x[0], a[1] + t * dv - x[1]
    lo, hi, lam = 0.0, 1.0, 1.0
    for _ in range(7):
        yu, yv = x[0] + lam * tu, x[1] + lam * tv
        if (
            segment_ok(d, blocked, x[0], x[1], yu, yv, T, zones)
            and segment_ok(d, blocked, a[0], a[1], yu, yv, T, zones)
            and segment_ok(d, blocked, yu, yv, c[0], c[1], T, zones)
        ):
            lo = lam
            if lam == 1.0:
                break
        else:
            hi = lam
        lam = 0.5 * (lo + hi)
    return lo, x[0] + lo * tu, x[1] + lo * tv


@njit(cache=True)
def pull(d, blocked, poly, T, zones, passes):
    """Tighten a polyline like a string: each inner vertex in turn moves towards the segment
    joining its neighbours as far as its two segments stay clear (:func:`_pull_one`), for up
    to ``passes`` passes or until the vertices move less than a hundredth of a cell; vertices
    left on the segment of their neighbours are dropped. The ends stay."""
    p = poly.copy()
    n = p.shape[0]
    for _ in range(passes):
        moved = 0.0
        for b in range(1, n - 1):
            lam, yu, yv = _pull_one(d, blocked, p[b - 1], p[b], p[b + 1], T, zones)
            if lam > 0.0:
                moved += math.hypot(yu - p[b, 0], yv - p[b, 1])
                p[b, 0], p[b, 1] = yu, yv
        if moved < 0.01:
            break
    keep = [0]
    for b in range(1, n - 1):
        a, c = p[keep[-1]], p[b + 1]
        if _point_segment(p[b, 0], p[b, 1], a[0], a[1], c[0], c[1]) > 1e-7:
            keep.append(b)
    keep.append(n - 1)
    return p[np.array(keep)]
