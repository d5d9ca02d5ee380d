"""The direct method (CasADi + IPOPT) on a map: the cross-check of map plans.

:mod:`.direct` transcribes the problem with disc obstacles; this module adds the penalty field of
an :class:`~leapfrog_planner.world.obstacle_map.ObstacleMap` (:mod:`..world.field`) to its
running cost, as the *same function* the indirect solver integrates::

    P(x, y) = W exp(-(max(u, 0)^2)^n),    u = sum_{i, j} coef[i, j] B5(gx - j) B5(gy - i)

where ``B5`` is the uniform quintic B-spline (knots at the integers ``j - 3 .. j + 3`` for node
``j``) and ``(gx, gy)`` are grid coordinates: the world point less the field's origin, turned by
minus the map's yaw and divided by the node spacing ``h``.

How it is built in CasADi:

* ``u`` is a ``casadi.bspline`` of degree ``[5, 5]`` with the knots ``-3 .. n + 2`` per axis and
  ``coef`` as coefficients (CasADi wants them flat with the first coordinate, ``gx``, fastest:
  that is ``coef.ravel()`` of the ``(ny, nx)`` array). CasADi's B-spline node cannot be expanded
  into the scalar (SX) graph that :class:`.DirectTranscription` hands IPOPT, so it lives in a
  Function marked ``never_inline``: the SX graph calls it, and its derivatives (other B-splines,
  of lower degree) are called the same way.
* Outside the usable nodes (``2 <= gx <= nx - 3``, likewise ``gy``) the reference evaluator
  returns the constant ``u_out``; here ``gx`` and ``gy`` are clamped into the usable range
  instead. A clamp has a kink, but not where it is used: the field is padded beyond the map
  with the map's outside policy, so on the outer six rows and columns of nodes (all that the
  spline reads near the clamp) either ``u <= 0`` (outside blocked: ``P = W`` exactly, flat) or
  ``u >= far_u()`` (outside free: ``P < e^-60 W``). :func:`shared_spline` checks this
  (:func:`flat_edges`) before it builds.
* ``max(u, 0)`` is ``fmax`` and the power ``constpow`` (no ``log`` of the base in its
  derivative, so no NaN where ``u <= 0``). The reference also returns exactly 0 where
  ``u^(2n) > 60 + log W``; here that tail (below ``e^-60 W``) is kept: smooth, and far below any
  tolerance.

The NLP (:class:`MapTranscription`) is built once per map object, mesh, model and disc count
(:func:`cached_map_transcription`; the map's field is data baked into it), and start, goal,
horizon, weight, exponent and the discs stay inputs of every solve, so many queries on one map
reuse it. A large map's B-spline is slow for CasADi to differentiate (2000 x 2000: 17 s once),
so a query may instead *crop* the field to the region it can reach (:class:`Window`).
:func:`solve_direct_map` solves a :class:`~..integrate.problem.OptimalControlProblem`
or a :class:`~.scenario.Scenario` with a map. The unicycle and the diff-drive are supported.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import ScenarioError, SettingsError
from ..world.field import MapField, far_u
from ..world.obstacle_map import ObstacleMap
from .direct import (
    DirectCase,
    DirectResult,
    DirectTranscription,
    StartPoint,
    best_result,
    check_guess,
    check_horizon,
    check_model,
    check_obstacles,
    check_positive,
    check_state,
    distinct_guesses,
    load_casadi,
    multistart_guesses,
    resample_guess,
    solve_all,
    straight_line_guess,
)
from .direct_arcs import CLEARANCE_SAMPLES, wheel_to_unicycle

__all__ = [
    "MapTranscription",
    "Window",
    "cached_map_transcription",
    "clear_map_transcriptions",
    "crop_window",
    "map_penalty_function",
    "map_spline",
    "query_box",
    "shared_spline",
    "solve_direct_map",
]

#: The nodes the quintic spline reads beyond the usable range's edge (both sides, each axis).
_EDGE = 6

# --------------------------------------------------------------------------- the field


def spline_knots(count: int) -> list[float]:
    """The knots of ``count`` uniform quintic basis functions, node ``j`` centred at ``j``."""
    return [float(k) for k in range(-3, count + 3)]


def flat_edges(field: MapField) -> bool:
    """Whether the outer :data:`_EDGE` rows and columns of ``field`` give a flat penalty: all
    ``u <= 0`` (``P = W``) or all ``u >= far_u()`` (``P < e^-60 W``); then clamping the grid
    coordinates into the usable range changes nothing."""
    coef = field.coef
    if min(coef.shape) < 2 * _EDGE:
        return False
    ring = np.concatenate(
        (
            coef[:_EDGE].ravel(),
            coef[-_EDGE:].ravel(),
            coef[:, :_EDGE].ravel(),
            coef[:, -_EDGE:].ravel(),
        )
    )
    return bool(np.all(ring <= 0.0) or np.all(ring >= far_u()))


def map_spline(field: MapField):
    """``u`` as a CasADi Function of the grid point ``g = (gx, gy)`` (a 2-vector; valid for
    ``2 <= gx <= nx - 3``, ``2 <= gy <= ny - 3``): the B-spline of degree ``[5, 5]`` with the
    field's coefficients, marked ``never_inline`` so that SX graphs call it (module docstring).
    CasADi derives its derivatives (B-splines of lower degree) on first use and keeps them with
    the Function: share it (:func:`shared_spline`)."""
    ca = load_casadi()
    ny, nx = field.coef.shape
    g = ca.MX.sym("g", 2)
    coef = ca.DM(np.ascontiguousarray(field.coef).ravel())  # gx fastest, as CasADi wants
    u = ca.bspline(g, coef, [spline_knots(nx), spline_knots(ny)], [5, 5], 1, {})
    return ca.Function("map_u", [g], [u], ["g"], ["u"], {"never_inline": True})


def map_penalty_expr(ca, spline, field: MapField, x, y, weight, exponent):
    """The map's ``P = W exp(-(max(u, 0)^2)^n)`` at the symbolic world point ``(x, y)``:
    rotation into grid coordinates, the clamp into the usable nodes, the spline, the profile."""
    ny, nx = field.coef.shape
    c, s, h = field.cos_yaw, field.sin_yaw, field.h
    dx, dy = x - field.x0, y - field.y0
    gx = ca.fmin(ca.fmax((c * dx + s * dy) / h, 2.0), nx - 3.0)
    gy = ca.fmin(ca.fmax((c * dy - s * dx) / h, 2.0), ny - 3.0)
    u = spline(ca.vertcat(gx, gy))
    return weight * ca.exp(-ca.constpow(ca.fmax(u, 0.0) ** 2, exponent))


def map_penalty_function(obstacle_map: ObstacleMap, window: Window | None = None):
    """A CasADi Function ``(xy, W, n) -> (P, dP/dxy)`` of the map's penalty alone (of its
    ``window``, if given): what the transcription integrates, for checking it against
    ``field_penalty_terms``."""
    ca = load_casadi()
    field, spline = shared_spline(obstacle_map, window)
    xy, weight, exponent = ca.SX.sym("xy", 2), ca.SX.sym("W"), ca.SX.sym("n")
    p = map_penalty_expr(ca, spline, field, xy[0], xy[1], weight, exponent)
    return ca.Function(
        "map_penalty",
        [xy, weight, exponent],
        [p, ca.gradient(p, xy)],
        ["xy", "W", "n"],
        ["P", "grad"],
    )


# --------------------------------------------------------------------------- cropping


@dataclass(frozen=True)
class Window:
    """Part of a map's field: node rows ``rows[0]:rows[1]`` and columns ``cols[0]:cols[1]``,
    and the world ``box`` ``(xmin, xmax, ymin, ymax)`` that the NLP's nodes are kept in. The
    cropped spline equals the whole one wherever the clamp does not act, which covers the box
    grown by ``slack`` metres (room for the RK4 stages between the nodes)."""

    rows: tuple[int, int]
    cols: tuple[int, int]
    box: tuple[float, float, float, float]

    def contains(self, box) -> bool:
        """Whether ``box`` ``(xmin, xmax, ymin, ymax)`` lies inside this window's box."""
        b = self.box
        return b[0] <= box[0] and box[1] <= b[1] and b[2] <= box[2] and box[3] <= b[3]


