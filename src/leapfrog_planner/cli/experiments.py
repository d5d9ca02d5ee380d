"""``leapfrog paper`` and ``leapfrog bench``: the experiments, with a progress bar.

Both write into an output folder (created if its parent exists) and exit 0 once the files are
written: a solver failure is a result of the experiment, shown in its tables, not an error.
"""

from __future__ import annotations

from pathlib import Path

import click

from .._atomic import write_text_atomic
from .common import EXIT_OK, console, err, output_folder, write_output
from .warmup import ensure_compiled, held_interrupts

# As bench.SOLVERS (the test checks), without importing the benchmark for --help.
SOLVER_CHOICES = ["leapfrog-mnm", "leapfrog-mnm-1path", "leapfrog-nm", "leapfrog-nleq-err",
                  "shooting", "bvp", "direct"]  # fmt: skip


def _output_dir(value: str, option: str) -> Path:
    """The output folder, created if needed; checked before any work (bad input exits 2)."""
    return output_folder(value, option)


def _progress_bar():
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),  # "0/?" until the total is known
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
    ]
    return Progress(*columns, console=err, transient=True)


def _run_with_bar(title: str, run, quiet: bool):
    """Call ``run(progress)`` with a rich progress bar fed by its events (none when quiet).
    Ctrl-C is held during the run and acted on at the next event: numba compiles kernels on
    their first call, and an interrupt in the middle of that crashed the process."""
    with held_interrupts() as pending:
        if quiet:
            return run(lambda ev: pending())
        with _progress_bar() as bar:
            task = bar.add_task(title, total=None, info="")

            def on_event(ev):
                pending()
                bar.update(task, total=ev.total, completed=ev.done, info=ev.label)

            return run(on_event)


def _shared_options(out: str, repeat: int, repeat_help: str, case_help: str):
    """``--out``, ``--repeat`` and ``--case``, the first options of ``paper`` and ``bench``."""
    options = [
        click.option("--out", "out", default=out, show_default=True, help="output folder"),
        click.option(
            "--repeat",
            type=click.IntRange(min=1),
            default=repeat,
            show_default=True,
            help=repeat_help,
        ),
        click.option("--case", "cases", type=click.IntRange(1, 4), multiple=True, help=case_help),
    ]

    def apply(command):
        for option in reversed(options):  # the first listed comes first in --help
            command = option(command)
        return command

    return apply


@click.command()
@_shared_options(
    "paper-out",
    5,
    "timed repetitions per case and method (the median is reported)",
    "run only this paper case (repeatable)  [default: all four]",
)
@click.option(
    "--time-weights",
    default=None,
    help="also the cases with the final time free at these prices of time k, e.g. 0.1,1,10"
    " (free_time.md, free_time.csv)",
)
@click.option("--quiet", is_flag=True, help="no progress bar and no table")
def paper(out, repeat, cases, time_weights, quiet):
    """Reproduce the paper's Table 1 and Figures 1-4 (NM and MNM on its four cases)."""
    from ..experiments.paper import PaperSettings, run_paper, table1_markdown
    from ..experiments.paper_free import run_free_time
    from ..experiments.paper_free import time_weights as parse_weights

    settings = PaperSettings(repeat=repeat, **({"cases": cases} if cases else {}))
    weights = parse_weights(time_weights) if time_weights is not None else ()
    folder = _output_dir(out, "--out")
    ensure_compiled(["unicycle"], show=not quiet, timed=True)
    result = _run_with_bar("paper", lambda cb: run_paper(settings, progress=cb), quiet)
    free = []
    if weights:
        run = lambda cb: run_free_time(settings.cases, weights, cb)  # noqa: E731
        free = _run_with_bar("free time", run, quiet)
    write_output(lambda f: _write_paper(result, free, f), folder, "--out")
    if not quiet:
        click.echo(table1_markdown(result))  # plain: rich would re-wrap the Markdown
        if free:
            from ..experiments.paper_free import free_time_markdown

            click.echo(free_time_markdown(free))
        console.print(f"written to {folder}/", markup=False, highlight=False)
    return EXIT_OK


