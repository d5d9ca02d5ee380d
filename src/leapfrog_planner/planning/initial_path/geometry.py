"""The geometry of polylines and discs: distances, clearance, homotopy signatures; and the end
states and the length tolerance of a path's input."""

from __future__ import annotations

import itertools
import math

import numpy as np

from ... import checks
from ..._jit import njit
from .curve import TWO_PI

# --------------------------------------------------------------------------- validation


def end_state(value, key: str) -> np.ndarray:
    """A start or goal ``[x, y, heading]``, checked."""
    return checks.vector(value, 3, key, " [x, y, heading]")


def tolerance(S: np.ndarray, G: np.ndarray, obs: np.ndarray) -> float:
    """The length below which two points of a path count as one: 1e-9 of the problem's scale."""
    scale = max(1.0, float(np.max(np.abs(S[:2]))), float(np.max(np.abs(G[:2]))))
    if obs.shape[0]:
        scale = max(scale, float(np.max(np.abs(obs))))
    return 1e-9 * scale


def point_text(point, tol: float) -> str:
    """``(x, y)`` for a path's label, to three digits, a coordinate within ``tol`` (the length
    tolerance) of zero as 0: a cusp on the x axis read "(3, -1.22e-16)"."""
    x, y = (0.0 if abs(float(v)) <= tol else float(v) for v in point[:2])
    return f"({x:.3g}, {y:.3g})"


# --------------------------------------------------------------------------- geometry helpers