def query_box(points, margin: float) -> tuple[float, float, float, float]:
    """The bounding box of ``points`` (``(..., 2)`` or more columns: x, y first) grown by
    ``margin`` metres."""
    xy = np.asarray(points, dtype=float).reshape(-1, np.shape(points)[-1])[:, :2]
    lo, hi = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def crop_window(field: MapField, box, slack: float = 1.0) -> Window:
    """The nodes the spline reads on ``box`` grown by ``slack`` metres (its corners turned into
    grid coordinates, 3 more nodes each side for the spline's support), within the field."""
    ny, nx = field.coef.shape
    x = np.array([box[0] - slack, box[1] + slack])[[0, 1, 0, 1]] - field.x0
    y = np.array([box[2] - slack, box[3] + slack])[[0, 0, 1, 1]] - field.y0
    c, s, h = field.cos_yaw, field.sin_yaw, field.h
    gx, gy = (c * x + s * y) / h, (c * y - s * x) / h
    cols = (max(0, math.floor(gx.min()) - 3), min(nx, math.ceil(gx.max()) + 4))
    rows = (max(0, math.floor(gy.min()) - 3), min(ny, math.ceil(gy.max()) + 4))
    return Window(rows, cols, tuple(float(b) for b in box))


def cropped_field(field: MapField, window: Window) -> MapField:
    """The field of ``window``'s nodes only: their coefficients, the origin moved to its
    first node."""
    (i0, i1), (j0, j1) = window.rows, window.cols
    c, s, h = field.cos_yaw, field.sin_yaw, field.h
    x0 = field.x0 + c * j0 * h - s * i0 * h
    y0 = field.y0 + s * j0 * h + c * i0 * h
    coef = np.ascontiguousarray(field.coef[i0:i1, j0:j1])
    return field._replace(coef=coef, x0=x0, y0=y0)