def _write_paper(result, free, folder) -> None:
    from ..experiments.paper import write_paper
    from ..experiments.paper_free import free_time_csv, free_time_markdown

    write_paper(result, folder)
    for name, text in (("free_time.md", free_time_markdown), ("free_time.csv", free_time_csv)):
        if free:
            content = text(free)
            write_text_atomic(folder / name, content)


@click.command()
@_shared_options(
    "bench-out",
    3,
    "timed solves after a warm-up (the median is reported)",
    "paper case to include (repeatable)  [default: all four]",
)
@click.option(
    "--random", "random_", type=click.IntRange(min=0), default=5, show_default=True,
    help="seeded random scenarios",
)  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--solver",
    "solvers",
    type=click.Choice(SOLVER_CHOICES),
    multiple=True,
    help="solver to run (repeatable)  [default: all]",
)  # fmt: skip
@click.option(
    "--mesh",
    "meshes",
    type=click.IntRange(min=2),
    multiple=True,
    help="direct-method intervals (repeatable)  [default: 100 and 200]",
)
@click.option("--no-profile", is_flag=True, help="skip the profile of one Leapfrog solve")
@click.option(
    "--work-precision",
    is_flag=True,
    help="time against accuracy instead: Leapfrog, IPOPT over meshes of 25 to 3200 intervals"
    " and solve_bvp over tolerances, on the paper cases and --random general scenarios",
)
@click.option("--targets", is_flag=True, help="also print each speed ratio and its target")
@click.option(
    "--map", "map_file", type=click.Path(dir_okay=False), default=None,
    help="instead: Leapfrog beside OMPL on random queries of this ROS map (YAML)",
)  # fmt: skip
@click.option(
    "--queries", type=click.IntRange(min=1), default=10, show_default=True,
    help="with --map: how many queries",
)  # fmt: skip
@click.option(
    "--ompl-time", type=click.FloatRange(min=1e-3, max=3600.0), default=1.0,
    show_default=True, help="with --map: OMPL's time per query (s)",
)  # fmt: skip
@click.option("--quiet", is_flag=True, help="no progress bar and no summary")
def bench(
    out, repeat, cases, random_, seed, solvers, meshes, no_profile, work_precision, targets,
    map_file, queries, ompl_time, quiet,
):  # fmt: skip
    """Benchmark Leapfrog against plain shooting, solve_bvp and CasADi/IPOPT (or, with --map,
    against OMPL on a map)."""
    from ..experiments.bench import BenchSettings, run_bench, write_bench

    if work_precision:
        return _work_precision(out, repeat, cases, random_, seed, meshes, quiet)
    if map_file is not None:
        return _map_bench(out, map_file, queries, seed, ompl_time, quiet)

    options = {"cases": cases, "solvers": solvers, "meshes": meshes}
    settings = BenchSettings(
        repeat=repeat,
        random=random_,
        seed=seed,
        profile=not no_profile,
        **{k: v for k, v in options.items() if v},
    )
    folder = _output_dir(out, "--out")
    ensure_compiled(["unicycle"], show=not quiet, timed=True)
    result = _run_with_bar("bench", lambda cb: run_bench(settings, progress=cb), quiet)
    write_output(lambda f: write_bench(result, f), folder, "--out")
    for note in result.notes:  # e.g. CasADi missing: said even when quiet
        err.print(f"note: {note}", markup=False, highlight=False, soft_wrap=True)
    if not quiet:
        _bench_summary(result, targets)
        if result.profile is not None:
            p = result.profile
            parts = ", ".join(
                f"{k.replace('_', ' ')} {100 * p.fraction(k):.0f}%" for k in p.parts_s
            )
            console.print(
                f"time split ({p.scenario}, {p.wall_s * 1e3:.0f} ms): {parts}",
                markup=False,
                highlight=False,
                soft_wrap=True,
            )
        console.print(f"written to {folder}/ (bench.md, bench.csv, bench.json, bench.png)",
                       markup=False, highlight=False)  # fmt: skip
    return EXIT_OK


