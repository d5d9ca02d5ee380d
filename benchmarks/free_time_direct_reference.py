"""Reference optima of the paper cases with the final time free, by the direct method.

    python benchmarks/free_time_direct_reference.py [--out tests/data/free_time_direct.json]
                                                   [--intervals 200] [--k 0.1 1 10]

For each paper case (``paper-case-1`` ... ``paper-case-4``: start, goal, obstacles, weight and
exponent; the scenario's own horizon is only the first guess of ``T``) and each price of time
``k``: :func:`~leapfrog_planner.planning.direct_free.solve_direct_free` with the multistart on
meshes of ``N`` and ``2N`` intervals, and the Richardson extrapolation (order 2) of the total
cost ``J`` (``k T`` included) and of the optimal ``T``. Both meshes must end on the same local
optimum (their paths within 1e-2 of each other), else the script stops with an error.

Prints a table; with ``--out`` also writes the rows as JSON: a list of ``{"case", "k", "cost",
"horizon", "cost_fine", "horizon_fine", "min_clearance"}`` (``cost``, ``horizon``: the
extrapolated figures; ``*_fine``: those of the mesh of ``2N``; ``min_clearance``: of the ``2N``
solution along its exact arcs, negative where the path crosses a disc, which a high price of
time makes worth it; ``null`` without discs).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from leapfrog_planner.planning.direct import richardson
from leapfrog_planner.planning.direct_free import solve_direct_free
from leapfrog_planner.planning.scenario import load_scenario

CASES = ("paper-case-1", "paper-case-2", "paper-case-3", "paper-case-4")


def same_path(coarse, fine) -> float:
    """Largest distance between the coarse path and the fine one at the coarse nodes."""
    step = (len(fine.states) - 1) // (len(coarse.states) - 1)
    return float(np.max(np.abs(fine.states[::step, :2] - coarse.states[:, :2])))


def reference_row(name: str, k: float, intervals: int) -> dict:
    sc = load_scenario(name)
    args = (sc.start, sc.goal, sc.obstacles, k)
    opts = {"horizon_guess": sc.horizon, "weight": sc.weight, "exponent": sc.exponent}
    coarse = solve_direct_free(*args, intervals=intervals, **opts)
    fine = solve_direct_free(*args, intervals=2 * intervals, **opts)
    for result in (coarse, fine):
        if not result.success:
            raise SystemExit(f"{name}, k={k}: {result.message}")
    gap = same_path(coarse, fine)
    if gap > 1e-2:
        raise SystemExit(f"{name}, k={k}: the meshes found different optima (gap {gap:.3g})")
    return {
        "case": name,
        "k": k,
        "cost": richardson(coarse.cost, fine.cost),
        "horizon": richardson(coarse.horizon, fine.horizon),
        "cost_fine": fine.cost,
        "horizon_fine": fine.horizon,
        "min_clearance": fine.min_clearance if math.isfinite(fine.min_clearance) else None,
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, help="write the rows to this JSON file")
    parser.add_argument("--intervals", type=int, default=200, help="the coarse mesh N")
    parser.add_argument("--k", type=float, nargs="+", default=[0.1, 1.0, 10.0])
    options = parser.parse_args(argv)
    rows = []
    print(f"{'case':14} {'k':>5} {'J':>12} {'T':>10} {'J (2N)':>12} {'T (2N)':>10} {'clear':>8}")
    for name in CASES:
        for k in options.k:
            tic = time.perf_counter()
            row = reference_row(name, k, options.intervals)
            rows.append(row)
            print(
                f"{name:14} {k:5g} {row['cost']:12.7f} {row['horizon']:10.6f} "
                f"{row['cost_fine']:12.7f} {row['horizon_fine']:10.6f} "
                f"{row['min_clearance'] or math.inf:8.4f}  ({time.perf_counter() - tic:.1f} s)",
                flush=True,
            )
    if options.out is not None:
        options.out.write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