_SPLINES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def shared_spline(obstacle_map: ObstacleMap, window: Window | None = None):
    """``(field, spline)`` of the map (or of its ``window``), built once per map object and
    window: the spline's derivatives are what costs (CasADi derives a B-spline's derivative
    coefficients in time ~ n^1.4 for n of them: 0.5 s for a million, 5 s for four million, and
    the Hessian needs five such derivatives)."""
    per_map = _SPLINES.setdefault(obstacle_map, {})
    key = None if window is None else (window.rows, window.cols)
    if key not in per_map:
        field = obstacle_map.field
        if not flat_edges(field):
            raise ScenarioError("map: its field has no flat padding to clamp into (or is empty)")
        if window is not None:
            field = cropped_field(field, window)
        per_map[key] = (field, map_spline(field))
    return per_map[key]


# --------------------------------------------------------------------------- transcription


class MapTranscription(DirectTranscription):
    """:class:`.DirectTranscription` whose running cost also holds the penalty field of
    ``obstacle_map`` (of its ``window`` only, if given: then the nodes are kept in the window's
    box). Built (and IPOPT set up) once; every :meth:`solve` takes new ends, horizon, weight,
    exponent and discs. The result's ``min_clearance`` is the least of the discs' and the map's
    (against the blocked cells, along the exact arcs of the controls).

    The transcription holds the map weakly (so that the cache, which holds transcriptions,
    does not keep dropped maps alive): keep the map while solving, or the map's clearance is
    left out of ``min_clearance``."""

    def __init__(
        self,
        obstacle_map: ObstacleMap,
        n_obstacles: int = 0,
        intervals: int = 100,
        *,
        window: Window | None = None,
        **kw,
    ) -> None:
        if not isinstance(obstacle_map, ObstacleMap):
            raise ScenarioError(f"map: expected an ObstacleMap, got {obstacle_map!r:.60}")
        self._map, self.window = weakref.ref(obstacle_map), window
        self._field, self._spline = shared_spline(obstacle_map, window)
        super().__init__(n_obstacles, intervals, **kw)

    @property
    def obstacle_map(self) -> ObstacleMap | None:
        """The map (None once it has been dropped)."""
        return self._map()

    def _rhs(self, ca, x, u, weight, exponent, obstacles):
        xdot, cost = super()._rhs(ca, x, u, weight, exponent, obstacles)
        extra = map_penalty_expr(ca, self._spline, self._field, x[0], x[1], weight, exponent)
        return xdot, cost + extra

    def _start_point(self, case: DirectCase, states0, controls0) -> StartPoint:
        """The base class's start point, with the node positions boxed into the window's box
        (the guess clipped into it)."""
        point = super()._start_point(case, states0, controls0)
        if self.window is not None:
            n, (xmin, xmax, ymin, ymax) = self.intervals, self.window.box
            for axis, lo, hi in ((0, xmin, xmax), (1, ymin, ymax)):
                inner = slice(3 + axis, 3 * n + axis, 3)  # nodes 1 .. N-1
                point.lbx[inner] = np.maximum(point.lbx[inner], lo)
                point.ubx[inner] = np.minimum(point.ubx[inner], hi)
                point.x0[inner] = np.clip(point.x0[inner], lo, hi)
        return point

    def _result(self, case: DirectCase, sol, stats, solve_time: float) -> DirectResult:
        result = super()._result(case, sol, stats, solve_time)
        unicycle = result.controls
        if self.model == "diff-drive":
            unicycle = wheel_to_unicycle(unicycle, self.wheel_radius, self.axle_length)
        world = self.obstacle_map
        if world is not None:
            clear = world.path_clearance(arc_points(result.states, unicycle, result.horizon))
            result = replace(result, min_clearance=min(result.min_clearance, clear))
        if self.window is not None and _touches(result.states, self.window.box):
            result = replace(
                result,
                success=False,
                status="crop_too_small",
                message=f"{result.message}; the path touches the crop's box",
            )
        return result


