"""A free final time: how often the planner converges, how its optimum compares with the direct
method's (T a variable, multistart), and what choosing T costs beside a fixed-T plan.

    python benchmarks/bench_free_time.py [--paper] [--n 200] [--seed 1] [--cruise-speed 1]
        [--direct] [--vmax V] [--omega W] [--car] [--indices 53,168] [--out FILE.jsonl]

``--paper``: the four paper cases at k = 0.1, 1 and 10 against the Richardson-extrapolated
direct optima of ``tests/data/free_time_direct.json``. Otherwise the general preset (``--n``
scenarios, ``--seed``) at the cruise speed given. For each scenario: the free-time plan
(in-process wall time, after a warm-up plan), then a fixed-T plan at the T it chose; the ratio
of the two times is what choosing T costs. With ``--direct``, the direct method with T free
(multistart, 100 intervals, from the straight distance at the cruise speed) on each scenario;
the best known optimum is the cheapest collision-free one of both, and "best" means within 1e-4
of it. ``--vmax V`` bounds the speed to ``[-V, V]`` (``--omega W`` the turn rate to ``[-W, W]``)
in both methods; ``--indices 53,168`` plans only those scenarios of the ``--n`` (a subset);
``--car`` plans the car (steering straight at both ends; the direct method has no car). No
assertions: run it on a quiet machine and read the figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.scenario import load_scenario
from leapfrog_planner.planning.scenario_time import FreeTime

REL = 1e-4
REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "data" / "free_time_direct.json"


def timed(sc):
    t = time.perf_counter()
    r = plan(sc)
    return r, time.perf_counter() - t


def vehicle(sc, vmax: float | None, omega: float | None, car: bool):
    """``sc`` with the speed and turn rate bounded as asked, or as the car."""
    if car:
        ends = {"start": [*sc.start, 0.0], "goal": [*sc.goal, 0.0]}
        return dataclasses.replace(sc, model="car", model_parameters={}, **ends)
    bounds = {}
    if vmax:
        bounds["v"] = (-vmax, vmax)
    if omega:
        bounds["omega"] = (-omega, omega)
    return dataclasses.replace(sc, control_bounds=bounds) if bounds else sc


def run_one(sc, free: FreeTime, direct: bool) -> dict:
    r, t_free = timed(dataclasses.replace(sc, free_time=free))
    f = r.free_time
    fixed, t_fixed = timed(dataclasses.replace(sc, horizon=f.horizon, free_time=None))
    row = {
        "name": sc.name, "status": str(r.status), "cost": r.cost, "T": f.horizon,
        "condition": f.condition, "clearance": r.min_clearance, "time_s": t_free,
        "fixed_time_s": t_fixed, "fixed_cost": fixed.cost + f.time_weight * f.horizon,
        "plans": sum(s.source == "plan" for s in f.steps),
    }  # fmt: skip
    if direct:
        from leapfrog_planner.planning.direct_free import solve_direct_free

        speed = math.sqrt(2 * f.time_weight)  # the unicycle's cruise
        guess = max(float(np.hypot(*(sc.goal[:2] - sc.start[:2]))), 0.1) / speed
        box = tuple(sc.control_bounds.get(c) for c in ("v", "omega"))
        d = solve_direct_free(
            sc.start, sc.goal, sc.obstacles, f.time_weight, horizon_guess=guess,
            weight=sc.weight, exponent=sc.exponent, control_bounds=box if any(box) else None,
        )  # fmt: skip
        row.update(direct_cost=d.cost if d.success else math.nan, direct_clearance=d.min_clearance)
        row.update(direct_T=d.horizon if d.success else math.nan)
    return row


def summary(rows: list[dict]) -> None:
    n = len(rows)
    conv = [r for r in rows if r["status"] == "converged"]
    print(f"converged {len(conv)}/{n} = {100 * len(conv) / n:.1f}%")
    worst = max((abs(r["condition"]) for r in conv), default=math.nan)
    print(f"largest |k + H| of a converged answer: {worst:.1e}")
    collide = [r for r in conv if r["clearance"] is not None and r["clearance"] < 0]
    print(f"converged through an obstacle: {len(collide)}")
    ratios = [r["time_s"] / r["fixed_time_s"] for r in rows]
    times = [r["time_s"] for r in rows]
    p90, p95 = np.percentile(ratios, [90, 95])  # interpolated: never below the median
    print(
        f"free-T plan: median {1e3 * statistics.median(times):.0f} ms, p95 "
        f"{1e3 * np.percentile(times, 95):.0f} ms; time / fixed-T plan at its T: median "
        f"{statistics.median(ratios):.2f}, p90 {p90:.2f}, p95 {p95:.2f}, max {max(ratios):.2f}"
    )
    if "direct_cost" in rows[0]:
        best_n = 0
        for r in rows:
            mine = r["cost"] if r["status"] == "converged" else math.inf
            theirs = r["direct_cost"]
            if not (r["direct_clearance"] is None or r["direct_clearance"] >= 0):
                theirs = math.inf
            best = min(mine, theirs if math.isfinite(theirs) else math.inf)
            best_n += mine <= best * (1 + REL)
            if mine > best * (1 + REL):
                print(
                    f"  {r['name']}: planner {mine:.8g} (T {r['T']:.5g}), direct {theirs:.8g}"
                    f" (T {r.get('direct_T', math.nan):.5g})"
                )
        print(f"within {REL:g} of the best of planner and direct: {best_n}/{n}")


def paper() -> list[dict]:
    rows = []
    for ref in json.loads(REFERENCE.read_text()):
        sc = load_scenario(ref["case"])
        row = run_one(sc, FreeTime(ref["k"]), direct=False)
        row.update(name=f"{ref['case']} k={ref['k']:g}", direct_cost=ref["cost"])
        row.update(direct_T=ref["horizon"], direct_clearance=ref["min_clearance"])
        print(
            f"{row['name']:22} {row['status']:9} J {row['cost']:.9f} (direct {ref['cost']:.9f},"
            f" {row['cost'] / ref['cost'] - 1:+.1e}) T {row['T']:.7f} (direct {ref['horizon']:.7f})"
            f" k+H {row['condition']:.0e} {1e3 * row['time_s']:.0f} ms"
            f" ({row['time_s'] / row['fixed_time_s']:.2f} x fixed)",
            flush=True,
        )
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--paper", action="store_true")
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cruise-speed", type=float, default=1.0)
    ap.add_argument("--direct", action="store_true")
    ap.add_argument("--vmax", type=float, default=None)
    ap.add_argument("--omega", type=float, default=None)
    ap.add_argument("--car", action="store_true")
    ap.add_argument("--indices", default=None, help="comma-separated scenario indices")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    plan("paper-case-1")  # warm-up: kernels loaded
    if a.paper:
        rows = paper()
    else:
        free = FreeTime(a.cruise_speed**2 / 2, a.cruise_speed)
        rows = []
        indices = None if a.indices is None else [int(i) for i in a.indices.split(",")]
        for sc in generate(GeneratorSpec.preset("general", n=a.n, seed=a.seed), indices):
            sc = vehicle(sc, a.vmax, a.omega, a.car)
            rows.append(run_one(sc, free, a.direct and not a.car))
            print(json.dumps(rows[-1]), flush=True)
    subset = f", {len(rows)} of them" if a.indices else ""
    print(f"\n{'paper cases' if a.paper else f'general preset, {a.n} (seed {a.seed}){subset}'}:")
    summary(rows)
    if a.out:
        Path(a.out).write_text("".join(json.dumps(r) + "\n" for r in rows))


if __name__ == "__main__":
    main()
