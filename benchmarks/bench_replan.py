#!/usr/bin/env python
"""``replan`` in a receding-horizon loop: the time of a warm re-plan, and its answer against a
cold plan of the same moved task.

Run from the repository root::

    python benchmarks/bench_replan.py              # paper cases 1-4 and 100 general scenarios
    python benchmarks/bench_replan.py --n 20       # fewer general scenarios
    python benchmarks/bench_replan.py --keep-horizon

Moves, from a converged plan of each scenario:

- ``start``: the robot drove 5% of the way along the answer: the new start is the trajectory's
  state at 5% of T, and the horizon is 95% of T (the arrival time kept, as a receding-horizon
  loop with a fixed arrival time has it; ``--keep-horizon`` keeps T instead: the robot then
  arrives later, a different task whose answer is not the previous one's tail);
- ``obstacle``: the obstacle nearest the path moved by its radius in a random direction
  (seeded), the rest of the task unchanged.

Each move is re-planned with ``replan`` (timed in-process, one call, the kernels loaded) and
planned cold with ``plan``. Printed: the median and 90th percentile of the replan time, the
share of warm and full answers, the share converged, and the share with the cold plan's cost to
1e-8 (relative), where they differ which is cheaper. No assertions: figures only.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

import leapfrog_planner as lp
from leapfrog_planner.batch.generate import GeneratorSpec, generate

SAME = 1e-8


def _state_at(result, t: float) -> np.ndarray:
    at = result.at(t)
    return np.array([float(np.asarray(at[n])) for n in result.state_names])


def _moved_obstacle(result, rng) -> np.ndarray | None:
    """The task's obstacles with the one nearest the path moved by its radius (None: none)."""
    obstacles = np.array(result.task.obstacles, dtype=float)
    if obstacles.size == 0:
        return None
    xy = result.trajectory.x[:, :2]
    d = [np.min(np.linalg.norm(xy - o[:2], axis=1)) - o[2] for o in obstacles]
    i = int(np.argmin(d))
    angle = rng.uniform(0.0, 2.0 * math.pi)
    obstacles[i, :2] += obstacles[i, 2] * np.array([math.cos(angle), math.sin(angle)])
    return obstacles


def _one(previous, move: dict) -> dict | None:
    """Replan and a cold plan of one move; None when the moved task is not a valid scenario
    (an end inside the moved obstacle)."""
    try:
        t0 = time.perf_counter()
        warm = lp.replan(previous, **move)
        seconds = time.perf_counter() - t0
    except lp.ScenarioError:
        return None
    cold = lp.plan(warm.task)
    same = (
        warm.success
        and cold.success
        and abs(warm.cost - cold.cost) <= SAME * max(1.0, abs(cold.cost))
    )
    return {
        "s": seconds,
        "how": warm.replan,
        "converged": warm.success,
        "same": same,
        "cheaper": None if same else ("replan" if warm.cost < cold.cost else "plan"),
        "warm": warm,
        "cold": cold,
    }


def _report(name: str, rows: list[dict]) -> None:
    if not rows:
        print(f"{name}: no moves")
        return
    ms = sorted(1e3 * r["s"] for r in rows)
    n = len(rows)
    p90 = ms[min(n - 1, math.ceil(0.9 * n) - 1)]
    warm = sum(r["how"] == "warm" for r in rows)
    conv = sum(r["converged"] for r in rows)
    same = sum(r["same"] for r in rows)
    print(
        f"{name}: {n} moves; replan median {statistics.median(ms):.2f} ms, p90 {p90:.2f} ms;"
        f" warm {warm}/{n}, full {n - warm}/{n}; converged {conv}/{n};"
        f" same cost as a cold plan {same}/{n} ({100.0 * same / n:.1f}%)"
    )
    warm_ms = [1e3 * r["s"] for r in rows if r["how"] == "warm"]
    if warm_ms:
        print(f"  warm only: median {statistics.median(warm_ms):.2f} ms, max {max(warm_ms):.2f}")
    for r in rows:
        if not r["same"]:
            w, c = r["warm"], r["cold"]
            print(
                f"  differs: {w.scenario}: replan {r['how']} {w.status} {w.cost:.10g},"
                f" plan {c.status} {c.cost:.10g}: {r['cheaper']} cheaper"
            )
        elif r["how"] == "full":
            print(f"  full: {r['warm'].scenario}: {r['warm'].message.rsplit('; ', 1)[-1]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=100, help="general scenarios (seed 1)")
    ap.add_argument("--keep-horizon", action="store_true", help="keep T after the 5%% move")
    args = ap.parse_args()
    scenarios = [lp.load_scenario(f"paper-case-{i}") for i in range(1, 5)]
    scenarios += list(generate(GeneratorSpec.preset("general", n=args.n, seed=1)))
    rng = np.random.default_rng(1)
    start_rows, obstacle_rows, skipped = [], [], 0
    for s in scenarios:
        previous = lp.plan(s)
        if not previous.success:
            skipped += 1
            continue
        T = previous.task.horizon
        move = {"start": _state_at(previous, 0.05 * T)}
        if not args.keep_horizon:
            move["horizon"] = 0.95 * T
        row = _one(previous, move)
        if row is not None:
            start_rows.append(row)
        obstacles = _moved_obstacle(previous, rng)
        if obstacles is not None and (row := _one(previous, {"obstacles": obstacles})):
            obstacle_rows.append(row)
    kept = "T kept" if args.keep_horizon else "T reduced by 5%"
    print(f"{len(scenarios)} scenarios, {skipped} without a converged first plan (not moved)")
    _report(f"start moved 5% along the answer ({kept})", start_rows)
    _report("nearest obstacle moved by its radius", obstacle_rows)


if __name__ == "__main__":
    main()
