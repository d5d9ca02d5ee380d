"""The exact tangent graph of the inflated discs and its compiled queries (winding of each step,
ray crossings); its shortest paths with barrier rays are :mod:`.dijkstra`'s."""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..._jit import njit
from .curve import TWO_PI
from .dijkstra import shortest_paths
from .geometry import clean_polyline, close_and_round, cross, rotate
from .spatial import DiscGrid, common_tangents, disc_grid, disc_pairs, points_inside, segments_cut

#: Arcs of the tangent graph are sampled with at most this angle between polyline vertices.
ARC_STEP = TWO_PI / 36


#: Above this many active circles, the common tangents are kept only when usable and free.
PRUNE_ABOVE = 100

# --------------------------------------------------------------------------- tangent graph


def _active_circles(C: np.ndarray, R: np.ndarray, tol: float) -> np.ndarray:
    """Discs not contained in another disc (of equal discs, the first is kept); only pairs of
    discs near each other are compared (a disc within another overlaps its box)."""
    m = R.size
    out = np.ones(m, bool)
    if m < 2:
        return out
    i, j = disc_pairs(disc_grid(C, R, abs(tol)), abs(tol))
    D = np.hypot(C[i, 0] - C[j, 0], C[i, 1] - C[j, 1])
    inside = D + R[i] <= R[j] + tol  # disc i within disc j
    D_t = np.hypot(C[j, 0] - C[i, 0], C[j, 1] - C[i, 1])
    mutual = inside & (D_t + R[j] <= R[i] + tol)
    out[i[inside & (~mutual | (j < i))]] = False
    return out