def _touches(states: np.ndarray, box, tol: float = 1e-6) -> bool:
    """Whether a node of ``states`` lies on an edge of ``box`` (the crop then binds)."""
    x, y = states[:, 0], states[:, 1]
    return bool(
        np.any(
            (x <= box[0] + tol) | (x >= box[1] - tol) | (y <= box[2] + tol) | (y >= box[3] - tol)
        )
    )


def arc_points(states: np.ndarray, unicycle_controls: np.ndarray, horizon: float) -> np.ndarray:
    """Points ``(M, 2)`` along the exact arcs of piecewise-constant ``(v, omega)`` from the node
    states: :data:`CLEARANCE_SAMPLES` per interval and the end node."""
    n = len(unicycle_controls)
    tau = horizon / n * np.arange(CLEARANCE_SAMPLES) / CLEARANCE_SAMPLES
    x0, y0, th0 = (states[:-1, i, None] for i in range(3))
    v, w = unicycle_controls[:, 0, None], unicycle_controls[:, 1, None]
    chord = v * tau * np.sinc(w * tau / (2.0 * np.pi))
    mid = th0 + w * tau / 2.0
    xs = np.concatenate(((x0 + chord * np.cos(mid)).ravel(), states[-1:, 0]))
    ys = np.concatenate(((y0 + chord * np.sin(mid)).ravel(), states[-1:, 1]))
    return np.column_stack((xs, ys))


_MAP_TRANSCRIPTIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Cropped transcriptions kept per map and mesh (the oldest is dropped beyond this).
CROPS_KEPT = 8


def cached_map_transcription(
    obstacle_map: ObstacleMap,
    n_obstacles: int,
    intervals: int,
    *,
    slot: int = 0,
    model: str = "unicycle",
    box=None,
    crop: float = 3.0,
    **kw,
) -> MapTranscription:
    """A :class:`MapTranscription` built once per map *object* (its identity: the cache holds
    the map weakly, so a dropped map frees its NLPs), disc count, mesh, ``slot`` (one per
    thread, as :func:`.cached_transcription`), model and options. With a ``box`` (the bounding
    box of the query, :func:`query_box`), a cropped one whose box holds it grown by at least
    ``crop / 2``, or a new one cropped to ``box`` grown by ``crop`` metres (:data:`CROPS_KEPT`
    kept per map and key)."""
    per_map = _MAP_TRANSCRIPTIONS.setdefault(obstacle_map, {})
    key = (n_obstacles, intervals, slot, model, box is not None, tuple(sorted(kw.items())))
    if box is None:
        if key not in per_map:
            per_map[key] = MapTranscription(obstacle_map, n_obstacles, intervals, model=model, **kw)
        return per_map[key]
    crops = per_map.setdefault(key, [])
    half = (box[0] - crop / 2, box[1] + crop / 2, box[2] - crop / 2, box[3] + crop / 2)
    for t in crops:
        if t.window.contains(half):  # at least half the margin on every side
            return t
    grown = (box[0] - crop, box[1] + crop, box[2] - crop, box[3] + crop)
    window = crop_window(obstacle_map.field, grown)
    crops.append(
        MapTranscription(obstacle_map, n_obstacles, intervals, window=window, model=model, **kw)
    )
    del crops[:-CROPS_KEPT]
    return crops[-1]


def clear_map_transcriptions() -> None:
    """Free every cached map transcription and spline."""
    _MAP_TRANSCRIPTIONS.clear()
    _SPLINES.clear()


# --------------------------------------------------------------------------- solving


_CONTROL_NAMES = {"unicycle": ("v", "omega"), "diff-drive": ("omega_R", "omega_L")}


