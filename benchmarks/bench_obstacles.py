"""Cost against the number of obstacles: plan time, CLI wall time and peak memory.

    python benchmarks/bench_obstacles.py [--sizes 10,30,100,300,1000,3000] [--seeds 1,2,3,4,5]

For each size and seed, a random scenario of the batch generator (radii 0.03 to 0.08, gaps of 0.03;
the square workspace grows with the count, 4 x 4 per 100 obstacles, so the density stays the
same; start and goal at least 0.7 of its side apart) is planned by the default planner:

- in a fresh subprocess, after a warm-up plan of another field (30 obstacles, another seed:
  it loads the kernels and runs the code paths a field needs once, as a process planning many
  scenarios has): the plan time of the scenario (in-process, warm) and that process's peak
  RSS. (A warm-up on paper case 1, which has no obstacles in the way, left 20 to 40 ms of
  first-use costs in the 100-obstacle figure.);
- by ``leapfrog solve FILE --quiet`` in another fresh subprocess: the wall time of the whole
  command (start-up and kernel loading included) and its peak RSS.

A row per scenario, then per size: how many converged, and the median and worst plan time,
CLI wall time and peak memory over the seeds (one lucky seed says little: at 1,000 obstacles
the seeds range from 2 to 5 s, and at 3,000 some end with every extremal through an obstacle).

Targets of the issue: 1,000 obstacles under 2 s and 1 GB (CLI, 2 cores), 100 obstacles under
300 ms in-process, judged on the medians. No assertions; the figures are printed as tables.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
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
plan(load_scenario(sys.argv[2]))  # the warm-up field
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
    (folder / "warm-up").mkdir(exist_ok=True)
    warm = scenario_file(30, 1000 + seed, folder / "warm-up")
    _, child_mb, out = run([sys.executable, "-c", _CHILD, str(path), str(warm)])
    row = {"obstacles": n, "plan_s": math.nan, "status": "failed", "cost": math.nan}
    try:
        row.update(json.loads(out))
        row["plan_s"] = row.pop("time_s")
    except ValueError:
        pass
    row["process_mb"] = child_mb
    row["cli_s"], row["cli_mb"], _ = run(["leapfrog", "solve", str(path), "--quiet"])
    return row


def summary(n: int, rows: list[dict]) -> dict:
    """Per size: converged count, median and worst plan and CLI times, worst peak memory."""
    plan = [r["plan_s"] for r in rows]
    cli = [r["cli_s"] for r in rows]
    return {
        "obstacles": n,
        "converged": sum(r["status"] == "converged" for r in rows),
        "runs": len(rows),
        "plan_median_s": statistics.median(plan),
        "plan_max_s": max(plan),
        "cli_median_s": statistics.median(cli),
        "cli_max_s": max(cli),
        "mb_max": max(max(r["cli_mb"], r["process_mb"]) for r in rows),
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10,30,100,300,1000,3000")
    ap.add_argument("--seeds", default="1,2,3,4,5")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    print(f"{'obstacles':>9} {'seed':>4} {'plan':>9} {'CLI wall':>9} {'CLI peak':>9}  status")
    sums = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            rows = []
            for seed in seeds:
                r = measure(n, seed, Path(tmp))
                rows.append(r)
                print(
                    f"{n:>9} {seed:>4} {r['plan_s']:>8.2f}s {r['cli_s']:>8.2f}s"
                    f" {max(r['cli_mb'], r['process_mb']):>7.0f}MB"
                    f"  {r['status']} (cost {r['cost']:.6g})",
                    flush=True,
                )
            sums[n] = summary(n, rows)
    print()
    head = f"{'obstacles':>9} {'converged':>9} {'plan median/worst':>18} {'CLI median/worst':>18}"
    print(head + "  peak")
    for m in sums.values():
        plan = f"{m['plan_median_s']:.2f}/{m['plan_max_s']:.2f} s"
        cli = f"{m['cli_median_s']:.2f}/{m['cli_max_s']:.2f} s"
        print(
            f"{m['obstacles']:>9} {m['converged']:>7}/{m['runs']:<1} {plan:>18} {cli:>18}"
            f"  {m['mb_max']:.0f} MB"
        )
    if 1000 in sums:
        m = sums[1000]
        ok = m["cli_median_s"] < TARGET_1000_S and m["mb_max"] < TARGET_1000_MB
        print(
            f"1,000 obstacles: CLI median {m['cli_median_s']:.2f} s (worst {m['cli_max_s']:.2f}),"
            f" peak {m['mb_max']:.0f} MB, {m['converged']} of {m['runs']} converged"
            f" (target < {TARGET_1000_S:g} s and {TARGET_1000_MB:g} MB):"
            f" {'met' if ok else 'missed'}"
        )
    if 100 in sums:
        ms = 1e3 * sums[100]["plan_median_s"]
        ok = ms < TARGET_100_MS
        print(
            f"100 obstacles: plan median {ms:.0f} ms in-process"
            f" (target < {TARGET_100_MS:g} ms): {'met' if ok else 'missed'}"
        )


if __name__ == "__main__":
    main()
