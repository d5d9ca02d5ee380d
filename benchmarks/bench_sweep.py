"""Sweep throughput: (scenario, method) pairs per second on random 7-obstacle scenarios.

    python benchmarks/bench_sweep.py [--n 60] [--workers 2] [--methods newton,modified-newton]
                                     [--initial-paths 1] [--dask] [--out benchmarks/out]

Three measurements on the same pairs:

1. serial, in this process (warm kernels): the pure compute time of every pair, and where it
   goes (initial path, Leapfrog sweeps, final solve, validation);
2. ``run_sweep`` with ``--workers`` local processes into a fresh results file;
3. with ``--dask``: the same on a ``LocalCluster`` of ``--workers`` single-thread processes.

For 2 and 3: throughput = pairs / wall time, with and without the one-off start-up (worker
processes, imports, kernel loading; the Dask cluster is warmed by a small sweep first), and the
overhead = 1 - compute / (workers x (wall - start-up)), where compute is the workers' own task
time: scheduling, transfers, writing the file and idle workers at the end all count.
Targets of the issue: >= 20 pairs/s with 2 workers, overhead < 10%. No assertions; the load
average is printed with the figures since the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.batch.store import read_records
from leapfrog_planner.batch.sweep import DEFAULT_PLANNER_OPTIONS, SweepSettings, run_sweep
from leapfrog_planner.planning.planner import Planner

TARGET_PAIRS_PER_S, TARGET_OVERHEAD = 20.0, 0.10


def serial(scenarios, methods, options):
    from leapfrog_planner.batch.tasks import _run_shooting

    Planner(scenarios[0], **options).plan()  # warm-up
    rows = []
    for sc in scenarios:
        for m in methods:
            t = time.perf_counter()
            if m == "shooting":
                r = _run_shooting(sc, options)
                phases = {"shooting": time.perf_counter() - t}
            else:
                res = Planner(sc, **options, method=m).plan()
                phases = {
                    "initial path": res.time_initial_path_s,
                    "sweeps": res.time_sweeps_s,
                    "final solve": res.time_final_s,
                    "validation": res.time_validation_s,
                }
                r = {"status": str(res.status)}
            rows.append((m, r["status"], time.perf_counter() - t, phases))
    return rows


def measure_sweep(scenarios, settings, label):
    """Wall time, start-up and overhead of one sweep into a fresh file."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.jsonl"
        stamps = []
        t0 = time.perf_counter()
        summary = run_sweep(
            scenarios,
            out,
            settings,
            progress=lambda ev: stamps.append(time.perf_counter()) if ev.record else None,
        )
        wall = time.perf_counter() - t0
        recs = read_records(out)
    n = len(recs)
    compute = sum(r["task_time_s"] for r in recs)
    warm = sum(r["warmup_s"] for r in recs)
    # Start-up: until the workers could start computing (process start, imports, kernel
    # loading). Local: the first record's arrival minus its own compute time. A warmed Dask
    # cluster has none (the chunked records arrive in batches, so this estimate would not fit).
    startup = 0.0
    if settings.scheduler is None and stamps:
        startup = stamps[0] - t0 - recs[0]["task_time_s"] if recs else 0.0
        startup = max(0.0, min(startup, stamps[0] - t0))
    busy = settings.workers * (wall - startup)
    return {
        "engine": label,
        "pairs": n,
        "converged": summary.converged,
        "wall_s": wall,
        "startup_s": startup,
        "warmup_s_total": warm,
        "compute_s": compute,
        "pairs_per_s": n / wall,
        "steady_pairs_per_s": n / (wall - startup),
        "ideal_pairs_per_s": settings.workers * n / compute,
        # Everything but the workers' own task time, start-up excluded: scheduling, result
        # transfer, writing, and idle workers at the end (load imbalance of the last pairs).
        "overhead": 1 - compute / busy,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=60, help="scenarios")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--obstacles", type=int, default=7)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--methods", default="newton,modified-newton")
    ap.add_argument("--initial-paths", type=int, default=1)
    ap.add_argument("--chunk-size", type=int, default=None, help="Dask pairs per task")
    ap.add_argument("--dask", action="store_true", help="also on a Dask LocalCluster")
    ap.add_argument("--no-serial", action="store_true")
    ap.add_argument("--out", default="benchmarks/out")
    args = ap.parse_args()
    methods = tuple(args.methods.split(","))
    options = {**DEFAULT_PLANNER_OPTIONS, "initial_paths": args.initial_paths}
    spec = GeneratorSpec(n=args.n, seed=args.seed, obstacles=(args.obstacles, args.obstacles))
    scenarios = list(generate(spec))
    print(f"cores: {os.cpu_count()}, load average at start: {os.getloadavg()}")
    print(
        f"{args.n} scenarios x {len(methods)} methods ({', '.join(methods)}), "
        f"{args.obstacles} obstacles, seed {args.seed}, planner options {options}"
    )
    report = {"load_start": os.getloadavg(), "options": options, "methods": methods}

    if not args.no_serial:
        rows = serial(scenarios, methods, options)
        times = [r[2] for r in rows]
        phases: dict[str, float] = {}
        for *_, ph in rows:
            for k, v in ph.items():
                phases[k] = phases.get(k, 0.0) + v
        total = sum(times)
        print(
            f"\nserial, in-process: {len(rows)} pairs in {total:.2f} s = "
            f"{len(rows) / total:.1f} pairs/s on one core; per pair median "
            f"{statistics.median(times) * 1e3:.0f} ms, mean {total / len(rows) * 1e3:.0f} ms, "
            f"max {max(times) * 1e3:.0f} ms"
        )
        srt = sorted(times, reverse=True)
        top = sum(srt[: max(1, len(srt) // 10)]) / total
        print(f"  the slowest 10% of pairs take {top:.0%} of the time")
        for k, v in phases.items():
            print(f"  {k:<13}{v:8.2f} s  {v / total:6.1%}")
        for m in methods:
            ts = [r[2] for r in rows if r[0] == m]
            ok = sum(r[1] == "converged" for r in rows if r[0] == m)
            print(
                f"  {m:<16} {ok}/{len(ts)} converged, median {statistics.median(ts) * 1e3:.0f}"
                f" ms, mean {statistics.mean(ts) * 1e3:.0f} ms"
            )
        report["serial"] = {
            "pairs": len(rows),
            "total_s": total,
            "pairs_per_s_one_core": len(rows) / total,
            "phases_s": phases,
        }

    runs = []
    local = SweepSettings(methods=methods, planner=options, workers=args.workers, sort=False)
    runs.append(measure_sweep(scenarios, local, f"local x{args.workers}"))
    if args.dask:
        from distributed import LocalCluster

        with LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster:
            warm = list(generate(GeneratorSpec(n=2 * args.workers, seed=args.seed + 10**6)))
            with tempfile.TemporaryDirectory() as tmp:  # load the kernels in every worker first
                run_sweep(
                    warm,
                    Path(tmp) / "w.jsonl",
                    SweepSettings(
                        methods=methods,
                        planner=options,
                        scheduler=cluster.scheduler_address,
                        chunk_size=1,
                    ),
                )
            dask = SweepSettings(
                methods=methods,
                planner=options,
                workers=args.workers,
                scheduler=cluster.scheduler_address,
                chunk_size=args.chunk_size,
                sort=False,
            )
            runs.append(measure_sweep(scenarios, dask, f"dask x{args.workers}"))

    print(
        f"\n{'engine':<10}{'pairs':>6}{'wall s':>8}{'start s':>8}{'pairs/s':>9}"
        f"{'no-start':>9}{'ideal/s':>9}{'overhead':>9}  verdict (>= {TARGET_PAIRS_PER_S:g}/s,"
        f" < {TARGET_OVERHEAD:.0%})"
    )
    for r in runs:
        ok_rate = r["steady_pairs_per_s"] >= TARGET_PAIRS_PER_S
        ok_over = r["overhead"] < TARGET_OVERHEAD
        print(
            f"{r['engine']:<10}{r['pairs']:>6}{r['wall_s']:>8.1f}{r['startup_s']:>8.1f}"
            f"{r['pairs_per_s']:>9.1f}{r['steady_pairs_per_s']:>9.1f}"
            f"{r['ideal_pairs_per_s']:>9.1f}{r['overhead']:>9.1%}  "
            f"throughput {'PASS' if ok_rate else 'MISS'}, overhead {'PASS' if ok_over else 'MISS'}"
        )
    report["runs"] = runs
    report["load_end"] = os.getloadavg()
    print(f"load average at end: {report['load_end']}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sweep.json").write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
