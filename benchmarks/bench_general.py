"""In-process time of the default planner on a preset's random scenarios (default: general).

    python benchmarks/bench_general.py [--preset general] [--n 200] [--seed 1]
                                       [--method modified-newton] [--initial-paths 3]
                                       [--out FILE.json]

Each scenario is planned once after a warm-up plan of the first (kernels loaded), with the
default planner settings (three initial paths, one thread per path), in this process. Prints
the median, 90th and 95th percentiles and the maximum of the wall time, the success rate
(converged and collision-free) and the slowest scenarios, against the targets of issue 17
(median <= 100 ms, 95th percentile <= 1 s on the general preset). No assertions: timings of a
shared machine drift, so run it beside a reference (for example ``bench_leapfrog.py``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.planning.planner import plan

TARGET_MEDIAN_S, TARGET_P95_S = 0.100, 1.0


def percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="general")
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--method", default="modified-newton")
    ap.add_argument("--initial-paths", type=int, default=3)
    ap.add_argument("--out", default=None, help="write the per-scenario rows as JSON")
    a = ap.parse_args()
    scenarios = list(generate(GeneratorSpec.preset(a.preset, n=a.n, seed=a.seed)))
    plan(scenarios[0], method=a.method, initial_paths=a.initial_paths)  # warm-up
    rows = []
    for sc in scenarios:
        t = time.perf_counter()
        r = plan(sc, method=a.method, initial_paths=a.initial_paths)
        dt = time.perf_counter() - t
        rows.append({"scenario": sc.name, "status": str(r.status), "cost": r.cost, "time_s": dt})
    times = [r["time_s"] for r in rows]
    ok = sum(r["status"] == "converged" for r in rows)
    med, p90, p95 = (percentile(times, q) for q in (0.5, 0.9, 0.95))
    print(f"{a.preset} preset, {a.n} scenarios (seed {a.seed}), {a.method}, default planner")
    print(f"converged (collision-free): {ok}/{len(rows)} = {ok / len(rows):.1%}")
    print(f"time: median {med * 1e3:.0f} ms, 90% {p90 * 1e3:.0f} ms, 95% {p95 * 1e3:.0f} ms,")
    print(f"      max {max(times) * 1e3:.0f} ms, mean {statistics.mean(times) * 1e3:.0f} ms")
    for name, value, target in (("median", med, TARGET_MEDIAN_S), ("95%", p95, TARGET_P95_S)):
        verdict = "PASS" if value <= target else "MISS"
        print(f"target {name} <= {target * 1e3:.0f} ms: {value / target:.2f}x  {verdict}")
    print("slowest:", ", ".join(f"{r['scenario']} {r['time_s']:.2f} s" for r in sorted(
        rows, key=lambda r: -r["time_s"])[:5]))  # fmt: skip
    if a.out:
        with open(a.out, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
