"""Leapfrog beside OMPL on a map: the same queries, footprint and horizon, scored with one cost.

Queries come from the ROS 2 navigation stack's planner-benchmark protocol
(:func:`..batch.generate.map_scenarios`: start and goal in free space, more than 3 m apart,
headings uniform, connected for the robot; the horizon the shortest route at ``speed``). On each:

- **Leapfrog**: the planner, in this process (warm), its cost ``J = int 1/2 (v^2 + omega^2) + P``
  (where the planner raised the obstacle weight to clear the obstacles, its motion is scored
  at the query's own weight, as OMPL's is).
- **OMPL** (:mod:`.ompl_peer`): a sampling-based planner in a Reeds-Shepp or Dubins space for
  the same disc footprint against the same exact clearance, its path driven at constant speed
  over the same horizon (:func:`.ompl_peer.timed`) and scored with the same ``J``
  (:func:`path_cost`: the controls are constant between its poses, so the energy is exact; the
  penalty by the trapezoidal rule on poses at most 2 cm apart).

Per query and solver: success (Leapfrog: ``converged``; OMPL: an exact, collision-free path),
cost, wall time, the largest curvature ``|omega / v|`` (infinite where the robot turns in place)
and the least clearance. :func:`summary` gives, over the queries both solve, how often Leapfrog
is cheaper and the median ratio of the costs.
"""

from __future__ import annotations

import csv
import io
import json
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from .. import checks
from .._atomic import write_text_atomic
from ..errors import SettingsError, require_integer
from .paper import ExperimentEvent

SOLVERS = ("leapfrog", "ompl")


@dataclass(frozen=True)
class MapBenchSettings:
    """What :func:`run_map_bench` measures: ``queries`` protocol queries (``seed``) for a robot
    of ``radius`` at ``speed`` (the horizon) and penalty ``weight``; OMPL's ``ompl_planner`` in
    its ``ompl_space`` with ``turning_radius``, given ``ompl_time`` seconds per query."""

    queries: int = 10
    seed: int = 0
    radius: float = 0.2
    speed: float = 0.5
    weight: float = 1.0
    ompl_planner: str = "BITstar"
    ompl_space: str = "reeds_shepp"
    ompl_time: float = 1.0
    turning_radius: float = 0.3

    def __post_init__(self):
        put = object.__setattr__
        put(self, "queries", require_integer("queries", self.queries, 1, 10_000))
        put(self, "seed", require_integer("seed", self.seed, 0, 2**31 - 2))
        for key, low, high in (("radius", 0.0, 100.0), ("speed", 1e-3, 100.0),
                               ("weight", 0.0, 1e6), ("ompl_time", 1e-3, 3600.0),
                               ("turning_radius", 1e-3, 1e3)):  # fmt: skip
            value = checks.real(getattr(self, key), key, error=SettingsError)
            put(self, key, checks.in_range(value, key, low, high, error=SettingsError))
        self.ompl_settings(0)  # OMPL's own checks of the planner and space

    def ompl_settings(self, query: int):
        from .ompl_peer import OmplSettings

        return OmplSettings(planner=self.ompl_planner, space=self.ompl_space,
                            turning_radius=self.turning_radius, time_limit=self.ompl_time,
                            seed=self.seed + query)  # fmt: skip


@dataclass(frozen=True)
class MapBenchRow:
    """One solver on one query."""

    query: str
    solver: str
    success: bool
    cost: float  # nan when it found no path
    time_s: float
    max_curvature: float  # 1/m; inf where the robot turns in place
    min_clearance: float  # m beyond the footprint; nan when it found no path
    horizon: float
    message: str


@dataclass(frozen=True)
class MapBenchResult:
    map_file: str
    settings: MapBenchSettings
    rows: tuple[MapBenchRow, ...]


