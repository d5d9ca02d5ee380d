"""Work count: integrator steps and F evaluations of the planner, which do not depend on the
machine's speed.

    python benchmarks/bench_work.py [--random 150] [--seed 1] [--workers 2]
                                    [--out benchmarks/out/work.json] [--compare OLD.json]

Wall times on a shared machine vary by 1.5-2x from one minute to the next, so a change of a few
percent cannot be seen in them. Accepted integrator steps summed over every flow of a run (the
validation's included) can: they are deterministic, and the time of a run follows them. This
script counts them, with the F evaluations, sweeps, status and cost, for

- the four paper cases with the default planner (all initial paths), NM and MNM;
- ``--random`` scenarios of ``leapfrog sweep``'s generator (3 to 10 obstacles, ``--seed``; the
  same scenarios as ``leapfrog sweep --n N --seed S``), NM and MNM, one initial path each.

``--compare OLD.json`` (an earlier ``--out``) sets this code beside that one on the same runs:
successes lost and won, optima that changed (relative 1e-6), and the ratio of steps. A change
is worth keeping when it loses no success and changes no optimum; the ratio says what it buys.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
from leapfrog_planner.experiments.profiling import count_work
from leapfrog_planner.planning.planner import Planner

METHODS = ("newton", "modified-newton")
PAPER = tuple(f"paper-case-{c}" for c in (1, 2, 3, 4))
SAME_COST = 1e-6  # relative: the same optimum


def run_one(job: tuple) -> list[dict]:
    """Both methods on one scenario: ``job = (kind, name or index, seed)``."""
    kind, key, seed = job
    if kind == "paper":
        scenario, options = key, {"threads": 1}
    else:
        scenario = generate_one(GeneratorSpec(n=key + 1, seed=seed), key)
        options = {"threads": 1, "initial_paths": 1}  # as the sweep runs them
    rows = []
    for method in METHODS:
        planner = Planner(scenario, method=method, **options)
        w = count_work(planner.plan)
        r = w.value
        rows.append(
            {
                "scenario": r.scenario,
                "kind": kind,
                "method": method,
                "converged": r.status == "converged",
                "cost": r.cost,
                "steps": w.steps,
                "integrations": w.integrations,
                "f_evals": r.f_evals,
                "sweeps": len(r.history),
            }
        )
    return rows


def summary(rows: list[dict]) -> list[str]:
    lines = [
        f"{'runs':8s} {'method':16s} {'converged':>10s} {'steps':>10s} {'F evals':>9s} "
        f"{'sweeps':>7s}"
    ]
    for kind in ("paper", "random"):
        for m in METHODS:
            rs = [r for r in rows if r["kind"] == kind and r["method"] == m]
            if rs:
                ok = sum(r["converged"] for r in rs)
                lines.append(
                    f"{kind:8s} {m:16s} {f'{ok}/{len(rs)}':>10s} "
                    f"{sum(r['steps'] for r in rs):10d} {sum(r['f_evals'] for r in rs):9d} "
                    f"{sum(r['sweeps'] for r in rs):7d}"
                )
    for r in rows:
        if r["kind"] == "paper":
            lines.append(
                f"  {r['scenario']:13s} {r['method']:16s} cost {r['cost']:.6f} "
                f"steps {r['steps']} F evals {r['f_evals']}"
            )
    return lines


def compare(old: list[dict], new: list[dict]) -> list[str]:
    """This run against an earlier one, on the runs both made."""
    before = {(r["scenario"], r["method"]): r for r in old}
    lines = []
    for kind in ("paper", "random"):
        for m in METHODS:
            pairs = [
                (before[r["scenario"], m], r)
                for r in new
                if r["kind"] == kind and r["method"] == m and (r["scenario"], m) in before
            ]
            if not pairs:
                continue
            lost = [b["scenario"] for a, b in pairs if a["converged"] and not b["converged"]]
            won = [b["scenario"] for a, b in pairs if b["converged"] and not a["converged"]]
            changed = [
                f"{b['scenario']} {a['cost']:.6f} -> {b['cost']:.6f}"
                for a, b in pairs
                if a["converged"]
                and b["converged"]
                and abs(b["cost"] - a["cost"]) > SAME_COST * abs(a["cost"])
            ]
            s0, s1 = sum(a["steps"] for a, _ in pairs), sum(b["steps"] for _, b in pairs)
            lines.append(
                f"{kind:8s} {m:16s} {len(pairs)} runs: lost {len(lost)} {lost}, won {len(won)} "
                f"{won}, optima changed {len(changed)} {changed}; steps {s0} -> {s1} "
                f"({s1 / s0:.3f})"
            )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--random", type=int, default=150, help="random scenarios (0: none)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "out" / "work.json")
    ap.add_argument("--compare", type=Path, help="an earlier --out to compare with")
    args = ap.parse_args()
    jobs = [("paper", name, None) for name in PAPER]
    jobs += [("random", i, args.seed) for i in range(args.random)]
    t = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [row for rs in pool.map(run_one, jobs, chunksize=4) for row in rs]
    print(f"{len(jobs)} scenarios x {len(METHODS)} methods in {time.perf_counter() - t:.0f} s")
    print("\n".join(summary(rows)))
    if args.compare:
        print(f"\nagainst {args.compare}:")
        print("\n".join(compare(json.loads(args.compare.read_text())["runs"], rows)))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"seed": args.seed, "runs": rows}, indent=1))
    tmp.replace(args.out)
    print(f"written to {args.out}")


if __name__ == "__main__":
    main()