def _map_bench(out, map_file, queries, seed, ompl_time, quiet):
    from ..experiments.map_bench import MapBenchSettings, run_map_bench, summary, write_map_bench
    from ..experiments.ompl_peer import OMPL_MISSING, ompl_available
    from ..planning.scenario_map import ScenarioMap

    if not ompl_available():
        raise click.UsageError(OMPL_MISSING)
    ScenarioMap(map_file)  # a bad map: one line and exit 2 before anything runs
    settings = MapBenchSettings(queries=queries, seed=seed, ompl_time=ompl_time)
    folder = _output_dir(out, "--out")
    ensure_compiled(["unicycle"], show=not quiet, timed=True)
    result = _run_with_bar(
        "bench --map", lambda cb: run_map_bench(map_file, settings, progress=cb), quiet
    )
    write_output(lambda f: write_map_bench(result, f), folder, "--out")
    if not quiet:
        head = summary(result)
        lines = [
            f"{solver}: {head[solver]['succeeded']}/{queries} succeeded, median"
            f" {head[solver]['median_time_s']:.3g} s, largest curvature"
            f" {head[solver]['max_curvature']:.3g} 1/m"
            for solver in ("leapfrog", "ompl")
        ]
        lines.append(
            f"both solved {head['both_solved']}: Leapfrog at most OMPL's cost on"
            f" {head['leapfrog_cheaper']} (median cost ratio {head['median_cost_ratio']:.3g})"
        )
        lines.append(f"written to {folder}/ (bench_map.md, bench_map.csv, bench_map.json)")
        for line in lines:
            console.print(line, markup=False, highlight=False, soft_wrap=True)
    return EXIT_OK


def _work_precision(out, repeat, cases, general, seed, meshes, quiet):
    from ..experiments.work_precision import (
        WorkPrecisionSettings,
        ratios,
        run_work_precision,
        write_work_precision,
    )

    options = {"cases": cases, "meshes": meshes}
    settings = WorkPrecisionSettings(
        repeat=repeat, general=general, seed=seed, **{k: v for k, v in options.items() if v}
    )
    folder = _output_dir(out, "--out")
    result = _run_with_bar(
        "work-precision", lambda cb: run_work_precision(settings, progress=cb), quiet
    )
    write_output(lambda f: write_work_precision(result, f), folder, "--out")
    for note in result.notes:
        err.print(f"note: {note}", markup=False, highlight=False, soft_wrap=True)
    if not quiet:
        for r in ratios(result):
            console.print(r.text, markup=False, highlight=False, soft_wrap=True)
        console.print(
            f"written to {folder}/ (work_precision.md, .csv, .png)", markup=False, highlight=False
        )
    return EXIT_OK


def _bench_summary(result, targets: bool) -> None:
    """Per solver: successes, best optima found and median time; the targets in one line (each
    with ``--targets``; all of them are in bench.md)."""
    from rich.table import Table

    from ..experiments.bench import summary_rows, target_ratios

    table = Table(title="peer benchmark")
    for col in ("solver", "succeeded", "best optimum found", "median time"):
        table.add_column(col, justify="left" if col == "solver" else "right")
    for solver, ok, at_best, n, t in summary_rows(result):
        table.add_row(solver, f"{ok}/{n}", f"{at_best}/{n}", f"{t * 1e3:.1f} ms")
    console.print(table)
    ratios = target_ratios(result)
    if targets:
        for r in ratios:
            console.print(r.text, markup=False, highlight=False, soft_wrap=True)
    elif ratios:
        met = sum(r.passed for r in ratios)
        console.print(
            f"speed targets met: {met} of {len(ratios)} (each one: --targets, or bench.md)",
            markup=False,
            highlight=False,
        )
