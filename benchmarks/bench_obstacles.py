"""Cost against the number of obstacles: plan time, CLI wall time and peak memory.

    python benchmarks/bench_obstacles.py [--sizes 10,30,100,300,1000,3000] [--seed 5]

For each size, one random scenario of the batch generator (radii 0.03 to 0.08, gaps of 0.03;
the square workspace grows with the count, 4 x 4 per 100 obstacles, so the density stays the
same; start and goal at least 0.7 of its side apart) is planned by the default planner:

- in a fresh subprocess, after a warm-up plan that loads the kernels: the plan time of the
  scenario (in-process, warm kernels) and that process's peak RSS;
- by ``leapfrog solve FILE --quiet`` in another fresh subprocess: the wall time of the whole
  command (start-up and kernel loading included) and its peak RSS.

Targets of the issue: 1,000 obstacles under 2 s and 1 GB (CLI, 2 cores), 100 obstacles under
300 ms in-process. No assertions; the figures are printed as a table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from leapfrog_planner.batch.generate import GeneratorSpec, generate

TARGET_1000_S, TARGET_1000_MB, TARGET_100_MS = 2.0, 1024.0, 300.0

_CHILD = """
import json, resource, sys, time
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import load_scenario
plan("paper-case-1")  # loads the kernels
scenario = load_scenario(sys.argv[1])
t = time.perf_counter()
result = plan(scenario)
elapsed = time.perf_counter() - t
json.dump({"time_s": elapsed, "status": str(result.status), "cost": float(result.cost)},
          sys.stdout)
"""


def scenario_file(n: int, seed: int, folder: Path) -> Path:
    side = 4.0 * math.sqrt(n / 100.0)
    spec = GeneratorSpec(
        n=1,
        seed=seed,
        obstacles=(n, n),
        workspace=(0.0, 0.0, side, side),
        radius=(0.03, 0.08),
        obstacle_gap=0.03,
        min_distance=0.7 * side,
        clearance=0.1,
    )
    (scenario,) = list(generate(spec))
    path = folder / f"obstacles-{n}.toml"
    path.write_text(scenario.to_toml())
    return path


def run(cmd: list[str]) -> tuple[float, float, str]:
    """Wall time, peak RSS (MB) and standard output of a fresh subprocess."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return time.perf_counter() - t, usage.ru_maxrss / 1024.0, out


def measure(n: int, seed: int, folder: Path) -> dict:
    path = scenario_file(n, seed, folder)
    _, child_mb, out = run([sys.executable, "-c", _CHILD, str(path)])
    row = {"obstacles": n, "plan_s": math.nan, "status": "failed", "cost": math.nan}
    try:
        row.update(json.loads(out))
        row["plan_s"] = row.pop("time_s")
    except ValueError:
        pass
    row["process_mb"] = child_mb
    row["cli_s"], row["cli_mb"], _ = run(["leapfrog", "solve", str(path), "--quiet"])
    return row


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10,30,100,300,1000,3000")
    ap.add_argument("--seed", type=int, default=5)
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"{'obstacles':>9} {'plan':>9} {'CLI wall':>9} {'CLI peak':>9} {'plan peak':>9}  status")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            r = measure(n, args.seed, Path(tmp))
            rows.append(r)
            print(
                f"{n:>9} {1e3 * r['plan_s']:>7.0f}ms {r['cli_s']:>8.2f}s {r['cli_mb']:>7.0f}MB"
                f" {r['process_mb']:>7.0f}MB  {r['status']} (cost {r['cost']:.6g})",
                flush=True,
            )
    by = {r["obstacles"]: r for r in rows}
    if 1000 in by:
        r = by[1000]
        ok = r["cli_s"] < TARGET_1000_S and r["cli_mb"] < TARGET_1000_MB
        print(
            f"1,000 obstacles: CLI {r['cli_s']:.2f} s, {r['cli_mb']:.0f} MB"
            f" (target < {TARGET_1000_S:g} s and {TARGET_1000_MB:g} MB):"
            f" {'met' if ok else 'missed'}"
        )
    if 100 in by:
        ms = 1e3 * by[100]["plan_s"]
        ok = ms < TARGET_100_MS
        print(
            f"100 obstacles: plan {ms:.0f} ms in-process"
            f" (target < {TARGET_100_MS:g} ms): {'met' if ok else 'missed'}"
        )


if __name__ == "__main__":
    main()
