"""OMPL as a benchmark peer on occupancy-grid maps: sampling-based planners (RRT*, BIT*, ...)
for a car that turns no tighter than a given radius, against the same exact map clearance as
Leapfrog. OMPL (``pip install ompl``) is what a robotics user would otherwise pick; it is optional
(:func:`ompl_available`) and imported only when a plan is asked for.

- :class:`OmplSettings`: planner, space (Reeds-Shepp: forward and reverse; Dubins: forward),
  turning radius, time limit, seed, resolution of the collision checks and of the path returned.
- :func:`ompl_plan`: one query on a :class:`~leapfrog_planner.world.MapClearance`, answered by an
  :class:`OmplPath` sampled densely along the path OMPL found; :func:`timed` drives that path at
  constant speed over a horizon, to be scored like ours.
- :func:`random_queries`, :func:`benchmark`, :func:`summarize`, :func:`main`: the measurement,
  ``python -m leapfrog_planner.experiments.ompl_peer MAP.yaml ...``.

The problem OMPL is given: SE(2) with Reeds-Shepp or Dubins curves of the turning radius, bounded
by the map's extent; a state is valid when ``clear.clearance(x, y, radius) >= margin`` (the disc
footprint against the exact clearance); motions are checked along their curve at states at most
``resolution`` apart in arclength; the objective is the path length. The default ``margin``,
``resolution / 2``, makes the whole curve safe: the distance to the blocked cells changes by at
most 1 m per metre travelled, so between two checked states the clearance stays >= 0
(``margin=0``: the bare rule at the checked states; the path may graze a corner between them).
The check is exact and fast: a point lies within half a cell diagonal of its cell's centre, whose
distance to the blocked cells (computed once per map) settles it unless it lies in that band.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
import weakref
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, fields

import numpy as np

from .. import checks
from ..errors import ScenarioError, SettingsError, describe, require_integer
from ..world.clearance import HALF_DIAGONAL, MapClearance

__all__ = ["PLANNERS", "RUN_FIELDS", "SPACES", "OmplPath", "OmplSettings", "benchmark", "main",
           "ompl_available", "ompl_plan", "random_queries", "summarize", "timed",
           "wrap_angle"]  # fmt: skip

#: Planners by name (the classes of ``ompl.geometric``). The first four improve their path until
#: the time limit; RRT and RRTConnect stop at their first path. Left out: PRM* (its roadmap
#: thread waits for the Python state check while the solving thread holds the interpreter: it
#: hangs); AORRTC on Dubins curves crashes OMPL 2.0.1 (a segmentation fault), so it is refused.
PLANNERS = ("RRTstar", "InformedRRTstar", "BITstar", "AORRTC", "RRTConnect", "RRT")
SPACES = ("reeds_shepp", "dubins")
TIME_LIMIT_MAX = 3600.0  # seconds
SLACK = 1e-9  # metres kept against rounding where the cell-centre bound decides a state
OMPL_MISSING = "OMPL is not installed: pip install 'leapfrog-planner[ompl]'"


def ompl_available() -> bool:
    """Whether OMPL's Python bindings (the ``ompl`` package of PyPI) can be imported."""
    try:
        import ompl.base  # noqa: F401
        import ompl.geometric  # noqa: F401
    except ImportError:
        return False
    return True


def _real(value, key: str, low: float, high: float) -> float:
    x = checks.real(value, key, error=SettingsError)
    return checks.in_range(x, key, low, high, error=SettingsError)


