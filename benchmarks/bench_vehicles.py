"""Bounded controls and the car against the direct method, on random layouts.

    python benchmarks/bench_vehicles.py [--n 100] [--seed 11] [--vmax 3.0] [--omega 4.0]
                                        [--preset default] [--car 50]

1. Control bounds: each scenario of ``--preset`` with ``v = [0, vmax]`` (and ``omega = [-omega,
   omega]`` unless ``--omega 0``), planned, and solved by
   IPOPT with the same box constraints (meshes of 100 and 200 intervals from the planner's
   initial paths, Richardson-extrapolated). Prints how many converged, how many match IPOPT to
   1e-3, the median relative difference, where IPOPT found a cheaper optimum, and the largest
   excess of a control over its bounds.
2. The car: ``--car`` scenarios of the same preset with the car's own start and goal (steering
   straight); how many converged and the plan times.
No assertions: it prints figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import time

import numpy as np

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.planning.direct import richardson, solve_direct
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.scenario import Scenario


def bounded_direct(sc: Scenario, box) -> float:
    s = np.linspace(0.0, 1.0, 201)
    guesses = [np.column_stack(p.curve(s)) for p in Planner(sc).initial_paths()]
    args = (sc.start, sc.goal, sc.horizon, sc.obstacles)
    coarse = solve_direct(
        *args, intervals=100, guesses=[g[::2] for g in guesses], control_bounds=box
    )
    fine = solve_direct(*args, intervals=200, guesses=guesses, control_bounds=box)
    if not (coarse.success and fine.success and fine.min_clearance >= 0.0):
        return math.nan
    return richardson(coarse.cost, fine.cost)


def bounds_table(n: int, seed: int, vmax: float, omega: float, preset: str = "default") -> None:
    converged, match, rel, cheaper, excess, failed_direct = 0, 0, [], [], 0.0, 0
    bounds = {"v": (0.0, vmax), **({"omega": (-omega, omega)} if omega else {})}
    box = (bounds["v"], bounds.get("omega"))
    active = 0
    for base in generate(GeneratorSpec.preset(preset, n=n, seed=seed)):
        sc = dataclasses.replace(base, control_bounds=bounds)
        r = plan(sc)
        if not r.success:
            print(f"{sc.name}: {r.status}: {r.message}")
            continue
        converged += 1
        v, w = r.trajectory.u[:, 0], r.trajectory.u[:, 1]
        excess = max(excess, -v.min(), v.max() - vmax)
        if omega:
            excess = max(excess, np.abs(w).max() - omega)
        active += bool(
            v.min() < 1e-3 or v.max() > vmax - 1e-3 or (omega and np.abs(w).max() > omega - 1e-3)
        )
        ref = bounded_direct(sc, box)
        if not math.isfinite(ref):
            failed_direct += 1
            print(f"{sc.name}: IPOPT did not converge (planner: {r.cost:.6g})")
            continue
        d = abs(r.cost - ref) / ref
        match += d <= 1e-3
        rel.append(d)
        if ref < r.cost * (1 - 1e-3):
            cheaper.append(f"{sc.name} ({r.cost:.6g} vs IPOPT {ref:.6g})")
    where = f"v in [0, {vmax:g}]" + (f", omega in [-{omega:g}, {omega:g}]" if omega else "")
    print(f"\ncontrol bounds {where}, {n} {preset} scenarios (seed {seed}); active in {active}:")
    print(
        f"  converged {converged}/{n}; match IPOPT to 1e-3: {match}; IPOPT failed: {failed_direct}"
    )
    med = statistics.median(rel) if rel else math.nan
    print(f"  median relative difference {med:.2g}; largest bound excess {excess:.2g}")
    print(f"  IPOPT cheaper: {', '.join(cheaper) or 'none'}")


def car_table(n: int, seed: int) -> None:
    times, status = [], {}
    for base in generate(GeneratorSpec(n=n, seed=seed)):
        sc = Scenario(
            name=base.name, horizon=base.horizon, start=[*base.start, 0.0],
            goal=[*base.goal, 0.0], obstacles=base.obstacles, model="car",
        )  # fmt: skip
        t0 = time.perf_counter()
        r = plan(sc)
        times.append(time.perf_counter() - t0)
        status[str(r.status)] = status.get(str(r.status), 0) + 1
    print(f"\ncar, {n} scenarios (seed {seed}): {status}")
    print(f"  time median {np.median(times):.2f} s, p95 {np.percentile(times, 95):.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--preset", default="default", help="generator preset of the bounds table")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--vmax", type=float, default=3.0)
    ap.add_argument("--omega", type=float, default=4.0, help="0: omega unbounded")
    ap.add_argument("--car", type=int, default=50)
    ap.add_argument("--car-seed", type=int, default=3)
    a = ap.parse_args()
    bounds_table(a.n, a.seed, a.vmax, a.omega, a.preset)
    if a.car:
        car_table(a.car, a.car_seed)


if __name__ == "__main__":
    main()
