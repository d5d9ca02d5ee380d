"""Plans on maps by the planner-benchmark protocol of the ROS 2 navigation stack.

    python benchmarks/bench_map_plans.py [--n 100] [--maps depot,tb3_sandbox,office,...]
                                         [--weight 1.0] [--seed 0] [--size 1000] [--json out]
                                         [--cruise-speed V] [--option KEY=VALUE ...]
                                         [--robot KEY=VALUE ...]

Per map: ``--n`` random queries (``leapfrog generate --map``: start and goal at least 0.3 m from
every blocked cell, more than 3 m apart, headings uniform, connected for the robot), robot
radius 0.2 m, horizon = the query's shortest path at 0.5 m/s. Each query is planned in this
process after a warm-up plan (numba's kernels loaded), one at a time. Printed per query (with
``--verbose``) and per map: how many converged, how many converged answers touch a blocked cell
(must be 0), how many failures hand back a collision-free motion, and the median and 95th
percentile of the plan's wall time; and the time to load the map and build its penalty field.
The real maps (depot, tb3_sandbox) are read from ``../shared/maps`` (navigation2's); office,
warehouse and shapes are the synthetic maps of ``world/synthetic.py`` (``--size`` cells a
side). ``--cruise-speed V``: the same queries with a free final time at a cruise speed of V m/s
(the planner chooses how long to take; ``horizon`` in the rows is then the time it chose).
``--option KEY=VALUE`` (repeatable): a planner setting for every plan, as ``leapfrog solve
--option`` takes it (``--option partitions=32 --option fewest_arcs=16`` for long horizons).
``--robot KEY=VALUE`` (repeatable): the vehicle model and its parameters, as a scenario's
``[robot]`` table gives them (``--robot model=diff-drive --robot wheel_radius=0.033 --robot
axle_length=0.16``: a TurtleBot3's wheels). With ``--verbose`` each query's line gives the
obstacle weight of its answer (raised where the extremals at the map's weight collided).
No assertions.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from leapfrog_planner.batch.generate import map_scenarios
from leapfrog_planner.cli.common import planner_options
from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario_time import FreeTime
from leapfrog_planner.world import nonconvex_field, office_maze, save_ros_map, warehouse

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps"
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


def run(scenarios, verbose: bool, options: dict) -> list[dict]:
    rows = []
    for sc in scenarios:
        t0 = time.perf_counter()
        r = Planner(sc, **options).plan()
        horizon = sc.horizon if r.free_time is None else r.free_time.horizon
        row = {"query": sc.name, "status": str(r.status), "cost": r.cost, "horizon": horizon,
               "wall_s": time.perf_counter() - t0, "clearance": r.min_clearance,
               "message": r.message,
               "condition": None if r.free_time is None else r.free_time.condition}  # fmt: skip
        rows.append(row)
        if verbose:
            print(f"  {sc.name} T={horizon:.1f}: {row['status']} {row['cost']:.6g}"
                  f" (weight {r.weight:g}) in {row['wall_s']:.2f} s", flush=True)  # fmt: skip
    return rows


def robot_fields(pairs: list[str]) -> dict:
    """``--robot`` pairs as scenario fields: ``model`` and ``model_parameters``."""
    fields: dict = {}
    params = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep:
            raise SystemExit(f"--robot {pair!r}: expected KEY=VALUE")
        if key == "model":
            fields["model"] = value
        else:
            params[key] = float(value)
    if params:
        fields["model_parameters"] = params
    return fields


def summary(name: str, rows: list[dict]) -> str:
    n = len(rows)
    conv = [r for r in rows if r["status"] == "converged"]
    touch = [r for r in conv if r["clearance"] is None or r["clearance"] < 0.0]
    failed = [r for r in rows if r["status"] != "converged"]
    handed = [r for r in failed if r["clearance"] is not None and r["clearance"] >= 0.0]
    times = sorted(r["wall_s"] for r in rows)
    p95 = times[min(n - 1, round(0.95 * (n - 1)))]
    return (f"{name}: {len(conv)}/{n} converged, {len(touch)} converged touching a blocked"
            f" cell, {len(handed)}/{len(failed)} failures with a collision-free motion; plan"
            f" median {statistics.median(times):.3f} s, p95 {p95:.3f} s")  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100)
    parser.add_argument("--maps", default="depot,tb3_sandbox,office,warehouse,shapes")
    parser.add_argument("--weight", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--size", type=int, default=1000, help="synthetic maps' cells a side")
    parser.add_argument("--verbose", action="store_true", help="a line per query")
    parser.add_argument("--json", default=None, help="write every plan's row here")
    parser.add_argument("--cruise-speed", type=float, default=None,
                        help="a free final time at this cruise speed (m/s)")  # fmt: skip
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                        help="a planner setting for every plan (repeatable)")  # fmt: skip
    parser.add_argument("--robot", action="append", default=[], metavar="KEY=VALUE",
                        help="the model (model=NAME) and its parameters (repeatable)")  # fmt: skip
    args = parser.parse_args(argv)
    options = planner_options(args.option)
    robot = robot_fields(args.robot)
    out, warm = {}, False
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.maps.split(","):
            path = map_file(name, Path(tmp), args.size)
            t0 = time.perf_counter()
            scenarios = map_scenarios(path, args.n, args.seed, weight=args.weight, prefix=name)
            if args.cruise_speed is not None:  # the unicycle's price of time: v^2 / 2
                v = args.cruise_speed
                free = FreeTime(v * v / 2, v)
                scenarios = [dataclasses.replace(sc, free_time=free) for sc in scenarios]
            scenarios = [dataclasses.replace(sc, **robot) for sc in scenarios]
            made = time.perf_counter() - t0
            if not warm:  # numba's kernels loaded before anything is timed
                run(scenarios[:1], False, options)
                warm = True
            out[name] = run(scenarios, args.verbose, options)
            print(f"{summary(name, out[name])} (queries and field {made:.1f} s)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