@dataclass(frozen=True)
class OmplSettings:
    """How :func:`ompl_plan` runs OMPL. Construction checks every field (a ``SettingsError``
    with one line); :meth:`from_mapping` also refuses unknown keys.

    ``planner``: one of :data:`PLANNERS`. ``space``: ``"reeds_shepp"`` (forward and reverse) or
    ``"dubins"`` (forward only). ``turning_radius`` (m): the tightest turn. ``time_limit`` (s):
    the planner's time (the optimising planners use all of it, but BIT* stops once its path meets
    its lower bound, as when the direct curve is free). ``seed``: OMPL's random seed (see
    :func:`ompl_plan` on determinism). ``resolution`` (m): the largest arclength between two
    states checked along a motion. ``margin`` (m): the clearance each checked state must keep,
    ``None`` for ``resolution / 2`` (module docstring). ``step`` (m): the largest arclength between
    two poses of the returned path. ``simplify``: let OMPL shorten the path it found (shortcuts,
    fewer states), checked again after."""

    planner: str = "RRTstar"
    space: str = "reeds_shepp"
    turning_radius: float = 0.3
    time_limit: float = 1.0
    seed: int = 0
    resolution: float = 0.01
    margin: float | None = None
    step: float = 0.02
    simplify: bool = True

    def __post_init__(self):
        for key, known in (("planner", PLANNERS), ("space", SPACES)):
            value = getattr(self, key)
            if value not in known:
                raise SettingsError(f"{key}: unknown {describe(value)} (known: {', '.join(known)})")
        if self.planner == "AORRTC" and self.space == "dubins":  # OMPL 2.0.1 crashes on it
            raise SettingsError("planner: AORRTC crashes OMPL 2.0.1 on Dubins curves")
        put = object.__setattr__
        put(self, "turning_radius", _real(self.turning_radius, "turning_radius", 1e-3, 1e3))
        put(self, "time_limit", _real(self.time_limit, "time_limit", 1e-3, TIME_LIMIT_MAX))
        put(self, "seed", require_integer("seed", self.seed, 0, 2**31 - 2))
        put(self, "resolution", _real(self.resolution, "resolution", 1e-4, 1.0))
        if self.margin is not None:
            put(self, "margin", _real(self.margin, "margin", 0.0, 10.0))
        put(self, "step", _real(self.step, "step", 1e-3, 1.0))
        if not isinstance(self.simplify, bool):
            raise SettingsError(f"simplify: expected a boolean, got {describe(self.simplify)}")

    @classmethod
    def from_mapping(cls, options: dict) -> OmplSettings:
        """Settings from a dict (a TOML table, command-line options): unknown keys are refused."""
        known = [f.name for f in fields(cls)]
        unknown = sorted(set(options) - set(known), key=str)
        if unknown:
            raise SettingsError(f"unknown option {unknown[0]!r} (known: {', '.join(known)})")
        return cls(**options)

    @property
    def clearance_margin(self) -> float:
        """The margin in force: ``margin``, or ``resolution / 2`` when it is ``None``."""
        return self.resolution / 2 if self.margin is None else self.margin


@dataclass(frozen=True, eq=False)
class OmplPath:
    """What :func:`ompl_plan` found. The arrays are read-only and empty when not solved; the
    poses are at most ``settings.step`` apart in arclength, the first the start, the last the
    goal. ``plan_time`` may pass the time limit by ``simplify_time``."""

    solved: bool  # an exact solution (it ends at the goal) whose poses all keep clearance >= 0
    poses: np.ndarray  # (N, 3): x, y, theta along the path
    arclength: np.ndarray  # (N,): the distance travelled to each pose (m)
    direction: np.ndarray  # (N - 1,): +1 forward, -1 reverse, per piece between two poses
    length: float  # m (nan when not solved)
    plan_time: float  # s of OMPL's work: setup, solve, simplification
    first_time: float  # s to the first exact solution (nan: none)
    simplify_time: float  # s spent simplifying
    max_curvature: float  # 1/m, the largest |dtheta/ds| between two poses
    cusps: int  # changes of direction (Reeds-Shepp)
    min_clearance: float  # m, the least clear.clearance of the poses at the robot's radius
    status: str  # OMPL's word: "Exact solution", "Approximate solution", "Invalid start", ...
    message: str  # one line
    settings: OmplSettings = field(repr=False)


def _failure(settings: OmplSettings, status: str, message: str, plan_time=0.0) -> OmplPath:
    empty = np.empty((0, 3))
    return OmplPath(
        False, empty, np.empty(0), np.empty(0, np.int8), math.nan, plan_time, math.nan, 0.0,
        math.nan, 0, math.nan, status, message, settings,
    )  # fmt: skip