def rotate(u: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([u[..., 0] * c - u[..., 1] * s, u[..., 0] * s + u[..., 1] * c], axis=-1)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def segment_distance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distances ``(E, M)`` from points ``c`` ``(M, 2)`` to segments ``a -> b`` ``(E, 2)``."""
    out = np.empty((a.shape[0], c.shape[0]))
    _segment_distance_loops(a, b, c, out)
    return out


@njit(cache=True, error_model="numpy")
def _segment_distance_loops(a, b, c, out):
    # A loop for the tangent graph's thousands of (segment, disc) pairs, without NumPy's
    # temporaries; the same operations as the vectorised formula (projection parameter clipped
    # to [0, 1], and 0 for a segment of length 0, where it is nan).
    for e in range(a.shape[0]):
        abx, aby = b[e, 0] - a[e, 0], b[e, 1] - a[e, 1]
        den = abx * abx + aby * aby
        for j in range(c.shape[0]):
            acx, acy = c[j, 0] - a[e, 0], c[j, 1] - a[e, 1]
            t = (acx * abx + acy * aby) / den
            if np.isnan(t):
                t = 0.0
            t = t if t > 0.0 else 0.0
            t = t if t < 1.0 else 1.0
            out[e, j] = math.hypot(acx - t * abx, acy - t * aby)


def clean_polyline(poly: np.ndarray, S2: np.ndarray, G2: np.ndarray, tol: float) -> np.ndarray:
    """Drop repeated vertices; make the ends exactly the start and goal positions."""
    keep = np.ones(poly.shape[0], bool)
    keep[1:] = np.hypot(*np.diff(poly, axis=0).T) > tol
    out = poly[keep]
    if math.hypot(*(out[-1] - G2)) <= tol and out.shape[0] >= 2:
        out = out.copy()
    else:
        out = np.vstack([out, G2])
    out[0] = S2
    out[-1] = G2
    return out


def midpoints(poly: np.ndarray) -> np.ndarray:
    out = np.empty((2 * poly.shape[0] - 1, 2))
    out[0::2] = poly
    out[1::2] = 0.5 * (poly[:-1] + poly[1:])
    return out


def homotopy_signature(poly: np.ndarray, obs: np.ndarray, tol: float) -> tuple[int, ...]:
    """Winding numbers of (polyline + reversed chord) round each obstacle centre."""
    if obs.shape[0] == 0:
        return ()
    cr, dt = _turn_terms(np.ascontiguousarray(poly), obs)  # one compiled variant
    turn = np.arctan2(cr, dt).sum(axis=1)
    return tuple(close_and_round(turn, poly[0], poly[-1], obs, tol).tolist())


def close_and_round(turn: np.ndarray, S2, G2, C: np.ndarray, tol: float) -> np.ndarray:
    """Winding numbers round the centres ``C[:, :2]`` of paths that turn by ``turn`` (shape
    ``(..., m)``) seen from them, closed by the straight chord back from goal to start.

    A centre on the chord sees the chord turn by +-pi; it counts 0 there, so the winding number
    is a half-integer, rounded away from zero (robustly: those are never near an integer).
    """
    cr, dt = _turn_terms(np.array([G2, S2]), C)
    cr, dt = cr[:, 0], dt[:, 0]
    bound = tol * max(math.hypot(*(G2 - S2)), tol)
    w = _round_winding(turn.reshape(-1, cr.size), cr, dt, np.arctan2(cr, dt), bound)
    return w.reshape(turn.shape)


@njit(cache=True)
def _turn_terms(poly, C):
    """Cross and dot products ``(m, n - 1)`` of the vectors from each centre ``C[j, :2]`` to
    consecutive vertices of ``poly``; their arctan2 is the turn of each step seen from there.
    A loop: signatures are needed for every candidate and turning arc, on small arrays."""
    m, n = C.shape[0], max(poly.shape[0] - 1, 0)
    cr = np.empty((m, n))
    dt = np.empty((m, n))
    for j in range(m):
        for i in range(n):
            ax, ay = poly[i, 0] - C[j, 0], poly[i, 1] - C[j, 1]
            bx, by = poly[i + 1, 0] - C[j, 0], poly[i + 1, 1] - C[j, 1]
            cr[j, i] = ax * by - ay * bx
            dt[j, i] = ax * bx + ay * by
    return cr, dt


@njit(cache=True)
def _round_winding(turn, cr, dt, closing, bound):
    # The end of close_and_round: per centre, on the chord (cross product within ``bound``
    # and behind) or not; then sign(w) floor(|w| + 1/2, or 3/4 on the chord).
    out = np.empty(turn.shape, np.int64)
    for j in range(turn.shape[1]):
        on = abs(cr[j]) <= bound and dt[j] < 0.0
        for p in range(turn.shape[0]):
            w = (turn[p, j] + (0.0 if on else closing[j])) / TWO_PI
            out[p, j] = np.int64(np.sign(w) * np.floor(abs(w) + (0.75 if on else 0.5)))
    return out


#: Points per chunk of the indexed clearance (bounds its candidate lists).
_CLEARANCE_CHUNK = 256


def smallest_clearance(xy: np.ndarray, obs: np.ndarray) -> float:
    """The smallest distance of the points ``xy`` to an obstacle edge (nan if any is nan):
    the minimum of the same terms as the plain loop, taken over the obstacles whose centres
    are near enough to matter (found with a k-d tree)."""
    if obs.shape[0] == 0:
        return math.inf
    xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    if obs.shape[0] <= 32 or xy.shape[0] == 0 or not np.all(np.isfinite(xy)):
        return _clearance_loops(xy, obs)
    from scipy.spatial import cKDTree  # here: scipy.spatial takes 0.08 s to import

    tree = cKDTree(obs[:, :2])
    rmax = float(np.max(obs[:, 2]))
    # An upper bound: each point's nearest centre. Any closer edge has its centre within
    # bound + rmax of some point (slightly more, for rounding).
    _, near = tree.query(xy)
    best = _pair_min(xy, obs, np.arange(xy.shape[0]), near)
    for lo in range(0, xy.shape[0], _CLEARANCE_CHUNK):
        part = xy[lo : lo + _CLEARANCE_CHUNK]
        reach = (best + rmax) * (1.0 + 1e-9) + 1e-12
        lists = tree.query_ball_point(part, reach)
        sizes = np.fromiter((len(x) for x in lists), np.int64, len(lists))
        rows = lo + np.repeat(np.arange(part.shape[0]), sizes)
        cols = np.fromiter(itertools.chain.from_iterable(lists), np.int64, int(sizes.sum()))
        best = min(best, _pair_min(xy, obs, rows, cols))
    return best


@njit(cache=True)
def _pair_min(xy, obs, rows, cols):
    # The terms of _clearance_loops for the pairs (rows[k], cols[k]).
    best = np.inf
    for k in range(rows.size):
        r, j = rows[k], cols[k]
        d = math.hypot(xy[r, 0] - obs[j, 0], xy[r, 1] - obs[j, 1]) - obs[j, 2]
        best = min(best, d)
    return best


@njit(cache=True)
def _clearance_loops(xy, obs):
    # The smallest distance of the points to an obstacle edge (nan if any is nan), without an
    # (n, m) temporary. hypot(dx, dy) >= max(|dx|, |dy|), also rounded: when that bound is no
    # closer than the best so far, the (slow) hypot cannot give a new minimum.
    best = np.inf
    for r in range(xy.shape[0]):
        for j in range(obs.shape[0]):
            dx, dy = xy[r, 0] - obs[j, 0], xy[r, 1] - obs[j, 1]
            if max(abs(dx), abs(dy)) - obs[j, 2] >= best:
                continue
            d = math.hypot(dx, dy) - obs[j, 2]
            if d < best or np.isnan(d):
                best = d
                if np.isnan(d):
                    return d
    return best
