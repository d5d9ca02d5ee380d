"""How often the default planner finds the best known optimum, and how long it takes, beside
another version of the planner in the same run.

    python benchmarks/bench_search.py [--preset general] [--n 500] [--seed 1]
        [--baseline DIR] [--reference FILE] [--out FILE.json]

Each scenario of the preset is planned in this process with the default settings (the time is
the in-process wall time of ``plan``, after a warm-up plan) and, with ``--baseline DIR`` (a
checkout of another version, e.g. a git worktree of an older commit), by that version in a
worker process, one after the other (never both at once), alternating which goes first.

The best known optimum of a scenario is the cheapest converged cost among both planners and a
thorough plan of this version (12 paths, no race); it is cached in ``--reference FILE`` (a JSON
object, scenario name -> cost) so that a second run only plans what is new. "Best" means
within 1e-4 (relative) of it. Prints, per planner: converged, best, the median, 90th and 95th
percentiles and the maximum of the time, and the scenarios where one is cheaper than the other.
No assertions: run it on a quiet machine and read the ratios.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.planning.planner import plan

REL = 1e-4

WORKER = """
import json, sys, time
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import scenario_from_dict
warm = False
for line in sys.stdin:
    sc = scenario_from_dict(json.loads(line))
    if not warm:
        plan(sc)
        warm = True
    t = time.perf_counter()
    r = plan(sc)
    dt = time.perf_counter() - t
    print(json.dumps({"status": str(r.status), "cost": r.cost, "time_s": dt}), flush=True)
"""


class Baseline:
    """Another version of the planner in a worker process: ``run(scenario)`` plans it there."""

    def __init__(self, checkout: str):
        env = {**os.environ, "PYTHONPATH": str(Path(checkout).resolve() / "src")}
        self.proc = subprocess.Popen(
            [sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            text=True, env=env,
        )  # fmt: skip

    def run(self, sc) -> dict:
        self.proc.stdin.write(json.dumps(sc.to_dict()) + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def here(sc) -> dict:
    t = time.perf_counter()
    r = plan(sc)
    dt = time.perf_counter() - t
    return {"status": str(r.status), "cost": r.cost, "time_s": dt}


def thorough(sc) -> float:
    r = plan(sc, initial_paths=12, candidate_paths=12, extra_paths=0)
    return r.cost if r.success else math.inf


def percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def summary(name: str, rows: list[dict], best: dict[str, float]) -> None:
    times = [r["time_s"] for r in rows]
    ok = [r for r in rows if r["status"] == "converged"]
    hits = sum(r["cost"] <= best[r["scenario"]] * (1 + REL) + 1e-12 for r in ok)
    n = len(rows)
    med, p90, p95 = (percentile(times, q) for q in (0.5, 0.9, 0.95))
    print(
        f"{name:>9}: converged {len(ok)}/{n}, best known {hits}/{n} = {hits / n:.1%};"
        f" time median {med * 1e3:.0f} ms, 90% {p90 * 1e3:.0f} ms, 95% {p95 * 1e3:.0f} ms,"
        f" max {max(times):.2f} s"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="general")
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--baseline", default=None, help="a checkout of another version")
    ap.add_argument("--reference", default=None, help="JSON cache of the best known costs")
    ap.add_argument("--out", default=None, help="write the per-scenario rows as JSON")
    a = ap.parse_args()
    scenarios = list(generate(GeneratorSpec.preset(a.preset, n=a.n, seed=a.seed)))
    ref_path = Path(a.reference) if a.reference else None
    reference = json.loads(ref_path.read_text()) if ref_path and ref_path.exists() else {}
    base = Baseline(a.baseline) if a.baseline else None
    plan(scenarios[0])  # warm-up: kernels loaded
    rows = {"new": [], "baseline": []}
    for i, sc in enumerate(scenarios):
        order = ["new", "baseline"] if i % 2 == 0 else ["baseline", "new"]
        for who in order:
            if who == "new":
                rows["new"].append({"scenario": sc.name, **here(sc)})
            elif base is not None:
                rows["baseline"].append({"scenario": sc.name, **base.run(sc)})
        if sc.name not in reference:
            reference[sc.name] = thorough(sc)
            if ref_path:
                ref_path.write_text(json.dumps(reference, indent=1))
        print(f"{i + 1}/{len(scenarios)} {sc.name}", file=sys.stderr, end="\r")
    if base is not None:
        base.close()
    best = {}
    for sc in scenarios:
        costs = [reference[sc.name]] + [
            r["cost"] for rs in rows.values() for r in rs
            if r["scenario"] == sc.name and r["status"] == "converged"
        ]  # fmt: skip
        best[sc.name] = min(costs)
    print(f"{a.preset} preset, {a.n} scenarios (seed {a.seed}), in-process plan times")
    for name, rs in rows.items():
        if rs:
            summary(name, rs, best)
    if base is not None:
        pairs = list(zip(rows["new"], rows["baseline"], strict=True))
        worse = [n["scenario"] for n, b in pairs if n["status"] != b["status"]]
        print(f"status differs on {len(worse)}: {', '.join(worse) or 'none'}")
        pairs = [(n, b) for n, b in pairs if n["status"] == b["status"] == "converged"]
        cheaper = [n["scenario"] for n, b in pairs if n["cost"] < b["cost"] * (1 - REL)]
        dearer = [n["scenario"] for n, b in pairs if n["cost"] > b["cost"] * (1 + REL)]
        ratio = percentile([n["time_s"] / b["time_s"] for n, b in pairs], 0.5)
        print(f"new against baseline: cheaper on {len(cheaper)}, dearer on {len(dearer)}"
              f" ({', '.join(dearer) or 'none'}); median time ratio {ratio:.2f}")  # fmt: skip
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
