"""Commands ``leapfrog generate``, ``leapfrog sweep`` and ``leapfrog report``.

Bad input fails before any work with one line on stderr and exit 2 (see :func:`.cli.main`).
"""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import LeapfrogError
from .common import (
    EXIT_OK,
    console,
    err,
    option_items,
    output_folder,
    output_path,
    planner_options,
    refuse_inputs_in,
    write_output,
)
from .warmup import ensure_compiled


def _range(kind, name, words=()):
    def convert(ctx, param, value):
        if value is None or value in words:
            return value
        from ..batch.generate import parse_range

        try:
            return parse_range(value, kind)
        except LeapfrogError as exc:
            raise click.BadParameter(str(exc)) from None

    return convert


def _generator_options(fn):
    """The generator's options, shared by ``generate`` and ``sweep``.

    ``--preset`` picks a distribution; each other option, when given, overrides its value.
    """
    opts = [
        click.option(
            "--n", "n", type=click.IntRange(min=0), default=None, help="number of scenarios"
        ),
        click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True),
        click.option(
            "--preset",
            type=click.Choice(["default", "general", "metric"]),
            default="default",
            show_default=True,
            help="the distribution: 'general' has headings in every direction, T in 0.5..3,"
            " radii 0.08..0.4 in a 3 x 3 room; 'metric' a 10 x 10 m room, discs of 0.3..1.5 m,"
            " headings in every direction, 1..1.5 s per metre; the options below override it",
        ),
        click.option(
            "--obstacles",
            default=None,
            callback=_range(int, "obstacles"),
            help="obstacles per scenario: N or LO..HI  [default preset: 3..10]",
        ),
        click.option(
            "--radius",
            default=None,
            callback=_range(float, "radius"),
            help="obstacle radius: R or LO..HI  [default preset: 0.05..0.2]",
        ),
        click.option(
            "--workspace",
            nargs=4,
            type=float,
            default=None,
            metavar="XMIN YMIN XMAX YMAX",
            help="[default preset: 0 0 2 2]",
        ),
        click.option(
            "--min-distance",
            type=float,
            default=None,
            help="minimum start-goal distance  [default preset: 1]",
        ),
        click.option(
            "--clearance",
            type=float,
            default=None,
            help="start and goal clearance from obstacle edges  [default preset: 0.05]",
        ),
        click.option(
            "--obstacle-gap",
            type=float,
            default=None,
            help="minimum gap between obstacles  [default preset: 0]",
        ),
        click.option(
            "--heading-spread",
            type=float,
            default=None,
            help="headings: goal direction +- this (radians)  [default preset: pi/4]",
        ),
        click.option(
            "--horizon",
            default=None,
            callback=_range(float, "horizon", ("free",)),
            help="T: a value or LO..HI (uniform), or free (the planner chooses T at the price"
            " of time of --cruise-speed)  [default preset: 1]",
        ),
        click.option(
            "--cruise-speed",
            default=None,
            callback=_range(float, "cruise-speed"),
            help="with --horizon free: the speed in free space, which sets the price of time"
            " (v^2 / 2 per second for the unicycle), a value or LO..HI (uniform)",
        ),
        click.option(
            "--pace",
            default=None,
            callback=_range(float, "pace"),
            help="T from the start-goal distance: seconds per metre, a value or LO..HI"
            " (instead of --horizon)  [metric preset: 1..1.5]",
        ),
        click.option(
            "--prefix", default=None, help="scenario name prefix  [default: the preset's]"
        ),
    ]
    for o in reversed(opts):
        fn = o(fn)
    return fn


