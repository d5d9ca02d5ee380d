"""Initial routes on occupancy maps (:func:`map_routes`): per-map preparation and query times.

    python benchmarks/bench_map_routes.py [--n 100] [--k 3] [--radius 0.2] [--margin 0.1]

Maps: navigation2's depot (604 x 307 cells) and TurtleBot3 sandbox (384 x 384) from
``../shared/maps`` beside the repository (the copies shipped with the tests when that folder is
missing), and a synthetic map of 2000 x 2000 cells at 5 cm (:func:`synthetic_map`: rooms of
12.5 m with doors, rows of shelves, 300 round pillars, an unknown corner; the origin turned by
0.3 rad).

Per map: the clearance's build (:class:`MapClearance`), the per-map preparation of the routes
(:func:`prepare_map`: the exact clearance field and the obstacles), the preparation for the
radius and margin (connected components, obstacles, search graph), then ``--n`` queries between
random free points (start and goal uniform among the cells with at least ``radius`` clearance,
at least 3 m apart, as navigation2's planner benchmark draws them), and queries between points
that are not connected (an answer of ``[]``). Medians, 95th percentiles and maxima in
milliseconds, with the CPU time of the queries beside their wall time (the machine may be
shared); the routes found per query; the lengths of the later routes against the first. The
first call of a new process also compiles (or loads) the kernels: a warm-up query comes first.
No assertions; the targets are a median <= 200 ms on 2000 x 2000 cells, preparation <= 1 s.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from leapfrog_planner.planning.initial_path.map_routes import map_routes, prepare_map
from leapfrog_planner.world import FREE, OCCUPIED, UNKNOWN, MapClearance, OccupancyMap, load_ros_map

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps"
SHIPPED = Path(__file__).resolve().parents[1] / "tests" / "data" / "maps"


def shared_map(name: str) -> OccupancyMap:
    folder = SHARED if (SHARED / f"{name}.yaml").is_file() else SHIPPED
    return load_ros_map(str(folder / f"{name}.yaml"))


def synthetic_map(n: int = 2000, seed: int = 0) -> OccupancyMap:
    """Rooms of 250 cells (walls 4 cells thick, doors of 40 cells), in every other room two
    rows of shelves (8 x 120 cells), 300 round pillars (radius 3 to 15 cells), an unknown corner
    of 300 x 300 cells; 5 cm cells, the origin at (-50, -50) turned by 0.3 rad."""
    rng = np.random.default_rng(seed)
    blocked = np.zeros((n, n), bool)
    blocked[:, :3] = blocked[:, -3:] = blocked[:3] = blocked[-3:] = True
    for k in range(100, n, 250):
        blocked[k : k + 4, :] = True
        blocked[:, k : k + 4] = True
    for k in range(100, n, 250):
        for m in range(200, n, 250):
            blocked[k : k + 4, m : m + 40] = False
            blocked[m : m + 40, k : k + 4] = False
    for a, top in enumerate(range(104, n - 250, 250)):
        for b, left in enumerate(range(104, n - 250, 250)):
            if (a + b) % 2 == 0:
                for row in (top + 70, top + 160):
                    blocked[row : row + 8, left + 60 : left + 180] = True
    yy, xx = np.mgrid[:n, :n]
    for cx, cy, r in zip(*rng.uniform(0, n, (2, 300)), rng.uniform(3, 15, 300), strict=True):
        box = np.s_[
            max(int(cy - r - 1), 0) : int(cy + r + 2), max(int(cx - r - 1), 0) : int(cx + r + 2)
        ]
        blocked[box] |= (xx[box] + 0.5 - cx) ** 2 + (yy[box] + 0.5 - cy) ** 2 <= r * r
    data = np.where(blocked, OCCUPIED, FREE).astype(np.int8)
    data[:300, :300] = UNKNOWN
    return OccupancyMap(data, 0.05, (-50.0, -50.0, 0.3), name="synthetic 2000 x 2000")


def timed(f, cpu: list | None = None):
    """Wall time of ``f()`` and its result; its CPU time (this process's) appended to ``cpu``
    (the machine may be shared: the CPU time shows the work itself)."""
    start, start_cpu = time.perf_counter(), time.process_time()
    out = f()
    if cpu is not None:
        cpu.append(time.process_time() - start_cpu)
    return time.perf_counter() - start, out


def free_points(clear: MapClearance, radius: float) -> np.ndarray:
    """World centres of the cells with at least ``radius`` clearance."""
    occ = clear.occupancy
    i, j = np.nonzero(~clear.blocked)
    x, y = occ.cell_center(i, j)
    keep = clear.distance(x, y) >= radius
    return np.column_stack([x[keep], y[keep]])


def random_pairs(points: np.ndarray, n: int, rng, apart: float = 3.0) -> list:
    pairs = []
    while len(pairs) < n:
        a, b = points[rng.integers(points.shape[0], size=2)]
        if np.hypot(*(a - b)) >= apart:
            pairs.append((a, b))
    return pairs


def disconnected_pairs(clear: MapClearance, points: np.ndarray, radius: float, n: int, rng):
    """Pairs of free points in different connected components of the cells with clearance
    ``radius`` (none when the map's free space is one component)."""
    from scipy import ndimage

    occ = clear.occupancy
    i, j = np.nonzero(~clear.blocked)
    x, y = occ.cell_center(i, j)
    good = np.zeros(occ.shape, bool)
    good[i, j] = clear.distance(x, y) >= radius
    lab, count = ndimage.label(good)
    pi, pj = occ.cell_index(points[:, 0], points[:, 1])
    comp = lab[pi, pj]
    if count < 2 or np.unique(comp).size < 2:
        return []
    pairs = []
    while len(pairs) < n:
        a, b = rng.integers(points.shape[0], size=2)
        if comp[a] != comp[b]:
            pairs.append((points[a], points[b]))
    return pairs


def stats(times: list[float], cpu: list[float]) -> str:
    ms, cpu_ms = np.array(times) * 1e3, np.array(cpu) * 1e3
    return (
        f"median {statistics.median(ms):6.1f}  p95 {np.percentile(ms, 95):6.1f}  "
        f"max {ms.max():6.1f} ms (CPU: median {statistics.median(cpu_ms):6.1f}  "
        f"p95 {np.percentile(cpu_ms, 95):6.1f})"
    )


def report(name: str, occ: OccupancyMap, args) -> None:
    rng = np.random.default_rng(args.seed)
    print(f"\n== {name}: {occ.shape[1]} x {occ.shape[0]} cells of {occ.resolution:g} m")
    t_clear, clear = timed(lambda: MapClearance(occ))
    t_map, _ = timed(lambda: prepare_map(clear))
    t_radius, _ = timed(lambda: prepare_map(clear, args.radius, args.margin))
    print(f"MapClearance {t_clear * 1e3:.0f} ms; preparation: per map {t_map * 1e3:.0f} ms, for")
    print(f"the radius and margin (components, obstacles, search graph) {t_radius * 1e3:.0f} ms")
    points = free_points(clear, args.radius)
    pairs = random_pairs(points, args.n, rng)
    query = dict(radius=args.radius, margin=args.margin, k=args.k)
    times, cpu, counts, ratios, margins = [], [], [], [], []
    for a, b in pairs:
        dt, routes = timed(lambda a=a, b=b: map_routes(clear, a, b, **query), cpu)
        times.append(dt)
        counts.append(len(routes))
        ratios += [r.length / routes[0].length for r in routes[1:]]
        margins += [r.margin for r in routes[:1]]
    print(f"{args.n} random queries: {stats(times, cpu)}")
    found = np.bincount(counts, minlength=args.k + 1)
    print("routes per query: " + ", ".join(f"{c}: {n}" for c, n in enumerate(found)))
    if ratios:
        print(f"later routes / first: median {np.median(ratios):.3f}, max {max(ratios):.3f}")
    print(f"queries at a smaller margin than asked: {sum(m < args.margin for m in margins)}")
    apart = disconnected_pairs(clear, points, args.radius, max(args.n // 5, 5), rng)
    if apart:
        cpu = []
        times = [timed(lambda a=a, b=b: map_routes(clear, a, b, **query), cpu)[0] for a, b in apart]
        print(f"{len(apart)} disconnected queries ([]): {stats(times, cpu)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=100, help="random queries per map")
    parser.add_argument("--k", type=int, default=3)
    parser.add_argument("--radius", type=float, default=0.2)
    parser.add_argument("--margin", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--maps", default="depot,tb3_sandbox,synthetic")
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} (1 min)")
    warm = MapClearance(OccupancyMap(np.zeros((20, 20), np.int8), 0.05))
    map_routes(warm, (0.2, 0.2), (0.8, 0.8), 0.05, 0.05)  # compile or load the kernels
    for name in args.maps.split(","):
        occ = synthetic_map() if name == "synthetic" else shared_map(name)
        report(name, occ, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