# --------------------------------------------------------------------------- the state check

_CENTRES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _centre_distances(clear: MapClearance) -> np.ndarray:
    """The exact distance (m) from each cell's centre to the blocked cells, row 0 at the bottom
    (computed once per ``MapClearance``, read-only)."""
    got = _CENTRES.get(clear)
    if got is None:
        rows, cols = clear.occupancy.shape
        v, u = np.mgrid[0:rows, 0:cols] + 0.5
        got = clear.grid_distance(u, v).reshape(rows, cols) * clear.occupancy.resolution
        got.setflags(write=False)
        _CENTRES[clear] = got
    return got


class _StateCheck:
    """OMPL's state validity checker: ``clear.clearance(x, y, radius) >= margin`` (a callable of
    an SE2 state). A byte per cell says whether the cell-centre bound settles its points (1: all
    valid, 0: all invalid, 2: ask the exact clearance); off the map the exact clearance is asked."""

    def __init__(self, clear: MapClearance, radius: float, margin: float):
        occ = clear.occupancy
        self.clear, self.radius, self.margin = clear, radius, margin
        centre = _centre_distances(clear)
        need, half = radius + margin, HALF_DIAGONAL * occ.resolution + SLACK
        verdict = np.full(centre.shape, 2, np.uint8)
        verdict[centre - half >= need] = 1
        verdict[centre + half < need] = 0
        self.verdict = verdict.tobytes()
        self.rows, self.cols = occ.shape
        x0, y0, yaw = occ.origin
        self.x0, self.y0, self.res = x0, y0, occ.resolution
        self.cos, self.sin = math.cos(yaw), math.sin(yaw)
        self.exact_calls = 0

    def exact(self, x: float, y: float) -> bool:
        self.exact_calls += 1
        return bool(self.clear.clearance(x, y, self.radius) >= self.margin)

    def __call__(self, state) -> bool:
        x, y = state.getX(), state.getY()
        dx, dy = x - self.x0, y - self.y0
        u = (self.cos * dx + self.sin * dy) / self.res
        v = (self.cos * dy - self.sin * dx) / self.res
        if 0.0 <= u < self.cols and 0.0 <= v < self.rows:
            verdict = self.verdict[int(v) * self.cols + int(u)]
            if verdict != 2:
                return verdict == 1
        return self.exact(x, y)


# --------------------------------------------------------------------------- planning


@contextmanager
def _quiet():
    """OMPL's log off (it prints at INFO and DEBUG by default), its level restored after."""
    from ompl import util as ou

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    try:
        yield
    finally:
        ou.setLogLevel(level)


def _setup(clear: MapClearance, check: _StateCheck, settings: OmplSettings):
    """OMPL's ``SimpleSetup``: the space, its bounds, the checks, the objective, the planner."""
    from ompl import base as ob
    from ompl import geometric as og

    rs = settings.space == "reeds_shepp"
    space = (ob.ReedsSheppStateSpace if rs else ob.DubinsStateSpace)(settings.turning_radius)
    bounds, extent = ob.RealVectorBounds(2), clear.occupancy.extent
    for axis in (0, 1):
        bounds.setLow(axis, extent[2 * axis])
        bounds.setHigh(axis, extent[2 * axis + 1])
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(check)
    si = ss.getSpaceInformation()
    motions = ob.ReedsSheppMotionValidator if rs else ob.DubinsMotionValidator
    si.setMotionValidator(motions(si))
    # A fraction of the space's extent: states along a motion at most `resolution` apart.
    si.setStateValidityCheckingResolution(settings.resolution / space.getMaximumExtent())
    ss.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
    ss.setPlanner(getattr(og, settings.planner)(si))
    return ss, space


def _solution_seen(ss):
    """Whether the planner holds an exact solution yet: its best cost is finite (RRT*, BIT*,
    AORRTC publish their path only at the end), or the problem has one (RRT, RRTConnect)."""
    planner, pdef = ss.getPlanner(), ss.getProblemDefinition()
    if hasattr(planner, "bestCost"):
        return lambda: math.isfinite(planner.bestCost().value())
    return pdef.hasExactSolution


