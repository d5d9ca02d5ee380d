"""How many initial paths find the best optimum: each scenario planned from each of its ``--paths``
best-ranked initial paths separately, then the share of scenarios whose best cost the top k hold.

    python benchmarks/bench_paths.py [--preset general] [--n 500] [--seed 1] [--paths 12]
                                     [--workers 2] [--out paths.jsonl]

For every scenario the planner ranks its initial paths by estimated cost (as it does to pick
the default three); here each of the best ``--paths`` is run by Leapfrog and validated on its
own. The reference is the cheapest collision-free extremal of them all. Prints, for k = 1 to
``--paths``, how many scenarios the top k hold the reference for (within 1e-4, relative), and
the same for an adaptive rule (run the next path while its estimate times f is below the best
cost found) at a few f, with the mean number of paths it runs. No assertions: it prints figures.
About 15 minutes for 500 general scenarios on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import math
from multiprocessing import Pool

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.planning.path_ranking import estimated_costs
from leapfrog_planner.planning.planner import Planner

_SCENARIOS: list = []


def _init(preset: str, n: int, seed: int) -> None:
    _SCENARIOS[:] = list(generate(GeneratorSpec.preset(preset, n=n, seed=seed)))


def _paths_of(job: tuple[int, int]) -> dict:
    """The estimate, clearance and cost of each of the best ``k`` paths of scenario ``i``."""
    i, k = job
    sc = _SCENARIOS[i]
    planner = Planner(sc, initial_paths=k, threads=1)
    paths = planner.initial_paths()
    ends = (sc.start, sc.goal)
    est = estimated_costs(planner.problem, paths, sc.horizon, ends=ends).tolist()
    rows = []
    for j, path in enumerate(paths):
        run = planner.run_path(path)
        cost = run.validation.cost if run.clear else None
        rows.append({"label": path.label, "estimate": est[j], "cost": cost})
    return {"name": sc.name, "paths": rows}


def _best(rows: list[dict]) -> float:
    return min((r["cost"] for r in rows if r["cost"] is not None), default=math.inf)


def _hits(records: list[dict], pick) -> tuple[int, float]:
    """Scenarios whose reference the rule ``pick(rows) -> rows run`` finds, and mean runs."""
    hits, runs = 0, 0
    for rec in records:
        ref, tried = _best(rec["paths"]), pick(rec["paths"])
        runs += len(tried)
        hits += not math.isfinite(ref) or _best(tried) <= ref * (1.0 + 1e-4)
    return hits, runs / len(records)


def _adaptive(f: float, first: int = 3):
    def pick(rows):
        tried = rows[:first]
        for row in rows[first:]:
            if not row["estimate"] * f < _best(tried):
                break
            tried = [*tried, row]
        return tried

    return pick


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="general")
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--paths", type=int, default=12)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="write the per-scenario rows as JSON lines")
    a = ap.parse_args()
    jobs = [(i, a.paths) for i in range(a.n)]
    with Pool(a.workers, initializer=_init, initargs=(a.preset, a.n, a.seed)) as pool:
        records = pool.map(_paths_of, jobs, chunksize=4)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as fh:
            fh.writelines(json.dumps(r) + "\n" for r in records)
    n = len(records)
    print(f"{a.preset} preset, {n} scenarios (seed {a.seed}), the best of {a.paths} paths each")
    for k in range(1, a.paths + 1):
        hits, runs = _hits(records, lambda rows, k=k: rows[:k])
        print(f"  top {k:2d}: best found on {hits} ({100 * hits / n:.1f}%), {runs:.1f} paths run")
    for f in (0.6, 0.4, 0.3, 0.2):
        hits, runs = _hits(records, _adaptive(f))
        print(f"  adaptive f = {f}: best found on {hits} ({100 * hits / n:.1f}%), {runs:.1f} run")


if __name__ == "__main__":
    main()