def _spec(n, seed, preset, prefix=None, **given):
    """The generator spec of ``preset`` with the options that were given on top."""
    from ..batch.generate import GeneratorSpec

    overrides = {k: v for k, v in given.items() if v is not None}
    if "workspace" in overrides:
        overrides["workspace"] = tuple(overrides["workspace"])
    if prefix is not None:
        overrides["prefix"] = prefix
    free = overrides.get("horizon") == "free"
    if free != ("cruise_speed" in overrides):
        raise click.UsageError("--horizon free and --cruise-speed go together")
    if free:  # the search starts at the preset's horizon
        del overrides["horizon"]
    elif "horizon" in overrides and "pace" not in overrides:  # a horizon given: no pace
        overrides["pace"] = None
    return GeneratorSpec.preset(preset, n=n, seed=seed, **overrides)


@click.command()
@_generator_options
@click.option(
    "--map",
    "map_file",
    default=None,
    help="queries on this ROS map (its YAML) by nav2's planner-benchmark protocol: robot radius"
    " 0.2 m, start and goal 0.3 m clear and over --min-distance (default 3 m) apart, connected,"
    " headings uniform, T = the shortest path at 0.5 m/s, weight 1",
)
@click.option("--out", required=True, help="folder for the files")
@click.option("--overwrite", is_flag=True, help="replace existing files with other content")
def generate(out, overwrite, map_file, **gen):
    """Write seeded random scenarios as TOML files (scenario i depends only on seed and i)."""
    from ..batch.generate import map_scenarios, write_all, write_scenarios

    if gen["n"] is None:
        raise click.UsageError("--n is required")
    if map_file is not None:  # drawn before the folder is made: a bad map writes nothing
        distance = 3.0 if gen["min_distance"] is None else gen["min_distance"]
        scenarios = map_scenarios(map_file, gen["n"], gen["seed"], min_distance=distance,
                                  prefix=gen["prefix"] or "map")  # fmt: skip
        output_folder(out, "--out", [map_file])
        paths = write_all(scenarios, out, overwrite=overwrite)
        click.echo(f"{len(paths)} scenarios in {out}")
        return EXIT_OK
    spec = _spec(**gen)
    output_folder(out, "--out")
    paths = write_scenarios(spec, out, overwrite=overwrite)
    click.echo(f"{len(paths)} scenarios in {out}")
    return EXIT_OK


def _load_sources(sources) -> list:
    from ..batch.sweep import SweepError
    from ..planning.scenario import load_scenario

    out = []
    for src in sources:
        p = Path(src)
        if p.is_dir():
            files = sorted(p.glob("*.toml"))
            if not files:
                raise SweepError(f"{src}: no .toml files in this folder")
            out += [load_scenario(f) for f in files]
        else:
            out.append(load_scenario(src))
    return out


@click.command()
@click.argument("sources", nargs=-1)
@_generator_options
@click.option(
    "--methods",
    default="newton,modified-newton",
    show_default=True,
    help="comma-separated: newton, modified-newton, nleq-err, shooting, direct",
)
@click.option("--out", required=True, help="results file (JSON Lines); an existing one is resumed")
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=2,
    show_default=True,
    help="local worker processes",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="run on this Dask scheduler (e.g. tcp://host:8786) instead of locally",
)
@click.option(
    "--time-limit",
    type=click.FloatRange(min=0, min_open=True),
    default=60.0,
    show_default=True,
    help="seconds per (scenario, method) pair",
)
@click.option(
    "--chunk-size",
    type=click.IntRange(min=1),
    default=None,
    help="pairs per Dask task  [default: about 8 tasks per worker thread]",
)
@click.option(
    "--initial-paths",
    type=click.IntRange(min=1),
    default=None,
    help="planner initial paths  [sweep default: 1]",
)
@option_items
@click.option("--no-sort", is_flag=True, help="leave the file in completion order at the end")
@click.option("--quiet", is_flag=True, help="no progress bar and no summary")
def sweep(
    sources,
    methods,
    out,
    workers,
    scheduler,
    time_limit,
    chunk_size,
    initial_paths,
    options,
    no_sort,
    quiet,
    **gen,
):
    """Run scenarios (SOURCES: folders, files, built-ins, and/or --n random ones) against methods.

    One JSON line per (scenario, method) pair is appended to --out; rerunning with the same --out
    runs only the missing pairs.
    """
    from ..batch.sweep import SweepSettings, run_sweep

    planner = planner_options(options)
    if initial_paths is not None:
        planner["initial_paths"] = initial_paths
    settings = SweepSettings(
        methods=tuple(m.strip() for m in methods.split(",") if m.strip()),
        planner=planner,
        time_limit=time_limit,
        workers=workers,
        scheduler=scheduler,
        chunk_size=chunk_size,
        sort=not no_sort,
    )
    _generator_options_need_n(gen)
    scenarios = _load_sources(sources)
    out_path = output_path(out, "--out", [s.source for s in scenarios if s.source])
    if gen["n"] is not None:
        from ..batch.generate import generate as gen_scenarios

        scenarios += list(gen_scenarios(_spec(**gen)))
    if not scenarios:
        raise click.UsageError("no scenarios: give folders or files, or --n for random ones")
    if scheduler is None:  # one compile, shared by the workers through the disk cache
        ensure_compiled([s.model for s in scenarios], show=not quiet)
    if quiet:
        summary = run_sweep(scenarios, out_path, settings)
    else:
        summary = _with_progress(scenarios, out_path, settings)
    if not quiet:
        _print_summary(summary)
    return EXIT_OK