def path_cost(problem, t, poses, v, omega) -> float:
    """``J = int 1/2 (v^2 + omega^2) + P dt`` of a motion whose controls ``v[k], omega[k]``
    hold from ``t[k]`` to ``t[k + 1]`` through ``poses`` (``N x 3``) of the unicycle, the penalty
    ``P`` of ``problem`` by the trapezoidal rule on the poses."""
    dt = np.diff(np.asarray(t, dtype=float))
    energy = 0.5 * float(np.sum((v[:-1] ** 2 + omega[:-1] ** 2) * dt))
    P = np.asarray(problem.penalty(np.asarray(poses, dtype=float)[:, :2]), dtype=float)
    return energy + float(np.sum(0.5 * (P[1:] + P[:-1]) * dt))


def curvature(v, omega) -> float:
    """The largest ``|omega / v|`` (``inf`` where ``v`` vanishes and ``omega`` does not)."""
    v, omega = np.abs(np.asarray(v, dtype=float)), np.abs(np.asarray(omega, dtype=float))
    moving = v > 1e-9 * max(float(v.max(initial=0.0)), 1e-300)
    turning = omega > 1e-9 * max(float(omega.max(initial=0.0)), 1e-300)
    if np.any(turning & ~moving):
        return math.inf
    return float(np.max(omega[moving] / v[moving], initial=0.0))


def run_map_bench(
    map_file, settings: MapBenchSettings, progress: Callable[[ExperimentEvent], None] | None = None
) -> MapBenchResult:
    """Leapfrog and OMPL on the same queries of ``map_file`` (module docstring); ``progress``
    hears of each run before it starts."""
    from ..batch.generate import map_scenarios
    from ..planning.planner import Planner

    scenarios = map_scenarios(str(map_file), settings.queries, settings.seed,
                              radius=settings.radius, speed=settings.speed,
                              weight=settings.weight)  # fmt: skip
    Planner(scenarios[0]).plan()  # warm-up: kernels loaded, the map's field built
    rows: list[MapBenchRow] = []
    total = 2 * len(scenarios)
    for k, sc in enumerate(scenarios):
        if progress is not None:
            progress(ExperimentEvent(2 * k, total, f"{sc.name}: leapfrog"))
        rows.append(_leapfrog_row(sc))
        if progress is not None:
            progress(ExperimentEvent(2 * k + 1, total, f"{sc.name}: OMPL"))
        rows.append(_ompl_row(sc, settings.ompl_settings(k)))
    return MapBenchResult(str(map_file), settings, tuple(rows))


def _leapfrog_row(sc) -> MapBenchRow:
    from ..planning.planner import Planner

    t0 = time.perf_counter()
    r = Planner(sc).plan()
    wall = time.perf_counter() - t0
    traj = r.trajectory
    v, omega = (traj.u[:, 0], traj.u[:, 1]) if traj is not None else (np.zeros(1), np.zeros(1))
    clear = r.min_clearance if r.min_clearance is not None else math.nan
    cost = float(r.cost)
    if traj is not None and r.weight != sc.weight:  # its cost at the query's own weight
        cost = path_cost(sc.problem(), traj.t, traj.x, v, omega)
    return MapBenchRow(sc.name, "leapfrog", bool(r.success), cost, wall,
                       curvature(v, omega), float(clear), sc.horizon, r.message)  # fmt: skip


def _ompl_row(sc, ompl) -> MapBenchRow:
    from .ompl_peer import ompl_plan, timed, wrap_angle

    world = sc.map.obstacles(sc.robot_radius)
    t0 = time.perf_counter()
    p = ompl_plan(world.cells, sc.start, sc.goal, sc.robot_radius, ompl)
    wall = time.perf_counter() - t0
    if not p.solved:
        return MapBenchRow(sc.name, "ompl", False, math.nan, wall, math.nan, math.nan,
                           sc.horizon, p.message)  # fmt: skip
    t, poses, v, omega = timed(p, sc.horizon)
    cost = path_cost(sc.problem(), t, poses, v, omega)
    # OMPL's headings are angles: its path may end whole turns away from the goal's heading.
    heading = poses[0, 2] + float(np.sum(wrap_angle(np.diff(poses[:, 2]))))
    turns = round((heading - float(sc.goal[2])) / (2.0 * math.pi))
    message = p.message if turns == 0 else f"{p.message}; ends {turns:+d} turns from the goal"
    return MapBenchRow(sc.name, "ompl", True, cost, wall, p.max_curvature, p.min_clearance,
                       sc.horizon, message)  # fmt: skip