def _state(space, pose):
    s = space.allocState()
    s.setXY(float(pose[0]), float(pose[1]))
    s.setYaw(float(pose[2]))
    return s


def _pose(value, key: str) -> np.ndarray:
    pose = checks.vector(value, 3, key, " [x, y, theta]")
    checks.magnitude(pose[:2], key, checks.COORDINATE_MAX)
    if not abs(pose[2]) <= checks.HEADING_MAX:
        raise ScenarioError(f"{key}[2]: must be at most {checks.HEADING_MAX:g} in size")
    return pose


def _check_ends(clear, check, start, goal, radius, settings) -> OmplPath | None:
    """A failure when the start or the goal lies off the map's box or is not a valid state."""
    xmin, xmax, ymin, ymax = clear.occupancy.extent
    for key, pose in (("start", start), ("goal", goal)):
        if not (xmin <= pose[0] <= xmax and ymin <= pose[1] <= ymax):
            return _failure(settings, f"Invalid {key}", f"{key}: off the map's extent")
        if not check.exact(pose[0], pose[1]):
            c, need = float(clear.clearance(pose[0], pose[1], radius)), settings.clearance_margin
            msg = f"{key}: clearance {c:.4g} m at radius {radius:g} m, below the margin {need:g} m"
            return _failure(settings, f"Invalid {key}", msg)
    return None


def ompl_plan(
    clear: MapClearance, start, goal, radius: float, settings: OmplSettings | None = None
) -> OmplPath:
    """Plan from ``start`` to ``goal`` (poses ``x, y, theta``) for a disc robot of ``radius`` (m)
    with OMPL (module docstring: the space, the checks, the objective), within
    ``settings.time_limit``; the path is simplified if ``settings.simplify``, checked again, and
    sampled every ``settings.step`` metres or closer.

    A query OMPL cannot solve gives ``solved`` False, ``status`` and ``message`` saying why (a
    start or goal in collision or off the map, no exact solution in time); bad arguments raise
    ``ScenarioError`` or ``SettingsError``, and a missing OMPL ``ImportError``.

    Determinism: OMPL's global seed is set to ``settings.seed + 1`` before every plan, so the
    random draws repeat from one plan to the next; but a time-limited planner runs as many
    iterations as fit in the time, so its answer depends on the machine's speed and load. Only
    planners that stop at their first path (RRTConnect, RRT) repeat their answer exactly. The
    seed and OMPL's log level (silenced during the plan) are the process's: plan in one thread.
    """
    if not ompl_available():
        raise ImportError(OMPL_MISSING)
    from ompl import util as ou

    settings = OmplSettings() if settings is None else settings
    if not isinstance(clear, MapClearance):
        raise ScenarioError(f"clear: expected a MapClearance, got {describe(clear)}")
    start, goal = _pose(start, "start"), _pose(goal, "goal")
    radius = checks.real(radius, "radius", ge=0)
    check = _StateCheck(clear, radius, settings.clearance_margin)
    failed = _check_ends(clear, check, start, goal, radius, settings)
    if failed is not None:
        return failed
    with _quiet():
        t0 = time.perf_counter()
        ou.RNG.setSeed(settings.seed + 1)
        ss, space = _setup(clear, check, settings)
        ends = [_state(space, start), _state(space, goal)]  # alive while OMPL works
        ss.setStartAndGoalStates(*ends)
        status, first = _solve(ss, settings, t0)
        exact = bool(ss.haveExactSolutionPath())
        t1 = time.perf_counter()
        if exact and settings.simplify:
            ss.simplifySolution()  # to the end (no time limit): repeatable
        simplify_time = time.perf_counter() - t1
        path = ss.getSolutionPath() if exact else None
        valid = path is not None and bool(path.check())
        plan_time = time.perf_counter() - t0
        if not exact:
            return _failure(settings, status, f"no exact solution in {plan_time:.3g} s", plan_time)
        poses, ds = _densify(space, path.getStates(), settings.step)
    times = (plan_time, first, simplify_time)
    return _finish(clear, radius, settings, poses, ds, valid, times, status)


