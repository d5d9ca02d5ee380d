"""Maps: load time, the clearance's and the penalty field's build times, the time of 10^4 queries.

    python benchmarks/bench_maps.py [--repeat 5]

Measured on navigation2's depot (604 x 307, shipped with the tests) and on a synthetic
2000 x 2000 map written to a temporary folder as PGM + YAML (rooms of 250 cells with doors, 300
round pillars, an unknown corner of 300 x 300, the origin turned by 0.3 rad), and, for the
clearance only, on 2000 x 2000 cells of noise (30 % occupied: 1.2 million cells with a free side,
the worst case of the k-d tree). The queries: 10^4 random points over the map, and a path of
10^4 samples (a widening spiral). The first build in a process also imports
``scipy.spatial``: it is timed once, apart. Medians (and minima) over ``--repeat`` runs, against
the targets (build under 1 s, 10^4 points well under 100 ms). The penalty field (robot radius
0.2 m, the default length scale 0.4 m): its build, and 10^6 evaluations with the Hessian along
the spiral (one thread). No assertions.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from leapfrog_planner.world import MapClearance, OccupancyMap, load_ros_map
from leapfrog_planner.world.field import field_penalty_rows
from leapfrog_planner.world.obstacle_map import ObstacleMap

DEPOT = Path(__file__).resolve().parents[1] / "tests" / "data" / "maps" / "depot.yaml"
TARGET_BUILD_S, TARGET_QUERY_MS = 1.0, 100.0


def timed(f, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = f()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times), result


def synthetic_map(folder: Path, n: int = 2000) -> Path:
    rng = np.random.default_rng(0)
    blocked = np.zeros((n, n), bool)
    blocked[:, :3] = blocked[:, -3:] = blocked[:3] = blocked[-3:] = True
    for k in range(100, n, 250):
        blocked[k : k + 4, :] = True
        blocked[:, k : k + 4] = True
    for k in range(100, n, 250):  # doors
        for m in range(200, n, 250):
            blocked[k : k + 4, m : m + 40] = False
            blocked[m : m + 40, k : k + 4] = False
    yy, xx = np.mgrid[:n, :n]
    for cx, cy, r in zip(*rng.uniform(0, n, (2, 300)), rng.uniform(3, 15, 300), strict=True):
        box = np.s_[
            max(int(cy - r - 1), 0) : int(cy + r + 2), max(int(cx - r - 1), 0) : int(cx + r + 2)
        ]
        blocked[box] |= (xx[box] + 0.5 - cx) ** 2 + (yy[box] + 0.5 - cy) ** 2 <= r * r
    image = np.where(blocked, 0, 254).astype(np.uint8)
    image[:300, :300] = 128  # unknown
    (folder / "big.pgm").write_bytes(f"P5\n{n} {n}\n255\n".encode() + image.tobytes())
    (folder / "big.yaml").write_text(
        "image: big.pgm\nresolution: 0.05\norigin: [-50.0, -50.0, 0.3]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    return folder / "big.yaml"


def spiral(m: OccupancyMap, n: int = 10_000) -> np.ndarray:
    x0, x1, y0, y1 = m.extent
    t = np.linspace(0.0, 6 * np.pi, n)
    r = np.linspace(0.05, 0.3, n)
    return np.column_stack(
        [
            (x0 + x1) / 2 + r * (x1 - x0) / 2 * np.cos(t),
            (y0 + y1) / 2 + r * (y1 - y0) / 2 * np.sin(t),
        ]
    )


def report_clearance(name: str, m: OccupancyMap, repeat: int) -> None:
    med, low, clear = timed(lambda: MapClearance(m), repeat)
    mark = "PASS" if med <= TARGET_BUILD_S else "MISS"
    print(
        f"{name}: build {med * 1e3:.1f} ms (min {low * 1e3:.1f}),"
        f" {clear.tree.n} cells in the tree  {mark}"
    )
    rng = np.random.default_rng(1)
    x0, x1, y0, y1 = m.extent
    x, y = rng.uniform(x0, x1, 10_000), rng.uniform(y0, y1, 10_000)
    path = spiral(m)
    free = MapClearance(m, unknown_is_occupied=False)
    for label, f in (
        ("10^4 random points", lambda: clear.distance(x, y)),
        ("10^4 random points, unknown free", lambda: free.distance(x, y)),
        ("a path of 10^4 samples", lambda: clear.path_clearance(path, radius=0.2)),
    ):
        med, low, _ = timed(f, repeat)
        mark = "PASS" if med * 1e3 <= TARGET_QUERY_MS else "MISS"
        print(f"  {label}: {med * 1e3:.1f} ms (min {low * 1e3:.1f})  {mark}")


def report_field(name: str, m: OccupancyMap, repeat: int) -> None:
    med, low, world = timed(lambda: ObstacleMap(m, radius=0.2), repeat)
    mark = "PASS" if med <= TARGET_BUILD_S else "MISS"
    mb = world.field.coef.nbytes / 2**20
    print(f"{name}: penalty field {med * 1e3:.0f} ms (min {low * 1e3:.0f}), {mb:.0f} MB  {mark}")
    xy = np.ascontiguousarray(np.repeat(spiral(m), 100, axis=0))
    out = np.empty((xy.shape[0], 6))
    med, low, _ = timed(lambda: field_penalty_rows(xy, world.field, 100.0, 2, True, out), repeat)
    print(f"  10^6 evaluations with the Hessian: {med * 1e3:.0f} ms ({med * 1e3:.0f} ns each)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    depot = load_ros_map(DEPOT)
    first_load = time.perf_counter() - start
    start = time.perf_counter()
    MapClearance(depot)
    first_build = time.perf_counter() - start
    print(f"first load {first_load * 1e3:.1f} ms, first build {first_build * 1e3:.0f} ms", end="")
    print(" (imports scipy.spatial)")
    med, low, depot = timed(lambda: load_ros_map(DEPOT), args.repeat)
    print(
        f"depot {depot.shape[1]} x {depot.shape[0]}: load {med * 1e3:.1f} ms (min {low * 1e3:.1f})"
    )
    with tempfile.TemporaryDirectory() as folder:
        path = synthetic_map(Path(folder))
        med, low, big = timed(lambda: load_ros_map(path), args.repeat)
    print(
        f"synthetic 2000 x 2000 (PGM): load {med * 1e3:.1f} ms (min {low * 1e3:.1f}),",
        big.counts(),
    )
    report_clearance("depot", depot, args.repeat)
    report_clearance("synthetic 2000 x 2000", big, args.repeat)
    report_field("depot", depot, args.repeat)
    report_field("synthetic 2000 x 2000", big, args.repeat)
    noise = np.where(np.random.default_rng(2).random((2000, 2000)) < 0.3, 100, 0).astype(np.int8)
    report_clearance("noise 2000 x 2000, 30 % occupied", OccupancyMap(noise, 0.05), args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