def summary(result: MapBenchResult) -> dict:
    """Per solver: successes, median time, the largest curvature; over the queries both solve:
    how many Leapfrog answers at most OMPL's cost, and the median of Leapfrog's cost over
    OMPL's."""
    out: dict = {"queries": result.settings.queries}
    for solver in SOLVERS:
        rows = [r for r in result.rows if r.solver == solver]
        out[solver] = {
            "succeeded": sum(r.success for r in rows),
            "median_time_s": statistics.median(r.time_s for r in rows),
            "max_curvature": max((r.max_curvature for r in rows if r.success), default=math.nan),
        }
    ours = {r.query: r for r in result.rows if r.solver == "leapfrog" and r.success}
    theirs = {r.query: r for r in result.rows if r.solver == "ompl" and r.success}
    both = sorted(set(ours) & set(theirs))
    ratios = [ours[q].cost / theirs[q].cost for q in both]
    out["both_solved"] = len(both)
    out["leapfrog_cheaper"] = sum(ours[q].cost <= theirs[q].cost for q in both)
    out["median_cost_ratio"] = statistics.median(ratios) if ratios else math.nan
    return out


def report(result: MapBenchResult) -> str:
    """The measurement as Markdown: settings, the summary, a row per query and solver."""
    s, head = result.settings, summary(result)
    lines = [
        f"# Leapfrog and OMPL on {Path(result.map_file).name}",
        "",
        f"{s.queries} queries (seed {s.seed}) by the planner-benchmark protocol; robot radius"
        f" {s.radius:g} m, horizon the shortest route at {s.speed:g} m/s, weight {s.weight:g};"
        f" OMPL {s.ompl_planner} in {s.ompl_space} (turning radius {s.turning_radius:g} m),"
        f" {s.ompl_time:g} s per query, its path driven at constant speed over the horizon and"
        " scored with the same cost J = int 1/2 (v^2 + omega^2) + P dt.",
        "",
        "| solver | succeeded | median time | largest curvature |",
        "|---|---|---|---|",
    ]
    for solver in SOLVERS:
        h = head[solver]
        lines.append(f"| {solver} | {h['succeeded']}/{s.queries} |"
                     f" {h['median_time_s']:.3g} s | {h['max_curvature']:.3g} 1/m |")  # fmt: skip
    lines += [
        "",
        f"Both solved {head['both_solved']}: Leapfrog at most OMPL's cost on"
        f" {head['leapfrog_cheaper']}, median cost ratio (Leapfrog / OMPL)"
        f" {head['median_cost_ratio']:.3g}.",
        "",
        "| query | solver | success | cost | time (s) | curvature (1/m) | clearance (m) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result.rows:
        lines.append(f"| {r.query} | {r.solver} | {'yes' if r.success else 'no'} |"
                     f" {r.cost:.6g} | {r.time_s:.3g} | {r.max_curvature:.3g} |"
                     f" {r.min_clearance:.3g} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def write_map_bench(result: MapBenchResult, folder) -> None:
    """``bench_map.md``, ``bench_map.csv`` (a row per query and solver) and ``bench_map.json``
    (settings, summary, rows) in ``folder``."""
    folder = Path(folder)
    names = [f.name for f in fields(MapBenchRow)]
    table = io.StringIO(newline="")
    w = csv.writer(table)
    w.writerow(names)
    w.writerows([getattr(r, n) for n in names] for r in result.rows)
    data = {"map_file": result.map_file, "settings": asdict(result.settings),
            "summary": summary(result), "rows": [asdict(r) for r in result.rows]}  # fmt: skip
    texts = {
        "bench_map.md": report(result),
        "bench_map.csv": table.getvalue(),
        "bench_map.json": json.dumps(_plain(data), indent=1, allow_nan=False) + "\n",
    }
    for name, text in texts.items():
        write_text_atomic(folder / name, text)


def _plain(value):
    """``value`` with non-finite numbers as strings ("nan", "inf"): strict JSON."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value
