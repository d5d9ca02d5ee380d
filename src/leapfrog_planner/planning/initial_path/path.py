"""The initial path: a collision-free motion from start to goal, with its polyline, homotopy
signature and clearance."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ... import checks
from ...errors import ScenarioError, SettingsError, require_integer
from .curve import SmoothCurve
from .ends import (
    FORWARD,
    Drive,
    EndModes,
    PoseCurve,
    Turn,
    angle_of,
    near_branch,
    with_turns,
)
from .geometry import (
    clean_polyline,
    end_state,
    homotopy_signature,
    smallest_clearance,
    tolerance,
)


@dataclass(frozen=True, eq=False)
class InitialPath:
    """A collision-free initial path from start to goal and its smoothed C1 curve.

    ``polyline`` holds the vertices from start to goal (both included), ``length`` the arclength
    of the smoothed curve, ``signature`` the homotopy class (per obstacle, the winding number of
    the path closed by the reversed straight chord; see the module notes), ``min_clearance`` the
    smallest distance of the smoothed curve to an obstacle edge (``inf`` without obstacles; a
    negative value means the curve enters an obstacle) and ``label`` a short description
    (``"straight"``, ``"visibility #2"``, ``"waypoints"``...). ``start`` and ``goal`` are the
    full end states ``(x, y, heading)``. Compare paths by ``signature``, not with ``==``.
    """

    polyline: np.ndarray
    length: float
    signature: tuple[int, ...]
    min_clearance: float
    label: str
    start: np.ndarray = field(repr=False)
    goal: np.ndarray = field(repr=False)
    _curve: PoseCurve = field(repr=False)
    modes: EndModes = FORWARD

    @classmethod
    def from_polyline(
        cls, polyline, start, goal, obstacles=None, *, label: str = "custom"
    ) -> InitialPath:
        """Smooth a given polyline from ``start[:2]`` to ``goal[:2]`` (no collision check; a
        turning arc is added at an end whose heading points more than 90 degrees off the leg).

        The first and last vertex must be the start and goal positions (they are set to exactly
        those). ``signature`` and ``min_clearance`` refer to ``obstacles`` (rows ``[cx, cy, r]``).
        """
        S = end_state(start, "start")
        G = end_state(goal, "goal")
        obs = checks.obstacles(obstacles)
        poly = checks.rows(polyline, 2, "polyline", "x, y")
        if poly.shape[0] < 2:
            raise ScenarioError(f"polyline: expected at least 2 vertices, got {poly.shape[0]}")
        tol = tolerance(S, G, obs)
        for key, p, end in (("first", poly[0], S), ("last", poly[-1], G)):
            if math.hypot(*(p - end[:2])) > tol:
                what = "start" if key == "first" else "goal"
                at, want = checks.fmt_point(p), checks.fmt_point(end[:2])
                raise ScenarioError(
                    f"polyline: {key} vertex {at} is not the {what} position {want}"
                )
        return smooth_path(clean_polyline(poly, S[:2], G[:2], tol), S, G, obs, label, tol)

    def curve(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(n, 2)`` and headings ``(n,)`` of the path at normalised time ``s``.

        ``s`` is a number or an array of numbers in ``[0, 1]``; the result always has a leading
        axis of length ``n = size(s)``. The path is followed at constant speed along the smoothed
        curve (``s`` is then its normalised arclength), after and before the turns in place of
        its :class:`EndModes`, which take the time of as many units of path as they turn
        radians. Headings are the tangent direction (plus pi when reversing), unwrapped along
        the curve from the start heading; if the goal heading asks for whole extra turns beyond
        the curve's own turning, those are added linearly in ``s``, so heading(0) is the start
        heading and heading(1) the goal heading (both up to rounding).
        """
        s = np.atleast_1d(np.asarray(s, dtype=np.float64)).ravel()
        if s.size and not (s.min() >= -1e-12 and s.max() <= 1.0 + 1e-12):  # also nan
            raise ValueError("s: normalised arclength must lie in [0, 1]")
        return self._curve.evaluate(np.clip(s, 0.0, 1.0))

    def junctions(self, q: int, horizon: float, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Times ``(q + 1,)`` and states ``(q + 1, 3)`` of ``q`` segments at constant speed.

        The times are uniform on ``[t0, t0 + horizon]`` and the junctions uniform in arclength.
        ``X[0]`` and ``X[-1]`` are exactly the start and goal states.
        """
        q = require_integer("q", q)
        horizon = checks.real(horizon, "horizon", error=SettingsError)
        t0 = checks.real(t0, "t0", error=SettingsError)
        if not horizon > 0.0:
            raise SettingsError(f"horizon: must be > 0, got {horizon!r}")
        frac = np.arange(q + 1, dtype=np.float64) / q
        frac[-1] = 1.0
        t = t0 + horizon * frac
        t[0] = t0
        t[-1] = t0 + horizon
        xy, heading = self._curve.evaluate(frac)
        X = np.column_stack([xy, heading])
        X[0] = self.start
        X[-1] = self.goal
        return t, X

    def retimed(self, sigma, label: str) -> InitialPath:
        """The same path on another clock: at normalised time ``s`` it is where this one is at
        ``sigma(s)`` (``sigma`` rising from 0 to 1, tabulated on a uniform grid of ``s``)."""
        sigma = np.asarray(sigma, dtype=np.float64)
        return replace(self, _curve=_Retimed(self._curve, sigma), label=label)


class _Retimed:
    """A pose curve followed on another clock: ``evaluate(s)`` is the base curve at
    ``sigma(s)`` (a monotone table on a uniform grid of ``s``)."""

    __slots__ = ("base", "grid", "sigma")

    def __init__(self, base, sigma: np.ndarray):
        self.base, self.sigma = base, sigma
        self.grid = np.linspace(0.0, 1.0, sigma.size)

    def evaluate(self, s: np.ndarray):
        return self.base.evaluate(np.interp(s, self.grid, self.sigma))


def smooth_path(poly, S, G, obs, label, tol, signature=None, modes=FORWARD) -> InitialPath:
    """Smooth ``poly`` for ``modes`` (adding turning arcs where the curve's end directions point
    away from it)."""
    offset = math.pi if modes.reverse else 0.0
    h0, h1 = S[2] + offset, G[2] + offset  # the curve's tangent direction at its ends
    if modes.turn_start and poly.shape[0] >= 2:
        h0 = near_branch(angle_of(poly[1] - poly[0]), h0)
    if modes.turn_goal and poly.shape[0] >= 2:
        h1 = near_branch(angle_of(poly[-1] - poly[-2]), h1)
    poly, sig = with_turns(poly, h0, h1, obs, tol, signature)
    curve = SmoothCurve(poly, h0, h1)
    if curve.delta and (modes.turn_start or modes.turn_goal):
        h0, h1 = _turned_in_place(curve.delta, h0 - offset, h1 - offset, S[2], G[2], modes)
        h0, h1 = h0 + offset, h1 + offset
        curve = SmoothCurve(poly, h0, h1)
    pieces = [Turn(S, S[2], h0 - offset), Drive(curve, offset)]
    pieces.append(Turn(G, h1 - offset, G[2]))
    return path_from_curve(poly, PoseCurve(pieces), S, G, obs, label, tol, sig, modes)


def _turned_in_place(delta, a0, a1, start, goal, modes) -> tuple[float, float]:
    """The headings ``(a0, a1)`` the drive starts and ends at, with the whole turns ``delta``
    that the goal heading asks for beyond the curve's own turning moved into a turn in place
    (at the start or the goal, whichever then turns less), not spread along the drive: there
    they turned the robot across its direction of travel (a reverse drive on the TurtleBot3
    map turned a whole turn sideways, and its initial segments failed every strategy)."""
    at_start = (abs(a0 + delta - start), a0 + delta, a1) if modes.turn_start else None
    at_goal = (abs(goal - (a1 - delta)), a0, a1 - delta) if modes.turn_goal else None
    _, b0, b1 = min(x for x in (at_start, at_goal) if x is not None)
    return b0, b1


def path_from_curve(poly, curve, S, G, obs, label, tol, signature, modes) -> InitialPath:
    poly = poly.copy()
    for arr in (poly, S, G):
        arr.setflags(write=False)
    return InitialPath(
        polyline=poly,
        length=curve.length,
        signature=homotopy_signature(poly, obs, tol) if signature is None else signature,
        min_clearance=smallest_clearance(curve.samples, obs),
        label=label,
        start=S,
        goal=G,
        _curve=curve,
        modes=modes,
    )
