"""How a path meets its end poses: driving forwards or in reverse, turning arcs, turns in
place; a path as a sequence of drives and turns, timed by the unicycle's metric."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .curve import TWO_PI, SmoothCurve
from .geometry import cross, homotopy_signature

#: A start (goal) heading more than 90 degrees off the first (last) leg's direction gets a
#: turning arc (cosine of that angle), sampled every 30 degrees at most.
_TURN_COS = 0.0
_TURN_STEP = math.pi / 6
#: Radii of those arcs tried, as fractions of the leg (smaller ones only to keep the class).
_TURN_RADII = (0.25, 0.1, 0.04)


@dataclass(frozen=True)
class EndModes:
    """How a path meets its end poses.

    ``reverse``: the path is driven backwards (heading = tangent direction + pi). ``turn_start``
    (``turn_goal``): the robot turns in place at the start (goal) between its heading and the
    direction of the first (last) leg, instead of leaving (arriving) along its heading with a
    turning arc. ``cusp``: the path drives (forwards, or backwards with ``reverse``) along the
    start heading to a cusp point, turns there in place as far as needed, and drives the other
    way into the goal along the goal heading: a three-point turn. The default is forward with
    turning arcs where needed.
    """

    reverse: bool = False
    turn_start: bool = False
    turn_goal: bool = False
    cusp: bool = False

    def describe(self) -> str:
        """``""`` for the default, else e.g. ``"reverse, turn in place at start"``."""
        if self.cusp:
            return "reverse, then forward" if self.reverse else "forward, then reverse"
        parts = ["reverse"] if self.reverse else []
        ends = [e for e, on in (("start", self.turn_start), ("goal", self.turn_goal)) if on]
        if ends:
            parts.append("turn in place at " + " and ".join(ends))
        return ", ".join(parts)


FORWARD = EndModes()


class Drive:
    """A smooth curve driven at constant speed: heading = tangent direction minus ``offset``
    (pi when reversing)."""

    __slots__ = ("curve", "offset")

    def __init__(self, curve: SmoothCurve, offset: float = 0.0):
        self.curve, self.offset = curve, float(offset)

    @property
    def metric(self) -> float:
        return self.curve.length

    @property
    def samples(self) -> np.ndarray:
        return self.curve.samples

    def evaluate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xy, th = self.curve.evaluate(u)
        return xy, (th - self.offset if self.offset else th)


class Turn:
    """A turn in place at ``xy`` from heading ``theta0`` to ``theta1``."""

    __slots__ = ("xy", "theta0", "theta1")

    def __init__(self, xy: np.ndarray, theta0: float, theta1: float):
        self.xy, self.theta0, self.theta1 = np.array(xy[:2], dtype=float), theta0, theta1

    @property
    def metric(self) -> float:
        return abs(self.theta1 - self.theta0)

    @property
    def samples(self) -> np.ndarray:
        return self.xy[None, :]

    def evaluate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.repeat(self.xy[None, :], u.size, axis=0), self.theta0 + (
            self.theta1 - self.theta0
        ) * u


class PoseCurve:
    """Poses ``(x, y, heading)`` at normalised time ``s`` along a sequence of pieces, each a
    drive along a smooth curve (:class:`Drive`) or a turn in place (:class:`Turn`).

    Time is shared in proportion to the unicycle's own metric (its cost is ``1/2 (v^2 +
    omega^2)``): a turn of ``rho`` radians takes the time of ``rho`` units of path. A single
    forward drive gives the curve's own poses, unchanged.
    """

    __slots__ = ("pieces", "shares", "length", "samples")

    def __init__(self, pieces: list):
        pieces = [p for p in pieces if not (isinstance(p, Turn) and p.metric == 0.0)]
        self.pieces = pieces
        metric = np.array([p.metric for p in pieces])
        total = metric.sum()
        cum = np.concatenate(([0.0], np.cumsum(metric))) / total if total > 0.0 else None
        if cum is None:
            cum = np.linspace(0.0, 1.0, len(pieces) + 1)
        cum[-1] = 1.0
        self.shares = cum
        self.length = float(sum(p.metric for p in pieces if isinstance(p, Drive)))
        self.samples = np.vstack([p.samples for p in pieces])

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(self.pieces) == 1:
            return self.pieces[0].evaluate(s)
        xy = np.empty((s.size, 2))
        th = np.empty(s.size)
        k = np.clip(np.searchsorted(self.shares, s, side="right") - 1, 0, len(self.pieces) - 1)
        for j, piece in enumerate(self.pieces):
            at = k == j
            if at.any():
                a, b = self.shares[j], self.shares[j + 1]
                u = np.clip((s[at] - a) / (b - a), 0.0, 1.0) if b > a else np.zeros(at.sum())
                xy[at], th[at] = piece.evaluate(u)
        return xy, th


def _turn_options(poly: np.ndarray, theta: float, frac: float) -> list[np.ndarray]:
    """``[poly]``, or ``poly`` with a turning arc after the start, on either side (the side the
    first leg lies on first), when the start heading points away from the first leg.

    A cubic that leaves a polyline more than 90 degrees off its first leg's direction turns
    sharply (curvature over 9 / leg length, and a cusp at 180 degrees). Instead, the path first
    turns on a circle of radius ``frac`` times the first leg, tangent to the start heading,
    until it heads straight for the leg's end.
    """
    leg = poly[1] - poly[0]
    ell = math.hypot(*leg)
    e = np.array([math.cos(theta), math.sin(theta)])
    if not ell > 0.0 or float(e @ leg) >= _TURN_COS * ell:
        return [poly]
    n = np.array([-e[1], e[0]])
    rho = frac * ell
    out = []
    for side in (1.0, -1.0) if cross(e, leg) >= 0.0 else (-1.0, 1.0):
        centre = poly[0] + side * rho * n
        w = poly[1] - centre
        tangent = math.atan2(w[1], w[0]) - side * math.acos(rho / math.hypot(*w))
        phi0 = math.atan2(-side * n[1], -side * n[0])
        span = (side * (tangent - phi0)) % TWO_PI
        pieces = max(2, math.ceil(span / _TURN_STEP))
        phi = phi0 + side * span * np.arange(1, pieces + 1) / pieces
        arc = centre + rho * np.column_stack([np.cos(phi), np.sin(phi)])
        out.append(np.vstack([poly[:1], arc, poly[1:]]))
    return out


def with_turns(poly, h0, h1, obs, tol, signature) -> tuple[np.ndarray, tuple[int, ...] | None]:
    """``poly`` with the turning arcs that the end tangent directions ``h0``, ``h1`` need, in the
    homotopy class ``signature`` (when given: smaller arcs are tried when the larger ones would
    change it, and none are added when no choice of sides and sizes keeps it), and its signature
    when that was checked (else ``None``)."""
    if poly.shape[0] < 2 or not math.hypot(*(poly[-1] - poly[0])) > tol:
        return poly, None
    for frac in _TURN_RADII:
        for first in _turn_options(poly, h0, frac):
            for last in _turn_options(first[::-1], h1 + math.pi, frac):
                if signature is None:
                    return np.ascontiguousarray(last[::-1]), None
                if homotopy_signature(last[::-1], obs, tol) == signature:
                    return np.ascontiguousarray(last[::-1]), signature
    return poly, None


def _points_away(leg: np.ndarray, theta: float) -> bool:
    """Whether direction ``theta`` is more than 90 degrees off ``leg`` (a turning arc is due)."""
    ell = math.hypot(*leg)
    return ell > 0.0 and math.cos(theta) * leg[0] + math.sin(theta) * leg[1] < _TURN_COS * ell


def near_branch(angle: float, target: float) -> float:
    """``angle`` plus the whole turns that bring it within pi of ``target``."""
    return angle + TWO_PI * round((target - angle) / TWO_PI)


def end_modes(poly: np.ndarray, start, goal) -> list[EndModes]:
    """The ways of meeting the end poses worth trying along ``poly``, forward first.

    Only forward when neither end heading points away from its leg (more than 90 degrees off).
    Otherwise also reverse, and at each end that points away in that direction a turn in place
    instead of the turning arc.
    """
    if poly.shape[0] < 2:
        return [FORWARD]
    first, last = poly[1] - poly[0], poly[-1] - poly[-2]
    th0, th1 = float(start[2]), float(goal[2])
    if not (_points_away(first, th0) or _points_away(last, th1)):
        return [FORWARD]
    out = []
    for reverse in (False, True):
        o = math.pi if reverse else 0.0
        turn0 = (False, True) if _points_away(first, th0 + o) else (False,)
        turn1 = (False, True) if _points_away(last, th1 + o) else (False,)
        out += [EndModes(reverse, a, b) for a in turn0 for b in turn1]
    return out


def points_away(start, goal) -> bool:
    """Whether an end heading points away from the chord from ``start`` to ``goal`` (more than
    90 degrees off): reverse legs, turns in place and three-point turns are natural there."""
    chord = np.vstack([np.asarray(start, float)[:2], np.asarray(goal, float)[:2]])
    return len(end_modes(chord, start, goal)) > 1


def angle_of(v: np.ndarray) -> float:
    return math.atan2(v[1], v[0])