class _Points:
    """The graph's points, gathered in order: start (0), goal (1), then tangent points, each
    with its circle (-1 for the ends)."""

    def __init__(self, S2: np.ndarray, G2: np.ndarray):
        self.xy = [S2[None, :], G2[None, :]]
        self.circ = [np.array([-1, -1])]
        self.count = 2

    def add(self, p: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Append points ``p`` on circles ``c``; their indices."""
        self.xy.append(p)
        self.circ.append(c)
        self.count += p.shape[0]
        return np.arange(self.count - p.shape[0], self.count)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate(self.xy), np.concatenate(self.circ)


class TangentGraph:
    """Directed tangent graph of the inflated discs ``(C, R)``; node 0 is the start, 1 the goal.

    Tangent point ``p >= 2`` on circle ``circ[p]`` is node ``2 + 2 (p - 2)`` when travelled
    counter-clockwise and node ``3 + 2 (p - 2)`` when travelled clockwise. Edges are stored in
    CSR order (sorted by source node) with their geometry: a segment ``[ax, ay, bx, by]`` or an
    arc ``[circle, phi0, span, nan]`` (counter-clockwise from angle ``phi0``).
    """

    def __init__(self, S2: np.ndarray, G2: np.ndarray, C: np.ndarray, R: np.ndarray, tol: float):
        self.S2, self.G2, self.C, self.R, self.tol = S2, G2, C, R, tol
        self._polylines: dict[bytes, np.ndarray] = {}
        self._active_grid: DiscGrid | None = None
        act = np.flatnonzero(_active_circles(C, R, tol)) if R.size else np.zeros(0, np.int64)
        self.active = act
        points = _Points(S2, G2)
        segs, one_way = self._end_tangents(points)
        segs += self._pair_tangents(points)
        self.xy, self.circ = points.arrays()
        rel = self.xy - C[np.maximum(self.circ, 0)] if C.shape[0] else self.xy
        self.angle = np.where(self.circ >= 0, np.arctan2(rel[:, 1], rel[:, 0]), 0.0)
        keep = self._usable_points()
        edges = self._segment_edges(segs, one_way, keep)
        self._add_arc_edges(keep, *edges)
        self._index(*edges)

    def _orient(self, p: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
        """+1 where direction ``d`` at point ``p`` of circle ``c`` turns counter-clockwise."""
        return np.where(cross(p - self.C[c], d) >= 0.0, 1, -1)

    def _end_tangents(self, points: _Points) -> tuple[list, int]:
        """Tangents from the start (travelled towards the circle) and to the goal (away from
        it): families of segments ``(point a, orientation a, point b, orientation b)``, and
        how many segments they hold (these are travelled one way only)."""
        C, R, tol, act = self.C, self.R, self.tol, self.active
        segs = []
        for end, P in ((0, self.S2), (1, self.G2)) if act.size else ():
            w = P[None, :] - C[act]
            d = np.hypot(w[:, 0], w[:, 1])
            u = w / np.maximum(d, tol)[:, None]
            out = d > R[act] + tol
            co, Ro, uo = act[out], R[act][out], u[out]
            gamma = np.arccos(np.clip(Ro / d[out], -1.0, 1.0))
            T = np.concatenate([C[co] + Ro[:, None] * rotate(uo, g) for g in (gamma, -gamma)])
            cT = np.concatenate([co, co])
            idx = points.add(T, cT)
            o = self._orient(T, cT, T - P if end == 0 else P - T)
            ends = np.full(idx.shape, end)
            segs.append((ends, 0 * ends, idx, o) if end == 0 else (idx, o, ends, 0 * ends))
            # An end on a circle (closer to the obstacle than the margin): both directions.
            on = act[~out]
            if on.size:
                idx = points.add(C[on] + R[on][:, None] * u[~out], on)
                ends = np.full(idx.shape, end)
                for o in (np.ones_like(idx), -np.ones_like(idx)):
                    segs.append((ends, 0 * ends, idx, o) if end == 0 else (idx, o, ends, 0 * ends))
        return segs, sum(s[0].size for s in segs)

    def _pair_tangents(self, points: _Points) -> list:
        """Common tangents of each pair of circles: outer (sigma = +1) and inner (sigma = -1).

        With more than :data:`PRUNE_ABOVE` active circles, only the tangents that are usable
        and free are kept (in the same order), so memory grows with the free tangents rather
        than with all pairs; the arcs then join fewer tangent points (the same shortest paths,
        lengths summed over fewer arcs)."""
        act = self.active
        segs = []
        if act.size < 2:
            return segs
        prune = act.size > PRUNE_ABOVE
        grid = self._grid()

        def family(signs):
            return common_tangents(grid, act, *signs, prune, self.tol)

        families = [(sigma, sgn) for sigma in (1.0, -1.0) for sgn in (1.0, -1.0)]
        workers = min(len(families), os.cpu_count() or 1) if prune else 1
        if workers > 1:  # the compiled loop releases the GIL: the families run side by side
            with ThreadPoolExecutor(workers, thread_name_prefix="tangents") as pool:
                found = list(pool.map(family, families))
        else:
            found = [family(signs) for signs in families]
        for Ti, Tj, ci, cj in found:  # in the families' order, however they ran
            pi, pj = points.add(Ti, ci), points.add(Tj, cj)
            o_i, o_j = self._orient(Ti, ci, Tj - Ti), self._orient(Tj, cj, Tj - Ti)
            segs.append((pi, o_i, pj, o_j))
        return segs

    def _usable_points(self) -> np.ndarray:
        """Tangent points inside another inflated disc are no use; the ends always are."""
        keep = np.ones(self.xy.shape[0], bool)
        if self.active.size:
            keep = ~points_inside(self.xy, self._grid(), self.tol)
            keep[:2] = True
        return keep

    def _grid(self) -> DiscGrid:
        """The grid of the active discs (built once)."""
        if self._active_grid is None:
            act = self.active
            grid = disc_grid(self.C[act], self.R[act])
            # Indices into the full disc arrays, which the loops read.
            C, R = np.ascontiguousarray(self.C), np.ascontiguousarray(self.R)
            self._active_grid = grid._replace(C=C, R=R, items=act[grid.items])
        return self._active_grid

    def _segment_edges(self, segs: list, one_way: int, keep: np.ndarray) -> tuple[list, ...]:
        """The straight start -> goal segment, then the tangents, kept when no disc cuts them:
        edge lists (sources, destinations, weights, geometry), both ways but for the ends'."""
        pa, oa, pb, ob = (
            np.concatenate([[x], *(s[i] for s in segs)]) for i, x in enumerate((0, 0, 1, 0))
        )
        both = np.arange(pa.size) > one_way
        ok = keep[pa] & keep[pb]
        if self.active.size:
            a, b = self.xy[pa[ok]], self.xy[pb[ok]]
            ok[ok] = ~segments_cut(a, b, self._grid(), self.tol)
        pa, oa, pb, ob, both = pa[ok], oa[ok], pb[ok], ob[ok], both[ok]
        A, B = self.xy[pa], self.xy[pb]
        seg_geo = np.column_stack([A, B])
        seg_w = np.hypot(*(B - A).T)
        src = [self.node(pa, oa), self.node(pb[both], -ob[both])]
        dst = [self.node(pb, ob), self.node(pa[both], -oa[both])]
        self.n_seg = seg_w.size + int(both.sum())
        return src, dst, [seg_w, seg_w[both]], [seg_geo, seg_geo[both]]

    def _add_arc_edges(self, keep, src, dst, wgt, geo) -> None:
        """Arcs between neighbouring tangent points of a circle, both ways, unless another disc
        covers them: appended to the edge lists."""
        R, act = self.R, self.active
        tp = np.flatnonzero(keep & (self.circ >= 0))
        tp = tp[np.lexsort((tp, self.angle[tp], self.circ[tp]))]
        cc = self.circ[tp]
        first = np.ones(tp.size, bool)
        first[1:] = cc[1:] != cc[:-1]
        group = np.cumsum(first) - 1
        g0 = np.flatnonzero(first)
        size = np.diff(np.append(g0, tp.size))[group]
        idx = np.arange(tp.size)
        nxt = g0[group] + (idx - g0[group] + 1) % np.maximum(size, 1)
        valid = size >= 2
        a_pts, b_pts = tp[valid], tp[nxt[valid]]
        wrap = nxt[valid] < idx[valid]
        span = np.where(
            wrap,
            self.angle[b_pts] + TWO_PI - self.angle[a_pts],
            np.mod(self.angle[b_pts] - self.angle[a_pts], TWO_PI),
        )
        ca = self.circ[a_pts]
        if act.size >= 2:
            free = self._arcs_free(ca, a_pts, span)
            a_pts, b_pts, span, ca = a_pts[free], b_pts[free], span[free], ca[free]
        arc_geo = np.column_stack([ca, self.angle[a_pts], span, np.full(span.shape, np.nan)])
        for o, (s_pts, d_pts) in ((1, (a_pts, b_pts)), (-1, (b_pts, a_pts))):
            src.append(self.node(s_pts, np.full(s_pts.shape, o)))
            dst.append(self.node(d_pts, np.full(d_pts.shape, o)))
            wgt.append(R[ca] * span)
            geo.append(arc_geo)

    def _arcs_free(self, ca: np.ndarray, a_pts: np.ndarray, span: np.ndarray) -> np.ndarray:
        """Per arc (on circle ``ca`` from point ``a_pts``, counter-clockwise by ``span``),
        whether no other active circle that meets circle ``ca`` lies in its direction: only the
        pairs of circles near each other are compared."""
        C, R = self.C, self.R
        i, j = disc_pairs(self._grid(), 0.0)  # i, j: indices of active discs
        D = np.hypot(C[i, 0] - C[j, 0], C[i, 1] - C[j, 1])
        meet = (np.abs(R[i] - R[j]) < D) & (D < R[i] + R[j])
        i, j = i[meet], j[meet]
        nb_ptr = np.zeros(R.size + 1, np.int64)
        np.cumsum(np.bincount(i, minlength=R.size), out=nb_ptr[1:])
        # (arc, neighbour) pairs: the arcs of circle c, each with c's neighbours.
        count = nb_ptr[ca + 1] - nb_ptr[ca]
        arc = np.repeat(np.arange(ca.size), count)
        first = np.repeat(nb_ptr[ca] - np.cumsum(count) + count, count)
        nb = j[first + np.arange(arc.size)]
        c = ca[arc]
        alpha = np.arctan2(C[nb, 1] - C[c, 1], C[nb, 0] - C[c, 0])
        into = np.mod(alpha - self.angle[a_pts][arc], TWO_PI) < span[arc]
        return np.bincount(arc[into], minlength=ca.size) == 0

    def _index(self, src, dst, wgt, geo) -> None:
        """The edges in CSR order (by source node), and the nodes' positions and circles."""
        src, dst, wgt, geo = (np.concatenate(x) for x in (src, dst, wgt, geo))
        is_arc = np.arange(src.size) >= self.n_seg
        self.n = 2 + 2 * (self.xy.shape[0] - 2)
        # By source, then destination, ties in list order: np.lexsort((dst, src)), twice as fast.
        order = np.argsort(src * self.n + dst, kind="stable")
        self.src, self.dst, self.geo, self.is_arc = (
            src[order],
            dst[order],
            geo[order],
            is_arc[order],
        )
        self.wgt = np.maximum(wgt[order], 1e-6 * self.tol)  # no zero-length edges
        self.indptr = np.zeros(self.n + 1, np.int64)
        np.cumsum(np.bincount(self.src, minlength=self.n), out=self.indptr[1:])
        nodes = np.arange(self.n)
        pts = self.point(nodes)
        self.node_xy = np.ascontiguousarray(self.xy[pts])
        self.node_circ = self.circ[pts].astype(np.int64)
        self.node_orient = np.where(nodes < 2, 0, 1 - 2 * ((nodes - 2) % 2)).astype(np.int64)
        self.node_angle = self.angle[pts]

    @staticmethod
    def node(p: np.ndarray, o: np.ndarray) -> np.ndarray:
        return np.where(p < 2, p, 2 + 2 * (p - 2) + (o < 0)).astype(np.int64)

    @staticmethod
    def point(v):
        return np.where(v < 2, v, 2 + (v - 2) // 2)

    def search(self, bits: np.ndarray, masks: np.ndarray):
        """Shortest start -> goal paths, one per blocking mask: lengths (``inf`` where there is
        none), node paths (padded with -1) and their sizes.

        ``bits[e]`` has bit ``b`` set when edge ``e`` crosses barrier ``b``; a mask blocks the
        barriers of its set bits.
        """
        return shortest_paths(self.indptr, self.dst, self.wgt, bits, masks, self.node_xy)

    def signatures(self, paths: np.ndarray, plen: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """Exact winding numbers ``(P, m)`` of each node path (closed by the reversed chord)
        round each obstacle centre; arcs count with their true turn, not as chords."""
        P, m = plen.size, obs.shape[0]
        found = np.flatnonzero(plen >= 2)
        out = np.zeros((P, m), np.int64)
        if m == 0 or found.size == 0:
            return out
        C = obs[:, :2]
        # Only the nodes and circles of the paths matter: renumbered in increasing order.
        sub = paths[found]
        nodes = np.unique(sub[sub >= 0])
        sub = np.where(sub >= 0, np.searchsorted(nodes, np.maximum(sub, 0)), -1)
        circ = self.node_circ[nodes]
        circles = np.unique(circ[circ >= 0])
        circ = np.where(circ >= 0, np.searchsorted(circles, np.maximum(circ, 0)), -1)
        # Direction angle of every node seen from every centre; a step turns by the difference,
        # taken in (-pi, pi] for a segment (or an arc seen from outside its circle, which stays
        # in a cone narrower than pi), and monotonically for an arc seen from inside its circle.
        rel = self.node_xy[nodes][:, None, :] - C[None, :, :]
        angle = np.arctan2(rel[:, :, 1], rel[:, :, 0])
        # Which centres lie inside each circle.
        inside = np.hypot(*(C[None, :, :] - self.C[circles][:, None, :]).transpose(2, 0, 1))
        inside = inside < self.R[circles][:, None]
        total = _step_turns(sub, plen[found], angle, circ, self.node_orient[nodes], inside)
        out[found] = close_and_round(total, self.S2, self.G2, obs, self.tol)
        return out

    def polyline(self, nodes) -> np.ndarray:
        """The path's vertices: the ends of its segments, with each run of arcs round one circle
        sampled uniformly, every :data:`ARC_STEP` at most (tangent points between them, which
        can be very close together, are not kept). Memoised, and read-only so that no caller
        changes the shared array: planning needs the shortest path's polyline, and smoothing
        needs it again."""
        nodes = np.asarray(nodes, dtype=np.int64)
        key = nodes.tobytes()
        if key not in self._polylines:
            poly = self._polyline(nodes)
            poly.setflags(write=False)
            self._polylines[key] = poly
        return self._polylines[key]

    def _polyline(self, nodes: np.ndarray) -> np.ndarray:
        # Python floats and lists: a path has a few dozen vertices, too few for NumPy's calls.
        xy = self.node_xy[nodes].tolist()
        circ = self.node_circ[nodes].tolist()
        angle = self.node_angle[nodes].tolist()
        nodes = nodes.tolist()
        last = len(nodes) - 1
        parts = [xy[0]]  # vertices, and arcs (circle, first angle, number of angles)
        angles = []  # of all arc samples
        i = 0
        while i < last:
            v0, c = nodes[i], circ[i]
            j = i
            while j < last and v0 >= 2 and nodes[j + 1] >= 2 and circ[j + 1] == c:
                j += 1  # nodes[i .. j] are joined by arcs round circle c
            if j > i:
                o = 1 if (v0 - 2) % 2 == 0 else -1
                span = 0.0
                for t in range(i, j):
                    span += ((angle[t + 1] - angle[t]) * o) % TWO_PI
                n = math.ceil(span / ARC_STEP)
                if n > 1:
                    parts.append((c, len(angles), n - 1))
                    angles.extend(angle[i] + o * span * k / n for k in range(1, n))
                parts.append(xy[j])
                i = j
            else:
                parts.append(xy[i + 1])
                i += 1
        cos, sin = np.cos(angles).tolist(), np.sin(angles).tolist()  # one call for all arcs
        out = []
        for part in parts:
            if isinstance(part, tuple):
                c, a, n = part
                cx, cy, r = float(self.C[c, 0]), float(self.C[c, 1]), float(self.R[c])
                out.extend([cx + r * cos[k], cy + r * sin[k]] for k in range(a, a + n))
            else:
                out.append(part)
        # Vertices much closer together than arc samples (the two ends of a tiny arc) would
        # make the smoothing turn sharply there: keep only the first of them, and the goal.
        gap = 0.25 * ARC_STEP * float(self.R[self.active].min()) if self.active.size else 0.0
        keep = [out[0]]
        for p in out[1:-1]:
            if math.hypot(p[0] - keep[-1][0], p[1] - keep[-1][1]) > gap:
                keep.append(p)
        if len(keep) > 1 and math.hypot(out[-1][0] - keep[-1][0], out[-1][1] - keep[-1][1]) <= gap:
            keep.pop()
        keep.append(out[-1])
        return clean_polyline(np.array(keep), self.S2, self.G2, self.tol)

    def crossings(self, origins: np.ndarray, dirs: np.ndarray, reach: float) -> np.ndarray:
        """Per edge, bit ``b`` set when it crosses the ray ``origins[b] + t dirs[b]``, t in
        ``[0, reach]``."""
        return _crossings(self.is_arc, self.geo, self.C, self.R, origins, dirs, reach)


@njit(cache=True)
def _crossings(is_arc, geo, C, R, origins, dirs, reach):
    bits = np.zeros(geo.shape[0], np.int64)
    two_pi = 2.0 * math.pi
    for e in range(geo.shape[0]):
        for b in range(origins.shape[0]):
            ox, oy, dx, dy = origins[b, 0], origins[b, 1], dirs[b, 0], dirs[b, 1]
            hit = False
            if not is_arc[e]:
                ax, ay = geo[e, 0], geo[e, 1]
                rx, ry = geo[e, 2] - ax, geo[e, 3] - ay
                sx, sy = dx * reach, dy * reach
                den = rx * sy - ry * sx
                if den != 0.0:
                    qx, qy = ox - ax, oy - ay
                    t = (qx * sy - qy * sx) / den
                    u = (qx * ry - qy * rx) / den
                    hit = (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
            else:
                c = np.int64(geo[e, 0])
                fx, fy = ox - C[c, 0], oy - C[c, 1]
                bb = fx * dx + fy * dy
                disc = bb * bb - (fx * fx + fy * fy - R[c] * R[c])
                if disc >= 0.0:
                    root = math.sqrt(disc)
                    for sgn in range(-1, 2, 2):
                        tt = -bb + sgn * root
                        if 0.0 <= tt <= reach:
                            x = math.atan2(fy + tt * dy, fx + tt * dx) - geo[e, 1]
                            if x - two_pi * np.floor(x / two_pi) <= geo[e, 2]:
                                hit = True
            if hit:
                bits[e] |= np.int64(1) << np.int64(b)
    return bits


@njit(cache=True)
def _step_turns(paths, plen, angle, node_circ, node_orient, inside):
    """For :meth:`TangentGraph.signatures`: the total turn ``(P, m)`` of each path seen from
    each centre (``angle``: directions of the nodes from the centres), summed over its steps in
    order. A loop over the steps of a few dozen paths, where NumPy's gathers and masks cost
    more; the same operations as those (``np.round`` is ``rint``)."""
    m = angle.shape[1]
    total = np.zeros((plen.size, m))
    for p in range(plen.size):
        for t in range(plen[p] - 1):
            u, v = paths[p, t], paths[p, t + 1]
            cu = node_circ[u]
            arc = u >= 2 and v >= 2 and cu >= 0 and cu == node_circ[v]
            o = np.float64(node_orient[u])
            for j in range(m):
                x = angle[v, j] - angle[u, j]
                if arc and inside[cu, j]:
                    step = o * ((o * x) % TWO_PI)
                else:
                    step = x - TWO_PI * np.rint(x / TWO_PI)
                total[p, j] = step if t == 0 else total[p, j] + step
    return total