def _task(task, start, goal, horizon, control_bounds) -> tuple[Any, DirectCase, dict]:
    """From a problem or scenario: the map, the checked :class:`._Case` and the transcription's
    model options (``model``, and the wheel radius and axle length of a diff-drive)."""
    if hasattr(task, "robot_radius") and hasattr(task, "footprint_obstacles"):  # a Scenario
        if task.map is None:
            raise ScenarioError("the scenario has no map: use direct.solve_direct")
        world = task.map.obstacles(task.robot_radius)
        obstacles, weight, exponent = task.footprint_obstacles, task.weight, task.exponent
        model, params = task.model, dict(task.model_parameters)
        start = task.start if start is None else start
        goal = task.goal if goal is None else goal
        horizon = task.horizon if horizon is None else horizon
        if control_bounds is None and task.control_bounds:
            control_bounds = [task.control_bounds.get(c) for c in _CONTROL_NAMES.get(model, ())]
    else:  # an OptimalControlProblem
        penalty, model = task.penalty, task.model.name
        world, obstacles = penalty.map, penalty.obstacles
        weight, exponent = penalty.weight, penalty.exponent
        params = dict(zip(task.model.parameters, task.parameters, strict=True))
        if world is None:
            raise ScenarioError("the problem has no map: use direct.solve_direct")
    options = {"model": check_model(model)}
    if model == "diff-drive":
        options.update(wheel_radius=params["wheel_radius"], axle_length=params["axle_length"])
    if start is None or goal is None or horizon is None:
        raise ScenarioError("start, goal and horizon are needed with a problem")
    case = DirectCase(
        check_state(start, "start"),
        check_state(goal, "goal"),
        check_horizon(horizon),
        check_obstacles(obstacles),
        weight,
        exponent,
        control_bounds,
    )
    return world, case, options


def solve_direct_map(
    task,
    start=None,
    goal=None,
    horizon=None,
    *,
    intervals: int = 100,
    multistart: bool = False,
    guesses=None,
    coarse_intervals: int | None = 40,
    control_bounds=None,
    crop: float | None = None,
    **kw,
) -> DirectResult:
    """Solve a problem with a map by the direct method; the same :class:`.DirectResult` as
    :func:`.solve_direct`.

    ``task`` is an :class:`~..integrate.problem.OptimalControlProblem` whose penalty has a map
    (then ``start``, ``goal`` and ``horizon`` are needed) or a :class:`~.scenario.Scenario` with
    a map (they default to the scenario's; so do its control bounds). Weight, exponent, discs
    and model come from ``task``.

    Tried are the ``(N+1, 3)`` state arrays in ``guesses``, or the straight line without them;
    with ``multistart=True`` also :func:`.multistart_guesses`, solved first on the coarse mesh
    of ``coarse_intervals`` and refined from each distinct coarse optimum (as
    :func:`.solve_direct`). The cheapest successful result is returned. Extra keywords
    (``substeps``, ``tol``, ``max_iter``, ``slot``) go to :func:`cached_map_transcription`.

    ``crop=None`` builds the NLP on the whole map, once per map object: about 1 s for a
    600 x 300 map, but 17 s and 0.4 GB for 2000 x 2000 (the B-spline's derivatives). With
    ``crop`` (metres) the spline holds only the part of the map around the bounding box of
    start, goal and guesses grown by ``crop``, the path's nodes are kept in that box, and a
    result whose path touches it fails with status ``crop_too_small``; later queries reuse a
    cached crop that holds their box grown by ``crop / 2`` (``crop`` is a least margin).
    """
    world, case, options = _task(task, start, goal, horizon, control_bounds)
    kw = {**options, **kw}
    user = [check_guess(g, "guesses", (intervals + 1, 3)) for g in (guesses or ())]
    if crop is not None:
        points = [case.start[None], case.goal[None], *(g[:, :2] for g in user)]
        if multistart:
            points += multistart_guesses(case.start, case.goal, coarse_intervals or intervals)
        box = query_box(np.vstack([p[:, :2] for p in points]), 0.0)
        kw.update(box=box, crop=check_positive(crop, "crop", error=SettingsError))
    starts = [(g, None) for g in user]
    if multistart:
        starts += _coarse_starts(world, case, intervals, coarse_intervals, kw)
    if not starts:
        starts = [(straight_line_guess(case.start, case.goal, case.horizon, intervals)[0], None)]
    transcription = cached_map_transcription(world, len(case.obstacles), intervals, **kw)
    return best_result(solve_all(transcription, case, starts))


def _coarse_starts(world, case: DirectCase, n: int, coarse: int | None, kw: dict) -> list:
    """The built-in guesses' starts on the mesh of ``n`` intervals: each distinct optimum on the
    coarse mesh (tolerance at most 1e-6), resampled; the raw guesses without one."""
    if coarse is not None and coarse < n:
        coarse_kw = {**kw, "tol": max(kw.get("tol", 1e-10), 1e-6)}
        solver = cached_map_transcription(world, len(case.obstacles), coarse, **coarse_kw)
        guesses = multistart_guesses(case.start, case.goal, coarse)
        optima = distinct_guesses(solve_all(solver, case, [(g, None) for g in guesses]))
        if optima:
            return [resample_guess(r, n) for r in optima]
    return [(g, None) for g in multistart_guesses(case.start, case.goal, n)]