def _generator_options_need_n(gen: dict) -> None:
    """Refuse the random scenarios' options without ``--n``: they shape only those, and the
    scenarios of files and built-ins would be swept as they are, the option ignored."""
    ctx = click.get_current_context()
    given = [
        name for name in gen if name != "n"
        and ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT
    ]  # fmt: skip
    if given and gen["n"] is None:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        hint = ""
        if {"horizon", "cruise_speed"} & set(given):
            hint = ' (a free horizon in a file: horizon = "free" and [cost] cruise_speed)'
        raise click.UsageError(
            f"{flags}: options of the random scenarios, which --n asks for; the scenarios of"
            f" files and built-ins are swept as they are{hint}"
        )


def _with_progress(scenarios, out_path, settings):
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from ..batch.sweep import run_sweep

    columns = [
        TextColumn("sweep"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    ]
    with Progress(*columns, console=err, transient=True) as bar:  # bad input: one line only
        task = bar.add_task("sweep", total=None, info="starting")

        def on_event(ev):
            info = f"{ev.converged} converged, {ev.failed} failed"
            if ev.skipped:
                info += f", {ev.skipped} already done"
            bar.update(task, total=ev.total, completed=ev.done, info=info)

        return run_sweep(scenarios, out_path, settings, progress=on_event)


def _print_summary(s):
    fails = ", ".join(f"{k} {v}" for k, v in s.failures.items())
    console.print(
        f"{s.path}: {s.total} pairs, {s.skipped} already done, {s.ran} run now "
        f"({s.converged} converged, {s.failed} failed{': ' + fails if fails else ''}) "
        f"in {s.wall_time_s:.1f} s on {s.engine}",
        highlight=False,
        markup=False,
    )


@click.command()
@click.argument("results", type=click.Path(dir_okay=False))
@click.option(
    "--out",
    default=None,
    help="folder for report.md and the figures",
)
def report(results, out):
    """Statistics of a sweep's RESULTS file: success, cost, time, paired comparisons."""
    from ..batch.report import build_report, save_report, summary_text
    from ..batch.store import read_records

    if not Path(results).is_file():
        raise click.UsageError(f"{results!r}: no such file")
    if out is not None:
        folder = output_folder(out, "--out", [results])
        refuse_inputs_in(folder, ["report.md"], [results], "--out")
    rep = build_report(read_records(results))
    if out is not None:
        write_output(lambda f: save_report(rep, f), folder, "--out")
    click.echo(summary_text(rep))
    more = f"written to {folder}/ (report.md: all tables)" if out else "all tables: --out DIR"
    click.echo(more)
    return EXIT_OK
