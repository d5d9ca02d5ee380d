"""Plans on maps by the planner-benchmark protocol of the ROS 2 navigation stack.

    python benchmarks/bench_map_plans.py [--n 100] [--maps depot,tb3_sandbox,office,warehouse,shapes]
                                         [--weight 1.0] [--seed 0] [--json out.json]

Per map: ``--n`` random queries (start and goal in free space at least 0.3 m from every blocked
cell, at least 3 m apart, headings uniform, connected for the robot; ``world/queries.py``),
robot radius 0.2 m, horizon = the query's shortest path at 0.5 m/s. Each query is planned in this
process after a warm-up plan (numba's kernels loaded), one at a time. Printed per map: how many
converged, how many converged answers touch a blocked cell (must be 0), how many failures hand
back a collision-free motion, and the median and 95th percentile of the plan's wall time; and
the time to load the map and build its penalty field. The real maps are read from
``../shared/maps`` (navigation2's depot and tb3_sandbox) when that folder exists; the others
are the synthetic maps of ``world/synthetic.py``, 1000 x 1000 cells at 5 cm (``--big`` makes them
2000 x 2000). No assertions.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario import Scenario
from leapfrog_planner.planning.scenario_map import ScenarioMap
from leapfrog_planner.world import load_ros_map
from leapfrog_planner.world.queries import random_queries
from leapfrog_planner.world.ros_map_write import save_ros_map
from leapfrog_planner.world.synthetic import nonconvex_field, office_maze, warehouse

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps"
RADIUS, SPEED, CLEARANCE, MIN_DISTANCE = 0.2, 0.5, 0.3, 3.0
SYNTHETIC = {"office": office_maze, "warehouse": warehouse, "shapes": nonconvex_field}


def map_file(name: str, folder: Path, size: int) -> Path:
    """The YAML of map ``name``: a real one from the shared folder, or a synthetic one written
    to ``folder``."""
    if name in SYNTHETIC:
        path = folder / f"{name}.yaml"
        save_ros_map(SYNTHETIC[name](size=size, seed=0), path)
        return path
    path = SHARED / f"{name}.yaml"
    if not path.exists():
        raise SystemExit(f"{path}: not found (the real maps come from ../shared/maps)")
    return path


def queries_of(world: ScenarioMap, n: int, seed: int):
    clear = world.obstacles(RADIUS).cells
    return random_queries(clear, n, seed=seed, radius=RADIUS, clearance=CLEARANCE,
                          min_distance=MIN_DISTANCE)  # fmt: skip


def plan_queries(name: str, world: ScenarioMap, queries, weight: float) -> dict:
    base = Scenario(name=name, horizon=1.0, start=np.zeros(3), goal=np.ones(3), weight=weight,
                    robot_radius=RADIUS, map=None)  # fmt: skip
    rows = []
    for k, q in enumerate(queries):
        sc = replace(base, name=f"{name}-{k:03d}", horizon=max(q.shortest / SPEED, 1.0),
                     start=np.array(q.start), goal=np.array(q.goal), map=world)  # fmt: skip
        t0 = time.perf_counter()
        r = Planner(sc).plan()
        wall = time.perf_counter() - t0
        clear = r.min_clearance
        rows.append({"query": k, "status": str(r.status), "cost": r.cost, "wall_s": wall,
                     "clearance": clear, "message": r.message})  # fmt: skip
    return {"map": name, "rows": rows}


def summary(block: dict) -> str:
    rows = block["rows"]
    n = len(rows)
    conv = [r for r in rows if r["status"] == "converged"]
    touch = [r for r in conv if r["clearance"] is None or r["clearance"] < 0.0]
    failed = [r for r in rows if r["status"] != "converged"]
    handed = [r for r in failed if r["clearance"] is not None and r["clearance"] >= 0.0]
    times = sorted(r["wall_s"] for r in rows)
    p95 = times[min(len(times) - 1, int(round(0.95 * (len(times) - 1))))]
    return (f"{block['map']}: {len(conv)}/{n} converged ({100 * len(conv) / n:.0f}%),"
            f" {len(touch)} converged touching a blocked cell, {len(handed)}/{len(failed)} failures"
            f" with a collision-free motion; plan median {statistics.median(times):.3f} s,"
            f" p95 {p95:.3f} s")  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100)
    parser.add_argument("--maps", default="depot,tb3_sandbox,office,warehouse,shapes")
    parser.add_argument("--weight", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--big", action="store_true", help="synthetic maps of 2000 x 2000 cells")
    parser.add_argument("--json", default=None, help="write every plan's row here")
    args = parser.parse_args(argv)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.maps.split(","):
            path = map_file(name, Path(tmp), 2000 if args.big else 1000)
            t0 = time.perf_counter()
            world = ScenarioMap(str(path))
            world.obstacles(RADIUS)
            load = time.perf_counter() - t0
            queries = queries_of(world, args.n, args.seed)
            if not out:  # warm-up: numba's kernels loaded, not timed
                plan_queries("warm-up", world, queries[:1], args.weight)
            block = plan_queries(name, world, queries, args.weight)
            block["load_s"] = load
            rows, cols = world.occupancy.shape
            print(f"{summary(block)}; map {cols} x {rows} loaded and its field built in {load:.2f} s",
                  flush=True)  # fmt: skip
            out.append(block)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