def _solve(ss, settings: OmplSettings, t0: float) -> tuple[str, float]:
    """Run the planner until ``t0 + time_limit`` (or its own end): OMPL's status word, and the
    time from ``t0`` to the first exact solution (``nan`` if none)."""
    from ompl import base as ob

    first = []
    found = _solution_seen(ss)

    def stop() -> bool:  # asked by the planner at every iteration
        now = time.perf_counter() - t0
        if not first and found():
            first.append(now)
        return now >= settings.time_limit

    status = ss.solve(ob.PlannerTerminationCondition(stop)).asString()
    if not first and ss.haveExactSolutionPath():  # RRT, RRTConnect: they stop at the first
        first.append(time.perf_counter() - t0)
    return status, first[0] if first else math.nan


def _densify(space, states, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Poses along the curves between OMPL's ``states``, at most ``step`` apart, and the
    arclength of each piece between two poses (the curves are parametrised by arclength)."""
    out = [(states[0].getX(), states[0].getY(), states[0].getYaw())]
    ds: list[float] = []
    tmp = space.allocState()
    for a, b in zip(states[:-1], states[1:], strict=True):
        length = space.distance(a, b)
        n = max(1, math.ceil(length / step))
        for k in range(1, n + 1):
            space.interpolate(a, b, k / n, tmp)
            out.append((tmp.getX(), tmp.getY(), tmp.getYaw()))
        ds += [length / n] * n
    return np.array(out), np.array(ds)


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles (differences of headings) into ``[-pi, pi)``: OMPL's headings are angles."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def _directions(poses: np.ndarray, ds: np.ndarray) -> np.ndarray:
    """+1 or -1 per piece between two poses: the sign of the displacement along the mean
    heading. A piece that holds a cusp moves little (its two parts cancel): below half its
    arclength it takes the direction of the piece before (after, at the start). A reverse part
    shorter than about a step may go unseen."""
    d = np.diff(poses[:, :2], axis=0)
    mid = poses[:-1, 2] + wrap_angle(np.diff(poses[:, 2])) / 2
    along = d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid)
    sign = np.where(along >= 0, 1, -1).astype(np.int8)
    clear_cut = np.abs(along) >= 0.5 * ds
    if not clear_cut.any():
        return sign
    idx = np.where(clear_cut, np.arange(sign.size), -1)
    idx = np.maximum.accumulate(idx)  # the last clear-cut piece at or before each piece
    idx[idx < 0] = np.flatnonzero(clear_cut)[0]
    return sign[idx]


def _finish(clear, radius, settings, poses, ds, valid, times, status) -> OmplPath:
    """The :class:`OmplPath` of a densified exact solution, checked again against the map."""
    arclength = np.concatenate([[0.0], np.cumsum(ds)])
    direction = _directions(poses, ds)
    curvature = np.abs(wrap_angle(np.diff(poses[:, 2]))) / np.maximum(ds, 1e-300)
    min_clear = float(clear.clearance(poses[:, 0], poses[:, 1], radius).min())
    cusps = int(np.count_nonzero(direction[1:] != direction[:-1]))
    solved = valid and min_clear >= 0.0
    if solved:
        message = f"{settings.planner}: length {arclength[-1]:.4g} m, {cusps} cusps"
    elif not valid:
        message = "OMPL's check of the (simplified) path failed"
    else:
        message = f"the densified path's clearance is {min_clear:.3g} m at radius {radius:g} m"
    for a in (poses, arclength, direction):
        a.setflags(write=False)
    return OmplPath(
        solved, poses, arclength, direction, float(arclength[-1]), *times,
        float(curvature.max()) if curvature.size else 0.0, cusps, min_clear, status, message,
        settings,
    )  # fmt: skip


def timed(path: OmplPath, horizon: float):
    """``path`` driven at constant speed ``length / horizon`` along its arclength, forward or in
    reverse as the path goes: ``(t, poses, v, omega)``, ``t`` from 0 to ``horizon`` (``N``),
    ``poses`` the path's (``N x 3``), and the speed ``v`` (negative in reverse) and turn rate
    ``omega`` that hold from ``t[k]`` to ``t[k + 1]`` (``N``; the last repeats the one before),
    so that the unicycle ``x' = v cos(theta), y' = v sin(theta), theta' = omega`` follows it."""
    horizon = checks.real(horizon, "horizon", gt=0)
    if not path.solved or path.poses.shape[0] < 2:
        raise ScenarioError("path: not solved, nothing to time")
    speed = path.length / horizon
    t = path.arclength * (horizon / path.length)
    t[-1] = horizon
    dt = np.diff(t)
    v = speed * path.direction.astype(float)
    omega = wrap_angle(np.diff(path.poses[:, 2])) / np.where(dt > 0, dt, np.inf)
    return t, path.poses.copy(), np.append(v, v[-1]), np.append(omega, omega[-1])


# --------------------------------------------------------------------------- the measurement


def random_queries(
    clear: MapClearance, n: int, seed: int, radius: float, clearance=0.3, min_distance=3.0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` seeded ``(start, goal)`` pose pairs on the map: each pose keeps ``clearance`` (m)
    beyond the footprint ``radius``, start and goal lie ``min_distance`` (m) apart or more, in
    one connected region of the cells whose centre keeps ``radius`` (a disc could drive between
    them; the turning radius may still forbid it), headings uniform. Depends only on the map and
    the arguments."""
    from scipy import ndimage

    n = require_integer("n", n, 0)
    rng = np.random.default_rng(require_integer("seed", seed, 0))
    occ = clear.occupancy
    regions, _ = ndimage.label(_centre_distances(clear) >= radius)
    xmin, xmax, ymin, ymax = occ.extent
    pool = np.empty((0, 2))
    for _ in range(100):  # points drawn in the map's box, kept where they are clear enough
        x, y = rng.uniform((xmin, ymin), (xmax, ymax), size=(4096, 2)).T
        keep = occ.contains(x, y) & (clear.clearance(x, y, radius) >= clearance)
        pool = np.vstack([pool, np.column_stack([x, y])[keep]])
        if len(pool) >= 2000:
            break
    i, j = occ.cell_index(pool[:, 0], pool[:, 1])
    region = regions[np.clip(i, 0, regions.shape[0] - 1), np.clip(j, 0, regions.shape[1] - 1)]
    out = []
    for _ in range(100 * n + 100):
        if len(out) == n or not len(pool):
            break
        a = rng.integers(len(pool))
        far = np.hypot(*(pool - pool[a]).T) >= min_distance
        ok = np.flatnonzero(far & (region == region[a]))
        if ok.size:
            b = ok[rng.integers(ok.size)]
            heading = rng.uniform(-np.pi, np.pi, 2)
            out.append((np.append(pool[a], heading[0]), np.append(pool[b], heading[1])))
    if len(out) < n:
        raise ScenarioError(f"{occ.name}: found only {len(out)} of {n} queries")
    return out


#: The fields of an :class:`OmplPath` that :func:`benchmark` keeps for each run.
RUN_FIELDS = ("solved", "length", "plan_time", "first_time", "simplify_time", "cusps",
              "max_curvature", "min_clearance", "message")  # fmt: skip


def benchmark(
    maps: Sequence[str],
    planners: Sequence[str] = ("RRTstar", "BITstar"),
    time_limits: Sequence[float] = (1.0, 5.0),
    queries: int = 20,
    seed: int = 0,
    radius: float = 0.2,
    progress=None,
    **options,
) -> list[dict]:
    """Every planner at every time limit on the same :func:`random_queries` (``queries`` per
    map, ``seed``; a ROS map YAML path each) for a robot of ``radius``; ``options`` are further
    :class:`OmplSettings` fields (``space``, ``turning_radius``, ...). OMPL's seed is ``seed +
    k`` for query ``k``. ``progress(text)`` is called before each plan. A row per run: ``map``,
    ``query`` (its index), ``planner``, ``time_limit`` and the :data:`RUN_FIELDS` of the path."""
    from ..world import load_ros_map

    runs = []
    for path in maps:
        clear = MapClearance(load_ros_map(path))
        name = clear.occupancy.name
        for k, (start, goal) in enumerate(random_queries(clear, queries, seed, radius)):
            for planner in planners:
                for limit in time_limits:
                    s = OmplSettings.from_mapping(
                        {**options, "planner": planner, "time_limit": limit, "seed": seed + k}
                    )
                    if progress is not None:
                        progress(f"{name} query {k + 1}/{queries} {planner} {limit:g} s")
                    p = ompl_plan(clear, start, goal, radius, s)
                    row = {"map": name, "query": k, "planner": planner, "time_limit": limit}
                    runs.append(row | {key: getattr(p, key) for key in RUN_FIELDS})
    return runs


def summarize(runs: Sequence[dict]) -> list[dict]:
    """Per map, planner and time limit: queries, solved, success rate, the median length (m)
    of the solved queries and of those every planner and limit solved on that map (``common``:
    like for like), the median plan time and time to the first solution (s)."""

    def median(values):
        values = [v for v in values if math.isfinite(v)]
        return statistics.median(values) if values else math.nan

    keys = list(dict.fromkeys((r["map"], r["planner"], r["time_limit"]) for r in runs))
    out = []
    for m, planner, limit in keys:
        on_map = [r for r in runs if r["map"] == m]
        common = {r["query"] for r in on_map} - {r["query"] for r in on_map if not r["solved"]}
        mine = [r for r in on_map if (r["planner"], r["time_limit"]) == (planner, limit)]
        solved = [r for r in mine if r["solved"]]
        out.append({
            "map": m, "planner": planner, "time_limit": limit, "queries": len(mine),
            "solved": len(solved), "success": len(solved) / len(mine),
            "median_length": median([r["length"] for r in solved]),
            "median_length_common": median([r["length"] for r in solved if r["query"] in common]),
            "common": len(common),
            "median_time": median([r["plan_time"] for r in mine]),
            "median_first_time": median([r["first_time"] for r in solved]),
        })  # fmt: skip
    return out


def _table(rows: list[dict]) -> str:
    head = "| map | planner | limit (s) | solved | median length (m) | median length, common (m) |"
    lines = [head + " median time (s) | median first solution (s) |", "|" + " --- |" * 8]
    for r in rows:
        lines.append(
            f"| {r['map']} | {r['planner']} | {r['time_limit']:g} | {r['solved']}/{r['queries']}"
            f" | {r['median_length']:.3f} | {r['median_length_common']:.3f} (of {r['common']})"
            f" | {r['median_time']:.3f} | {r['median_first_time']:.3f} |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """The measurement from the command line: ``python -m
    leapfrog_planner.experiments.ompl_peer MAP.yaml ... [--queries 20] [--csv FILE]``; prints
    a Markdown table (progress on stderr)."""
    import csv
    import sys

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("maps", nargs="+", help="ROS map YAML files")
    ap.add_argument("--planners", default="RRTstar,BITstar")
    ap.add_argument("--time-limits", default="1,5")
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--radius", type=float, default=0.2, help="the robot's disc (m)")
    ap.add_argument("--space", default="reeds_shepp")
    ap.add_argument("--turning-radius", type=float, default=0.3)
    ap.add_argument("--csv", help="write every run to this file")
    a = ap.parse_args(argv)
    runs = benchmark(
        a.maps, a.planners.split(","), [float(t) for t in a.time_limits.split(",")],
        a.queries, a.seed, a.radius, lambda text: print(text, file=sys.stderr, flush=True),
        space=a.space, turning_radius=a.turning_radius,
    )  # fmt: skip
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(runs[0]))
            w.writeheader()
            w.writerows(runs)
    print(_table(summarize(runs)))


if __name__ == "__main__":
    main()
